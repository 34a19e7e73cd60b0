// Sampling and evaluation of lights.json's lights for next-event estimation
// (scene/lights.h has the definitions).
#pragma once

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
  bool Sample(const Eigen::Vector3d& p, double u0, double u1, LightSample* s) const;
  // Radiance of a distant disc light along world direction `dir` (zero
  // outside the disc and for delta lights), with the pdf Sample would have
  // given that direction.
  Eigen::Vector3d EvalDistant(const Eigen::Vector3d& dir, double* pdf) const;

 private:
  Light light_;
  double cos_cone_ = 0, cos_falloff_ = 1;       // spot
  double cos_max_ = 1, one_minus_cos_max_ = 0;  // distant disc
  Eigen::Vector3d radiance_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d t_, b_;  // frame around light_.direction
};

}  // namespace mr
