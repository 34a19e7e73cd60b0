// What the reflection models share: a BSDF sample, and the GGX microfacet
// distribution (Walter et al. 2007) with Smith's height-correlated masking.
#pragma once

#include <Eigen/Core>

namespace mr {

// GGX (Trowbridge-Reitz) with roughness alpha, in the local frame: the
// normal distribution D(h), Smith's Lambda(w) (G1 = 1 / (1 + Lambda)), and
// a normal sampled from the normals wo sees (Heitz 2018).
double GgxD(const Eigen::Vector3d& h, double alpha);
double GgxLambda(const Eigen::Vector3d& w, double alpha);
// wo need not be above the horizon for the call to return (Bsdf::Sample
// rejects wo.z <= 0 before).
Eigen::Vector3d SampleGgxVisibleNormal(const Eigen::Vector3d& wo, double alpha, double u0, double u1);

struct BsdfSample {
  Eigen::Vector3d wi;  // local frame
  Eigen::Vector3d f;   // BSDF value
  double pdf = 0;      // solid angle, of the combined (mixture) sampling
  // A direction no other could have given (an ior-1 interface's straight
  // pass): f and pdf are then a pair whose ratio alone means anything, and
  // Eval and Pdf of wi do not include it.
  bool delta = false;
};

}  // namespace mr
