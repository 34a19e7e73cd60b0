#include "core/spherical.h"

#include <OpenEXR/ImfEnvmap.h>
#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "core/math.h"
#include "core/sampling.h"

namespace mr {
namespace {

// mr's lat-long mapping is OpenEXR's: compare against OpenEXR's own code.
TEST(LatLong, MatchesOpenExrEnvmap) {
  const int w = 64, h = 32;
  const IMATH_NAMESPACE::Box2i window(IMATH_NAMESPACE::V2i(0, 0), IMATH_NAMESPACE::V2i(w - 1, h - 1));
  Pcg32 rng(1, 2);
  for (int i = 0; i < 1000; ++i) {
    Eigen::Vector2d px(rng.NextDouble() * (w - 1), rng.NextDouble() * (h - 1));
    IMATH_NAMESPACE::V3f d = Imf::LatLongMap::direction(window, IMATH_NAMESPACE::V2f(px.x(), px.y()));
    Eigen::Vector3d ours = LatLongPixelToDirection(px, w, h);
    // float (OpenEXR) against double (ours): 1e-5 is a few float ulps at 1.
    EXPECT_NEAR(ours.x(), d.x, 1e-5);
    EXPECT_NEAR(ours.y(), d.y, 1e-5);
    EXPECT_NEAR(ours.z(), d.z, 1e-5);
    IMATH_NAMESPACE::V2f back = Imf::LatLongMap::pixelPosition(window, d);
    Eigen::Vector2d ours_px = DirectionToLatLongPixel(ours, w, h);
    // Pixel positions of OpenEXR's float math are good to ~1e-4 px.
    EXPECT_NEAR(ours_px.x(), back.x, 1e-3);
    EXPECT_NEAR(ours_px.y(), back.y, 1e-3);
  }
  // Named directions from ImfEnvmap.h: +y up at row 0, +z at the centre.
  EXPECT_NEAR(LatLongPixelToDirection({(w - 1) / 2.0, 0}, w, h).y(), 1.0, 1e-12);
  Eigen::Vector3d centre = LatLongPixelToDirection({(w - 1) / 2.0, (h - 1) / 2.0}, w, h);
  EXPECT_NEAR(centre.z(), 1.0, 1e-12);
}

TEST(LatLong, RoundTripIncludingPoles) {
  for (const Eigen::Vector3d& d : {Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(1e-9, 1, 0),
                                   Eigen::Vector3d(0.3, -0.2, -0.9), Eigen::Vector3d(-1, 0, 0)}) {
    Eigen::Vector3d n = d.normalized();
    Eigen::Vector3d back = LatLongToDirection(DirectionToLatLong(n));
    EXPECT_NEAR((back - n).norm(), 0.0, 1e-12) << n.transpose();
  }
  // Near the pole asin(y) loses precision; the acos branch does not.
  LatLong ll = DirectionToLatLong(Eigen::Vector3d(1e-8, 1, 0));
  EXPECT_NEAR(ll.latitude, kPi / 2 - 1e-8, 1e-15);
}

TEST(LatLong, SolidAnglesSumToFourPi) {
  for (auto [w, h] : {std::pair{8, 4}, std::pair{256, 128}, std::pair{3, 2}}) {
    CompensatedSum<double> s;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) s += LatLongPixelSolidAngle(x, y, w, h);
    EXPECT_NEAR(s.Value(), kFourPi, 1e-12) << w << "x" << h;
  }
  // Pole rows are half as tall; their solid angle is small but positive.
  EXPECT_GT(LatLongPixelSolidAngle(5, 0, 256, 128), 0.0);
}

TEST(CoordinateSystem, IsOrthonormalIncludingNegativeZ) {
  for (const Eigen::Vector3d& n : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0),
                                   Eigen::Vector3d(0.6, 0.0, -0.8), Eigen::Vector3d(0, 1e-20, -1)}) {
    Eigen::Vector3d t, b;
    CoordinateSystem(n.normalized(), &t, &b);
    EXPECT_NEAR(t.norm(), 1, 1e-12);
    EXPECT_NEAR(b.norm(), 1, 1e-12);
    EXPECT_NEAR(t.dot(b), 0, 1e-12);
    EXPECT_NEAR(t.dot(n.normalized()), 0, 1e-12);
    EXPECT_NEAR((t.cross(b) - n.normalized()).norm(), 0, 1e-12);
  }
}

}  // namespace
}  // namespace mr
