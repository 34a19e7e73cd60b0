#include "render/pixel_accumulator.h"

#include <gtest/gtest.h>

namespace mr {
namespace {

// A 5x5 image whose pixels all took 16 identical samples (no noise) but the
// centre, whose samples alternate: the centre and its eight neighbours keep
// sampling (a neighbour's zero variance may be chance), the outer ring
// stops; a pixel below min_spp never stops and counts as noisy for its
// neighbours; a stop is kept.
TEST(AdaptiveSampling, AChanceZeroNextToNoiseKeepsSampling) {
  PixelAccumulator acc(5, 5);
  const std::vector<char> valid(25, 1);
  for (size_t i = 0; i < 25; ++i) {
    const int n = i == 24 ? 8 : 16;  // the last corner has too few samples
    acc.Count(i, n);
    for (int s = 0; s < n; ++s) {
      const double d = i == 12 ? (s % 2 ? 1.0 : 0.0) : 0.25;
      acc.Add(i, Eigen::Vector3d::Constant(1 + d), Eigen::Vector3d::Constant(1), false);
    }
  }
  AdaptiveSampling a;
  a.threshold = 1e-3;
  a.min_spp = 16;
  EXPECT_EQ(acc.CompositeRelVariance(0), 0.0);
  EXPECT_GT(acc.CompositeRelVariance(12), 1e-3);  // 0.25/15 / (1.5^2 + 0.01)
  std::vector<char> stopped(25, 0);
  // 25 - 9 (the centre's block) - 1 (too few samples) - 2 (next to it).
  EXPECT_EQ(UpdateAdaptiveStops(acc, a, valid, &stopped), 13);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) {
      const bool near_centre = std::abs(x - 2) <= 1 && std::abs(y - 2) <= 1;
      const bool near_corner = std::abs(x - 4) <= 1 && std::abs(y - 4) <= 1;
      EXPECT_EQ(stopped[static_cast<size_t>(y * 5 + x)], !near_centre && !near_corner) << x << " " << y;
    }
  // Stops are kept, and no pixel is counted twice.
  EXPECT_EQ(UpdateAdaptiveStops(acc, a, valid, &stopped), 0);
  // A pixel whose samples were all exactly zero (the object's change not
  // yet drawn) never stops, however converged it looks.
  PixelAccumulator zeros(3, 3);
  for (size_t i = 0; i < 9; ++i) {
    zeros.Count(i, 64);
    for (int s = 0; s < 64; ++s) zeros.Add(i, Eigen::Vector3d::Constant(0.5), Eigen::Vector3d::Constant(0.5), false);
  }
  EXPECT_EQ(zeros.CompositeRelVariance(4), 0.0);
  std::vector<char> z(9, 0);
  EXPECT_EQ(UpdateAdaptiveStops(zeros, a, std::vector<char>(9, 1), &z), 0);
  // Invalid pixels never stop.
  std::vector<char> none(25, 0);
  const std::vector<char> invalid(25, 0);
  EXPECT_EQ(UpdateAdaptiveStops(acc, a, invalid, &none), 0);
}

}  // namespace
}  // namespace mr
