// Lanes (core/lanes.h): the kernels' accuracy, and lanes that give the
// scalar calls' bits.
#include "core/lanes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "core/math.h"
#include "core/sampling.h"

namespace mr {
namespace {

// SinCos against libm: |error| <= 2.3e-16 on [-2 pi, 2 pi] (a double's
// half-ulp at 1 is 1.1e-16; measured 1.1e-16), the quadrants' edges
// included; relative 1e-15 of the larger of the two at |x| up to 1e5.
TEST(Lanes, SinCosMatchesLibm) {
  Pcg32 rng(7);
  double worst = 0, worst_far = 0;
  auto check = [&](double x, double* w) {
    double s, c;
    SinCos(x, &s, &c);
    *w = std::max({*w, std::abs(s - std::sin(x)), std::abs(c - std::cos(x))});
  };
  for (int k = -8; k <= 8; ++k) {
    check(k * kPi / 4, &worst);
    check(std::nextafter(k * kPi / 4, 10.0), &worst);
    check(std::nextafter(k * kPi / 4, -10.0), &worst);
  }
  for (int i = 0; i < 200000; ++i) check((2 * rng.NextDouble() - 1) * kTwoPi, &worst);
  for (int i = 0; i < 20000; ++i) check((2 * rng.NextDouble() - 1) * 1e5, &worst_far);
  check(1e-300, &worst);
  check(0.0, &worst);
  EXPECT_LE(worst, 2.3e-16);
  EXPECT_LE(worst_far, 1e-15 * 1e0);
  double s, c;
  SinCos(-0.0, &s, &c);
  EXPECT_EQ(c, 1.0);
  for (double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity()}) {
    SinCos(bad, &s, &c);
    EXPECT_TRUE(std::isnan(s) && std::isnan(c)) << bad;
  }
}

// Atan2 against libm: |error| <= 4.5e-16 (measured 4.4e-16) over the whole
// circle, ratios of magnitudes from 1e-300 to 1e300, the axes and the
// octants' edges; the signs of zero and NaN as its contract says.
TEST(Lanes, Atan2MatchesLibm) {
  Pcg32 rng(5);
  double worst = 0;
  auto check = [&](double y, double x) {
    const double e = std::abs(Atan2(y, x) - std::atan2(y, x));
    worst = std::max(worst, e);
    return e;
  };
  for (int i = 0; i < 200000; ++i) {
    const double a = (2 * rng.NextDouble() - 1) * kPi;
    double s, c;
    SinCos(a, &s, &c);
    const double scale = std::pow(10.0, 600 * rng.NextDouble() - 300);
    check(s * scale, c * scale);
  }
  for (double y : {-1.0, 0.0, 1.0, 1e-300, -1e300})
    for (double x : {-1.0, 1.0, 1e-300, -1e300, 2.0, -0.5}) check(y, x);
  for (int k = -4; k <= 4; ++k) check(std::sin(k * kPi / 4), std::cos(k * kPi / 4));
  check(0.41421356237309503, 1.0);  // the reduction's edge
  check(0.41421356237309509, 1.0);
  EXPECT_LE(worst, 4.5e-16);
  EXPECT_EQ(Atan2(0.0, 1.0), 0.0);
  EXPECT_TRUE(std::signbit(Atan2(-0.0, 1.0)));
  EXPECT_NEAR(Atan2(0.0, -1.0), kPi, 1e-15);
  EXPECT_NEAR(Atan2(-0.0, -1.0), -kPi, 1e-15);
  EXPECT_EQ(Atan2(0.0, 0.0), 0.0);
  EXPECT_TRUE(std::isnan(Atan2(std::numeric_limits<double>::quiet_NaN(), 1.0)));
  EXPECT_TRUE(std::isnan(Atan2(1.0, std::numeric_limits<double>::quiet_NaN())));
}

// Samplers drawing ahead in lanes return, draw for draw, what they would
// have drawn one by one, and DropAhead puts back what was not drawn: 300
// samplers (chunks of 64 and a partial one) at different sample indices
// and dimensions, a pattern of 1D and 2D draws, a second round after it,
// one sampler stopping halfway, independent samplers left alone.
TEST(Lanes, DrawingAheadGivesTheSameNumbers) {
  const std::vector<uint8_t> pattern = {2, 2, 1, 2, 1, 2, 2, 1};
  std::vector<Sampler> ahead, plain;
  for (uint32_t i = 0; i < 300; ++i) {
    Sampler s = i % 7 == 3 ? Sampler::Random(11, i) : Sampler::Stratified(HashCombine(5, i % 13), i / 13);
    for (uint32_t k = 0; k < i % 5; ++k) s.NextDouble();  // different dimensions
    ahead.push_back(s);
    plain.push_back(s);
  }
  std::vector<Sampler*> ptrs;
  for (Sampler& s : ahead) ptrs.push_back(&s);
  int compared = 0;
  std::vector<double> values[2];
  for (int round = 0; round < 2; ++round) {
    Sampler::DrawAhead(ptrs, pattern, &values[round]);
    for (size_t i = 0; i < ahead.size(); ++i) {
      if (ahead[i].stratified()) {
        ASSERT_NE(ahead[i].Ahead(0), nullptr) << i;
      }
      for (size_t d = 0; d < pattern.size(); ++d) {
        if (round == 1 && i == 17 && d == 4) {  // this one stops here
          ahead[i].DropAhead();
          break;
        }
        if (pattern[d] == 1) {
          const double a = ahead[i].NextDouble(), b = plain[i].NextDouble();
          ASSERT_EQ(a, b) << i << " " << d;
        } else {
          const auto a = ahead[i].Next2D(), b = plain[i].Next2D();
          ASSERT_EQ(a, b) << i << " " << d;
        }
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 4000);
  // After the drop, sampler 17 continues as the plain one would.
  for (size_t i = 0; i < ahead.size(); ++i) ASSERT_EQ(ahead[i].Next2D(), plain[i].Next2D()) << i;
}

// The cosine hemisphere in lanes gives the scalar call's bits; the centre
// of the square maps to the pole, every point to the unit hemisphere.
TEST(Lanes, CosineHemisphereLanesGiveTheScalarBits) {
  Pcg32 rng(3);
  const size_t n = 1000;
  std::vector<double> u0(n), u1(n), x(n), y(n), z(n);
  for (size_t k = 0; k < n; ++k) {
    u0[k] = rng.NextDouble();
    u1[k] = rng.NextDouble();
  }
  u0[0] = u1[0] = 0.5;
  u0[1] = 0.0, u1[1] = 0.5;
  SampleCosineHemisphere(n, u0.data(), u1.data(), x.data(), y.data(), z.data());
  for (size_t k = 0; k < n; ++k) {
    const auto d = SampleCosineHemisphere(u0[k], u1[k]);
    ASSERT_EQ(d[0], x[k]) << k;
    ASSERT_EQ(d[1], y[k]) << k;
    ASSERT_EQ(d[2], z[k]) << k;
    ASSERT_NEAR(x[k] * x[k] + y[k] * y[k] + z[k] * z[k], 1.0, 1e-14);
    ASSERT_GE(z[k], 0.0);
  }
  EXPECT_EQ(z[0], 1.0);
  EXPECT_NEAR(x[1], -1.0, 1e-15);
}

}  // namespace
}  // namespace mr
