// `vpl`: differential instant radiosity (Knecht et al. 2010,
// ../shared/papers/differential-instant-radiosity.txt), offline on the CPU.
// Virtual point lights with the paper's real/virtual flags, built once per
// render and gathered with exact shadow rays; the clamp's bias is measured
// and reported.  The method in full: docs/methods.md, "vpl".
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/report.h"
#include "render/caustics.h"
#include "render/method.h"
#include "render/path_common.h"
#include "render/path_tracer.h"
#include "render/pixel_loop.h"
#include "render/vpl_tree.h"

namespace mr {

struct VplSettings {
  int paths = 1024;  // light paths from the emitters
  // The direct light of the environment and the lights: sampled at every
  // shading point per camera sample (false), or, as the paper's, from one
  // fixed set of `directions` directional VPLs (true: flicker-free, but that
  // one draw's error stays in every pixel of every frame and does not fall
  // with the samples: 18% on a floor under a sunny sky at 128 directions).
  bool fixed_directions = false;
  int directions = 128;  // the fixed set's directional VPLs (fixed_directions)
  // Samples of the direct light (DirectDiffuse) at each camera point per
  // camera sample, each weighted 1/n: the direct light's noise falls
  // without more of the VPLs' gather, which costs the most (4: the same
  // seconds a frame as 1 on the main job's dynamic capture and the bunny
  // room, 8-23% less error, docs/benchmarks.md).
  int direct_samples = 4;
  // Samples of the direct light at camera points on the virtual objects,
  // each weighted 1/n (at least direct_samples): the objects' pixels are
  // few, and at low spp their direct light's noise is most of the region's
  // error (docs/benchmarks.md, "The objects' own pixels").
  int object_direct_samples = 16;
  // Samples of the virtual objects' shadows at real camera points, each
  // weighted 1/n (DirectDiffuse's `shadows`): the lights' virtual shadows
  // and the environment's difference, traced only where an object can
  // block; the light itself keeps one sample.  1: direct_samples already
  // repeats them (4: 3-37% less error for 10-110% more time).
  int shadow_samples = 1;
  int max_depth = 5;          // surface bounces of a whole path, as pt's max_depth
  double clamp_distance = 0;  // metres; 0: 2% of the scene's diagonal
  bool compensate = false;    // add back the clamped energy (Kollig & Keller)
  int glossy_depth = 2;       // glossy bounces followed by BSDF-sampled rays
  // Shadow tests of VPLs whose unshadowed contribution to a point is below
  // this fraction of the mean one are not traced (the VPL is dropped there).
  double drop_threshold = 1e-3;
  uint64_t seed = 0;
  // The glossy rays from virtual surfaces take the plate where it sees the
  // real point they meet, as pt's paths do (PlateView).
  bool plate_reflections = true;
  // At virtual points the camera sees, indirect light by one BSDF-sampled
  // ray per sample (a final gather) instead of the VPLs: the plate's
  // radiance where it sees the real point met, else the VPLs' light there
  // and the direct light its diffuse lobe reflects (not its glossy lobe's:
  // a caustic that made fireflies; the bias is measured in docs/methods.md).
  // VPLs from light paths are sparse next to a small object (one per m² on
  // a 6 m floor), so without it the object misses most of its near bounce
  // light (docs/methods.md, "vpl").
  bool final_gather = true;
  // Rays of that final gather per camera sample (splitting): the object's
  // pixels are few, so each costs little, and one ray a sample left the
  // object's noise most of the region's error (docs/benchmarks.md).
  int gather_rays = 4;
  // Photons for the light that reaches the virtual objects by one glossy
  // reflection in a real surface (render/caustics.h); the VPLs' glossy
  // lobes then leave that light out at virtual points.  0: none, the VPLs'
  // glossy lobes carry it (in splotches) and the final gather misses it.
  int caustic_photons = 1 << 18;
  // Lightcuts (Walter et al. 2005): the VPLs are gathered through a light
  // tree, each cluster by one representative (drawn afresh at each point)
  // and one shadow test, refined until no cluster's bound on its error
  // exceeds cut_error of the point's estimated light, or the cut holds
  // max_cut clusters.  0: every VPL is tested (the exhaustive gather, with
  // drop_threshold).  0.1: the errors of 0.02 in 40% less time on the main
  // job's dynamic capture and the bunny room (docs/benchmarks.md).
  // Below cut_min_vpls VPLs the trees cost about what they save
  // (docs/benchmarks.md: even at about 60 VPLs, 1.3-1.4x faster at 230 and
  // 8.6x at 3753 on the table-top): every VPL is tested.
  double cut_error = 0.1;
  int max_cut = 1000;
  int cut_min_vpls = 64;
  // A pixel's later camera samples in a pass reuse the cut its first sample
  // made on the same surface facing the same way (normals within about 25
  // degrees), testing the same clusters (each by a representative drawn
  // afresh) at their own points: the bounds and the refinement are paid
  // once per pixel.  A
  // cluster that carried less than 1% of the first sample's light is
  // tested with probability share/1% (at least 1/4), weighted by its
  // inverse (unbiased).
  bool reuse_cuts = true;
};

enum VplSets : uint8_t { kLightsReal = 1, kLightsMixed = 2, kLightsBoth = 3 };

struct Vpl {
  Eigen::Vector3d p;           // on the surface, offset along n
  ShadingFrame frame;          // n faces the side the light arrived on
  Eigen::Vector3d wi_local;    // towards where the light came from, in frame
  Eigen::Vector3d flux;        // arriving flux (W)
  Bsdf bsdf;                   // the surface's, with its albedo there
  Bsdf diffuse;                // its diffuse lobe alone
  uint8_t sets = kLightsBoth;  // which solutions it lights
  bool on_virtual = false;
  int depth = 0;  // surfaces met along its path before (0: lit by the emitter)
};

struct DirectionalVpl {
  Eigen::Vector3d dir;         // unit, towards the emitter
  Eigen::Vector3d irradiance;  // at normal incidence, this VPL's share
  uint8_t sets = kLightsBoth;
};

// Directional lights standing for the environment and the disc lights:
// `directions` environment directions, half importance-sampled and half
// uniform, weighted by the balance heuristic; disc lights by their cones
// (a quarter as many each); delta distant lights exactly.
std::vector<DirectionalVpl> DirectionalLights(const RenderScene& scene, int directions, uint64_t seed,
                                              const Eigen::Vector3d& centre);

// The VPLs of a scene: view-independent, built once per render and reused by
// every frame (so frames do not flicker).
class VplSet {
 public:
  static std::shared_ptr<const VplSet> Build(const RenderScene& scene, const VplSettings& settings);
  const std::vector<Vpl>& vpls() const { return vpls_; }
  const std::vector<DirectionalVpl>& directional() const { return directional_; }
  // Light trees over the VPLs, one per set (shared, mixed-only, real-only);
  // empty unless settings().cut_error > 0 and there are cut_min_vpls VPLs.
  const std::vector<VplTree>& trees() const { return trees_; }
  // Photons of the caustics on the virtual objects (empty: none).
  const CausticMap& caustics() const { return caustics_; }
  const VplSettings& settings() const { return settings_; }
  double clamp_distance() const { return clamp_; }
  double build_seconds() const { return build_seconds_; }
  // Counts by kind, and what was left out while building, for the report.
  void Describe(Report* report) const;

 private:
  std::vector<Vpl> vpls_;
  std::vector<DirectionalVpl> directional_;
  std::vector<VplTree> trees_;
  CausticMap caustics_;
  VplSettings settings_;
  double clamp_ = 0, build_seconds_ = 0;
  int64_t paths_ended_below_ = 0;  // VPLs not stored: flux below the drop threshold
};

class VplFrameRenderer : public PixelLoopMethod {
 public:
  VplFrameRenderer(const RenderScene& scene, std::shared_ptr<const VplSet> vpls, const CameraModel& camera,
                   const Rigid3& world_from_cam, uint64_t seed, int frame, const CameraExposure& exposure = {},
                   const PlateViews& plates = {});
  // Real points met by glossy rays from virtual surfaces: from the plate or rendered.
  const PlateCounters& plate_counters() const { return plate_tracer_.plate_counters(); }
  void RenderPass(int spp) override;
  // Energy the clamp removed, over the energy rendered (luminance, I_m and I_r).
  double clamp_bias_mixed() const;
  double clamp_bias_real() const;
  void Describe(Report* report, int frame) const;

  struct Counters {
    int64_t shadow_rays = 0, dropped = 0, virtual_tests_skipped = 0, rays = 0, compensation_rays = 0, gather_rays = 0;
    // Lightcuts: points gathered through the trees, the clusters of their
    // cuts, and the VPLs those clusters stood for.
    int64_t cut_points = 0, cut_clusters = 0, cut_vpls = 0, cuts_reused = 0;
    Counters& operator+=(const Counters& o) {
      cuts_reused += o.cuts_reused;
      cut_points += o.cut_points;
      cut_clusters += o.cut_clusters;
      cut_vpls += o.cut_vpls;
      shadow_rays += o.shadow_rays;
      dropped += o.dropped;
      virtual_tests_skipped += o.virtual_tests_skipped;
      rays += o.rays;
      compensation_rays += o.compensation_rays;
      gather_rays += o.gather_rays;
      return *this;
    }
  };

 private:
  void Shade(const Ray& ray, Sampler& rng, int64_t row, size_t pixel, int sample, PathSample* out) override;
  const RenderScene& scene_;
  std::shared_ptr<const VplSet> set_;
  DifferentialPathTracer plate_tracer_;  // the plate at real points (PlateAtRealPoint) only
  std::vector<double> bias_m_, bias_r_, lum_m_, lum_r_;
  std::vector<Counters> rows_;  // this pass's, per image row
  int64_t pass_ = 0;            // RenderPass calls: a pixel's cuts are reused within one
  Counters counters_;
};

// The registry's `vpl` (render.vpl: VplSettings' fields).
std::unique_ptr<RenderMethod> MakeVplMethod(JsonSettings& block, const Scene& scene);

}  // namespace mr
