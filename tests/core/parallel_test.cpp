#include "core/parallel.h"

#include <gtest/gtest.h>

#include <cstring>

#include "core/sampling.h"

namespace mr {
namespace {

double SumWithThreads(int threads) {
  SetThreadCount(threads);
  // Terms spanning 12 orders of magnitude, so that order matters for rounding.
  return DeterministicSum(
      0, 1'000'003,
      [](int64_t i) {
        Pcg32 rng(17, static_cast<uint64_t>(i));
        return std::pow(10.0, 12.0 * rng.NextDouble() - 6.0);
      },
      1000);
}

TEST(Parallel, SumsAreBitIdenticalForAnyThreadCount) {
  const double one = SumWithThreads(1);
  for (int t : {2, 3, 4, 8}) {
    double many = SumWithThreads(t);
    EXPECT_EQ(std::memcmp(&one, &many, sizeof(double)), 0) << t << " threads: " << many << " vs " << one;
  }
  SetThreadCount(0);
}

TEST(Parallel, PerIndexOutputsDoNotDependOnSchedule) {
  std::vector<float> a(10007), b(10007);
  auto fill = [](std::vector<float>* v) {
    ParallelFor(
        0, static_cast<int64_t>(v->size()),
        [&](int64_t i) {
          Pcg32 rng(5, static_cast<uint64_t>(i));  // one generator per index
          (*v)[static_cast<size_t>(i)] = rng.NextFloat();
        },
        13);
  };
  SetThreadCount(1);
  fill(&a);
  SetThreadCount(4);
  fill(&b);
  SetThreadCount(0);
  EXPECT_EQ(a, b);
  EXPECT_EQ(DeterministicSum(5, 5, [](int64_t) { return 1.0; }), 0.0);
}

}  // namespace
}  // namespace mr
