// Errors for bad data and bad input (the user's problem, not a bug).
//
// Three channels (docs/conventions.md):
//  - a broken invariant (a bug) is MR_CHECK / MR_DCHECK (check.h): abort with file:line;
//  - bad data or a bad file throws mr::Error, naming the file and the place in it;
//  - bad options fail an Options::Check(), which throws mr::UsageError.
#pragma once

#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace mr {

// A place in an input: a file, and optionally a line and column (1-based) or a
// key path inside a structured file ("virtual[1].material.albedo").
struct FileLoc {
  std::string file;
  int line = 0;
  int column = 0;
  std::string key;  // JSON key path, empty when not applicable

  // "file:line:col", "file: key", or "file".
  std::string ToString() const;
};

// Bad data: thrown by readers and by library code that detects bad input.
// what() is the whole message, "FILE:LINE:COL: message".
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message);
  Error(FileLoc loc, const std::string& message);

  const FileLoc& loc() const { return loc_; }
  const std::string& message() const { return message_; }

 private:
  FileLoc loc_;
  std::string message_;
};

// A bad command line or option value: tools exit with code 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws mr::Error with a formatted message.
template <typename... Args>
[[noreturn]] void ThrowError(fmt::format_string<Args...> f, Args&&... args) {
  throw Error(fmt::format(f, std::forward<Args>(args)...));
}
template <typename... Args>
[[noreturn]] void ThrowErrorAt(const FileLoc& loc, fmt::format_string<Args...> f, Args&&... args) {
  throw Error(loc, fmt::format(f, std::forward<Args>(args)...));
}

}  // namespace mr
