// Holding what C libraries print on stderr (libpng through OpenImageIO,
// libmrcal's parser), so that their lines do not come before mr's own
// message: a failed call's diagnostic goes into the mr::Error instead.
#pragma once

#include <string>

namespace mr {

// While it lives, file descriptor 2 goes to a temporary file.  Captures are
// process-wide and serialised by a mutex: hold one only around a library
// call.  Nothing is lost: what is not taken (the call succeeded, or another
// thread logged meanwhile) is written to stderr when the capture ends.
class StderrCapture {
 public:
  StderrCapture();
  ~StderrCapture();  // restores stderr and writes to it what was held and not taken
  StderrCapture(const StderrCapture&) = delete;
  StderrCapture& operator=(const StderrCapture&) = delete;
  // Restores stderr and returns what was printed, whitespace-trimmed, its
  // lines joined by "; " (at most 2000 bytes).
  std::string Take();

 private:
  void Restore();
  int saved_ = -1;
  int file_ = -1;
  bool locked_ = false;
};

}  // namespace mr
