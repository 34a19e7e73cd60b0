// Real spherical harmonics (orthonormal over the sphere), as used by
// precomputed radiance transfer (Sloan, Kautz and Snyder 2002).
//
// Order L means the bands l = 0 .. L-1: L^2 coefficients, index l(l+1)+m.
//   m > 0:  sqrt(2) K_l^m cos(m phi) P_l^m(cos theta)
//   m = 0:  K_l^0 P_l^0(cos theta)
//   m < 0:  sqrt(2) K_l^|m| sin(|m| phi) P_l^|m|(cos theta)
// with theta measured from +z, phi from +x towards +y, and P_l^m including
// the Condon-Shortley phase.
#pragma once

#include <Eigen/Core>

namespace mr {

inline constexpr int kMaxShOrder = 8;
inline int ShCount(int order) { return order * order; }

// Writes the ShCount(order) basis values at unit direction `d` into `out`.
void ShEvaluate(const Eigen::Vector3d& d, int order, double* out);

// The Lanczos sigma factor of band l for a projection of order L: scaling
// band l by it damps the ringing (Gibbs overshoot) that truncation causes
// around a bright, small source such as the sun.
double ShLanczosWindow(int l, int order);

}  // namespace mr
