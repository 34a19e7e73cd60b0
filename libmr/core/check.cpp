#include "core/check.h"

#include <cstdio>
#include <cstdlib>

namespace mr::detail {

void CheckFailed(const char* file, int line, const char* expr, const std::string& detail) {
  std::fprintf(stderr, "mr: internal error (a bug, please report it): %s:%d: check failed: %s%s%s\n", file, line, expr,
               detail.empty() ? "" : " (", detail.empty() ? "" : (detail + ")").c_str());
  std::fflush(stderr);
  std::abort();
}

}  // namespace mr::detail
