#include "core/sampling.h"

#include <gtest/gtest.h>

#include <set>
#include <vector>

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

// The draws of pixel `seed`'s samples 0..n-1 after `skip_1d` 1D draws and
// `skip_2d` 2D draws: draw `which` (1D or 2D).
std::vector<std::array<double, 2>> Draws(uint64_t seed, int n, int skip_1d, int skip_2d, bool two_d) {
  std::vector<std::array<double, 2>> out;
  for (int i = 0; i < n; ++i) {
    Sampler s = Sampler::Stratified(seed, static_cast<uint32_t>(i));
    for (int k = 0; k < skip_2d; ++k) s.Next2D();
    for (int k = 0; k < skip_1d; ++k) s.NextDouble();
    out.push_back(two_d ? s.Next2D() : std::array<double, 2>{s.NextDouble(), 0.0});
  }
  return out;
}

// In every 1D draw the first 2^m samples fall one in each interval of 2^-m.
TEST(Sampler, Every1DDrawIsStratifiedForPowerOfTwoPrefixes) {
  for (uint64_t seed : {0ull, 1ull, 0xdeadbeefull})
    for (int skip = 0; skip < 4; ++skip)
      for (int m = 0; m <= 12; ++m) {
        const int n = 1 << m;
        std::vector<int> bins(static_cast<size_t>(n), 0);
        for (const auto& u : Draws(seed, n, skip, skip % 2, false)) {
          ASSERT_GE(u[0], 0.0);
          ASSERT_LT(u[0], 1.0);
          ++bins[static_cast<size_t>(u[0] * n)];
        }
        for (int b : bins) ASSERT_EQ(b, 1) << "seed " << seed << " skip " << skip << " m " << m;
      }
}

// In every 2D draw the first 2^m samples form a (0,m,2)-net: exactly one
// point in each elementary box of 2^-a by 2^-(m-a).
TEST(Sampler, Every2DDrawIsA02Net) {
  for (uint64_t seed : {3ull, 77ull})
    for (int skip = 0; skip < 3; ++skip)
      for (int m = 0; m <= 10; ++m) {
        const int n = 1 << m;
        const auto pts = Draws(seed, n, skip, skip, true);
        for (int a = 0; a <= m; ++a) {
          std::vector<int> boxes(static_cast<size_t>(n), 0);
          for (const auto& u : pts) {
            const int bx = static_cast<int>(u[0] * (1 << a)), by = static_cast<int>(u[1] * (1 << (m - a)));
            ++boxes[static_cast<size_t>(bx * (1 << (m - a)) + by)];
          }
          for (int b : boxes) ASSERT_EQ(b, 1) << "seed " << seed << " skip " << skip << " m " << m << " a " << a;
        }
      }
}

// Different draws are decorrelated: two successive 1D draws of 4096
// samples, binned 16 x 16, fill the bins evenly (chi-square with 255
// degrees of freedom: mean 255, sd 22.6; the bound 400 is 6.4 sd).  Without
// the index shuffle the second draw is a function of the first (only 16 of
// the 256 bins are hit: chi-square 61 440).
TEST(Sampler, SuccessiveDrawsAreDecorrelated) {
  const int n = 4096;
  std::vector<int> bins(256, 0);
  for (int i = 0; i < n; ++i) {
    Sampler s = Sampler::Stratified(12345, static_cast<uint32_t>(i));
    const double a = s.NextDouble(), b = s.NextDouble();
    ++bins[static_cast<size_t>(static_cast<int>(a * 16) * 16 + static_cast<int>(b * 16))];
  }
  double chi2 = 0;
  for (int b : bins) chi2 += (b - 16.0) * (b - 16.0) / 16.0;
  EXPECT_LT(chi2, 400);
}

// Each point on its own is uniform over seeds (what keeps estimates
// unbiased): sample 5's first 1D draw over 20 000 pixels has mean 1/2 and
// variance 1/12 (standard errors 0.002 and 0.0006; tolerances five of them).
TEST(Sampler, EachPointIsUniformOverSeeds) {
  const int n = 20000;
  double sum = 0, sum2 = 0;
  for (int p = 0; p < n; ++p) {
    Sampler s = Sampler::Stratified(HashCombine(9, static_cast<uint64_t>(p)), 5);
    s.NextDouble();
    const double u = s.Next2D()[1];
    sum += u;
    sum2 += u * u;
  }
  EXPECT_NEAR(sum / n, 0.5, 0.01);
  EXPECT_NEAR(sum2 / n - (sum / n) * (sum / n), 1.0 / 12, 0.003);
}

// Independent mode draws what a Pcg32 draws; a copy continues where the
// original is (the real and mixed paths stay aligned).
TEST(Sampler, RandomModeIsPcg32AndCopiesContinueAligned) {
  Sampler s = Sampler::Random(17, 4);
  Pcg32 p(17, 4);
  for (int i = 0; i < 10; ++i) ASSERT_EQ(s.NextDouble(), p.NextDouble());
  const auto pair = s.Next2D();
  EXPECT_EQ(pair[0], p.NextDouble());
  EXPECT_EQ(pair[1], p.NextDouble());
  for (Sampler t : {Sampler::Random(5, 6), Sampler::Stratified(5, 6)}) {
    t.NextDouble();
    Sampler copy = t;
    for (int i = 0; i < 5; ++i) {
      EXPECT_EQ(copy.NextDouble(), t.NextDouble());
      EXPECT_EQ(copy.Next2D(), t.Next2D());
    }
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
