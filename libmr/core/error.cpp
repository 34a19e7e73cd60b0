#include "core/error.h"

namespace mr {

std::string FileLoc::ToString() const {
  std::string s = file;
  if (line > 0) {
    s += fmt::format(":{}", line);
    if (column > 0) s += fmt::format(":{}", column);
  }
  if (!key.empty()) s += (s.empty() ? "" : ": ") + key;
  return s;
}

Error::Error(const std::string& message) : std::runtime_error(message), message_(message) {}

Error::Error(FileLoc loc, const std::string& message)
    : std::runtime_error(loc.ToString().empty() ? message : loc.ToString() + ": " + message),
      loc_(std::move(loc)),
      message_(message) {}

}  // namespace mr
