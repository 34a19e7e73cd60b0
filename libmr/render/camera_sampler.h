// Camera rays of a frame, the same for every method.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/sampling.h"
#include "geometry/embree_scene.h"

namespace mr {

// Camera sample positions shared by the methods: sample s of pixel i of a
// frame has its own generator, seeded by (seed, frame, s, i), and its
// direction is the bilinear blend of the pixel's unprojected corners at the
// generator's first two numbers.
class CameraSampler {
 public:
  CameraSampler(const CameraModel& camera, const Rigid3& world_from_cam, uint64_t seed, int frame);
  int width() const { return width_; }
  int height() const { return height_; }
  // False for pixels outside the lens's valid region.
  bool PixelValid(int x, int y) const;
  // The generator of sample `s` of pixel (x, y), already advanced past the
  // two numbers that placed the camera ray `ray`.
  Pcg32 Sample(int x, int y, int s, Ray* ray) const;
  // World-space unit directions through the pixel's corners, in order around it.
  void CornerDirections(int x, int y, Eigen::Vector3d c[4]) const;
  const Rigid3& pose() const { return world_from_cam_; }

 private:
  int width_, height_;
  Rigid3 world_from_cam_;
  Eigen::Matrix3d R_;
  std::vector<Eigen::Vector3d> corner_dirs_;  // (W+1) x (H+1) unprojected pixel corners, camera frame
  std::vector<char> corner_ok_;
  uint64_t frame_seed_ = 0;
};

}  // namespace mr
