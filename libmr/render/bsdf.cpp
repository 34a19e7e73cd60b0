#include "render/bsdf.h"

#include "core/color.h"

#include <cmath>

#include "core/math.h"
#include "core/sampling.h"

namespace mr {

namespace {
double Lum(const Eigen::Vector3d& c) { return Luminance(c); }
}  // namespace

Bsdf::Bsdf(const Material& m) : albedo_(m.albedo), specular_(m.specular), alpha_(m.roughness * m.roughness) {
  alpha_ = std::max(alpha_, 1e-4);  // a perfect mirror is a delta; keep it a (very) sharp lobe
  const double d = Lum(albedo_), g = Lum(specular_);
  diffuse_weight_ = d + g > 0 ? d / (d + g) : 0;
  glossy_weight_ = d + g > 0 ? g / (d + g) : 0;
}

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

double Bsdf::D(const Eigen::Vector3d& h) const { return GgxD(h, alpha_); }
double Bsdf::Lambda(const Eigen::Vector3d& w) const { return GgxLambda(w, alpha_); }

Eigen::Vector3d Bsdf::Eval(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const {
  if (wo.z() <= 0 || wi.z() <= 0) return Eigen::Vector3d::Zero();
  Eigen::Vector3d f = albedo_ * kInvPi;
  if (glossy_weight_ > 0) {
    Eigen::Vector3d h = (wo + wi).normalized();
    const double g = 1.0 / (1.0 + Lambda(wo) + Lambda(wi));  // height-correlated Smith
    // At grazing angles 4 wo.z wi.z underflows to 0 where g is 0: no light.
    const double denom = 4 * wo.z() * wi.z();
    if (g > 0 && denom > 0) f += specular_ * (D(h) * g / denom);
  }
  return f;
}

Eigen::Vector3d Bsdf::DiffuseBound() const { return albedo_ * kInvPi; }

Eigen::Vector3d Bsdf::GlossyBound(const Eigen::Vector3d& wo) const {
  if (glossy_weight_ <= 0 || wo.z() <= 0) return Eigen::Vector3d::Zero();
  // f cos = specular D G / (4 wo.z), D <= 1/(pi a^2) and G <= 1: the first
  // bound, which grows without limit at grazing wo.  There the masking
  // takes over: G <= 1 / (1 + Lambda(wo)) <= 2 wo.z / (a sin(theta_o)),
  // so f cos <= specular / (2 pi a^3 sin(theta_o)).  The smaller holds.
  const double z = std::min(wo.z(), 1.0), sin_o = std::sqrt(std::max(0.0, 1 - z * z));
  const double a2 = alpha_ * alpha_;
  const double grazing = sin_o > 0 ? 1 / (2 * kPi * a2 * alpha_ * sin_o) : INFINITY;
  return specular_ * std::min(1 / (4 * kPi * a2 * z), grazing);
}

double Bsdf::Pdf(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const {
  if (wo.z() <= 0 || wi.z() <= 0) return 0;
  double pdf = diffuse_weight_ * wi.z() * kInvPi;
  if (glossy_weight_ > 0) {
    Eigen::Vector3d h = (wo + wi).normalized();
    // Visible normals: D_wo(h) = G1(wo) max(0, wo . h) D(h) / wo.z, mapped to
    // wi by / (4 wo . h).
    if (wo.dot(h) > 0) pdf += glossy_weight_ * D(h) / ((1 + Lambda(wo)) * 4 * wo.z());
  }
  return pdf;
}

bool Bsdf::Sample(const Eigen::Vector3d& wo, double u_lobe, double u0, double u1, BsdfSample* s) const {
  if (wo.z() <= 0 || IsBlack()) return false;
  if (u_lobe < diffuse_weight_) {
    auto d = SampleCosineHemisphere(u0, u1);
    s->wi = Eigen::Vector3d(d[0], d[1], d[2]);
  } else {
    const Eigen::Vector3d h = SampleGgxVisibleNormal(wo, alpha_, u0, u1);
    s->wi = 2 * wo.dot(h) * h - wo;
  }
  if (s->wi.z() <= 0) return false;
  s->f = Eval(wo, s->wi);
  s->pdf = Pdf(wo, s->wi);
  return s->pdf > 0;
}

}  // namespace mr
