// Lanes: one computation done for many independent inputs at once, written
// as a loop over arrays that the compiler turns into SIMD instructions
// (docs/methods.md, "Lanes").  Each kernel here is an inline scalar function
// of plain arithmetic (no libm call, no branch, no table), so that
//  - a loop over it vectorises: 4 doubles a register with AVX2;
//  - the scalar call and every lane give the same bits (IEEE +, -, *, /
//    and sqrt are exact-rounded, and the files that hold lane loops are
//    compiled without fused multiply-add contraction), whatever the
//    instruction set the loop was compiled for.
// MR_LANES on a function that holds lane loops compiles it twice, for AVX2
// and for the baseline, and picks one at load time (GCC's target_clones).
#pragma once

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace mr {

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(MR_NO_LANE_CLONES)
#define MR_LANES __attribute__((target_clones("avx2", "default")))
#else
#define MR_LANES
#endif

// How many lanes a function stages on its stack at a time.
inline constexpr size_t kLaneChunk = 64;

// sin x and cos x, |error| <= 2.3e-16 for |x| <= 2 pi, accurate to 1e-15
// relative up to |x| = 1e5 (measured, tests/core/lanes_test.cpp); NaN for
// NaN or infinite x.  Reduction by pi/2 (Cody and Waite, two-part constant),
// then Taylor polynomials to degree 17 and 18 on [-pi/4, pi/4], whose
// truncation error is below 1e-19.
inline void SinCos(double x, double* s, double* c) {
  constexpr double kShift = 6755399441055744.0;  // 1.5 * 2^52: adding it rounds to an integer
  const double t = x * 0.63661977236758134308 + kShift;
  const uint64_t k = std::bit_cast<uint64_t>(t);  // the quadrant, in the low bits
  const double q = t - kShift;
  const double r = (x - q * 1.57079632673412561417e+00) - q * 6.07710050650619224932e-11;
  const double r2 = r * r;
  double sp = 1.0 / 355687428096000.0;  // 1/17!
  sp = sp * r2 - 1.0 / 1307674368000.0;
  sp = sp * r2 + 1.0 / 6227020800.0;
  sp = sp * r2 - 1.0 / 39916800.0;
  sp = sp * r2 + 1.0 / 362880.0;
  sp = sp * r2 - 1.0 / 5040.0;
  sp = sp * r2 + 1.0 / 120.0;
  sp = sp * r2 - 1.0 / 6.0;
  const double sr = r + r * r2 * sp;
  double cp = 1.0 / 6402373705728000.0;  // 1/18!
  cp = cp * r2 - 1.0 / 20922789888000.0;
  cp = cp * r2 + 1.0 / 87178291200.0;
  cp = cp * r2 - 1.0 / 479001600.0;
  cp = cp * r2 + 1.0 / 3628800.0;
  cp = cp * r2 - 1.0 / 40320.0;
  cp = cp * r2 + 1.0 / 720.0;
  cp = cp * r2 - 1.0 / 24.0;
  cp = cp * r2 + 0.5;
  const double cr = 1.0 - r2 * cp;
  const double ss = (k & 1) ? cr : sr, cc = (k & 1) ? sr : cr;
  *s = (k & 2) ? -ss : ss;
  *c = ((k + 1) & 2) ? -cc : cc;
}

// atan2(y, x) in [-pi, pi], |error| <= 4.5e-16 (measured,
// tests/core/lanes_test.cpp); Atan2(+-0, x) = +-0 for x >= 0 and +-pi for
// x < 0, +-0 for x = -0 (std::atan2 gives +-pi there); NaN in, NaN out.
// The ratio of the smaller to the larger magnitude a in [0, 1], reduced to
// |z| <= tan(pi/8) by atan a = pi/4 + atan((a - 1)/(a + 1)) above
// tan(pi/8); then atan z = z + z w P(w), w = z^2, P of degree 10 fitted to
// the series on Chebyshev nodes (its own error under 1e-16 on the range).
inline double Atan2(double y, double x) {
  constexpr double kPi = 3.14159265358979323846, kTanPi8 = 0.41421356237309503;
  const double ax = x < 0 ? -x : x, ay = y < 0 ? -y : y;
  const double big = ax > ay ? ax : ay, small = ax > ay ? ay : ax;
  const double a = small / (big == 0 ? 1.0 : big);
  const bool reduced = a > kTanPi8;
  const double z_reduced = (a - 1) / (a + 1);
  const double z = reduced ? z_reduced : a, offset = reduced ? kPi / 4 : 0.0;
  const double w = z * z;
  double p = -0.019973205041451468;
  p = p * w + 0.039875645418169514;
  p = p * w - 0.05107509596347854;
  p = p * w + 0.058623167250339676;
  p = p * w - 0.0666498517680449;
  p = p * w + 0.076922163288856;
  p = p * w - 0.09090905978053472;
  p = p * w + 0.11111111048769029;
  p = p * w - 0.14285714285061468;
  p = p * w + 0.19999999999997117;
  p = p * w - 0.33333333333333365;
  const double t0 = offset + (z + z * w * p);
  const double t1 = ay > ax ? kPi / 2 - t0 : t0;
  const double t2 = x < 0 ? kPi - t1 : t1;
  return std::copysign(t2, y);
}

}  // namespace mr
