#include "probe/unwrap.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "core/check.h"
#include "core/error.h"
#include "core/json.h"
#include "core/json_node.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/spherical.h"

namespace mr {

void UnwrapOptions::Check() const {
  if (width < 8 || width > 16384 || width % 2 != 0)
    throw UsageError(fmt::format("map width {} must be even, 8-16384", width));
  if (!(reflectance > 0 && reflectance <= 1))
    throw UsageError(fmt::format("reflectance {} not in (0, 1]", reflectance));
  if (!(camera_cone_deg >= 0 && camera_cone_deg < 90)) throw UsageError("camera_cone_deg must be in [0, 90)");
}

bool MirrorSpherePoint(const Eigen::Vector3d& c, double R, const Eigen::Vector3d& d, Eigen::Vector3d* point) {
  const double L = c.norm();
  if (!(L > R)) return false;
  const Eigen::Vector3d e1 = -c / L;  // from the centre towards the camera
  Eigen::Vector3d w = d - d.dot(e1) * e1;
  const double wn = w.norm();
  if (wn < 1e-12) {
    if (d.dot(e1) <= 0) return false;  // straight behind the sphere
    *point = c + R * e1;
    return true;
  }
  const Eigen::Vector3d e2 = w / wn;
  const double phi = std::atan2(d.dot(e2), d.dot(e1));
  const double theta_max = std::acos(R / L);  // the rim: the view ray grazes
  auto psi = [&](double theta, Eigen::Vector3d* p) {
    const Eigen::Vector3d n = std::cos(theta) * e1 + std::sin(theta) * e2;
    *p = c + R * n;
    const Eigen::Vector3d v = p->normalized();
    const Eigen::Vector3d r = v - 2 * v.dot(n) * n;
    return std::atan2(r.dot(e2), r.dot(e1));
  };
  Eigen::Vector3d p;
  if (phi >= psi(theta_max, &p)) return false;  // behind the rim: blind
  double lo = 0, hi = theta_max;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (psi(mid, &p) < phi ? lo : hi) = mid;
  }
  psi(0.5 * (lo + hi), point);
  return true;
}

namespace {

// Shared by both unwrappers: `to_pixel` maps a camera-frame direction to a
// photograph pixel (false: not seen); `factor` weights a direction's
// confidence; `usable` marks photograph pixels that show the probe.
template <typename ToPixel, typename Factor>
Image Resample(const Image& photo, const std::vector<uint8_t>& usable, const std::vector<uint8_t>* clipped,
               const Eigen::Matrix3d& cam_from_env, const UnwrapOptions& o, double gain, const ToPixel& to_pixel,
               const Factor& factor, UnwrapReport* report) {
  const int W = o.width, H = o.width / 2;
  const int pw = photo.width(), ph = photo.height();
  int64_t n_clipped = 0;
  if (clipped) {
    MR_CHECK(clipped->size() == usable.size());
    for (size_t i = 0; i < usable.size(); ++i) n_clipped += usable[i] && (*clipped)[i];
  }
  const bool with_clipped = n_clipped > 0;
  Image env(W, H,
            with_clipped ? std::vector<std::string>{"R", "G", "B", "confidence.Y", "clipped.Y"}
                         : std::vector<std::string>{"R", "G", "B", "confidence.Y"});
  ParallelFor(0, H, [&](int64_t y) {
    for (int x = 0; x < W; ++x) {
      // The Jacobian in the map's angular units: steps of one map pixel's
      // height (pi / H) along two tangents of the direction (defined at the
      // poles too, where longitude steps vanish).
      const Eigen::Vector3d d_env = LatLongPixelToDirection(Eigen::Vector2d(x, y), W, H);
      Eigen::Vector3d t, b;
      CoordinateSystem(d_env, &t, &b);
      const double step = 0.5 * kPi / H;
      auto map = [&](const Eigen::Vector3d& dir, Eigen::Vector2d* q) {
        return to_pixel(cam_from_env * dir.normalized(), q);
      };
      Eigen::Vector2d q0, qx0, qx1, qy0, qy1;
      if (!map(d_env, &q0)) continue;
      Eigen::Matrix2d J;
      const bool x0 = map(d_env - step * t, &qx0), x1 = map(d_env + step * t, &qx1);
      const bool y0 = map(d_env - step * b, &qy0), y1 = map(d_env + step * b, &qy1);
      // A central difference, one-sided where only one side maps.
      auto column = [&](bool ok0, bool ok1, const Eigen::Vector2d& q_minus, const Eigen::Vector2d& q_plus,
                        Eigen::Vector2d* c) {
        if (ok0 && ok1)
          *c = q_plus - q_minus;
        else if (ok0 || ok1)
          *c = 2 * (ok1 ? q_plus - q0 : q0 - q_minus);
        return ok0 || ok1;
      };
      Eigen::Vector2d jx, jy;
      if (!column(x0, x1, qx0, qx1, &jx) || !column(y0, y1, qy0, qy1, &jy)) continue;
      J << jx, jy;
      const Eigen::Matrix2d S = J * J.transpose() / 4 + 0.25 * Eigen::Matrix2d::Identity();
      const Eigen::Matrix2d Q = S.inverse();
      const int rx = std::min(100, static_cast<int>(std::ceil(3 * std::sqrt(S(0, 0))))),
                ry = std::min(100, static_cast<int>(std::ceil(3 * std::sqrt(S(1, 1)))));
      const int cx = static_cast<int>(std::lround(q0.x())), cy = static_cast<int>(std::lround(q0.y()));
      double sum[3] = {0, 0, 0}, ws = 0, wall = 0, wclip = 0;
      for (int v = cy - ry; v <= cy + ry; ++v)
        for (int u = cx - rx; u <= cx + rx; ++u) {
          const Eigen::Vector2d dq(u - q0.x(), v - q0.y());
          const double e = dq.dot(Q * dq);
          if (e > 9) continue;
          const double wgt = std::exp(-0.5 * e);
          wall += wgt;
          if (u < 0 || v < 0 || u >= pw || v >= ph || !usable[static_cast<size_t>(v) * pw + u]) continue;
          ws += wgt;
          for (int c = 0; c < 3; ++c) sum[c] += wgt * photo.at(u, v, c);
          if (with_clipped && (*clipped)[static_cast<size_t>(v) * pw + u]) wclip += wgt;
        }
      if (!(ws > 0)) continue;
      for (int c = 0; c < 3; ++c) env.at(x, static_cast<int>(y), c) = static_cast<float>(gain * sum[c] / ws);
      env.at(x, static_cast<int>(y), 3) =
          static_cast<float>(std::abs(J.determinant()) * factor(cam_from_env * d_env) * ws / wall);
      if (with_clipped) env.at(x, static_cast<int>(y), 4) = static_cast<float>(wclip / ws);
    }
  });
  if (report) {
    double seen = 0, total = 0;
    std::vector<float> conf;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const double sa = LatLongPixelSolidAngle(x, y, W, H);
        total += sa;
        if (env.at(x, y, 3) > 0) {
          seen += sa;
          conf.push_back(env.at(x, y, 3));
        }
      }
    report->seen_fraction = seen / total;
    report->clipped_pixels = n_clipped;
    double clipped_sa = 0;
    if (with_clipped)
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
          if (env.at(x, y, 3) > 0 && env.at(x, y, 4) > 0) clipped_sa += LatLongPixelSolidAngle(x, y, W, H);
    report->clipped_fraction = seen > 0 ? clipped_sa / seen : 0;
    report->blind_fraction = 1 - report->seen_fraction;
    if (!conf.empty()) {
      std::nth_element(conf.begin(), conf.begin() + static_cast<std::ptrdiff_t>(conf.size() / 2), conf.end());
      report->median_confidence = conf[conf.size() / 2];
    }
  }
  return env;
}

void CheckPhoto(const Image& photo, const CameraModel& camera, const std::string& name) {
  if (photo.width() != camera.width() || photo.height() != camera.height())
    ThrowErrorAt(FileLoc{name}, "is {}x{} but its camera model is {}x{}", photo.width(), photo.height(), camera.width(),
                 camera.height());
  if (photo.channels() < 3 || photo.channel_names()[0] != "R")
    ThrowErrorAt(FileLoc{name}, "needs R, G, B channels first");
  for (int y = 0; y < photo.height(); ++y)
    for (int x = 0; x < photo.width(); ++x)
      for (int c = 0; c < 3; ++c)
        if (!std::isfinite(photo.at(x, y, c)) || photo.at(x, y, c) < 0)
          ThrowErrorAt(FileLoc{name}, "pixel ({}, {}) is {}: radiance must be finite and non-negative", x, y,
                       photo.at(x, y, c));
}

}  // namespace

Image UnwrapMirrorSphere(const Image& photo, const ProbeGeometry& probe, const UnwrapOptions& o,
                         const std::string& name, UnwrapReport* report, const std::vector<uint8_t>* clipped) {
  o.Check();
  CheckPhoto(photo, probe.camera, name);
  const Eigen::Vector3d& c = probe.centre_cam;
  const double R = probe.radius_m;
  // Photograph pixels whose ray meets the sphere.
  std::vector<uint8_t> on_sphere(static_cast<size_t>(photo.pixel_count()), 0);
  const double c2 = c.squaredNorm() - R * R;
  ParallelFor(0, photo.height(), [&](int64_t y) {
    for (int x = 0; x < photo.width(); ++x) {
      Eigen::Vector3d d;
      if (!probe.camera.Unproject(Eigen::Vector2d(x, y), &d)) continue;
      d.normalize();
      const double b = d.dot(c);
      on_sphere[static_cast<size_t>(y) * photo.width() + x] = b > 0 && b * b - c2 >= 0;
    }
  });
  const Eigen::Matrix3d cam_from_env = probe.world_from_cam.transpose() * o.rotate.transpose();
  const Eigen::Vector3d towards_camera = -c.normalized();
  const double cone = o.camera_cone_deg * kDegToRad;
  return Resample(
      photo, on_sphere, clipped, cam_from_env, o, 1.0 / o.reflectance,
      [&](const Eigen::Vector3d& d, Eigen::Vector2d* q) {
        Eigen::Vector3d p;
        return MirrorSpherePoint(c, R, d, &p) && probe.camera.Project(p, q);
      },
      [&](const Eigen::Vector3d& d) {
        if (cone <= 0) return 1.0;
        const double a = std::acos(std::clamp(d.dot(towards_camera), -1.0, 1.0));
        if (a >= cone) return 1.0;
        const double u = a / cone;
        return 1e-3 + (1 - 1e-3) * u * u * (3 - 2 * u);  // smoothstep from 1e-3
      },
      report);
}

Image UnwrapFisheye(const Image& photo, const CameraModel& camera, const Eigen::Matrix3d& world_from_cam,
                    const UnwrapOptions& o, const std::string& name, UnwrapReport* report,
                    const std::vector<uint8_t>* clipped) {
  o.Check();
  CheckPhoto(photo, camera, name);
  std::vector<uint8_t> imaged(static_cast<size_t>(photo.pixel_count()), 0);
  ParallelFor(0, photo.height(), [&](int64_t y) {
    for (int x = 0; x < photo.width(); ++x) {
      Eigen::Vector3d d;
      imaged[static_cast<size_t>(y) * photo.width() + x] = camera.Unproject(Eigen::Vector2d(x, y), &d);
    }
  });
  const Eigen::Matrix3d cam_from_env = world_from_cam.transpose() * o.rotate.transpose();
  return Resample(
      photo, imaged, clipped, cam_from_env, o, 1.0 / o.reflectance,
      [&](const Eigen::Vector3d& d, Eigen::Vector2d* q) {
        if (!camera.Project(d, q)) return false;
        return q->x() >= -0.5 && q->y() >= -0.5 && q->x() <= camera.width() - 0.5 && q->y() <= camera.height() - 0.5;
      },
      [](const Eigen::Vector3d&) { return 1.0; }, report);
}

Image MergeProbeViews(const std::vector<Image>& views) {
  if (views.empty()) ThrowError("no views to merge");
  bool any_clipped = false;
  for (const Image& v : views) {
    if (v.width() != views[0].width() || v.height() != views[0].height() || v.channels() < 4 ||
        v.channel_names()[3] != "confidence.Y")
      ThrowError("probe views differ in size or layers");
    any_clipped = any_clipped || v.ChannelIndex("clipped.Y") >= 0;
  }
  Image out(views[0].width(), views[0].height(),
            any_clipped ? std::vector<std::string>{"R", "G", "B", "confidence.Y", "clipped.Y"}
                        : std::vector<std::string>{"R", "G", "B", "confidence.Y"});
  const int no = out.channels();
  for (int64_t p = 0; p < out.pixel_count(); ++p) {
    double sum[3] = {0, 0, 0}, ws = 0, wclip = 0;
    for (const Image& v : views) {
      const float* px = &v.values()[static_cast<size_t>(p * v.channels())];
      ws += px[3];
      for (int c = 0; c < 3; ++c) sum[c] += px[3] * px[c];
      if (v.channels() > 4) wclip += px[3] * px[4];
    }
    float* o = &out.values()[static_cast<size_t>(p * no)];
    for (int c = 0; c < 3; ++c) o[c] = ws > 0 ? static_cast<float>(sum[c] / ws) : 0.0f;
    o[3] = static_cast<float>(ws);
    if (any_clipped) o[4] = ws > 0 ? static_cast<float>(wclip / ws) : 0.0f;
  }
  return out;
}

}  // namespace mr
