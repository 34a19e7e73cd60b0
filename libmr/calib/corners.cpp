#include "calib/corners.h"

#include <mrgingham/mrgingham.hh>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdlib>

#include "core/error.h"

namespace mr {

std::vector<std::vector<int>> BoardSymmetries(const BoardSpec& b) {
  const int nx = b.inner_x, ny = b.inner_y, n = nx * ny;
  std::vector<std::vector<int>> out;
  std::vector<int> id(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) id[static_cast<size_t>(i)] = i;
  out.push_back(id);
  if (b.type != "chessboard") return out;  // ChArUco markers fix the order
  // Squares (i, j) keep their colour under a half turn iff (nx + ny) is even.
  if ((nx + ny) % 2 == 0) {
    std::vector<int> half(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) half[static_cast<size_t>(i)] = n - 1 - i;
    out.push_back(half);
    if (nx == ny) {  // and a quarter turn: corner (x, y) -> (y, n-1-x) and back
      std::vector<int> q1(static_cast<size_t>(n)), q3(static_cast<size_t>(n));
      for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x) {
          q1[static_cast<size_t>(y * nx + x)] = x * nx + (nx - 1 - y);
          q3[static_cast<size_t>(y * nx + x)] = (nx - 1 - x) * nx + y;
        }
      out.push_back(q1);
      out.push_back(q3);
    }
  }
  return out;
}

namespace {

cv::Mat ToGray8(const Image& img) {
  cv::Mat m(img.height(), img.width(), CV_8UC1);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      double v = 0;
      for (int c = 0; c < img.channels(); ++c) v += img.at(x, y, c);
      v /= img.channels();
      m.at<uint8_t>(y, x) = static_cast<uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255));
    }
  return m;
}

// Among the symmetric orderings, the one whose corner 0 is nearest the
// image's top-left.
void FixOrder(const BoardSpec& b, CornerDetection* d) {
  const auto syms = BoardSymmetries(b);
  if (syms.size() == 1 || d->pixels.size() != static_cast<size_t>(b.inner_x * b.inner_y)) return;
  size_t best = 0;
  double best_score = INFINITY;
  for (size_t s = 0; s < syms.size(); ++s) {
    // Under ordering s, board corner 0 is detected corner syms[s][0].
    const Eigen::Vector2d& p = d->pixels[static_cast<size_t>(syms[s][0])];
    const double score = p.x() + p.y();
    if (score < best_score) {
      best_score = score;
      best = s;
    }
  }
  std::vector<Eigen::Vector2d> reordered(d->pixels.size());
  for (size_t i = 0; i < reordered.size(); ++i) reordered[i] = d->pixels[static_cast<size_t>(syms[best][i])];
  d->pixels = reordered;
  d->order = fmt::format(
      "the board looks the same turned by {} degrees: corner 0 taken as the one nearest the "
      "image's top-left{}",
      syms.size() == 2 ? "180" : "90", best == 0 ? "" : " (reordered)");
}

}  // namespace

CornerDetection DetectCorners(const Image& gray, const BoardSpec& b, const std::string& name, const CornerOptions& o) {
  CornerDetection d;
  d.image = name;
  const cv::Mat m = ToGray8(gray);
  d.saturated_fraction = static_cast<double>(cv::countNonZero(m >= 254)) / static_cast<double>(m.total());
  const int n = b.inner_x * b.inner_y;
  if (b.type == "chessboard" && b.detector == "mrgingham") {
    if (b.inner_x != b.inner_y)
      ThrowErrorAt(FileLoc{b.name},
                   "mrgingham finds square grids only; this board has {}x{} inner corners: use "
                   "detector \"opencv\"",
                   b.inner_x, b.inner_y);
    d.detector = "mrgingham";
    std::vector<mrgingham::PointDouble> pts;
    signed char* levels = nullptr;
    const int level = mrgingham::find_chessboard_from_image_array(pts, &levels, b.inner_x, m, -1);
    std::free(levels);
    if (level >= 0 && static_cast<int>(pts.size()) == n) {
      d.found = true;
      for (const auto& p : pts) d.pixels.emplace_back(p.x, p.y);
    }
  } else if (b.type == "chessboard") {
    d.detector = "opencv-sb";
    std::vector<cv::Point2f> pts;
    const bool ok = cv::findChessboardCornersSB(m, cv::Size(b.inner_x, b.inner_y), pts,
                                                cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
    if (ok && static_cast<int>(pts.size()) == n) {
      d.found = true;
      for (const auto& p : pts) d.pixels.emplace_back(p.x, p.y);
      const cv::Scalar sharp = cv::estimateChessboardSharpness(m, cv::Size(b.inner_x, b.inner_y), pts);
      d.sharpness_px = sharp[0];
    }
  } else {
    d.detector = "opencv-charuco";
    const CharucoDetection c = DetectCharuco(b, gray);
    if (c.ids.size() >= 4) {
      d.found = true;
      d.pixels = c.corners;
      d.ids = c.ids;
    } else {
      d.reason = fmt::format("{} ChArUco corners from {} markers (at least 4 needed)", c.ids.size(), c.markers);
    }
  }
  if (d.found && d.ids.empty()) {
    FixOrder(b, &d);
    for (int i = 0; i < n; ++i) d.ids.push_back(i);
  }
  if (d.found && d.sharpness_px > o.max_sharpness_px) {
    d.found = false;
    d.reason = fmt::format("blurry: edges {:.1f} px wide (limit {:.1f}); corners would be unreliable", d.sharpness_px,
                           o.max_sharpness_px);
  }
  if (!d.found && d.reason.empty()) {
    if (d.saturated_fraction > o.max_saturated)
      d.reason = fmt::format("over-exposed: {:.0f}% of the pixels are clipped", 100 * d.saturated_fraction);
    else
      d.reason = fmt::format("no {}x{} board found", b.inner_x, b.inner_y);
  }
  return d;
}

}  // namespace mr
