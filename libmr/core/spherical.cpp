#include "core/spherical.h"

#include <algorithm>
#include <cmath>

#include "core/check.h"
#include "core/math.h"

namespace mr {

LatLong DirectionToLatLong(const Eigen::Vector3d& dir) {
  const double len = dir.norm();
  MR_DCHECK(len > 0);
  const double r = std::hypot(dir.z(), dir.x());
  LatLong ll;
  ll.latitude = (r < std::abs(dir.y())) ? std::copysign(SafeACos(r / len), dir.y()) : SafeASin(dir.y() / len);
  ll.longitude = (dir.z() == 0 && dir.x() == 0) ? 0.0 : std::atan2(dir.x(), dir.z());
  return ll;
}

Eigen::Vector3d LatLongToDirection(const LatLong& ll) {
  const double cl = std::cos(ll.latitude);
  return {std::sin(ll.longitude) * cl, std::sin(ll.latitude), std::cos(ll.longitude) * cl};
}

Eigen::Vector2d DirectionToLatLongPixel(const Eigen::Vector3d& dir, int width, int height) {
  MR_CHECK(width >= 2 && height >= 2);
  LatLong ll = DirectionToLatLong(dir);
  const double px = (-ll.longitude / kTwoPi + 0.5) * (width - 1);
  const double py = (-ll.latitude / kPi + 0.5) * (height - 1);
  return {px, py};
}

Eigen::Vector3d LatLongPixelToDirection(const Eigen::Vector2d& pixel, int width, int height) {
  MR_CHECK(width >= 2 && height >= 2);
  LatLong ll;
  ll.latitude = -kPi * (pixel.y() / (height - 1) - 0.5);
  ll.longitude = -kTwoPi * (pixel.x() / (width - 1) - 0.5);
  return LatLongToDirection(ll);
}

double LatLongPixelSolidAngle(int px, int py, int width, int height) {
  MR_CHECK(width >= 2 && height >= 2);
  MR_CHECK(px >= 0 && px < width && py >= 0 && py < height);
  const double dlat = kPi / (height - 1);
  const double dlon = kTwoPi / (width - 1);
  const double lat = kPi / 2 - py * dlat;
  const double lat_hi = std::min(kPi / 2, lat + dlat / 2);
  const double lat_lo = std::max(-kPi / 2, lat - dlat / 2);
  const double lon_width = (px == 0 || px == width - 1) ? dlon / 2 : dlon;
  // Integral of cos(lat) dlat dlon = dlon * (sin hi - sin lo), written as a
  // product to avoid cancellation near the poles: sin a - sin b = 2 cos((a+b)/2) sin((a-b)/2).
  const double dsin = 2.0 * std::cos((lat_hi + lat_lo) / 2) * std::sin((lat_hi - lat_lo) / 2);
  return lon_width * dsin;
}

void CoordinateSystem(const Eigen::Vector3d& n, Eigen::Vector3d* t, Eigen::Vector3d* b) {
  const double sign = std::copysign(1.0, n.z());
  const double a = -1.0 / (sign + n.z());
  const double bb = n.x() * n.y() * a;
  *t = Eigen::Vector3d(1.0 + sign * n.x() * n.x() * a, sign * bb, -sign * n.x());
  *b = Eigen::Vector3d(bb, sign + n.y() * n.y() * a, -n.y());
}

}  // namespace mr
