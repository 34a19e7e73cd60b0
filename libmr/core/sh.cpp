#include "core/sh.h"

#include <cmath>

#include "core/check.h"
#include "core/math.h"

namespace mr {

namespace {
// K_l^m = sqrt((2l+1)/(4 pi) (l-m)!/(l+m)!), computed as a product to stay finite.
double K(int l, int m) {
  double r = (2.0 * l + 1.0) / (4.0 * kPi);
  for (int k = l - m + 1; k <= l + m; ++k) r /= k;
  return std::sqrt(r);
}
}  // namespace

void ShEvaluate(const Eigen::Vector3d& d, int order, double* out) {
  MR_CHECK(order >= 1 && order <= kMaxShOrder);
  const double x = Clamp(d.z(), -1.0, 1.0);
  const double s = std::sqrt(std::max(0.0, 1 - x * x));
  // cos(m phi) sin^m(theta) and sin(m phi) sin^m(theta) by the angle-sum recurrence,
  // from (d.x, d.y) = sin(theta) (cos phi, sin phi): no atan2, no division at the poles.
  double cm[kMaxShOrder], sm[kMaxShOrder];
  cm[0] = 1;
  sm[0] = 0;
  for (int m = 1; m < order; ++m) {
    cm[m] = cm[m - 1] * d.x() - sm[m - 1] * d.y();
    sm[m] = sm[m - 1] * d.x() + cm[m - 1] * d.y();
  }
  // P_l^m / sin^m(theta): the associated Legendre functions without their
  // sin^m factor, which cm/sm carry.
  for (int m = 0; m < order; ++m) {
    double pmm = 1;  // (-1)^m (2m-1)!!
    for (int k = 1; k <= m; ++k) pmm *= -(2.0 * k - 1.0);
    double p_prev = 0, p = pmm;
    for (int l = m; l < order; ++l) {
      if (l == m + 1) {
        p_prev = p;
        p = x * (2.0 * m + 1.0) * pmm;
      } else if (l > m + 1) {
        const double next = ((2.0 * l - 1.0) * x * p - (l + m - 1.0) * p_prev) / (l - m);
        p_prev = p;
        p = next;
      }
      const double k = K(l, m);
      if (m == 0) {
        out[l * (l + 1)] = k * p;
      } else {
        out[l * (l + 1) + m] = std::sqrt(2.0) * k * p * cm[m];
        out[l * (l + 1) - m] = std::sqrt(2.0) * k * p * sm[m];
      }
    }
  }
  (void)s;
}

double ShLanczosWindow(int l, int order) {
  if (l == 0) return 1;
  const double x = kPi * l / order;
  return std::sin(x) / x;
}

}  // namespace mr
