// The camera's shutter interval and lens (render/camera_sampler.h): the
// geometry of the samples, exactly.
#include <gtest/gtest.h>

#include <cmath>

#include "gi_scenes.h"
#include "render/camera_sampler.h"

namespace mr {
namespace {

const CameraModel kCam = gi_test::Pinhole(32, 24, 30);

Rigid3 Pose(double yaw, const Eigen::Vector3d& t) {
  return Rigid3(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY())), t);
}

// Without an exposure the samples are the pinhole's, bit for bit, and an
// aperture of 0 with no motion is no exposure.
TEST(CameraExposure, NoneIsThePinhole) {
  const Rigid3 pose = Pose(0.3, {1, 2, 3});
  const CameraSampler a(kCam, pose, 5, 2), b(kCam, pose, 5, 2, CameraExposure{});
  for (int s = 0; s < 4; ++s) {
    Ray ra, rb;
    a.Sample(7, 9, s, &ra);
    b.Sample(7, 9, s, &rb);
    EXPECT_EQ(ra.origin, rb.origin);
    EXPECT_EQ(ra.direction, rb.direction);
  }
  EXPECT_FALSE(CameraExposure{}.any());
}

// Thin lens: every sample of a pixel passes through the one point where its
// pinhole ray meets the focal plane (z = focus in the camera frame), up to
// the pixel's own extent (the samples spread over it: at most a pixel's
// footprint at that depth); the lens points fill the aperture disc (mean
// radius^2 = A^2 / 2 for a uniform disc).
TEST(CameraExposure, ThinLensRaysMeetOnTheFocalPlane) {
  const Rigid3 pose = Pose(0.2, {0.5, -1, 2});
  CameraExposure e;
  e.aperture_radius = 0.05;
  e.focus_distance = 3;
  const CameraSampler cs(kCam, pose, 1, 0, e);
  const double pixel = 3.0 / 30;  // a pixel's footprint at 3 m (f = 30 px)
  double r2 = 0;
  const int n = 4000;
  Eigen::Vector3d first_hit;
  for (int s = 0; s < n; ++s) {
    Ray ray;
    cs.Sample(16, 12, s, &ray);
    const Eigen::Vector3d o = pose.Inverse() * ray.origin.cast<double>();
    const Eigen::Vector3d d = pose.rotation.conjugate() * ray.direction.cast<double>();
    ASSERT_NEAR(o.z(), 0, 1e-6);
    r2 += o.squaredNorm() / n;
    ASSERT_LE(o.norm(), e.aperture_radius + 1e-6);
    const Eigen::Vector3d hit = o + (3 - o.z()) / d.z() * d;
    if (s == 0) first_hit = hit;
    ASSERT_LT((hit - first_hit).norm(), 1.5 * pixel) << "sample " << s;
  }
  EXPECT_NEAR(r2, e.aperture_radius * e.aperture_radius / 2, 0.05 * e.aperture_radius * e.aperture_radius);
}

// Shutter: the samples' camera centres are spread uniformly over the path
// open -> frame pose -> close (half the samples on each half), and their
// rotations follow it (slerp); a camera that does not move is not moving.
TEST(CameraExposure, ShutterSpreadsSamplesOverThePath) {
  const Rigid3 open = Pose(0.0, {0, 0, 0}), mid = Pose(0.1, {1, 0, 0}), close = Pose(0.2, {1, 1, 0});
  CameraExposure e;
  e.moves = true;
  e.open = open;
  e.close = close;
  const CameraSampler cs(kCam, mid, 3, 0, e);
  int first_half = 0;
  const int n = 4000;
  double mean_x = 0;
  for (int s = 0; s < n; ++s) {
    Ray ray;
    cs.Sample(16, 12, s, &ray);
    const Eigen::Vector3d c = ray.origin.cast<double>();
    ASSERT_NEAR(c.z(), 0, 1e-6);
    const bool on_first = c.y() < 1e-9;  // open -> mid runs along x at y = 0
    first_half += on_first;
    mean_x += c.x() / n;
    // The rotation matches the centre's place on the path: yaw 0.1 per unit of path.
    const double t = on_first ? c.x() : 1 + c.y();
    const Rigid3 expected = InterpolatePose(on_first ? open : mid, on_first ? mid : close, on_first ? t : t - 1);
    const Eigen::Vector3d d_expected = expected.rotation * Eigen::Vector3d(0, 0, 1);
    const Eigen::Vector3d d = ray.direction.cast<double>().normalized();
    ASSERT_GT(d.dot(d_expected), std::cos(0.05));  // the centre pixel's ray, within a pixel or two
  }
  EXPECT_NEAR(first_half, n / 2, 4 * std::sqrt(n / 4.0));
  EXPECT_NEAR(mean_x, 0.75, 0.02);  // x: uniform on [0, 1] half the time, 1 the other half
  // Interpolation: the ends, the middle, and the shorter way round.
  EXPECT_LT((InterpolatePose(open, close, 0).translation - open.translation).norm(), 1e-12);
  EXPECT_LT(InterpolatePose(open, close, 1).rotation.angularDistance(close.rotation), 1e-9);
  EXPECT_NEAR(InterpolatePose(open, close, 0.5).rotation.angularDistance(open.rotation), 0.1, 1e-9);
  Rigid3 flipped = close;
  flipped.rotation.coeffs() *= -1;  // the same rotation
  EXPECT_NEAR(InterpolatePose(open, flipped, 0.5).rotation.angularDistance(open.rotation), 0.1, 1e-9);
}

}  // namespace
}  // namespace mr
