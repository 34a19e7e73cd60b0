#include "calib/corners.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "core/image.h"
#include "test_util.h"

namespace mr {
namespace {

BoardSpec Board(const std::string& file) { return ReadBoard(fs::path(MR_SOURCE_DIR) / "calib" / "boards" / file); }

// Every `step`-th file of a folder, sorted (the detector takes about a
// second per photograph; the full sets run in the benchmarks).
std::vector<fs::path> Files(const fs::path& dir, const std::string& ext, size_t step) {
  std::vector<fs::path> all, out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ext) all.push_back(e.path());
  std::sort(all.begin(), all.end());
  for (size_t i = 0; i < all.size(); i += step) out.push_back(all[i]);
  return out;
}

TEST(Corners, SymmetriesOfBoards) {
  BoardSpec b;
  b.inner_x = 8;
  b.inner_y = 6;
  EXPECT_EQ(BoardSymmetries(b).size(), 2u);  // 9 x 7 squares: a half turn maps colours onto themselves
  b.inner_x = 9;
  EXPECT_EQ(BoardSymmetries(b).size(), 1u);  // 10 x 7 squares: it does not
  b.inner_x = b.inner_y = 10;
  const auto s = BoardSymmetries(b);
  ASSERT_EQ(s.size(), 4u);  // 11 x 11 squares: quarter turns too
  for (const auto& p : s) {  // each a permutation
    std::vector<int> q = p;
    std::sort(q.begin(), q.end());
    for (int i = 0; i < 100; ++i) ASSERT_EQ(q[static_cast<size_t>(i)], i);
  }
}

// The real fish-eye photographs of ../shared/data: the board is found in
// most of them, and where the half-turn symmetric 8x6 board is found, its
// corner 0 is the one nearest the top-left.
TEST(Corners, RealFisheyePhotographs) {
  MR_REQUIRE_SHARED_DATA("fisheye-mono-ros");
  const BoardSpec b = Board("chessboard-8x6.json");
  int found = 0, total = 0;
  for (const auto& f : Files(test::SharedData("fisheye-mono-ros") / "calibrationdata", ".png", 3)) {
    const CornerDetection d = DetectCorners(ReadImage(f), b, f.filename().string());
    ++total;
    if (!d.found) {
      std::printf("%s: %s\n", d.image.c_str(), d.reason.c_str());
      continue;
    }
    ++found;
    ASSERT_EQ(d.pixels.size(), 48u);
    EXPECT_FALSE(d.order.empty());
    EXPECT_LE(d.pixels.front().sum(), d.pixels.back().sum());
  }
  std::printf("found %d of %d\n", found, total);
  EXPECT_GE(found, total * 3 / 4);
}

TEST(Corners, RealStereoPhotographs) {
  MR_REQUIRE_SHARED_DATA("fisheye-stereo");
  const BoardSpec b = Board("chessboard-9x6-24.23mm.json");
  int found = 0, total = 0;
  for (const auto& f : Files(test::SharedData("fisheye-stereo") / "imgs", ".jpg", 5)) {
    const CornerDetection d = DetectCorners(ReadImage(f), b, f.filename().string());
    ++total;
    found += d.found;
    if (d.found) EXPECT_TRUE(d.order.empty());  // 10 x 7 squares: no symmetry to resolve
    else std::printf("%s: %s\n", d.image.c_str(), d.reason.c_str());
  }
  std::printf("found %d of %d\n", found, total);
  EXPECT_GE(found, total * 3 / 4);
}

}  // namespace
}  // namespace mr
