// Caustic photons on the virtual objects: light that reaches an object by
// one reflection in a glossy real surface (the sun in a glossy table top,
// reflected onto the underside of the object on it).  A path from the
// object that finds this light must hit the small part of the surface that
// mirrors the emitter towards it; traced from the emitters, it is found by
// every photon the surface reflects into the object.  `vpl` takes this
// light from here instead of from the glossy lobes of the VPLs on real
// surfaces (docs/methods.md, "vpl": the caustic).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/report.h"
#include "render/bsdf.h"

namespace mr {

class RenderScene;
struct ShadingFrame;

struct CausticSettings {
  int photons = 1 << 16;  // photons sent towards the objects (0: none)
  // Photons enter through the sphere around the objects' bounding sphere
  // `reach` times as wide: the glossy surfaces within it can reflect light
  // into the objects.
  double reach = 4;
  // Photons gathered at a point, about: the gather radius is set so that
  // this many would fall in it if the stored photons covered the objects'
  // bounding sphere evenly, within [radius / 50, radius / 3].
  int neighbours = 32;
  uint64_t seed = 0;
};

class CausticMap {
 public:
  // Photons from the environment and every light of the scene towards the
  // virtual objects' bounding sphere (centre, radius); none when radius is
  // 0 or no real surface is glossy (a photon whose first surface is not
  // glossy is not followed).
  static CausticMap Build(const RenderScene& scene, const CausticSettings& settings, const Eigen::Vector3d& centre,
                          double radius);
  bool empty() const { return photons_.empty(); }
  // The radiance the stored photons give towards wo_l at point p (frame,
  // BSDF `bsdf`): their flux through the BSDF, in a cone filter of the
  // gather radius, from photons on the side the normal faces.
  Eigen::Vector3d Radiance(const Eigen::Vector3d& p, const ShadingFrame& frame, const Bsdf& bsdf,
                           const Eigen::Vector3d& wo_l) const;
  void Describe(Report* report) const;

 private:
  struct Photon {
    Eigen::Vector3d p, wi, n;  // position, towards where it came from, the surface's normal there
    Eigen::Vector3d flux;
  };
  std::vector<Photon> photons_;  // sorted by cell
  std::vector<int64_t> cell_keys_;
  std::vector<uint32_t> cell_begin_;  // photons_[cell_begin_[i], cell_begin_[i + 1]) lie in cell_keys_[i]
  double radius_ = 0, cell_ = 1;
  int64_t sent_ = 0, reflected_ = 0;
  std::string skipped_;  // why none were sent ("": sent)
  int64_t Key(int64_t x, int64_t y, int64_t z) const;
};

}  // namespace mr
