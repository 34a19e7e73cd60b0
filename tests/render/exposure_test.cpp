// The camera's shutter interval and lens (render/camera_sampler.h): the
// geometry of the samples, exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

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

// The corner rays, found by Newton from the neighbours' rays, are the
// general solve's (CameraModel::Unproject) to 1e-8 rad, and the corners
// outside a lens' domain are left out the same: OpenCV8, an OpenCV4 lens
// whose domain ends inside the image, and a splined fish-eye past 180
// degrees.
TEST(CameraSampler, CornerRaysAreTheGeneralSolves) {
  std::vector<double> splined = {300, 300, 319.5, 239.5};
  for (int i = 0; i < 2 * 16 * 12; ++i) splined.push_back(0.004 * std::sin(1.7 * i));
  const CameraModel lenses[] = {
      CameraModel("LENSMODEL_OPENCV8", {500, 510, 319.5, 239.5, 0.3, 0.02, 1e-3, -1e-3, 0.001, 0.6, 0.05, 0.002}, 640,
                  480),
      // Barrel distortion that folds back at 195 px from the centre: the
      // image's outer part is outside the domain.
      CameraModel("LENSMODEL_OPENCV4", {300, 300, 319.5, 239.5, -0.35, 0, 1e-3, -1e-3}, 640, 480),
      CameraModel("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=220", splined, 640, 480)};
  for (const CameraModel& m : lenses) {
    const CameraSampler cs(m, Rigid3(), 1, 0);
    int valid = 0, invalid = 0;
    double worst = 0;
    for (int y = 0; y < 480; y += 7)
      for (int x = 0; x < 640; x += 5) {
        Eigen::Vector3d c[4], d;
        cs.CornerDirections(x, y, c);
        const bool ok = m.Unproject(Eigen::Vector2d(x - 0.5, y - 0.5), &d);
        bool all = true;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            Eigen::Vector3d e;
            all = m.Unproject(Eigen::Vector2d(x + dx - 0.5, y + dy - 0.5), &e) && all;
          }
        EXPECT_EQ(cs.PixelValid(x, y), all) << m.lensmodel() << " at " << x << ", " << y;
        if (!ok) {
          ++invalid;
          continue;
        }
        ++valid;
        worst = std::max(worst, (c[0] - d).norm());
      }
    EXPECT_GT(valid, 1000) << m.lensmodel();
    if (m.lensmodel() == "LENSMODEL_OPENCV4") EXPECT_GT(invalid, 1000);
    // Both stop at 1e-8 px of reprojection error; near the OpenCV4 lens' fold
    // (dq/dtheta -> 0) that is 1.2e-9 rad; elsewhere 5e-11.
    EXPECT_LT(worst, 1e-8) << m.lensmodel();
  }
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
