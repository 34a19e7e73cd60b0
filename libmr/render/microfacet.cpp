#include "render/microfacet.h"

#include <algorithm>
#include <cmath>

#include "core/lanes.h"
#include "core/math.h"

namespace mr {

double GgxD(const Eigen::Vector3d& h, double alpha) {
  if (h.z() <= 0) return 0;
  const double a2 = alpha * alpha;
  const double c2 = h.z() * h.z();
  const double t = c2 * (a2 - 1) + 1;
  return a2 / (kPi * t * t);
}

double GgxLambda(const Eigen::Vector3d& w, double alpha) {
  const double c2 = w.z() * w.z();
  if (c2 >= 1) return 0;
  const double t2 = (1 - c2) / c2;  // tan^2
  return (std::sqrt(1 + alpha * alpha * t2) - 1) / 2;
}

namespace {

// The normals wo sees (Heitz 2018, "Sampling the GGX Distribution of
// Visible Normals"): the weight f cos / pdf of a lobe sampled so is
// G2(wo, wi) / G1(wo) <= 1, where sampling D(h) cos(theta_h) gives weights
// up to ~2 / alpha at grazing wo (fireflies off glossy surfaces seen at a
// grazing angle).  Written out without a branch, with core/lanes.h's
// SinCos for libm's sin and cos (14 ns against 23, docs/benchmarks.md).
inline void GgxVisibleNormal(double wx, double wy, double wz, double alpha, double u0, double u1, double* hx,
                             double* hy, double* hz) {
  // wo stretched to the unit-roughness configuration, and a frame around it
  const double sx = alpha * wx, sy = alpha * wy;
  const double sl = std::sqrt(sx * sx + sy * sy + wz * wz);
  const double vx = sx / sl, vy = sy / sl, vz = wz / sl;
  const double len2 = vx * vx + vy * vy;
  const bool tilted = len2 > 0;
  const double len = std::sqrt(tilted ? len2 : 1.0);
  const double t1x = tilted ? -vy / len : 1.0, t1y = tilted ? vx / len : 0.0;  // t1.z = 0
  const double t2x = -vz * t1y, t2y = vz * t1x, t2z = vx * t1y - vy * t1x;     // vh x t1
  // a point of the projected half disc
  const double r = std::sqrt(u0);
  double sin_phi, cos_phi;
  SinCos(kTwoPi * u1, &sin_phi, &cos_phi);
  const double p1 = r * cos_phi, sh = 0.5 * (1 + vz);
  const double p2 = (1 - sh) * std::sqrt(std::max(0.0, 1 - p1 * p1)) + sh * r * sin_phi;
  const double p3 = std::sqrt(std::max(0.0, 1 - p1 * p1 - p2 * p2));
  // lifted to the hemisphere, and unstretched
  const double mx = alpha * (p1 * t1x + p2 * t2x + p3 * vx);
  const double my = alpha * (p1 * t1y + p2 * t2y + p3 * vy);
  const double mz = std::max(1e-12, p2 * t2z + p3 * vz);
  const double ml = std::sqrt(mx * mx + my * my + mz * mz);
  *hx = mx / ml;
  *hy = my / ml;
  *hz = mz / ml;
}

}  // namespace

Eigen::Vector3d SampleGgxVisibleNormal(const Eigen::Vector3d& wo, double alpha, double u0, double u1) {
  Eigen::Vector3d h;
  GgxVisibleNormal(wo.x(), wo.y(), wo.z(), alpha, u0, u1, &h.x(), &h.y(), &h.z());
  return h;
}

}  // namespace mr
