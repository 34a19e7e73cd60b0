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

// The generated ChArUco board is the one OpenCV detects: every marker and
// every inner corner is found, each corner where the board geometry puts it.
TEST(Board, CharucoBoardIsDetectedWithEveryCorner) {
  BoardSpec b = ReadBoard(fs::path(MR_SOURCE_DIR) / "calib" / "boards" / "charuco-8x11-A4.json");
  const double ppmm = 4.0;  // 96 px squares, 72 px markers: well above detection limits
  Image img = CharucoImage(b, ppmm);
  EXPECT_EQ(img.width(), 768);
  EXPECT_EQ(img.height(), 1056);
  // Detection wants a quiet zone around the board: pad with white.
  const int pad = 40;
  Image padded = Image::Gray(img.width() + 2 * pad, img.height() + 2 * pad, 1.0f);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) padded.at(x + pad, y + pad, 0) = img.at(x, y, 0);
  CharucoDetection d = DetectCharuco(b, padded);
  EXPECT_EQ(d.markers, b.squares_x() * b.squares_y() / 2);  // 44 markers in the white squares
  ASSERT_EQ(d.ids.size(), static_cast<size_t>(b.inner_x * b.inner_y));
  // Corner id k sits at inner corner (k % inner_x, k / inner_x), one square in
  // from the board's top-left, on the pixel edge (x.5 in mr's convention).
  // OpenCV 4.6 reports these ideal step corners +0.49 px off in x and y (a
  // half-pixel convention bias, measured here; mr-calibrate must correct it),
  // so 0.75 px bounds the error: a wrong layout would be off by a square.
  const double sq_px = b.square_m * 1000.0 * ppmm;
  double worst = 0;
  for (size_t i = 0; i < d.ids.size(); ++i) {
    const int k = d.ids[i];
    Eigen::Vector2d expected(pad - 0.5 + sq_px * (1 + k % b.inner_x), pad - 0.5 + sq_px * (1 + k / b.inner_x));
    worst = std::max(worst, (d.corners[i] - expected).norm());
  }
  EXPECT_LT(worst, 0.75);
  std::string svg = BoardSvg(b);
  EXPECT_NE(svg.find("width=\"212mm\""), std::string::npos);                    // 8 x 24 mm + 2 x 10 mm
  EXPECT_NE(svg.find("data:image/png;base64,iVBORw0KGgo"), std::string::npos);  // PNG magic
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
  EXPECT_EQ(err(R"({"inner_corners": [10], "square_mm": 30})"),
            "b.json: inner_corners: expected 2 integers [per row, per column]");
  EXPECT_EQ(err(R"({"inner_corners": [10, 10], "square_mm": -1})"),
            "b.json: square_mm: expected a positive number (millimetres)");
  EXPECT_EQ(err(R"({"inner_corners": [10, 10], "square_mm": 30, "colour": 1})"), "b.json: colour: unknown key");
}

}  // namespace
}  // namespace mr
