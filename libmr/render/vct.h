// `vct`: delta global illumination by voxel cone tracing (Thöner & Kuijper
// 2016, ../shared/papers/delta-gi-voxel-cone-tracing.txt), on the CPU.
// Light, delta and visibility volumes around the virtual objects, read by
// diffuse, specular and shadow cones.  The volumes, the accumulation rules
// and the relighting modes, with their measured effect: docs/methods.md, "vct".
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "camera/camera_model.h"
#include "core/report.h"
#include "render/method.h"
#include "render/path_tracer.h"
#include "render/pixel_loop.h"

namespace mr {

struct PathVertex;  // render/path_common.h

struct VctSettings {
  int resolution = 32;  // voxels along the volume's longest side
  int directions = 64;  // environment directions injected
  // Bounces of light in the volumes: 1, the paper's (the light that the
  // lights and the environment's directions deposit), or 2: each occupied
  // voxel then also reflects what it gathers of the first through diffuse
  // cones from both its sides (docs/methods.md, "vct").
  int bounces = 2;
  // Samples of the direct light at each camera point per camera sample, each
  // weighted 1/n (DirectDiffuseSamples).
  int direct_samples = 1;
  // Samples of the direct light at camera points on the virtual objects,
  // each weighted 1/n (at least direct_samples): the objects' pixels are
  // few, and at low spp their direct light's noise is most of the region's
  // error (docs/benchmarks.md, "The objects' own pixels").
  int object_direct_samples = 16;
  // Samples of the virtual objects' shadows at real camera points, each
  // weighted 1/n (DirectDiffuse's `shadows`): the lights' virtual shadows
  // and the environment's difference, traced only where an object can
  // block; the light itself keeps one sample.  1: vct's lights' shadows
  // are cones, each costing about a camera sample's cones (4: 4-55% less
  // error for 35-90% more time).
  int shadow_samples = 1;
  double injection_spacing = 0.5;        // injection ray spacing, voxels
  double shadow_aperture_deg = 2;        // shadow cone, full angle
  double min_specular_aperture_deg = 1;  // specular cone, full angle at roughness 0
  bool paper_accumulation = false;
  bool split_relighting = true;  // false: the paper's delta volume (see docs/benchmarks.md)
  int far_field_width = 64;      // lat-long far field, width (height: half)
  int far_field_samples = 16;    // paths per far-field texel
  double cone_offset = 1.0;      // cone origins lifted off the surface, voxels
  int max_depth = 5;             // far-field paths
  // At the virtual points the camera sees, indirect light along
  // cosine-sampled rays (gather_rays), from the point each meets as vct shades it,
  // instead of six diffuse cones from the object's own surface (which
  // missed half a backlit object's bounce light: docs/methods.md, "vct").
  bool final_gather = true;
  // Rays of that final gather per camera sample, each weighted 1/n (as
  // vpl's): the objects' pixels are few, so each ray costs little.
  int gather_rays = 4;
  uint64_t seed = 0;
};

// What one cone gathered: light of the mixed (I_m), real (I_r) and delta
// solutions and the occlusion each accumulated.
struct ConeResult {
  Eigen::Vector3d mixed = Eigen::Vector3d::Zero(), real = Eigen::Vector3d::Zero(), delta = Eigen::Vector3d::Zero();
  double occ_mixed = 0, occ_real = 0;
  int steps = 0;
};

class VctVolumes {
 public:
  struct Voxel {
    float occ_r = 0, occ_v = 0;                                                    // occupancy (fraction of sub-voxels)
    Eigen::Vector3f n_r = Eigen::Vector3f::Zero(), n_v = Eigen::Vector3f::Zero();  // mean normal x occupancy
    Eigen::Vector3f l_m = Eigen::Vector3f::Zero(), l_r = Eigen::Vector3f::Zero();  // radiance x occupancy
    // Mean normal of the lit sides (facing the light), weighted by
    // reflected light, x luminance(l): light leaves a voxel towards where
    // its lit surfaces face.
    Eigen::Vector3f nl_m = Eigen::Vector3f::Zero(), nl_r = Eigen::Vector3f::Zero();
  };
  struct Level {
    int nx = 0, ny = 0, nz = 0;
    double size = 0;  // voxel edge, world units
    std::vector<Voxel> v;
    size_t Index(int x, int y, int z) const { return (static_cast<size_t>(z) * ny + y) * nx + x; }
  };

  // With `previous` (the last frame's volumes, the world having changed):
  // the voxel grid is kept while the virtual objects stay inside it, the
  // real surfaces' voxelisation is kept, and the virtual surfaces' is kept
  // too unless `objects_moved`; light is always injected again.
  static std::shared_ptr<const VctVolumes> Build(const RenderScene& scene, const VctSettings& settings,
                                                 const VctVolumes* previous = nullptr, bool objects_moved = true);
  // What the last Build did with the voxelisation: "full", "virtual
  // surfaces only" or "kept".
  const std::string& voxelised() const { return voxelised_; }
  const VctSettings& settings() const { return settings_; }
  const Eigen::AlignedBox3d& box() const { return box_; }
  double voxel() const { return levels_.empty() ? 0 : levels_[0].size; }
  const std::vector<Level>& levels() const { return levels_; }
  double build_seconds() const { return build_seconds_; }

  // What a cone reads: diffuse cones the light volumes and, beyond them, the
  // far field's surfaces (steps of one diameter, as the paper's); specular
  // cones also the far field's sky (half-diameter steps); shadow cones the
  // virtual visibility volume alone (occ_mixed; half-diameter steps).
  enum class Cone { kDiffuse, kSpecular, kShadow };
  // Marches a cone of half-angle `half_angle` (radians) from `origin` along
  // unit `dir`, from `t_start` to `t_max` along it.
  ConeResult March(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double half_angle, double t_start,
                   double t_max, Cone kind) const;
  // The far field along `dir` prefiltered to a cone of half-angle `half_angle`.
  void FarField(const Eigen::Vector3d& dir, double half_angle, bool sky, Eigen::Vector3d* mixed,
                Eigen::Vector3d* real) const;
  void Describe(Report* report) const;

 private:
  Voxel Sample(const Eigen::Vector3d& p, double level) const;
  void BuildMips();        // levels_[1..] from levels_[0]
  void AddSecondBounce();  // VctSettings::bounces 2; needs the mips and the far field
  VctSettings settings_;
  Eigen::AlignedBox3d box_;
  std::vector<Level> levels_;
  // Far field: lat-long maps per prefilter level; [level][texel] of
  // {surface mixed, surface real, sky mixed, sky real}.
  int far_w_ = 0, far_h_ = 0;
  std::vector<double> far_half_angles_;
  std::vector<std::vector<std::array<Eigen::Vector3f, 4>>> far_;
  double build_seconds_ = 0;
  std::string box_reason_, voxelised_ = "full";
  // The voxelisation (area and area-weighted normal sums per level-0 voxel,
  // real and virtual), kept for the next frame's Build.
  std::vector<double> area_r_, area_v_;
  std::vector<Eigen::Vector3d> nsum_r_, nsum_v_;
  std::vector<Eigen::Vector3d> albedo_r_, albedo_v_;  // area-weighted albedo sums
  int dims_[3] = {0, 0, 0};
  int64_t injection_rays_ = 0, voxelisation_rays_ = 0, far_field_paths_ = 0, occupied_ = 0;
};

class VctFrameRenderer : public PixelLoopMethod {
 public:
  VctFrameRenderer(const RenderScene& scene, std::shared_ptr<const VctVolumes> volumes, const CameraModel& camera,
                   const Rigid3& world_from_cam, uint64_t seed, int frame, const CameraExposure& exposure = {},
                   const PlateViews& plates = {});
  void RenderPass(int spp) override;
  void Describe(Report* report, int frame) const;

  struct Counters {
    int64_t diffuse_cones = 0, specular_cones = 0, shadow_cones = 0, shadow_cones_skipped = 0, steps = 0, rays = 0,
            relight_skipped = 0, gather_rays = 0, glass_paths = 0;
    Counters& operator+=(const Counters& o) {
      diffuse_cones += o.diffuse_cones;
      specular_cones += o.specular_cones;
      shadow_cones += o.shadow_cones;
      shadow_cones_skipped += o.shadow_cones_skipped;
      steps += o.steps;
      rays += o.rays;
      relight_skipped += o.relight_skipped;
      gather_rays += o.gather_rays;
      glass_paths += o.glass_paths;
      return *this;
    }
  };
  const Counters& counters() const { return counters_; }

 private:
  void Shade(const Ray& ray, Sampler& rng, int64_t row, size_t pixel, int sample, PathSample* out) override;
  void ShadeGlossyLobe(const PathVertex& v, bool xv, const Eigen::Vector3d& origin, bool want_m, bool want_r,
                       Sampler& g, Counters* counters, Eigen::Vector3d* mixed, Eigen::Vector3d* real) const;
  const RenderScene& scene_;
  std::shared_ptr<const VctVolumes> vol_;
  // A transmissive asset's BSDF-sampled rays, path-traced (the plate where
  // a refracted ray meets the room it shows, as pt).
  DifferentialPathTracer glass_tracer_;
  std::vector<Counters> rows_;  // this pass's, per image row
  Counters counters_;
};

// The registry's `vct` (render.vct: VctSettings' fields; accumulation
// "front_to_back" or "paper", relight "split" or "delta").
std::unique_ptr<RenderMethod> MakeVctMethod(JsonSettings& block, const Scene& scene);

}  // namespace mr
