// Sampling and evaluation of lights.json's lights for next-event estimation
// (scene/lights.h has the definitions).
#pragma once

#include <cstddef>

#include <Eigen/Core>

#include "light/lights_file.h"

namespace mr {

struct LightSample {
  Eigen::Vector3d wi;   // unit, from the shaded point towards the light
  double distance = 0;  // to the light (infinity for distant lights)
  Eigen::Vector3d li;   // radiance (area lights) or irradiance-at-normal-incidence (delta lights)
  double pdf = 1;       // solid-angle pdf; 1 for delta lights
  bool delta = true;
};

class LightSource {
 public:
  explicit LightSource(const Light& light);
  const Light& light() const { return light_; }
  bool is_virtual() const { return light_.is_virtual; }
  // Samples the light as seen from `p`; false when it sends nothing there.
  // An area light: a uniform point of it (u0, u1 over its rectangle, or
  // its disc by the concentric map), pdf in solid angle at p; `delta` is
  // true for it too, since area lights are not geometry: only the rays
  // next-event estimation never samples meet them (HitArea), so its
  // samples take no MIS weight.
  // `ahead`, if given, is SampleAhead's value for (u0, u1): the same
  // result, not computed again.
  bool Sample(const Eigen::Vector3d& p, double u0, double u1, LightSample* s,
              const Eigen::Vector3d* ahead = nullptr) const;
  // Whether Sample has a part that does not depend on p (a distant disc
  // light's direction, an area light's point), and that part for n lanes
  // (core/lanes.h) of numbers (u0, u1)[k], into (x, y, z)[k], bit for bit
  // as Sample computes it; nothing for the other lights.
  bool TakesAhead() const {
    return light_.type == LightType::kArea || (light_.type == LightType::kDistant && light_.angular_radius_deg > 0);
  }
  void SampleAhead(size_t n, const double* u0, const double* u1, double* x, double* y, double* z) const;
  // Radiance of a distant disc light along world direction `dir` (zero
  // outside the disc and for delta lights), with the pdf Sample would have
  // given that direction.
  Eigen::Vector3d EvalDistant(const Eigen::Vector3d& dir, double* pdf) const;
  // An area light met by the ray o + t d (d unit) at 0 < t < t_max from its
  // emitting side: its radiance, *t set; zero otherwise (and for the other
  // types).
  Eigen::Vector3d HitArea(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max, double* t) const;

 private:
  Light light_;
  double cos_cone_ = 0, cos_falloff_ = 1;       // spot
  double cos_max_ = 1, one_minus_cos_max_ = 0;  // distant disc
  Eigen::Vector3d radiance_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d t_, b_;  // frame around light_.direction
};

// The luminance irradiance `l` gives a surface at p with normal n, nothing
// in between: strata x strata stratified light samples (a delta light's
// one is exact).
double UnoccludedIrradiance(const LightSource& l, const Eigen::Vector3d& p, const Eigen::Vector3d& n, int strata = 32);

}  // namespace mr
