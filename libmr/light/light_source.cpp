#include "light/light_source.h"

#include <cmath>

#include "core/color.h"
#include "core/math.h"
#include "core/spherical.h"

namespace mr {

LightSource::LightSource(const Light& light) : light_(light) {
  CoordinateSystem(light_.direction, &t_, &b_);
  if (light_.type == LightType::kArea && light_.shape == AreaShape::kRect) {
    t_ = (light_.axis - light_.axis.dot(light_.direction) * light_.direction).normalized();
    b_ = light_.direction.cross(t_);
  }
  if (light_.type == LightType::kSpot) {
    cos_cone_ = std::cos(light_.cone_deg * kDegToRad);
    cos_falloff_ = std::cos(light_.falloff_start_deg * kDegToRad);
  }
  if (light_.type == LightType::kDistant && light_.angular_radius_deg > 0) {
    const double th = light_.angular_radius_deg * kDegToRad;
    const double s = std::sin(0.5 * th);
    one_minus_cos_max_ = 2 * s * s;  // 1 - cos(th) without cancellation for the sun's 0.27 degrees
    cos_max_ = 1 - one_minus_cos_max_;
    const double sin2 = std::sin(th) * std::sin(th);
    radiance_ = light_.irradiance / (kPi * sin2);  // a uniform disc: E = L pi sin^2(th)
  }
}

bool LightSource::Sample(const Eigen::Vector3d& p, double u0, double u1, LightSample* s) const {
  switch (light_.type) {
    case LightType::kPoint:
    case LightType::kSpot: {
      const Eigen::Vector3d d = light_.position - p;
      const double d2 = d.squaredNorm();
      if (!(d2 > 0)) return false;
      s->distance = std::sqrt(d2);
      s->wi = d / s->distance;
      double falloff = 1;
      if (light_.type == LightType::kSpot) {
        const double c = -s->wi.dot(light_.direction);
        if (c <= cos_cone_) return false;
        if (c < cos_falloff_) {
          const double x = (c - cos_cone_) / (cos_falloff_ - cos_cone_);
          falloff = x * x * (3 - 2 * x);  // smoothstep
        }
      }
      s->li = light_.intensity * (falloff / d2);
      s->pdf = 1;
      s->delta = true;
      return s->li.maxCoeff() > 0;
    }
    case LightType::kArea: {
      Eigen::Vector3d q = light_.position;
      if (light_.shape == AreaShape::kRect) {
        q += (u0 - 0.5) * light_.width * t_ + (u1 - 0.5) * light_.height * b_;
      } else {
        // Shirley-Chiu's concentric map: strata stay compact on the disc.
        const double a = 2 * u0 - 1, b = 2 * u1 - 1;
        double r = 0, phi = 0;
        if (a != 0 || b != 0) {
          if (std::abs(a) > std::abs(b)) {
            r = a;
            phi = 0.25 * kPi * (b / a);
          } else {
            r = b;
            phi = 0.5 * kPi - 0.25 * kPi * (a / b);
          }
        }
        q += 0.5 * light_.width * r * (std::cos(phi) * t_ + std::sin(phi) * b_);
      }
      const Eigen::Vector3d v = q - p;
      const double d2 = v.squaredNorm();
      if (!(d2 > 0)) return false;
      s->distance = std::sqrt(d2);
      s->wi = v / s->distance;
      const double cos_l = -s->wi.dot(light_.direction);
      if (cos_l <= 0) return false;
      s->li = light_.radiance;
      s->pdf = d2 / (light_.Area() * cos_l);
      s->delta = true;
      return s->li.maxCoeff() > 0;
    }
    case LightType::kDistant: {
      s->distance = INFINITY;
      if (light_.angular_radius_deg <= 0) {
        s->wi = light_.direction;
        s->li = light_.irradiance;
        s->pdf = 1;
        s->delta = true;
        return s->li.maxCoeff() > 0;
      }
      // Uniform in the cone: 1 - cos(theta) uniform in [0, 1 - cos_max].
      const double omc = u0 * one_minus_cos_max_;
      const double sin_t = SafeSqrt(omc * (2 - omc)), cos_t = 1 - omc;
      const double phi = kTwoPi * u1;
      s->wi = (cos_t * light_.direction + sin_t * (std::cos(phi) * t_ + std::sin(phi) * b_)).normalized();
      s->li = radiance_;
      s->pdf = 1 / (kTwoPi * one_minus_cos_max_);
      s->delta = false;
      return s->li.maxCoeff() > 0;
    }
  }
  return false;
}

Eigen::Vector3d LightSource::EvalDistant(const Eigen::Vector3d& dir, double* pdf) const {
  *pdf = 0;
  if (light_.type != LightType::kDistant || light_.angular_radius_deg <= 0) return Eigen::Vector3d::Zero();
  // 1 - cos of the angle to the axis, computed from the chord to avoid cancellation.
  const double omc = 0.5 * (dir - light_.direction).squaredNorm();
  if (omc > one_minus_cos_max_) return Eigen::Vector3d::Zero();
  *pdf = 1 / (kTwoPi * one_minus_cos_max_);
  return radiance_;
}

Eigen::Vector3d LightSource::HitArea(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max,
                                     double* t) const {
  if (light_.type != LightType::kArea) return Eigen::Vector3d::Zero();
  const double denom = d.dot(light_.direction);
  if (!(denom < 0)) return Eigen::Vector3d::Zero();  // parallel, or from behind
  const double tt = (light_.position - o).dot(light_.direction) / denom;
  if (!(tt > 0 && tt < t_max)) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d q = o + tt * d - light_.position;
  const double x = q.dot(t_), y = q.dot(b_);
  const bool inside = light_.shape == AreaShape::kRect
                          ? std::abs(x) <= 0.5 * light_.width && std::abs(y) <= 0.5 * light_.height
                          : x * x + y * y <= 0.25 * light_.width * light_.width;
  if (!inside) return Eigen::Vector3d::Zero();
  *t = tt;
  return light_.radiance;
}

double UnoccludedIrradiance(const LightSource& l, const Eigen::Vector3d& p, const Eigen::Vector3d& n, int strata) {
  double e = 0;
  for (int j = 0; j < strata; ++j)
    for (int i = 0; i < strata; ++i) {
      LightSample s;
      if (!l.Sample(p, (i + 0.5) / strata, (j + 0.5) / strata, &s)) continue;
      e += Luminance(s.li) * std::max(0.0, s.wi.dot(n)) / s.pdf;
    }
  return e / (static_cast<double>(strata) * strata);
}

}  // namespace mr
