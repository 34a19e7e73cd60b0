#include "render/bsdf.h"

#include "core/color.h"

#include <algorithm>

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

double Bsdf::D(const Eigen::Vector3d& h) const { return GgxD(h, alpha_); }
double Bsdf::Lambda(const Eigen::Vector3d& w) const { return GgxLambda(w, alpha_); }

void Bsdf::SetGeometricNormal(const Eigen::Vector3d& ng, bool shadowing) {
  ng_ = ng;
  has_ng_ = true;
  shadowing_ = shadowing;
}

// Chiang et al. 2019, eq. 4-5: G = min(1, (ng . wi) / ((ns . wi)(ng . ns))),
// smoothed as -G^3 + G^2 + G; ns is the local z.
double Bsdf::GeometricFactor(const Eigen::Vector3d& wi) const {
  if (!has_ng_) return 1;
  const double gi = wi.dot(ng_);
  if ((gi > 0) != (wi.z() > 0) || gi == 0) return 0;
  if (!shadowing_) return 1;
  const double denom = std::abs(wi.z() * ng_.z());
  const double g = denom > 0 ? std::min(1.0, std::abs(gi) / denom) : 1.0;
  return -g * g * g + g * g + g;
}

Eigen::Vector3d Bsdf::Eval(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const {
  if (!has_ng_) return EvalLobes(wo, wi);
  const double g = GeometricFactor(wi);
  return g > 0 ? Eigen::Vector3d(EvalLobes(wo, wi) * g) : Eigen::Vector3d::Zero();
}

Bsdf::Bsdf(const PbrBsdf& pbr, const GlassBsdf& glass, double transmission)
    : diffuse_weight_(1), pbr_(pbr), glass_(glass), transmission_(std::clamp(transmission, 0.0, 1.0)) {}

Eigen::Vector3d Bsdf::EvalLobes(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const {
  if (glass_) {
    Eigen::Vector3d f = transmission_ * glass_->Eval(wo, wi);
    if (transmission_ < 1) f += (1 - transmission_) * pbr_->Eval(wo, wi);
    return f;
  }
  if (pbr_) return pbr_->Eval(wo, wi);
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

Eigen::Vector3d Bsdf::DiffuseBound() const { return pbr_ ? pbr_->DiffuseBound() : Eigen::Vector3d(albedo_ * kInvPi); }

Eigen::Vector3d Bsdf::GlossyBound(const Eigen::Vector3d& wo) const {
  if (pbr_) return pbr_->GlossyBound(wo);
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
  if (glass_)
    return transmission_ * glass_->Pdf(wo, wi) + (transmission_ < 1 ? (1 - transmission_) * pbr_->Pdf(wo, wi) : 0.0);
  if (pbr_) return pbr_->Pdf(wo, wi);
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

bool Bsdf::Sample(const Eigen::Vector3d& wo, double u_lobe, double u0, double u1, BsdfSample* s,
                  const Eigen::Vector3d* cosine) const {
  if (glass_) {  // one lobe chosen by u_lobe, then f and pdf of the mixture
    const bool glass = u_lobe < transmission_;
    const double u = glass ? u_lobe / transmission_ : (u_lobe - transmission_) / (1 - transmission_);
    if (!(glass ? glass_->Sample(wo, u, u0, u1, s) : pbr_->Sample(wo, u, u0, u1, s, cosine))) return false;
    if (s->delta) {  // chosen with probability transmission_, weighted by it: the ratio stays
      s->f *= transmission_ * GeometricFactor(s->wi);
      s->pdf *= transmission_;
      return s->f.maxCoeff() > 0;
    }
    s->f = Eval(wo, s->wi);
    s->pdf = Pdf(wo, s->wi);
    return s->pdf > 0 && s->f.maxCoeff() > 0;
  }
  if (pbr_) {
    if (!pbr_->Sample(wo, u_lobe, u0, u1, s, cosine)) return false;
    if (has_ng_) s->f *= GeometricFactor(s->wi);
    return !has_ng_ || s->f.maxCoeff() > 0;
  }
  if (wo.z() <= 0 || IsBlack()) return false;
  if (u_lobe < diffuse_weight_ && cosine) {
    s->wi = *cosine;
  } else if (u_lobe < diffuse_weight_) {
    auto d = SampleCosineHemisphere(u0, u1);
    s->wi = Eigen::Vector3d(d[0], d[1], d[2]);
  } else {
    const Eigen::Vector3d h = SampleGgxVisibleNormal(wo, alpha_, u0, u1);
    s->wi = 2 * wo.dot(h) * h - wo;
  }
  if (s->wi.z() <= 0) return false;
  s->f = Eval(wo, s->wi);
  if (has_ng_ && s->f.maxCoeff() <= 0) return false;
  s->pdf = Pdf(wo, s->wi);
  return s->pdf > 0;
}

}  // namespace mr
