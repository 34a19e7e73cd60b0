#include "core/sampling.h"

#include <gtest/gtest.h>

#include <set>

namespace mr {
namespace {

TEST(Pcg32, MatchesReferenceImplementation) {
  // pcg32-demo (pcg-c-basic) with pcg32_srandom_r(&rng, 42u, 54u).
  Pcg32 rng(42u, 54u);
  const uint32_t expected[6] = {0xa15c02b7, 0x7b47f409, 0xba1d3330, 0x83d2f293, 0xbfa4784b, 0xcbed606e};
  for (uint32_t e : expected) EXPECT_EQ(rng.NextU32(), e);
}

TEST(Pcg32, AdvanceMatchesStepping) {
  Pcg32 a(7, 3), b(7, 3);
  for (int i = 0; i < 1000; ++i) a.NextU32();
  b.Advance(1000);
  EXPECT_EQ(a, b);
  b.Advance(-1000);
  EXPECT_EQ(b, Pcg32(7, 3));
}

TEST(Pcg32, FloatsStayBelowOneAndStreamsDiffer) {
  Pcg32 r(1, 1);
  for (int i = 0; i < 100000; ++i) {
    float f = r.NextFloat();
    ASSERT_GE(f, 0.0f);
    ASSERT_LT(f, 1.0f);
  }
  EXPECT_NE(Pcg32(1, 1).NextU32(), Pcg32(1, 2).NextU32());
  Pcg32 b(3, 4);
  for (int i = 0; i < 1000; ++i) ASSERT_LT(b.NextBounded(7), 7u);
}

TEST(Halton, RadicalInverseValues) {
  EXPECT_EQ(RadicalInverse(0, 0), 0.0);
  EXPECT_EQ(RadicalInverse(0, 1), 0.5);
  EXPECT_EQ(RadicalInverse(0, 2), 0.25);
  EXPECT_EQ(RadicalInverse(0, 3), 0.75);
  EXPECT_NEAR(RadicalInverse(1, 1), 1.0 / 3, 1e-15);
  EXPECT_NEAR(RadicalInverse(1, 5), 2.0 / 3 + 1.0 / 9, 1e-15);  // 5 = 12_3 -> 0.21_3
  EXPECT_LT(RadicalInverse(0, ~uint64_t{0}), 1.0);
}

// A (0,2)-sequence: each run of 2^m points has exactly one point in every
// elementary interval of area 2^-m.
// Returns the number of (elementary-interval shape) that are not stratified.
int UnstratifiedShapes(uint32_t first, int m, uint32_t seed, bool scramble) {
  const uint32_t n = 1u << m;
  int bad = 0;
  for (int a = 0; a <= m; ++a) {
    std::set<std::pair<int, int>> cells;
    for (uint32_t i = first; i < first + n; ++i) {
      auto p = Sobol2D(i, seed, scramble);
      cells.insert({static_cast<int>(p[0] * (1 << a)), static_cast<int>(p[1] * (1 << (m - a)))});
    }
    bad += cells.size() != n;
  }
  return bad;
}

TEST(Sobol, FirstTwoDimensionsAreA02Sequence) {
  for (int m = 1; m <= 8; ++m) {
    EXPECT_EQ(UnstratifiedShapes(0, m, 0, false), 0) << "m=" << m;
    EXPECT_EQ(UnstratifiedShapes(0, m, 12345, true), 0) << "m=" << m << " scrambled";
    EXPECT_EQ(UnstratifiedShapes(1u << m, m, 99, true), 0) << "m=" << m << " second run, scrambled";
  }
}

TEST(Sampling, CosineHemisphereHasTheRightMean) {
  // E[z] = 2/3 and E[z^2] = 1/2 under p = cos/pi; 65536 stratified points give
  // errors far below 1e-3 (the sequence is a (0,2)-net).
  double sz = 0, sz2 = 0;
  const int n = 1 << 16;
  for (int i = 0; i < n; ++i) {
    auto u = Sobol2D(static_cast<uint32_t>(i));
    auto d = SampleCosineHemisphere(u[0], u[1]);
    ASSERT_NEAR(d[0] * d[0] + d[1] * d[1] + d[2] * d[2], 1.0, 1e-12);
    ASSERT_GE(d[2], 0.0);
    sz += d[2];
    sz2 += d[2] * d[2];
  }
  EXPECT_NEAR(sz / n, 2.0 / 3, 1e-3);
  EXPECT_NEAR(sz2 / n, 0.5, 1e-3);
  auto s = SampleUniformSphere(0.0, 0.0);
  EXPECT_NEAR(s[2], 1.0, 1e-15);
}

}  // namespace
}  // namespace mr
