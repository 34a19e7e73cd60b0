#include "render/camera_sampler.h"

#include "core/parallel.h"
#include "render/path_common.h"

namespace mr {

CameraSampler::CameraSampler(const CameraModel& camera, const Rigid3& world_from_cam, uint64_t seed, int frame)
    : width_(camera.width()),
      height_(camera.height()),
      world_from_cam_(world_from_cam),
      R_(world_from_cam.rotation.toRotationMatrix()) {
  corner_dirs_.resize(static_cast<size_t>(width_ + 1) * (height_ + 1));
  corner_ok_.resize(corner_dirs_.size());
  ParallelFor(0, height_ + 1, [&](int64_t y) {
    for (int x = 0; x <= width_; ++x) {
      const size_t i = static_cast<size_t>(y) * (width_ + 1) + x;
      Eigen::Vector3d d;
      corner_ok_[i] = camera.Unproject(Eigen::Vector2d(x - 0.5, static_cast<double>(y) - 0.5), &d);
      corner_dirs_[i] = corner_ok_[i] ? d : Eigen::Vector3d::UnitZ();
    }
  });
  frame_seed_ = HashCombine(seed, static_cast<uint64_t>(frame));
}

bool CameraSampler::PixelValid(int x, int y) const {
  const size_t c00 = static_cast<size_t>(y) * (width_ + 1) + x, c10 = c00 + 1, c01 = c00 + width_ + 1, c11 = c01 + 1;
  return corner_ok_[c00] && corner_ok_[c10] && corner_ok_[c01] && corner_ok_[c11];
}

Pcg32 CameraSampler::Sample(int x, int y, int s, Ray* ray) const {
  const size_t i = static_cast<size_t>(y) * width_ + x;
  const size_t c00 = static_cast<size_t>(y) * (width_ + 1) + x, c10 = c00 + 1, c01 = c00 + width_ + 1, c11 = c01 + 1;
  // One generator per (pixel, sample index): samples are independent of
  // each other, of the thread count and of how passes split them.
  Pcg32 rng(HashCombine(frame_seed_, static_cast<uint64_t>(s)), i);
  const double fx = rng.NextDouble(), fy = rng.NextDouble();
  const Eigen::Vector3d d = (1 - fy) * ((1 - fx) * corner_dirs_[c00] + fx * corner_dirs_[c10]) +
                            fy * ((1 - fx) * corner_dirs_[c01] + fx * corner_dirs_[c11]);
  *ray = MakeRay(world_from_cam_.translation, (R_ * d).normalized(), kMaskAll);
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
