// Progress on stderr, only when stderr is a terminal (pipes and CI logs stay clean).
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace mr {

class Progress {
 public:
  Progress(std::string label, int64_t total);
  ~Progress();
  // Thread-safe; redraws at most every 0.2 s.
  void Update(int64_t done);
  void Done();
  static bool Enabled();

 private:
  std::string label_;
  int64_t total_;
  bool enabled_, finished_ = false;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace mr
