// Directions on the sphere and the lat-long environment map mapping.
//
// The lat-long mapping is OpenEXR's (ImfEnvmap.h, envmap attribute LATLONG),
// written down once here and in docs/conventions.md:
//   direction d = (x, y, z), +y up, latitude 0 longitude 0 along +z,
//   longitude +pi/2 along +x;
//   latitude  = asin(d.y),  longitude = atan2(d.x, d.z);
//   pixel (px, py) of a W x H image (pixel centres at integer coordinates,
//   (0,0) the centre of the top-left pixel):
//     latitude  = -pi  * (py / (H - 1) - 0.5)    (row 0 is the +y pole)
//     longitude = -2pi * (px / (W - 1) - 0.5)    (column 0 is longitude +pi)
// so the first and last columns both lie on longitude +-pi and the first and
// last rows on the poles; their pixels cover half the solid angle of others.
#pragma once

#include <Eigen/Core>

namespace mr {

struct LatLong {
  double latitude = 0;   // [-pi/2, pi/2]
  double longitude = 0;  // (-pi, pi]
};

// Accurate near the poles (uses acos of the horizontal radius there, as OpenEXR).
LatLong DirectionToLatLong(const Eigen::Vector3d& dir);
Eigen::Vector3d LatLongToDirection(const LatLong& ll);

// Continuous pixel coordinates (pixel centres at integers) <-> direction.
Eigen::Vector2d DirectionToLatLongPixel(const Eigen::Vector3d& dir, int width, int height);
Eigen::Vector3d LatLongPixelToDirection(const Eigen::Vector2d& pixel, int width, int height);

// Solid angle (steradians) covered by pixel (px, py) of a W x H lat-long map,
// exact for the cell bounded halfway to its neighbours; sums to 4 pi.
double LatLongPixelSolidAngle(int px, int py, int width, int height);

// Orthonormal basis around a unit vector n (Duff et al. 2017): returns
// (t, b) such that (t, b, n) is right-handed.
void CoordinateSystem(const Eigen::Vector3d& n, Eigen::Vector3d* t, Eigen::Vector3d* b);

}  // namespace mr
