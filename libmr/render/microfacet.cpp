#include "render/microfacet.h"

#include <algorithm>
#include <cmath>

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

// The normals wo sees (Heitz 2018, "Sampling the GGX Distribution of
// Visible Normals"): the weight f cos / pdf of a lobe sampled so is
// G2(wo, wi) / G1(wo) <= 1, where sampling D(h) cos(theta_h) gives weights
// up to ~2 / alpha at grazing wo (fireflies off glossy surfaces seen at a
// grazing angle).
Eigen::Vector3d SampleGgxVisibleNormal(const Eigen::Vector3d& wo, double alpha, double u0, double u1) {
  const Eigen::Vector3d vh = Eigen::Vector3d(alpha * wo.x(), alpha * wo.y(), wo.z()).normalized();
  const double len2 = vh.x() * vh.x() + vh.y() * vh.y();
  const Eigen::Vector3d t1 =
      len2 > 0 ? Eigen::Vector3d(-vh.y(), vh.x(), 0) / std::sqrt(len2) : Eigen::Vector3d(1, 0, 0);
  const Eigen::Vector3d t2 = vh.cross(t1);
  const double r = std::sqrt(u0), phi = kTwoPi * u1;
  const double p1 = r * std::cos(phi), sh = 0.5 * (1 + vh.z());
  const double p2 = (1 - sh) * SafeSqrt(1 - p1 * p1) + sh * r * std::sin(phi);
  const Eigen::Vector3d nh = p1 * t1 + p2 * t2 + SafeSqrt(1 - p1 * p1 - p2 * p2) * vh;
  return Eigen::Vector3d(alpha * nh.x(), alpha * nh.y(), std::max(1e-12, nh.z())).normalized();
}

}  // namespace mr
