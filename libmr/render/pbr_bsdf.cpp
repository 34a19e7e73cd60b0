#include "render/pbr_bsdf.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "core/color.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"

namespace mr {

double FresnelDielectric(double cos_i, double eta) {
  cos_i = std::clamp(cos_i, 0.0, 1.0);
  const double sin_t2 = (1 - cos_i * cos_i) / (eta * eta);
  if (sin_t2 >= 1) return 1;  // total internal reflection (eta < 1 only)
  const double cos_t = std::sqrt(1 - sin_t2);
  const double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  const double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

namespace {

Eigen::Vector3d Schlick(const Eigen::Vector3d& f0, double cos_i) {
  const double m = std::clamp(1 - cos_i, 0.0, 1.0), m5 = m * m * m * m * m;
  return f0 + (Eigen::Vector3d::Ones() - f0) * m5;
}

// Kulla and Conty's multiple-scattering Fresnel: the average Fresnel over
// the bounces inside the microsurface.
double Fms(double f_avg, double e_avg) { return f_avg * f_avg * e_avg / (1 - f_avg * (1 - e_avg)); }
Eigen::Vector3d Fms(const Eigen::Vector3d& f_avg, double e_avg) {
  return {Fms(f_avg[0], e_avg), Fms(f_avg[1], e_avg), Fms(f_avg[2], e_avg)};
}

// Grids with nodes at both ends: mu in [0, 1] (the first node at 1e-3,
// where the integrand is defined), perceptual roughness (sqrt alpha) in
// [0, 1], eta in [1, 3].
constexpr int kMu = 32, kAlpha = 32, kEta = 16;
constexpr double kEtaMax = 3.0;
double MuAt(int i) { return std::max(1e-3, static_cast<double>(i) / (kMu - 1)); }
double RoughAt(int j) { return static_cast<double>(j) / (kAlpha - 1); }
double EtaAt(int k) { return 1 + (kEtaMax - 1) * k / (kEta - 1); }
// Trapezoid weights of node i for 2 int_0^1 g(mu) mu dmu.
double AvgWeight(int i) { return 2 * MuAt(i) * (i == 0 || i == kMu - 1 ? 0.5 : 1.0) / (kMu - 1); }

// Linear interpolation weights of x on a grid at i / (n - 1), clamped.
void Cell(double x, int n, int* i0, double* t) {
  const double f = std::clamp(x * (n - 1), 0.0, n - 1.0);
  *i0 = std::min(static_cast<int>(f), n - 2);
  *t = f - *i0;
}

// The directional albedo at mu of GGX (alpha) with Fresnel F(cos wo.h):
// a midpoint rule over the visible normals (their weight G2/G1 F is smooth).
template <class F>
double Albedo(double mu, double alpha, F fresnel) {
  constexpr int n = 48;
  const Eigen::Vector3d wo(std::sqrt(1 - mu * mu), 0, mu);
  const double l_o = GgxLambda(wo, alpha);
  double sum = 0;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const Eigen::Vector3d h = SampleGgxVisibleNormal(wo, alpha, (a + 0.5) / n, (b + 0.5) / n);
      const Eigen::Vector3d wi = 2 * wo.dot(h) * h - wo;
      if (wi.z() <= 0) continue;
      sum += (1 + l_o) / (1 + l_o + GgxLambda(wi, alpha)) * fresnel(wo.dot(h));
    }
  return sum / (n * n);
}

struct Tables {
  std::vector<double> e, e_avg, ed, ed_avg, f_avg;  // [alpha][mu], [alpha], [eta][alpha][mu], [eta][alpha], [eta]
  Tables() : e(kAlpha * kMu), e_avg(kAlpha), ed(kEta * kAlpha * kMu), ed_avg(kEta * kAlpha), f_avg(kEta) {}
  std::vector<double*> Parts() { return {e.data(), e_avg.data(), ed.data(), ed_avg.data(), f_avg.data()}; }
  std::vector<size_t> Sizes() const { return {e.size(), e_avg.size(), ed.size(), ed_avg.size(), f_avg.size()}; }
};

// The tables from their definition (1.3 s on 2 cores, 8.5 s under ASan:
// what every process paid before they were embedded).
Tables Compute() {
  Tables t;
  for (int k = 0; k < kEta; ++k) {  // 2 int_0^1 F(mu) mu dmu, midpoint rule
    double s = 0;
    for (int i = 0; i < 1000; ++i) s += 2 * ((i + 0.5) / 1000) * FresnelDielectric((i + 0.5) / 1000, EtaAt(k)) / 1000;
    t.f_avg[static_cast<size_t>(k)] = s;
  }
  // Each roughness row on its own (the rows are independent: the same
  // numbers whatever the thread count).
  ParallelFor(0, kAlpha, [&](int64_t jj) {
    const int j = static_cast<int>(jj);
    const double alpha = std::max(RoughAt(j) * RoughAt(j), 1e-4);
    double avg = 0;
    for (int i = 0; i < kMu; ++i) {
      const double v = Albedo(MuAt(i), alpha, [](double) { return 1.0; });
      t.e[static_cast<size_t>(j * kMu + i)] = v;
      avg += AvgWeight(i) * v;
    }
    t.e_avg[static_cast<size_t>(j)] = avg;
    for (int k = 0; k < kEta; ++k) {
      const double eta = EtaAt(k);
      const double fms = Fms(t.f_avg[static_cast<size_t>(k)], avg);
      double davg = 0;
      for (int i = 0; i < kMu; ++i) {
        const double single = Albedo(MuAt(i), alpha, [&](double c) { return FresnelDielectric(c, eta); });
        // The multiple-scattering lobe's albedo at mu is (1 - E(mu)) F_ms.
        const double v = single + (1 - t.e[static_cast<size_t>(j * kMu + i)]) * fms;
        t.ed[static_cast<size_t>((k * kAlpha + j) * kMu + i)] = v;
        davg += AvgWeight(i) * v;
      }
      t.ed_avg[static_cast<size_t>(k * kAlpha + j)] = davg;
    }
  });
  return t;
}

// The tables as Compute() gave them, embedded (pbr_tables_data.inc, written
// by bench/gen_pbr_tables.cpp; the test PbrTables.EmbeddedAreTheirDefinition
// recomputes them).
#include "render/pbr_tables_data.inc"

const Tables& GetTables() {
  static const Tables t = [] {
    Tables e;
    static_assert(sizeof(kPbrTableValues) / sizeof(double) == kAlpha * kMu * (1 + kEta) + kAlpha * (1 + kEta) + kEta);
    const double* v = kPbrTableValues;
    const std::vector<size_t> sizes = e.Sizes();
    const std::vector<double*> parts = e.Parts();
    for (size_t p = 0; p < parts.size(); ++p) {
      std::copy(v, v + sizes[p], parts[p]);
      v += sizes[p];
    }
    return e;
  }();
  return t;
}

void EtaCell(double eta, int* k0, double* t) {
  const double f = std::clamp((eta - 1) / (kEtaMax - 1) * (kEta - 1), 0.0, kEta - 1.0);
  *k0 = std::min(static_cast<int>(f), kEta - 2);
  *t = f - *k0;
}

}  // namespace

double PbrTables::E(double mu, double alpha) const {
  const Tables& t = GetTables();
  int i, j;
  double ti, tj;
  Cell(mu, kMu, &i, &ti);
  Cell(std::sqrt(alpha), kAlpha, &j, &tj);
  auto at = [&](int jj, int ii) { return t.e[static_cast<size_t>(jj * kMu + ii)]; };
  return (1 - tj) * ((1 - ti) * at(j, i) + ti * at(j, i + 1)) + tj * ((1 - ti) * at(j + 1, i) + ti * at(j + 1, i + 1));
}

double PbrTables::Eavg(double alpha) const {
  int j;
  double tj;
  Cell(std::sqrt(alpha), kAlpha, &j, &tj);
  const auto& e = GetTables().e_avg;
  return (1 - tj) * e[static_cast<size_t>(j)] + tj * e[static_cast<size_t>(j + 1)];
}

double PbrTables::Ed(double mu, double alpha, double eta) const {
  const Tables& t = GetTables();
  int i, j, k;
  double ti, tj, tk;
  Cell(mu, kMu, &i, &ti);
  Cell(std::sqrt(alpha), kAlpha, &j, &tj);
  EtaCell(eta, &k, &tk);
  auto at = [&](int kk, int jj, int ii) { return t.ed[static_cast<size_t>((kk * kAlpha + jj) * kMu + ii)]; };
  auto bilinear = [&](int kk) {
    return (1 - tj) * ((1 - ti) * at(kk, j, i) + ti * at(kk, j, i + 1)) +
           tj * ((1 - ti) * at(kk, j + 1, i) + ti * at(kk, j + 1, i + 1));
  };
  return (1 - tk) * bilinear(k) + tk * bilinear(k + 1);
}

double PbrTables::EdAvg(double alpha, double eta) const {
  const Tables& t = GetTables();
  int j, k;
  double tj, tk;
  Cell(std::sqrt(alpha), kAlpha, &j, &tj);
  EtaCell(eta, &k, &tk);
  auto at = [&](int kk, int jj) { return t.ed_avg[static_cast<size_t>(kk * kAlpha + jj)]; };
  return (1 - tk) * ((1 - tj) * at(k, j) + tj * at(k, j + 1)) + tk * ((1 - tj) * at(k + 1, j) + tj * at(k + 1, j + 1));
}

double PbrTables::FavgDielectric(double eta) const {
  int k;
  double tk;
  EtaCell(eta, &k, &tk);
  const auto& f = GetTables().f_avg;
  return (1 - tk) * f[static_cast<size_t>(k)] + tk * f[static_cast<size_t>(k + 1)];
}

const PbrTables& GetPbrTables() {
  static const PbrTables t;
  GetTables();  // copied from the embedded values on first use (thread-safe static)
  return t;
}

std::vector<double> ComputePbrTableValues(bool embedded) {
  Tables t = embedded ? GetTables() : Compute();
  std::vector<double> out;
  for (size_t p = 0; p < t.Sizes().size(); ++p) out.insert(out.end(), t.Parts()[p], t.Parts()[p] + t.Sizes()[p]);
  return out;
}

PbrBsdf::PbrBsdf(const PbrParams& p)
    : diffuse_(p.base_color.cwiseMax(0.0).cwiseMin(1.0) * (1 - std::clamp(p.metallic, 0.0, 1.0))),
      f0_metal_(p.base_color.cwiseMax(0.0).cwiseMin(1.0)),
      tint_(p.specular_color.cwiseMax(0.0).cwiseMin(1.0)),
      metallic_(std::clamp(p.metallic, 0.0, 1.0)),
      alpha_(std::max(p.roughness * p.roughness, 1e-4)),
      eta_(std::clamp(p.ior, 1.0, kEtaMax)) {}

Eigen::Vector3d PbrBsdf::Eval(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const {
  if (wo.z() <= 0 || wi.z() <= 0) return Eigen::Vector3d::Zero();
  const PbrTables& t = GetPbrTables();
  const double mo = std::min(wo.z(), 1.0), mi = std::min(wi.z(), 1.0);
  Eigen::Vector3d f = Eigen::Vector3d::Zero();
  // The microfacet lobe, its Fresnel the metal's and the dielectric's mix.
  const Eigen::Vector3d h = (wo + wi).normalized();
  const double g = 1.0 / (1.0 + GgxLambda(wo, alpha_) + GgxLambda(wi, alpha_));
  const double denom = 4 * mo * mi;
  if (g > 0 && denom > 0) {
    const double c = wo.dot(h);
    const Eigen::Vector3d fr = metallic_ * Schlick(f0_metal_, c) + (1 - metallic_) * FresnelDielectric(c, eta_) * tint_;
    f += fr * (GgxD(h, alpha_) * g / denom);
  }
  // The multiple-scattering lobe (Kulla and Conty).
  const double e_avg = t.Eavg(alpha_);
  if (e_avg < 1) {
    const Eigen::Vector3d f_avg_metal = f0_metal_ + (Eigen::Vector3d::Ones() - f0_metal_) / 21.0;  // Schlick's
    const Eigen::Vector3d fms =
        metallic_ * Fms(f_avg_metal, e_avg) + (1 - metallic_) * Fms(t.FavgDielectric(eta_), e_avg) * tint_;
    f += fms * ((1 - t.E(mo, alpha_)) * (1 - t.E(mi, alpha_)) / (kPi * (1 - e_avg)));
  }
  // The base under the dielectric coat, given what the coat lets through.
  if (metallic_ < 1) {
    const double ed_avg = t.EdAvg(alpha_, eta_);
    f += diffuse_ * ((1 - t.Ed(mo, alpha_, eta_)) * (1 - t.Ed(mi, alpha_, eta_)) / (kPi * (1 - ed_avg)));
  }
  return f;
}

Eigen::Vector3d PbrBsdf::DiffuseBound() const {
  // (1 - E_d(mu_o)) (1 - E_d(mu_i)) <= 1; the multiple-scattering lobe's
  // (1 - E)(1 - E) F_ms / (pi (1 - E_avg)) <= 1 / (pi (1 - E_avg)).
  const PbrTables& t = GetPbrTables();
  const double e_avg = t.Eavg(alpha_);
  return diffuse_ / (kPi * std::max(1 - t.EdAvg(alpha_, eta_), 1e-6)) +
         Eigen::Vector3d::Constant(e_avg < 1 ? 1 / (kPi * (1 - e_avg)) : 0);
}

Eigen::Vector3d PbrBsdf::GlossyBound(const Eigen::Vector3d& wo) const {
  // F <= 1: Bsdf's bound of a GGX lobe of reflectance 1.
  if (wo.z() <= 0) return Eigen::Vector3d::Zero();
  const double z = std::min(wo.z(), 1.0), sin_o = std::sqrt(std::max(0.0, 1 - z * z));
  const double a2 = alpha_ * alpha_;
  const double grazing = sin_o > 0 ? 1 / (2 * kPi * a2 * alpha_ * sin_o) : INFINITY;
  return Eigen::Vector3d::Constant(std::min(1 / (4 * kPi * a2 * z), grazing));
}

// The share of samples the microfacet lobe takes at mu_o: its albedo's
// luminance against the cosine-sampled lobes' (base and multiple
// scattering), with a floor so that neither is starved.
double PbrBsdf::SpecularWeight(double mu_o) const {
  const PbrTables& t = GetPbrTables();
  const double e = t.E(mu_o, alpha_);
  const double spec = metallic_ * Luminance(f0_metal_) * e + (1 - metallic_) * (t.Ed(mu_o, alpha_, eta_) - 0.0);
  const double cosine = (1 - metallic_) * Luminance(diffuse_) * (1 - t.Ed(mu_o, alpha_, eta_)) + metallic_ * (1 - e);
  return std::clamp(spec / std::max(spec + cosine, 1e-12), 0.05, 0.95);
}

double PbrBsdf::Pdf(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const {
  if (wo.z() <= 0 || wi.z() <= 0) return 0;
  const double ws = SpecularWeight(std::min(wo.z(), 1.0));
  double pdf = (1 - ws) * wi.z() * kInvPi;
  const Eigen::Vector3d h = (wo + wi).normalized();
  if (wo.dot(h) > 0) pdf += ws * GgxD(h, alpha_) / ((1 + GgxLambda(wo, alpha_)) * 4 * wo.z());
  return pdf;
}

bool PbrBsdf::Sample(const Eigen::Vector3d& wo, double u_lobe, double u0, double u1, BsdfSample* s,
                     const Eigen::Vector3d* cosine) const {
  if (wo.z() <= 0) return false;
  if (u_lobe < SpecularWeight(std::min(wo.z(), 1.0))) {
    const Eigen::Vector3d h = SampleGgxVisibleNormal(wo, alpha_, u0, u1);
    s->wi = 2 * wo.dot(h) * h - wo;
  } else if (cosine) {
    s->wi = *cosine;
  } else {
    const auto d = SampleCosineHemisphere(u0, u1);
    s->wi = Eigen::Vector3d(d[0], d[1], d[2]);
  }
  if (s->wi.z() <= 0) return false;
  s->f = Eval(wo, s->wi);
  s->pdf = Pdf(wo, s->wi);
  return s->pdf > 0;
}

}  // namespace mr
