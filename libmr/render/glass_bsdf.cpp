#include "render/glass_bsdf.h"

#include <algorithm>
#include <cmath>

#include "render/pbr_bsdf.h"

namespace mr {

bool Refract(const Eigen::Vector3d& wo, const Eigen::Vector3d& h, double eta, Eigen::Vector3d* wi) {
  const double cos_i = wo.dot(h);
  const double sin_t2 = std::max(0.0, 1 - cos_i * cos_i) / (eta * eta);
  if (sin_t2 >= 1) return false;
  const double cos_t = std::sqrt(1 - sin_t2);
  *wi = (-wo / eta + (cos_i / eta - cos_t) * h).normalized();
  return true;
}

GlassBsdf::GlassBsdf(const GlassParams& p) : p_(p) {
  p_.alpha = std::clamp(p_.alpha, 1e-4, 1.0);
  p_.eta = std::clamp(p_.eta, 1.0 / 3, 3.0);
  pass_ = std::abs(p_.eta - 1) < 1e-3;
}

namespace {
Eigen::Vector3d FlipZ(Eigen::Vector3d w) {
  w.z() = -w.z();
  return w;
}
}  // namespace

bool GlassBsdf::HalfVector(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi, Eigen::Vector3d* h,
                           bool* transmit) const {
  if (pass_ || wo.z() <= 0 || wi.z() == 0) return false;
  *transmit = wi.z() < 0;
  Eigen::Vector3d m;
  if (!*transmit || p_.thin) {
    m = wo + (*transmit ? FlipZ(wi) : wi);
  } else {
    m = -(wo + p_.eta * wi);  // Walter et al. eq. 16, on wo's side
    if (m.z() < 0) m = -m;
  }
  const double len = m.norm();
  if (!(len > 1e-9)) return false;
  *h = m / len;
  if (h->z() <= 0 || wo.dot(*h) <= 0) return false;
  // A refraction must leave through the microfacet's far side.
  if (*transmit && !p_.thin && wi.dot(*h) >= 0) return false;
  return true;
}

Eigen::Vector3d GlassBsdf::Eval(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const {
  Eigen::Vector3d h;
  bool transmit = false;
  if (!HalfVector(wo, wi, &h, &transmit)) return Eigen::Vector3d::Zero();
  const double F = FresnelDielectric(wo.dot(h), p_.eta);
  const double D = GgxD(h, p_.alpha);
  const double G = 1 / (1 + GgxLambda(wo, p_.alpha) + GgxLambda(wi, p_.alpha));
  if (!transmit) return Eigen::Vector3d::Constant(F * D * G / (4 * wo.z() * wi.z()));
  if (p_.thin) return p_.tint * ((1 - F) * D * G / (4 * wo.z() * std::abs(wi.z())));
  const double denom = wo.dot(h) + p_.eta * wi.dot(h);
  const double v = (1 - F) * D * G * std::abs(wo.dot(h) * wi.dot(h)) / (wo.z() * std::abs(wi.z()) * denom * denom);
  return p_.tint * v;
}

double GlassBsdf::Pdf(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const {
  Eigen::Vector3d h;
  bool transmit = false;
  if (!HalfVector(wo, wi, &h, &transmit)) return 0;
  const double F = FresnelDielectric(wo.dot(h), p_.eta);
  // The visible normals' density D_wo(h) = G1(wo) (wo . h) D(h) / wo.z.
  const double dh = GgxD(h, p_.alpha) * wo.dot(h) / ((1 + GgxLambda(wo, p_.alpha)) * wo.z());
  if (!transmit) return F * dh / (4 * wo.dot(h));
  if (p_.thin) return (1 - F) * dh / (4 * wo.dot(h));
  const double denom = wo.dot(h) + p_.eta * wi.dot(h);
  return (1 - F) * dh * p_.eta * p_.eta * std::abs(wi.dot(h)) / (denom * denom);
}

bool GlassBsdf::Sample(const Eigen::Vector3d& wo, double u_lobe, double u0, double u1, BsdfSample* s) const {
  if (wo.z() <= 0) return false;
  if (pass_) {
    s->wi = -wo;
    s->f = p_.tint / wo.z();
    s->pdf = 1;
    s->delta = true;
    return true;
  }
  const Eigen::Vector3d h = SampleGgxVisibleNormal(wo, p_.alpha, u0, u1);
  const double F = FresnelDielectric(wo.dot(h), p_.eta);
  const Eigen::Vector3d r = 2 * wo.dot(h) * h - wo;
  if (u_lobe < F) {
    s->wi = r;
  } else if (p_.thin) {
    s->wi = FlipZ(r);
  } else if (!Refract(wo, h, p_.eta, &s->wi)) {
    return false;  // F = 1 there: not reached
  }
  if (s->wi.z() == 0 || (u_lobe < F) != (s->wi.z() > 0)) return false;
  s->f = Eval(wo, s->wi);
  s->pdf = Pdf(wo, s->wi);
  return s->pdf > 0 && s->f.maxCoeff() > 0;
}

}  // namespace mr
