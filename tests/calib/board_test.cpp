#include "calib/board.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "test_util.h"

namespace mr {
namespace {

TEST(Board, BundledDefinitionsParse) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(fs::path(MR_SOURCE_DIR) / "calib" / "boards")) {
    BoardSpec b = ReadBoard(e.path());
    EXPECT_GT(b.square_m, 0) << e.path();
    ++n;
  }
  EXPECT_GE(n, 3);
}

TEST(Board, ObjectPointsAndSvgSize) {
  BoardSpec b = ParseBoard(ParseJsonStrict(R"({"name": "t", "inner_corners": [10, 7], "square_mm": 30})", "t"), "t");
  auto p = b.ObjectPoints();
  ASSERT_EQ(p.size(), 70u);
  EXPECT_EQ(p[1], Eigen::Vector3d(0.03, 0, 0));   // x along a row
  EXPECT_EQ(p[10], Eigen::Vector3d(0, 0.03, 0));  // next row
  std::string svg = BoardSvg(b, 0.01);
  // 11 squares of 30 mm + 2 x 10 mm margin = 350 mm wide.
  EXPECT_NE(svg.find("width=\"350mm\""), std::string::npos);
  // 11 x 8 squares, half of them black (rounded up): 44.
  size_t rects = 0;
  for (size_t pos = 0; (pos = svg.find("<rect", pos)) != std::string::npos; ++pos) ++rects;
  EXPECT_EQ(rects, 44u + 1u);  // + the white background
}

TEST(Board, BadDefinitionsNameTheKey) {
  auto err = [](const char* text) {
    try {
      ParseBoard(ParseJsonStrict(text, "b.json"), "b.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(err(R"({"inner_corners": [10], "square_mm": 30})"), "b.json: inner_corners: expected 2 integers [per row, per column]");
  EXPECT_EQ(err(R"({"inner_corners": [10, 10], "square_mm": -1})"), "b.json: square_mm: expected a positive number (millimetres)");
  EXPECT_EQ(err(R"({"inner_corners": [10, 10], "square_mm": 30, "colour": 1})"), "b.json: colour: unknown key");
}

}  // namespace
}  // namespace mr
