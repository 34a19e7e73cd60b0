#include "synth/board_view.h"

#include <cmath>

#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"

namespace mr {

Image RenderBoardView(const BoardSpec& b, const CameraModel& camera, const Rigid3& cam_from_board,
                      const BoardViewOptions& o) {
  const int W = camera.width(), H = camera.height(), S = std::max(1, o.supersample);
  const Rigid3 board_from_cam = cam_from_board.Inverse();
  const Eigen::Matrix3d R = board_from_cam.rotation.toRotationMatrix();
  const Eigen::Vector3d c = board_from_cam.translation;  // camera centre in the board frame
  const double sq = b.square_m;
  const double paper = std::min(1.0, 0.9 * o.exposure), ink = std::min(1.0, 0.05 * o.exposure);
  // Board frame: inner corner (0, 0) at the origin; squares from -1 to inner+0 squares, margin one more.
  auto shade = [&](double x, double y) {
    const double u = x / sq + 1, v = y / sq + 1;  // in squares, 0 at the outer edge of the printed grid
    if (u < -1 || v < -1 || u > b.squares_x() + 1 || v > b.squares_y() + 1) return o.background * o.exposure;
    if (u < 0 || v < 0 || u >= b.squares_x() || v >= b.squares_y()) return paper;
    const int i = static_cast<int>(std::floor(u)), j = static_cast<int>(std::floor(v));
    return ((i + j) % 2 == 0) ? ink : paper;  // the top-left square is black
  };
  Image img = Image::Gray(W, H);
  ParallelFor(0, H, [&](int64_t y) {
    for (int x = 0; x < W; ++x) {
      double sum = 0;
      int n = 0;
      for (int sy = 0; sy < S; ++sy)
        for (int sx = 0; sx < S; ++sx) {
          const Eigen::Vector2d q(x - 0.5 + (sx + 0.5) / S, static_cast<double>(y) - 0.5 + (sy + 0.5) / S);
          Eigen::Vector3d d;
          ++n;
          if (!camera.Unproject(q, &d)) {
            sum += 0;  // outside the lens: black
            continue;
          }
          const Eigen::Vector3d db = R * d;
          double value = o.background * o.exposure;
          if (std::abs(db.z()) > 1e-12) {
            const double t = -c.z() / db.z();
            if (t > 0) value = shade(c.x() + t * db.x(), c.y() + t * db.y());
          }
          sum += std::min(1.0, value);
        }
      img.at(x, static_cast<int>(y), 0) = static_cast<float>(sum / n);
    }
  });
  if (o.blur_sigma_px > 0) {  // separable Gaussian
    const int r = static_cast<int>(std::ceil(3 * o.blur_sigma_px));
    std::vector<double> k(static_cast<size_t>(2 * r + 1));
    double ks = 0;
    for (int i = -r; i <= r; ++i) ks += k[static_cast<size_t>(i + r)] = std::exp(-0.5 * i * i / (o.blur_sigma_px * o.blur_sigma_px));
    for (auto& v : k) v /= ks;
    Image tmp = img;
    for (int pass = 0; pass < 2; ++pass) {
      const Image src = pass == 0 ? img : tmp;
      Image& dst = pass == 0 ? tmp : img;
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          double s = 0;
          for (int i = -r; i <= r; ++i) {
            const int xx = pass == 0 ? Clamp(x + i, 0, W - 1) : x, yy = pass == 1 ? Clamp(y + i, 0, H - 1) : y;
            s += k[static_cast<size_t>(i + r)] * src.at(xx, yy, 0);
          }
          dst.at(x, y, 0) = static_cast<float>(s);
        }
    }
  }
  if (o.noise_sigma > 0)
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        Pcg32 rng(o.seed, static_cast<uint64_t>(y) * W + x);
        const double u1 = std::max(1e-12, rng.NextDouble()), u2 = rng.NextDouble();
        const double g = std::sqrt(-2 * std::log(u1)) * std::cos(kTwoPi * u2);
        img.at(x, y, 0) = static_cast<float>(Clamp(img.at(x, y, 0) + o.noise_sigma * g, 0.0, 1.0));
      }
  return img;
}

}  // namespace mr
