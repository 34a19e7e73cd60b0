// glTF 2.0's metallic-roughness reflection model as a BSDF (reflection
// only; transmission comes with the glass work of issue 38), energy
// conserving and reciprocal (docs/methods.md, "Asset materials"):
//  - a GGX microfacet lobe (Walter et al. 2007; height-correlated Smith
//    masking) whose Fresnel term is the exact dielectric one at the
//    material's ior for the dielectric part (tinted by specular_color) and
//    Schlick's with F0 = base colour for the metal part, as the glTF
//    specification's appendix B defines them;
//  - the energy single scattering loses on rough microfacets put back by
//    Kulla and Conty's multiple-scattering lobe (2017, "Revisiting
//    Physically Based Shading at Imageworks"): f_ms = (1 - E(mu_o))
//    (1 - E(mu_i)) / (pi (1 - E_avg)) F_ms, so that a white metal of any
//    roughness reflects all the light in a white furnace;
//  - a Lambertian base of colour base x (1 - metallic) under the dielectric
//    lobe, scaled by (1 - E_d(mu_o)) (1 - E_d(mu_i)) / (1 - E_d,avg) where
//    E_d is the dielectric lobe's own directional albedo (Kulla and Conty's
//    albedo scaling): what the coat does not reflect reaches the base, and
//    a white base under it loses nothing.
// E, E_avg and E_d are tables computed once by deterministic quadrature
// (PbrTables()).  Local frame: z is the shading normal, wo and wi point away.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "render/microfacet.h"

namespace mr {

struct PbrParams {
  Eigen::Vector3d base_color = Eigen::Vector3d::Ones();      // linear, [0, 1]
  double metallic = 0;                                       // [0, 1]
  double roughness = 0.5;                                    // perceptual; alpha = roughness^2
  double ior = 1.5;                                          // the dielectric part's, [1, 3] (clamped)
  Eigen::Vector3d specular_color = Eigen::Vector3d::Ones();  // tints the dielectric Fresnel
};

class PbrBsdf {
 public:
  explicit PbrBsdf(const PbrParams& p);
  Eigen::Vector3d Eval(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const;
  double Pdf(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const;
  // Chooses the specular lobe (visible normals) or the cosine-distributed
  // ones (the base and the multiple-scattering lobe) by their albedos at wo.
  // `cosine`: as Bsdf::Sample's.
  bool Sample(const Eigen::Vector3d& wo, double u_lobe, double u0, double u1, BsdfSample* s,
              const Eigen::Vector3d* cosine = nullptr) const;
  double alpha() const { return alpha_; }
  // Bounds on f(wo, wi) wi.z over wi (Bsdf::DiffuseBound, GlossyBound): the
  // base's cosine-free part, and the microfacet and multiple-scattering
  // lobes' as Bsdf bounds a GGX lobe of reflectance 1.
  Eigen::Vector3d DiffuseBound() const;
  Eigen::Vector3d GlossyBound(const Eigen::Vector3d& wo) const;

 private:
  double SpecularWeight(double mu_o) const;
  Eigen::Vector3d diffuse_, f0_metal_, tint_;
  double metallic_, alpha_, eta_;
};

// The directional albedo tables (mu = cos theta, alpha, eta), bilinear or
// trilinear in their grids.
struct PbrTables {
  // GGX single scattering with F = 1.
  double E(double mu, double alpha) const;
  double Eavg(double alpha) const;
  // The dielectric lobe (single scattering with the exact Fresnel at eta,
  // plus its multiple-scattering lobe): what the base under it does not get.
  double Ed(double mu, double alpha, double eta) const;
  double EdAvg(double alpha, double eta) const;
  // The hemispherical average of the exact dielectric Fresnel.
  double FavgDielectric(double eta) const;
};
const PbrTables& GetPbrTables();
// The tables' values in one list (E, E_avg, Ed, Ed_avg, F_avg): computed
// from their definition (seconds), or as embedded in the library (what
// GetPbrTables reads).  For the generator of the embedded values and the
// test that they are their definition's.
std::vector<double> ComputePbrTableValues(bool embedded);

// Exact unpolarised Fresnel reflectance of a dielectric interface at
// cos_i (> 0) from the outside, relative ior eta (>= 1).
double FresnelDielectric(double cos_i, double eta);

}  // namespace mr
