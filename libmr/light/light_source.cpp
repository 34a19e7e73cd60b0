#include "light/light_source.h"

#include <cmath>

#include <Eigen/Geometry>

#include "core/color.h"
#include "core/lanes.h"
#include "core/math.h"
#include "core/spherical.h"

namespace mr {

namespace {

// The parts of LightSource::Sample that do not depend on the shaded point,
// written out without a branch or a libm call, so that lanes of them
// vectorise and give the scalar call's bits (core/lanes.h).  `t`, `b`: the
// light's frame, as three doubles each.

// A distant disc light's direction: 1 - cos(theta) uniform in [0, omc_max]
// (uniform in the cone around `d`), phi uniform.
inline void DiscDirection(const double* d, const double* t, const double* b, double omc_max, double u0, double u1,
                          double* x, double* y, double* z) {
  const double omc = u0 * omc_max;
  const double sin_t = std::sqrt(std::max(0.0, omc * (2 - omc))), cos_t = 1 - omc;
  double s, c;
  SinCos(kTwoPi * u1, &s, &c);
  const double wx = cos_t * d[0] + sin_t * (c * t[0] + s * b[0]);
  const double wy = cos_t * d[1] + sin_t * (c * t[1] + s * b[1]);
  const double wz = cos_t * d[2] + sin_t * (c * t[2] + s * b[2]);
  const double len = std::sqrt(wx * wx + wy * wy + wz * wz);
  *x = wx / len;
  *y = wy / len;
  *z = wz / len;
}

// An area light's point: uniform over its w x h rectangle around `o`, or
// over its disc of diameter w by Shirley and Chiu's concentric map (strata
// stay compact on the disc).
inline void AreaPoint(const double* o, const double* t, const double* b, double w, double h, bool disc, double u0,
                      double u1, double* x, double* y, double* z) {
  const double ox = 2 * u0 - 1, oy = 2 * u1 - 1;
  const bool wide = std::abs(ox) > std::abs(oy);
  const double r = wide ? ox : oy, other = wide ? oy : ox;
  const double ratio = other / (r == 0 ? 1.0 : r);
  double s, c;
  SinCos(wide ? 0.25 * kPi * ratio : 0.5 * kPi - 0.25 * kPi * ratio, &s, &c);
  // along t and b: the rectangle's offsets, or the disc's point (r = 0 at its centre)
  const double ct = disc ? 0.5 * w * r * c : (u0 - 0.5) * w, cb = disc ? 0.5 * w * r * s : (u1 - 0.5) * h;
  *x = o[0] + (ct * t[0] + cb * b[0]);
  *y = o[1] + (ct * t[1] + cb * b[1]);
  *z = o[2] + (ct * t[2] + cb * b[2]);
}

}  // namespace

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

MR_LANES void LightSource::SampleAhead(size_t n, const double* __restrict u0, const double* __restrict u1,
                                       double* __restrict x, double* __restrict y, double* __restrict z) const {
  const double *d = light_.direction.data(), *o = light_.position.data(), *t = t_.data(), *b = b_.data();
  if (light_.type == LightType::kDistant) {
    const double omc_max = one_minus_cos_max_;
    for (size_t k = 0; k < n; ++k) DiscDirection(d, t, b, omc_max, u0[k], u1[k], &x[k], &y[k], &z[k]);
  } else if (light_.type == LightType::kArea) {
    const double w = light_.width, h = light_.height;
    const bool disc = light_.shape != AreaShape::kRect;
    for (size_t k = 0; k < n; ++k) AreaPoint(o, t, b, w, h, disc, u0[k], u1[k], &x[k], &y[k], &z[k]);
  }
}

bool LightSource::Sample(const Eigen::Vector3d& p, double u0, double u1, LightSample* s,
                         const Eigen::Vector3d* ahead) const {
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
      Eigen::Vector3d q;
      if (ahead)
        q = *ahead;
      else
        AreaPoint(light_.position.data(), t_.data(), b_.data(), light_.width, light_.height,
                  light_.shape != AreaShape::kRect, u0, u1, &q.x(), &q.y(), &q.z());
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
      if (ahead)
        s->wi = *ahead;
      else
        DiscDirection(light_.direction.data(), t_.data(), b_.data(), one_minus_cos_max_, u0, u1, &s->wi.x(), &s->wi.y(),
                      &s->wi.z());
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
