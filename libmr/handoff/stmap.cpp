#include "handoff/stmap.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <vector>

#include "core/error.h"
#include "core/math.h"
#include "core/parallel.h"

namespace mr {

namespace {

void SetSt(Image* img, int x, int y, double s, double t) {
  img->at(x, y, 0) = static_cast<float>(s);
  img->at(x, y, 1) = static_cast<float>(t);
  img->at(x, y, 2) = 1;  // Blender's Map UV node reads B as the alpha (its UV pass's)
  img->at(x, y, 3) = 1;
}

void SetUnmapped(Image* img, int x, int y) {
  img->at(x, y, 0) = img->at(x, y, 1) = -1;
  img->at(x, y, 2) = img->at(x, y, 3) = 0;
}

}  // namespace

StMaps MakeStMaps(const CameraModel& lens, double max_angle_deg) {
  if (!(max_angle_deg > 0 && max_angle_deg < 90))
    throw Error(fmt::format("ST-maps: the widest angle must lie in (0, 90) degrees, not {}", max_angle_deg));
  const int w = lens.width(), h = lens.height();
  const Eigen::Vector4d core = lens.Core();
  const double fx = core[0], fy = core[1], cx = core[2], cy = core[3];
  const double cos_max = std::cos(max_angle_deg * kDegToRad);
  // Every lens pixel's ray (Newton from the left neighbours' extrapolation,
  // as the renderer's camera rays); rows are independent.
  std::vector<Eigen::Vector3d> dirs(static_cast<size_t>(w) * h);
  std::vector<char> ok(dirs.size(), 0);
  ParallelFor(0, h, [&](int64_t y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const Eigen::Vector2d q(x, static_cast<double>(y));
      Eigen::Vector3d d;
      const bool good = x > 1 && ok[i - 1] && ok[i - 2] ? lens.UnprojectNear(q, 2 * dirs[i - 1] - dirs[i - 2], &d)
                                                        : lens.Unproject(q, &d);
      ok[i] = good && d.allFinite() && d.norm() > 0;
      dirs[i] = ok[i] ? Eigen::Vector3d(d.normalized()) : Eigen::Vector3d::UnitZ();
    }
  });
  // Where the lens's rays land on the core's image plane: the overscan.
  double lo_x = -0.5, hi_x = w - 0.5, lo_y = -0.5, hi_y = h - 0.5;
  for (size_t i = 0; i < dirs.size(); ++i) {
    if (!ok[i] || dirs[i].z() < cos_max) continue;
    const double px = fx * dirs[i].x() / dirs[i].z() + cx, py = fy * dirs[i].y() / dirs[i].z() + cy;
    lo_x = std::min(lo_x, px - 0.5), hi_x = std::max(hi_x, px + 0.5);
    lo_y = std::min(lo_y, py - 0.5), hi_y = std::max(hi_y, py + 0.5);
  }
  StMaps m;
  m.max_angle_deg = max_angle_deg;
  // Whole pixels, the unprojection's round-off (1e-12 px) not counted.
  auto grow = [](double by) { return std::max(0, static_cast<int>(std::ceil(by - 1e-6))); };
  m.overscan_left = grow(-0.5 - lo_x);
  m.overscan_top = grow(-0.5 - lo_y);
  const int right = grow(hi_x - (w - 0.5)), bottom = grow(hi_y - (h - 0.5));
  const int W = w + m.overscan_left + right, H = h + m.overscan_top + bottom;
  if (static_cast<int64_t>(W) * H > int64_t{16} * w * h + 4096)
    throw Error(
        fmt::format("ST-maps of {}: the pinhole holding its view within {} degrees would be {} x {} pixels; "
                    "give a smaller widest angle",
                    lens.lensmodel(), max_angle_deg, W, H));
  const double cxu = cx + m.overscan_left, cyu = cy + m.overscan_top;
  m.pinhole = CameraModel("LENSMODEL_PINHOLE", {fx, fy, cxu, cyu}, W, H);
  m.redistort = Image::Rgba(w, h);
  std::atomic<int64_t> unmapped{0};
  ParallelFor(0, h, [&](int64_t y) {
    int64_t row = 0;
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (!ok[i] || dirs[i].z() < cos_max) {
        SetUnmapped(&m.redistort, x, static_cast<int>(y));
        ++row;
        continue;
      }
      const double px = fx * dirs[i].x() / dirs[i].z() + cxu, py = fy * dirs[i].y() / dirs[i].z() + cyu;
      SetSt(&m.redistort, x, static_cast<int>(y), (px + 0.5) / W, 1 - (py + 0.5) / H);
    }
    unmapped += row;
  });
  m.unmapped = unmapped.load();
  // A direction outside the lens's calibrated domain can project into the
  // image where the polynomial folds back: kept only where the lens pixel
  // it lands on sees it (within two pixels' angle).
  auto SameRay = [&](const Eigen::Vector3d& d, const Eigen::Vector2d& q) {
    const int x = std::clamp(static_cast<int>(std::lround(q.x())), 0, w - 1);
    const int y = std::clamp(static_cast<int>(std::lround(q.y())), 0, h - 1);
    const size_t i = static_cast<size_t>(y) * w + x;
    if (!ok[i]) return false;
    const size_t j = x + 1 < w ? i + 1 : i - 1, k = y + 1 < h ? i + w : i - w;
    const double pixel = std::max(std::acos(std::clamp(dirs[i].dot(dirs[j]), -1.0, 1.0)),
                                  std::acos(std::clamp(dirs[i].dot(dirs[k]), -1.0, 1.0)));
    return std::acos(std::clamp(d.dot(dirs[i]), -1.0, 1.0)) <= 2 * pixel + 1e-9;
  };
  m.undistort = Image::Rgba(W, H);
  ParallelFor(0, H, [&](int64_t y) {
    for (int x = 0; x < W; ++x) {
      const Eigen::Vector3d d((x - cxu) / fx, (static_cast<double>(y) - cyu) / fy, 1);
      Eigen::Vector2d q;
      if (d.normalized().z() >= cos_max && lens.Project(d, &q) && q.allFinite() && q.x() >= -0.5 && q.x() <= w - 0.5 &&
          q.y() >= -0.5 && q.y() <= h - 0.5 && SameRay(d.normalized(), q))
        SetSt(&m.undistort, x, static_cast<int>(y), (q.x() + 0.5) / w, 1 - (q.y() + 0.5) / h);
      else
        SetUnmapped(&m.undistort, x, static_cast<int>(y));
    }
  });
  return m;
}

}  // namespace mr
