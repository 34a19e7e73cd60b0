#include "render/camera_sampler.h"

#include <algorithm>
#include <cmath>

#include "core/parallel.h"
#include "render/path_common.h"

namespace mr {

Rigid3 InterpolatePose(const Rigid3& a, const Rigid3& b, double t) {
  Eigen::Quaterniond qb = b.rotation;
  if (a.rotation.dot(qb) < 0) qb.coeffs() = -qb.coeffs();  // the shorter way round
  // Slerp written out (Eigen's clamps nothing but is defined on [0, 1]).
  const double cos_angle = std::clamp(a.rotation.dot(qb), -1.0, 1.0);
  const double angle = std::acos(cos_angle);
  Eigen::Quaterniond q;
  if (angle < 1e-9) {
    q = a.rotation;
  } else {
    const double sa = std::sin(angle);
    q.coeffs() = std::sin((1 - t) * angle) / sa * a.rotation.coeffs() + std::sin(t * angle) / sa * qb.coeffs();
  }
  return Rigid3(q.normalized(), (1 - t) * a.translation + t * b.translation);
}

CameraSampler::CameraSampler(const CameraModel& camera, const Rigid3& world_from_cam, uint64_t seed, int frame,
                             const CameraExposure& exposure)
    : width_(camera.width()),
      height_(camera.height()),
      world_from_cam_(world_from_cam),
      R_(world_from_cam.rotation.toRotationMatrix()),
      exposure_(exposure) {
  corner_dirs_.resize(static_cast<size_t>(width_ + 1) * (height_ + 1));
  corner_ok_.resize(corner_dirs_.size());
  // Each corner by Newton from its left neighbours' rays extrapolated (two
  // or three projections; libmrcal's general solve for a distorted lens
  // costs several times more); a row's first corners, or those after a
  // corner outside the lens' domain, by the general solve.  Rows are
  // independent: the same rays whatever the thread count.
  ParallelFor(0, height_ + 1, [&](int64_t y) {
    for (int x = 0; x <= width_; ++x) {
      const size_t i = static_cast<size_t>(y) * (width_ + 1) + x;
      const Eigen::Vector2d q(x - 0.5, static_cast<double>(y) - 0.5);
      Eigen::Vector3d d;
      if (x > 1 && corner_ok_[i - 1] && corner_ok_[i - 2])
        corner_ok_[i] = camera.UnprojectNear(q, 2 * corner_dirs_[i - 1] - corner_dirs_[i - 2], &d);
      else
        corner_ok_[i] = camera.Unproject(q, &d);
      corner_dirs_[i] = corner_ok_[i] ? d : Eigen::Vector3d::UnitZ();
    }
  });
  frame_seed_ = HashCombine(seed, static_cast<uint64_t>(frame));
}

bool CameraSampler::PixelValid(int x, int y) const {
  const size_t c00 = static_cast<size_t>(y) * (width_ + 1) + x, c10 = c00 + 1, c01 = c00 + width_ + 1, c11 = c01 + 1;
  return corner_ok_[c00] && corner_ok_[c10] && corner_ok_[c01] && corner_ok_[c11];
}

Sampler CameraSampler::Sample(int x, int y, int s, Ray* ray) const {
  const size_t i = static_cast<size_t>(y) * width_ + x;
  const size_t c00 = static_cast<size_t>(y) * (width_ + 1) + x, c10 = c00 + 1, c01 = c00 + width_ + 1, c11 = c01 + 1;
  // One sequence per pixel, sample s of it: samples depend on neither the
  // thread count nor how passes split them, and a pixel's first 2^m samples
  // are stratified in every draw.
  Sampler rng = Sampler::Stratified(HashCombine(frame_seed_, i), static_cast<uint32_t>(s));
  const auto [fx, fy] = rng.Next2D();
  const Eigen::Vector3d d = (1 - fy) * ((1 - fx) * corner_dirs_[c00] + fx * corner_dirs_[c10]) +
                            fy * ((1 - fx) * corner_dirs_[c01] + fx * corner_dirs_[c11]);
  // The pixel cone: the square root of the solid angle between its corners.
  const Eigen::Vector3d a = corner_dirs_[c00].normalized();
  const float spread = static_cast<float>(
      std::sqrt((corner_dirs_[c10].normalized() - a).cross(corner_dirs_[c01].normalized() - a).norm()));
  if (!exposure_.any()) {
    *ray = MakeRay(world_from_cam_.translation, (R_ * d).normalized(), kMaskAll);
    ray->cone_spread = std::isfinite(spread) ? spread : 0.0f;
    return rng;
  }
  Rigid3 pose = world_from_cam_;
  if (exposure_.moves) {
    const double t = rng.NextDouble();
    pose = t < 0.5 ? InterpolatePose(exposure_.open, world_from_cam_, 2 * t)
                   : InterpolatePose(world_from_cam_, exposure_.close, 2 * t - 1);
  }
  Eigen::Vector3d origin = Eigen::Vector3d::Zero(), dir = d.normalized();
  if (exposure_.aperture_radius > 0) {
    // Thin lens: the ray through the lens point that meets the pinhole ray
    // where it crosses the focal surface.
    const auto [u1, u2] = rng.Next2D();
    const double r = exposure_.aperture_radius * std::sqrt(u1), phi = 2 * 3.14159265358979323846 * u2;
    const double along = dir.z() > 0.1 ? exposure_.focus_distance / dir.z() : exposure_.focus_distance;
    const Eigen::Vector3d focus = along * dir;
    origin = Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), 0);
    dir = (focus - origin).normalized();
  }
  *ray = MakeRay(pose * origin, pose.rotation * dir, kMaskAll);
  ray->cone_spread = std::isfinite(spread) ? spread : 0.0f;
  return rng;
}

void CameraSampler::CornerDirections(int x, int y, Eigen::Vector3d c[4]) const {
  const size_t c00 = static_cast<size_t>(y) * (width_ + 1) + x, c10 = c00 + 1, c01 = c00 + width_ + 1, c11 = c01 + 1;
  c[0] = (R_ * corner_dirs_[c00]).normalized();
  c[1] = (R_ * corner_dirs_[c10]).normalized();
  c[2] = (R_ * corner_dirs_[c11]).normalized();
  c[3] = (R_ * corner_dirs_[c01]).normalized();
}

}  // namespace mr
