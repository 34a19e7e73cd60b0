#include "core/stderr_capture.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <mutex>

namespace mr {

namespace {
std::recursive_mutex g_capture_mutex;  // recursive: a capture inside a capture is harmless
}  // namespace

StderrCapture::StderrCapture() {
  g_capture_mutex.lock();
  locked_ = true;
  std::fflush(stderr);
  // mkstemp's template in the temporary folder ($TMPDIR, else /tmp).
  std::error_code ec;
  std::string name = (std::filesystem::temp_directory_path(ec) / "mr-stderr-XXXXXX").string();
  if (ec) name = "/tmp/mr-stderr-XXXXXX";
  file_ = ::mkstemp(name.data());
  if (file_ < 0) return;  // nothing captured: the library's lines go to stderr as before
  ::unlink(name.c_str());
  saved_ = ::dup(2);
  if (saved_ < 0 || ::dup2(file_, 2) < 0) {
    if (saved_ >= 0) ::close(saved_);
    saved_ = -1;
  }
}

void StderrCapture::Restore() {
  if (saved_ >= 0) {
    std::fflush(stderr);
    ::dup2(saved_, 2);
    ::close(saved_);
    saved_ = -1;
  }
}

StderrCapture::~StderrCapture() {
  const bool held = saved_ >= 0;
  Restore();
  if (held && file_ >= 0) {  // not taken: pass it on
    char buf[4096];
    off_t at = 0;
    for (ssize_t n; (n = ::pread(file_, buf, sizeof(buf), at)) > 0; at += n)
      if (::write(2, buf, static_cast<size_t>(n)) < 0) break;
  }
  if (file_ >= 0) ::close(file_);
  if (locked_) g_capture_mutex.unlock();
}

std::string StderrCapture::Take() {
  Restore();
  std::string text;
  if (file_ >= 0) {
    char buf[2048];
    const ssize_t n = ::pread(file_, buf, sizeof(buf), 0);
    if (n > 0) text.assign(buf, static_cast<size_t>(n));
    ::close(file_);
    file_ = -1;
  }
  std::string out;
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(start, end - start);
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first != std::string::npos) out += (out.empty() ? "" : "; ") + line.substr(first);
    start = end + 1;
  }
  return out;
}

}  // namespace mr
