// A rough dielectric interface (glTF's KHR_materials_transmission with
// KHR_materials_ior and _volume): GGX microfacet reflection and refraction
// (Walter, Marschner, Li and Torrance 2007, "Microfacet Models for
// Refraction through Rough Surfaces"), the exact unpolarised Fresnel
// choosing between them, total internal reflection included.  Local frame:
// z is the shading normal on wo's side, wo.z > 0; wi.z < 0 is transmission.
//  - solid: `eta` is the index on the far side over the index on wo's side
//    (ior entering, 1/ior leaving); refracted directions bend (radiance
//    transport: f_t carries no eta^2 factor, as pbrt's Radiance mode).
//  - thin-walled (KHR_materials_volume absent or thickness 0): the light
//    passes a sheet without bending; the transmitted direction is the
//    reflected one mirrored through the surface (Fresnel at ior).
// Transmitted light is tinted by `tint` (glTF: the base colour).
// An interface of eta within 1e-3 of 1 reflects nothing (F < 3e-7) and
// bends nothing: it passes every ray straight on (a delta sample), since
// the refraction half vector degenerates there.
// Single scattering: a rough glass loses what GGX's masking loses (no
// multiple-scattering compensation; docs/methods.md, "Glass").
#pragma once

#include <Eigen/Core>

#include "render/microfacet.h"

namespace mr {

struct GlassParams {
  double alpha = 1e-4;  // GGX roughness (roughness^2), >= 1e-4
  double eta = 1.5;     // relative index across the interface, > 0
  bool thin = false;
  Eigen::Vector3d tint = Eigen::Vector3d::Ones();
};

class GlassBsdf {
 public:
  explicit GlassBsdf(const GlassParams& p);
  Eigen::Vector3d Eval(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const;
  double Pdf(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const;
  // A visible normal, then reflection with probability F(wo . h), else
  // transmission.
  bool Sample(const Eigen::Vector3d& wo, double u_lobe, double u0, double u1, BsdfSample* s) const;

 private:
  // The microfacet normal that takes wo to wi (on wo's side, h.z > 0), and
  // whether wi is a transmission; false where none does.
  bool HalfVector(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi, Eigen::Vector3d* h, bool* transmit) const;
  GlassParams p_;
  bool pass_ = false;  // eta ~ 1: straight through
};

// The direction refracted from wo (pointing away) through a surface of
// normal h (on wo's side) with relative index eta; false at total internal
// reflection.
bool Refract(const Eigen::Vector3d& wo, const Eigen::Vector3d& h, double eta, Eigen::Vector3d* wi);

}  // namespace mr
