// Reflection models of mr-render: Lambertian diffuse plus a GGX microfacet
// lobe (Walter et al. 2007, Smith height-correlated masking), in a local
// frame whose z axis is the shading normal.  `specular` scales the glossy
// lobe (no Fresnel term: the captured materials are fitted as reflectances);
// albedo + specular <= 1 keeps the model energy-conserving (tested).
#pragma once

#include <optional>

#include <Eigen/Core>

#include "render/glass_bsdf.h"
#include "render/microfacet.h"
#include "render/pbr_bsdf.h"
#include "scene/scene.h"

namespace mr {

class Bsdf {
 public:
  Bsdf() = default;  // black: reflects nothing
  explicit Bsdf(const Material& m);
  // An asset's material at a point (render/pbr_bsdf.h): every call below
  // goes to it.
  explicit Bsdf(const PbrBsdf& pbr) : diffuse_weight_(1), pbr_(pbr) {}
  // A transmissive asset material: (1 - transmission) of `pbr` and
  // `transmission` of the glass interface (glTF: the dielectric base's
  // diffuse part replaced by the specular transmission).
  Bsdf(const PbrBsdf& pbr, const GlassBsdf& glass, double transmission);
  // Whether wi below the local horizon can carry light (transmission).
  bool Transmits() const { return glass_.has_value(); }
  // wo and wi in the local frame (z = normal), both pointing away from the surface.
  Eigen::Vector3d Eval(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const;
  double Pdf(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const;
  // Returns false when no direction was produced (e.g. below the horizon).
  // `cosine`, if given, is SampleCosineHemisphere(u0, u1), computed ahead
  // (in lanes, for a batch of paths): the same result, not computed again.
  bool Sample(const Eigen::Vector3d& wo, double u_lobe, double u0, double u1, BsdfSample* s,
              const Eigen::Vector3d* cosine = nullptr) const;
  bool IsBlack() const { return diffuse_weight_ + glossy_weight_ <= 0; }
  // Shading normals (docs/methods.md, "Shading normals"): `ng` is the unit
  // geometric normal in this BSDF's local frame (whose z is the shading
  // normal), on wo's side.  From then on a wi on the other side of the
  // geometric surface than its local z says (wi . ng and wi.z of different
  // sign) gets nothing, so no light leaks through the surface, and with
  // `shadowing` (a normal-mapped point) f is multiplied by Chiang, Li and
  // Burley's shadowing term (2019) against the terminator's hard edge.
  // Pdf is unchanged: it is the sampling density.
  void SetGeometricNormal(const Eigen::Vector3d& ng, bool shadowing);
  // Bounds on f(wo, wi) wi.z over every wi, per channel, for a light tree's
  // error bounds: the diffuse part's is albedo/pi times the cosine (the
  // caller bounds the cosine), `glossy` is specular times the smaller of
  // 1/(4 pi alpha^2 wo.z) (GGX's D peaks at 1/(pi alpha^2), the masking
  // term is at most 1) and 1/(2 pi alpha^3 sin theta_o) (the masking term
  // at grazing wo): finite for every wo.
  Eigen::Vector3d DiffuseBound() const;
  Eigen::Vector3d GlossyBound(const Eigen::Vector3d& wo) const;

 private:
  double D(const Eigen::Vector3d& h) const;
  double Lambda(const Eigen::Vector3d& w) const;
  Eigen::Vector3d EvalLobes(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const;
  double GeometricFactor(const Eigen::Vector3d& wi) const;
  Eigen::Vector3d albedo_ = Eigen::Vector3d::Zero(), specular_ = Eigen::Vector3d::Zero();
  double alpha_ = 1;
  double diffuse_weight_ = 0, glossy_weight_ = 0;  // lobe selection probabilities
  std::optional<PbrBsdf> pbr_;
  std::optional<GlassBsdf> glass_;
  double transmission_ = 0;
  Eigen::Vector3d ng_ = Eigen::Vector3d::UnitZ();
  bool has_ng_ = false, shadowing_ = false;
};

}  // namespace mr
