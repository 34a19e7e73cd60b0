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

// What one frame's exposure spreads its camera samples over (docs/conventions.md,
// "Shutter and lens"): the shutter interval, over which the camera moves
// from `open` through the frame's pose (at the interval's middle) to
// `close` (translation linear, rotation slerp, each half on its own), and a
// thin lens of `aperture_radius` focused at `focus_distance` along the
// optical axis (a plane, for directions less than 84 degrees from the
// axis; a sphere of that radius beyond, as a fish-eye past 90 degrees
// needs).  The default is neither: a pinhole at one instant.
struct CameraExposure {
  bool moves = false;
  Rigid3 open, close;
  double aperture_radius = 0;  // metres
  double focus_distance = 1;   // metres
  bool any() const { return moves || aperture_radius > 0; }
};

// The pose at fraction `t` of the way from `a` to `b` (t may lie outside
// [0, 1]: extrapolated).
Rigid3 InterpolatePose(const Rigid3& a, const Rigid3& b, double t);

// Camera sample positions shared by the methods: sample s of pixel i of a
// frame has its own generator, seeded by (seed, frame, s, i), and its
// direction is the bilinear blend of the pixel's unprojected corners at the
// generator's first two numbers.  With a CameraExposure the next numbers
// place the sample in the shutter interval (one) and on the lens (two).
class CameraSampler {
 public:
  CameraSampler(const CameraModel& camera, const Rigid3& world_from_cam, uint64_t seed, int frame,
                const CameraExposure& exposure = {});
  int width() const { return width_; }
  int height() const { return height_; }
  // False for pixels outside the lens's valid region.
  bool PixelValid(int x, int y) const;
  // The numbers of sample `s` of pixel (x, y): sample s of the pixel's
  // stratified sequence (Sampler), already past the draws that placed the
  // camera ray `ray` (the point in the pixel, then the shutter time and the
  // lens point where the exposure has them).
  Sampler Sample(int x, int y, int s, Ray* ray) const;
  // World-space unit directions through the pixel's corners, in order around
  // it, at the frame's pose (the middle of the shutter interval).
  void CornerDirections(int x, int y, Eigen::Vector3d c[4]) const;
  const Rigid3& pose() const { return world_from_cam_; }
  const CameraExposure& exposure() const { return exposure_; }

 private:
  int width_, height_;
  Rigid3 world_from_cam_;
  Eigen::Matrix3d R_;
  std::vector<Eigen::Vector3d> corner_dirs_;  // (W+1) x (H+1) unprojected pixel corners, camera frame
  std::vector<char> corner_ok_;
  uint64_t frame_seed_ = 0;
  CameraExposure exposure_;
};

}  // namespace mr
