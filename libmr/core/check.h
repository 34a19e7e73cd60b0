// Invariant checks: a failure is a bug in mr, never a user error.
// MR_CHECK is always on; MR_DCHECK only in debug builds (NDEBUG unset).
#pragma once

#include <fmt/format.h>

namespace mr::detail {
[[noreturn]] void CheckFailed(const char* file, int line, const char* expr, const std::string& detail);
}  // namespace mr::detail

#define MR_CHECK(cond)                                                     \
  do {                                                                     \
    if (!(cond)) [[unlikely]]                                              \
      ::mr::detail::CheckFailed(__FILE__, __LINE__, #cond, std::string()); \
  } while (false)

#define MR_CHECK_MSG(cond, ...)                                                       \
  do {                                                                                \
    if (!(cond)) [[unlikely]]                                                         \
      ::mr::detail::CheckFailed(__FILE__, __LINE__, #cond, fmt::format(__VA_ARGS__)); \
  } while (false)

#define MR_CHECK_OP(a, op, b)                                                       \
  do {                                                                              \
    const auto& mr_check_a_ = (a);                                                  \
    const auto& mr_check_b_ = (b);                                                  \
    if (!(mr_check_a_ op mr_check_b_)) [[unlikely]]                                 \
      ::mr::detail::CheckFailed(__FILE__, __LINE__, #a " " #op " " #b,              \
                                fmt::format("{} vs {}", mr_check_a_, mr_check_b_)); \
  } while (false)

#define MR_CHECK_EQ(a, b) MR_CHECK_OP(a, ==, b)
#define MR_CHECK_NE(a, b) MR_CHECK_OP(a, !=, b)
#define MR_CHECK_LT(a, b) MR_CHECK_OP(a, <, b)
#define MR_CHECK_LE(a, b) MR_CHECK_OP(a, <=, b)
#define MR_CHECK_GT(a, b) MR_CHECK_OP(a, >, b)
#define MR_CHECK_GE(a, b) MR_CHECK_OP(a, >=, b)

#ifdef NDEBUG
#define MR_DCHECK(cond) \
  do {                  \
  } while (false && (cond))
#else
#define MR_DCHECK(cond) MR_CHECK(cond)
#endif
