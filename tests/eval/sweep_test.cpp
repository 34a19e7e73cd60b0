// The sweep's answer to "which method reaches pt's error fastest"
// (eval/sweep.h, FastestAtPtErrors), on rows with known times and errors.
#include "eval/sweep.h"

#include <gtest/gtest.h>

namespace mr {
namespace {

SweepRow Row(const std::string& method, const std::string& setting, double seconds, double region, double whole) {
  SweepRow r;
  r.method = method;
  r.setting = setting;
  r.seconds = seconds;
  r.region_relmse = region;
  r.relmse = whole;
  r.frames = 1;
  return r;
}

TEST(Sweep, FastestAtEachOfPtsErrors) {
  std::vector<SweepRow> rows = {Row("pt", "spp=1", 0.1, 1e-2, 1e-3), Row("pt", "spp=4", 0.4, 4e-3, 4e-4),
                                Row("pt", "spp=16", 1.6, 1e-3, 1e-4), Row("ic", "rays=32", 0.3, 3e-3, 5e-4),
                                Row("vct", "resolution=16", 0.2, 5e-3, 2e-4)};
  const std::vector<FastestAtError> f = FastestAtPtErrors(rows);
  ASSERT_EQ(f.size(), 3u);
  // pt at 1 spp is the quickest run of all: nothing beats it at its error.
  EXPECT_EQ(f[0].method, "pt");
  EXPECT_DOUBLE_EQ(f[0].speedup, 1);
  // pt's 4-spp error (4e-3): ic reaches 3e-3 in 0.3 s, vct's 5e-3 does not count.
  EXPECT_EQ(f[1].method, "ic");
  EXPECT_DOUBLE_EQ(f[1].speedup, 0.4 / 0.3);
  // 1e-3: only pt itself; of the quicker runs, ic comes nearest (3 x its
  // error in 0.3 / 1.6 of its time).  At 1 spp no other run is quicker.
  EXPECT_EQ(f[2].method, "pt");
  EXPECT_EQ(f[2].setting, "spp=16");
  EXPECT_EQ(f[2].nearest_method, "ic");
  EXPECT_DOUBLE_EQ(f[2].nearest_error_ratio, 3e-3 / 1e-3);
  EXPECT_DOUBLE_EQ(f[2].nearest_time_ratio, 0.3 / 1.6);
  EXPECT_TRUE(f[0].nearest_method.empty());
  EXPECT_TRUE(f[1].nearest_method.empty());  // ic is the fastest there
  // Rows without a region error (0): the whole image's decides; vct's 2e-4
  // in 0.2 s is then at or below pt's 4-spp 4e-4.
  for (SweepRow& r : rows) r.region_relmse = 0;
  const std::vector<FastestAtError> w = FastestAtPtErrors(rows);
  EXPECT_EQ(w[1].method, "vct");
  EXPECT_DOUBLE_EQ(w[1].error, 4e-4);
  EXPECT_TRUE(FastestAtPtErrors({Row("ic", "rays=32", 0.3, 3e-3, 5e-4)}).empty());
}

}  // namespace
}  // namespace mr
