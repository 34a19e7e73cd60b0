// Robust scalar math: the few functions whose naive forms fail on real data
// (acos(1+eps) = NaN, catastrophic cancellation, long float sums).
// Cf. pbrt-v4 util/math.h.
#pragma once

#include <cmath>
#include <limits>
#include <numbers>

#include "core/check.h"

namespace mr {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kInvPi = std::numbers::inv_pi;
inline constexpr double kTwoPi = 2.0 * std::numbers::pi;
inline constexpr double kFourPi = 4.0 * std::numbers::pi;
inline constexpr double kDegToRad = std::numbers::pi / 180.0;
inline constexpr double kRadToDeg = 180.0 / std::numbers::pi;

// Largest finite half-float value.
inline constexpr float kHalfMax = 65504.0f;

template <typename T>
constexpr T Square(T v) {
  return v * v;
}

template <typename T>
constexpr T Clamp(T v, T lo, T hi) {
  return v < lo ? lo : (v > hi ? hi : v);
}

// Tolerance for "slightly out of range" arguments: a few ulps of rounding
// error from upstream dot products.  Larger deviations are bugs.
template <typename T>
constexpr T kRangeSlack = T(1e-3);

// sqrt of a value that is mathematically >= 0 but may be slightly negative
// from rounding.
template <typename T>
inline T SafeSqrt(T x) {
  MR_DCHECK(!(x < -kRangeSlack<T>));
  return std::sqrt(std::max(T(0), x));
}

template <typename T>
inline T SafeACos(T x) {
  MR_DCHECK(!(x < T(-1) - kRangeSlack<T> || x > T(1) + kRangeSlack<T>));
  return std::acos(Clamp(x, T(-1), T(1)));
}

template <typename T>
inline T SafeASin(T x) {
  MR_DCHECK(!(x < T(-1) - kRangeSlack<T> || x > T(1) + kRangeSlack<T>));
  return std::asin(Clamp(x, T(-1), T(1)));
}

// a*b - c*d with one rounding error (Kahan's algorithm with FMA).
template <typename T>
inline T DifferenceOfProducts(T a, T b, T c, T d) {
  T cd = c * d;
  T err = std::fma(-c, d, cd);
  T dop = std::fma(a, b, -cd);
  return dop + err;
}

// Neumaier's compensated summation: the error does not grow with the number
// of terms, and it stays exact when a huge term is followed by tiny ones
// (a sun pixel among sky pixels).
template <typename T>
class CompensatedSum {
 public:
  CompensatedSum() = default;
  explicit CompensatedSum(T v) : sum_(v) {}

  CompensatedSum& operator+=(T v) {
    T t = sum_ + v;
    if (std::abs(sum_) >= std::abs(v))
      c_ += (sum_ - t) + v;
    else
      c_ += (v - t) + sum_;
    sum_ = t;
    return *this;
  }
  CompensatedSum& operator+=(const CompensatedSum& o) {
    *this += o.sum_;
    *this += o.c_;
    return *this;
  }
  T Value() const { return sum_ + c_; }
  explicit operator T() const { return Value(); }

 private:
  T sum_ = 0;
  T c_ = 0;
};

// Real roots of a x^2 + b x + c = 0 without cancellation (t0 <= t1).
// Returns false when there are none.  Handles a == 0 (linear).
template <typename T>
inline bool SolveQuadratic(T a, T b, T c, T* t0, T* t1) {
  if (a == 0) {
    if (b == 0) return false;
    *t0 = *t1 = -c / b;
    return true;
  }
  T discrim = DifferenceOfProducts(b, b, T(4) * a, c);
  if (discrim < 0) return false;
  T root = std::sqrt(discrim);
  T q = T(-0.5) * (b + std::copysign(root, b));
  if (q == 0) {  // b == 0 and c == 0
    *t0 = *t1 = 0;
    return true;
  }
  *t0 = q / a;
  *t1 = c / q;
  if (*t0 > *t1) std::swap(*t0, *t1);
  return true;
}

// Angle between two unit vectors, accurate near 0 and pi (unlike acos(dot)).
template <typename Vec>
inline auto AngleBetween(const Vec& a, const Vec& b) {
  using T = std::remove_cvref_t<decltype(a.dot(b))>;
  if (a.dot(b) < 0) return T(kPi) - T(2) * SafeASin(T((a + b).norm() / 2));
  return T(2) * SafeASin(T((b - a).norm() / 2));
}

// True when every value is finite.
template <typename It>
inline bool AllFinite(It begin, It end) {
  for (; begin != end; ++begin)
    if (!std::isfinite(*begin)) return false;
  return true;
}

}  // namespace mr
