// `ic`: differential irradiance caching (Kán & Kaufmann 2013,
// ../shared/papers/differential-irradiance-caching.txt), offline on the CPU.
// Indirect diffuse light comes from world-space cache records of mixed and
// real irradiance, kept across the frames of a render; direct light and
// glossy lobes are traced per camera sample, and the points glossy rays meet
// take their indirect light from the records too.  How records are made,
// weighted, splatted, looked up and re-evaluated: docs/methods.md, "ic".
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "camera/camera_model.h"
#include "core/large_buffer.h"
#include "core/report.h"
#include "render/method.h"
#include "render/path_tracer.h"
#include "render/pixel_loop.h"

namespace mr {

struct IcSettings {
  int rays = 128;
  // Rays of a record on a virtual object (at least `rays`): the objects'
  // records are few (28 of 4447 on the main job's static capture) and
  // their noise shows as blotches on the objects themselves, where viewers
  // look (128 at 32 rays: 6% less error on the objects' pixels there, for
  // no measurable time; docs/benchmarks.md, "Records on the objects").
  int object_rays = 128;
  double accuracy = 0.3;
  double min_spacing_px = 2, max_spacing_px = 32;  // influence radius (accuracy x R_i) clamp, pixels
  int t_max = 8;
  int tile = 16;
  // Records are not made at real points where the virtual objects' bounding
  // spheres subtend a form factor below this (and no virtual light exists):
  // there the indirect difference is taken as zero.  Only with a photograph.
  double influence_threshold = 1e-3;
  // Bounces of the glossy lobe's path from a camera hit, at most max_depth;
  // 0: the glossy lobe takes next-event light only; -1: max_depth.
  // With glossy_cache, a chain of glossy reflections: every point a glossy
  // ray meets is shaded as a camera point is (emission, direct light, the
  // records' indirect diffuse light, and its own glossy lobe while the
  // chain is shorter than glossy_depth).  Without, a BSDF-sampled
  // differential path of glossy_depth bounces, as pt's: unbiased only at
  // max_depth, and the paths through a glossy table to the sun are then
  // fireflies (docs/methods.md, "ic").
  int glossy_depth = 2;
  // The diffuse points glossy rays meet take their indirect light from the
  // records (Ward's irradiance caching of secondary rays), found in a world
  // grid; an influenced point no record reaches takes one cosine-sampled
  // path instead.  false: glossy paths are path traced (glossy_depth).
  bool glossy_cache = true;
  int miss_rays = 32;  // cosine-sampled paths where no record reaches (glossy_cache)
  // Rays of the glossy lobe at each camera sample's point (splitting; the
  // points they meet take one each): the lobe's variance, which the records
  // do not touch, falls as 1/glossy_rays at a fraction of a camera sample's
  // cost (docs/methods.md, "ic": 2 takes 12-26% off the glossy bunny's
  // error for 2-9% more time).
  int glossy_rays = 2;
  // Samples of the direct light at camera points on the virtual objects,
  // each weighted 1/n (at least direct_samples): the objects' pixels are
  // few, and at low spp their direct light's noise is most of the region's
  // error (docs/benchmarks.md, "The objects' own pixels").
  int object_direct_samples = 16;
  // Samples of the virtual objects' shadows at real camera points, each
  // weighted 1/n (DirectDiffuse's `shadows`): the lights' virtual shadows
  // and the environment's difference, traced only where an object can
  // block; the light itself keeps one sample (4: 15-60% less error at
  // 1-4 spp for 5-50% more time, docs/benchmarks.md, "The objects' own
  // pixels").
  int shadow_samples = 4;
  // Glossy paths from virtual surfaces take the plate's radiance where it
  // sees the real point they meet (render/path_tracer.h, PlateView).
  bool plate_reflections = true;
  // Records no frame has used (splatted with weight > 0) for this many
  // frames are evicted, so that a camera moving on does not grow the cache
  // without bound; 0: never.
  int evict_after = 30;
  // Irradiance gradients (Ward & Heckbert 1992): each record estimates how
  // its irradiance changes as the normal turns and the point moves, from
  // its own rays, and interpolation extrapolates along them (first order)
  // instead of taking the record's value as flat.  docs/methods.md, "ic".
  bool gradients = true;
  // The normal term of the records' weight: a normal this far from the
  // record's counts as far as a point R_i away; with accuracy a, a record
  // reaches normals within about a x normal_deg of its own.  Tabellion &
  // Lamorlette's 10 degrees suits records without gradients; with them the
  // rotational gradient corrects, to first order, what a wider cone lets
  // through, and 30 degrees keeps a fused room's noisy normals from asking
  // a record of nearly every sample (docs/methods.md, "ic").
  double normal_deg = 30;
  bool photograph = true;  // I_c is given: real pixels need only I_m - I_r
  int max_depth = 5;
  uint64_t seed = 0;
};

struct WorldChange;
struct PathVertex;

struct IcRecord {
  Eigen::Vector3d p, n;
  Eigen::Vector3d e_mixed = Eigen::Vector3d::Zero(), e_real = Eigen::Vector3d::Zero();
  // The gradients, one row per channel (zero without IcSettings::gradients):
  // E(p', n') ~ E + rot (n x n') + trans (p' - p).
  Eigen::Matrix3d rot_mixed = Eigen::Matrix3d::Zero(), rot_real = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d trans_mixed = Eigen::Matrix3d::Zero(), trans_real = Eigen::Matrix3d::Zero();
  double r_hit = 0;             // least distance the record's rays met
  double r = 0;                 // R_i after the clamps
  double r_min = 0, r_max = 0;  // the pixel clamps, world units
  bool on_virtual = false;
  int evaluated_frame = 0;
  int used_frame = 0;  // the last frame that splatted it with weight > 0
  bool stale = false;  // the world changed: re-evaluate at the next frame
  uint64_t index = 0;  // its random stream
};

// The records, kept across the frames of a render.
class IrradianceCache {
 public:
  IrradianceCache(const RenderScene& scene, const IcSettings& settings);
  const IcSettings& settings() const { return settings_; }
  const std::vector<IcRecord>& records() const { return records_; }
  // Integrates E_m, E_r, their gradients and R_i at the record's point
  // with its own stream.  `from_virtual` (a tracer holding the frame's
  // plates and probes): a record on a virtual surface gathers its mixed
  // light through it, the plate or a probe's radiance where a gather ray
  // meets the real room (as pt: docs/methods.md, "The room's own light").
  void Evaluate(IcRecord* record, int frame, const DifferentialPathTracer* from_virtual = nullptr) const;
  // The rays Evaluate traces for `record`: rays, or object_rays on an object.
  int RaysFor(const IcRecord& record) const {
    return std::max(1, record.on_virtual ? std::max(settings_.rays, settings_.object_rays) : settings_.rays);
  }
  // Limits the gradients to what the record's reach (R_i after the clamps)
  // allows: within it no channel changes by more than its value.
  void ClampGradients(IcRecord* record) const;
  // Whether a real point can see a change of indirect light (form factor bound).
  bool InInfluence(const Eigen::Vector3d& p) const;
  // The world changed between frames (render/world.h): with new light
  // every record is re-evaluated at the next frame (they keep their places,
  // so the interpolation does not jump); when objects move, the records on
  // virtual surfaces go, and the real records within the old or the new
  // reach of the virtual objects are re-evaluated; the rest are kept.  Says
  // what it did.
  std::string WorldChanged(const WorldChange& change);
  void Describe(Report* report) const;

 private:
  friend class IcFrameRenderer;
  const RenderScene& scene_;
  IcSettings settings_;
  DifferentialPathTracer tracer_;
  std::vector<IcRecord> records_;
  std::vector<Eigen::Vector4d> spheres_;  // virtual bounding spheres (centre, radius)
  bool virtual_light_ = false;
  uint64_t next_index_ = 0;  // the next record's random stream
  int64_t created_ = 0, reevaluated_ = 0, record_rays_ = 0, passes_ = 0, evicted_ = 0, invalidated_ = 0;
  void UpdateSpheres();
};

class IcFrameRenderer : public PixelLoopMethod {
 public:
  IcFrameRenderer(const RenderScene& scene, IrradianceCache* cache, const CameraModel& camera,
                  const Rigid3& world_from_cam, uint64_t seed, int frame, const CameraExposure& exposure = {},
                  const PlateViews& plates = {});
  // Real points met by glossy paths from virtual surfaces: from the plate or rendered.
  const PlateCounters& plate_counters() const { return glossy_tracer_.plate_counters(); }
  // The G-buffer, misses and new records, then shading: one pass per frame.
  void RenderPass(int spp) override;
  // Indirect irradiance the frame interpolated (luminance, per pixel, first
  // sample; NaN where nothing was interpolated), for the temporal figure.
  const std::vector<float>& interpolated() const { return interpolated_; }
  const std::vector<Eigen::Vector3f>& positions() const { return positions_; }
  void Describe(Report* report, int frame) const;

 private:
  // One G-buffer sample: the first hit of a mixed or a real camera ray.  No
  // member initialisers, so that an array of them can be allocated without
  // touching it: the G-buffer pass writes every entry (Clear), in parallel.
  // The sums in single precision: a pixel's few hundred records at most add
  // in float's 1e-7.
  struct Entry {
    Eigen::Vector3d p;
    Eigen::Vector3f n;
    float footprint;  // world size of a pixel there
    float w;
    Eigen::Vector3f sum_m, sum_r;  // sums of w E_m, w E_r
    bool valid, is_virtual, needed;
    void Clear() {  // invalid, no weight
      p.setZero(), n.setZero(), sum_m.setZero(), sum_r.setZero();
      footprint = w = 0;
      valid = is_virtual = needed = false;
    }
  };
  // The parts of a pass: camera samples' first hits, the records kept from
  // earlier frames brought up to date, new records where no record reaches.
  void BuildGBuffer(int spp);
  void RefreshRecords();
  void AddRecordsWhereMissing();
  void Shade(const Ray& ray, Sampler& rng, int64_t row, size_t pixel, int sample, PathSample* out) override;
  void Splat(size_t record, int64_t first_row, int64_t last_row);
  void SplatAll(const std::vector<size_t>& records);
  // One surface point for the wanted solutions, times beta: emission, direct
  // light, indirect diffuse light (e_m, e_r) and the glossy lobe, whose ray
  // goes on at glossy bounce `depth` + 1 (Continue, or a path).  Returns rays.
  int64_t ShadePoint(const PathVertex& v, bool on_virtual, bool want_m, bool want_r, const Eigen::Vector3d& e_m,
                     const Eigen::Vector3d& e_r, int depth, const Eigen::Vector3d& beta, Sampler& g,
                     Eigen::Vector3d* mixed, Eigen::Vector3d* real);
  // Radiance along a glossy ray (bounce `depth`) for the wanted solutions,
  // times beta: each point met shaded by ShadePoint with the records'
  // irradiance there (LookUp), or one cosine-sampled path where none reaches
  // an influenced point.  Returns rays.
  int64_t Continue(Ray ray, bool want_m, bool want_r, int depth, const Eigen::Vector3d& beta, double prev_pdf,
                   Sampler& g, Eigen::Vector3d* mixed, Eigen::Vector3d* real);
  // The records' interpolated E_m, E_r at a point (virtual records at
  // virtual points, real ones at real); false where none has weight > 0.
  bool LookUp(const Eigen::Vector3d& p, const Eigen::Vector3d& n, bool on_virtual, Eigen::Vector3d* e_m,
              Eigen::Vector3d* e_r);
  void BuildGrid();

  const RenderScene& scene_;
  IrradianceCache* cache_;
  CameraModel camera_;  // a copy: renderers may outlive the caller's model
  DifferentialPathTracer glossy_tracer_;
  // Records on virtual surfaces gather through it: the plates and probes
  // (null without any).
  std::unique_ptr<DifferentialPathTracer> virtual_tracer_;
  int frame_;
  int64_t new_records_ = 0, reevaluated_ = 0, splatted_ = 0, miss_passes_ = 0, outside_influence_ = 0, evicted_ = 0;
  int64_t pass_record_rays_ = 0;  // the rays of the records this pass evaluated
  // Seconds of the frame's parts: G-buffer, records (re-evaluation, splats, miss
  // passes), shading.
  double gbuffer_s_ = 0, records_s_ = 0, shade_s_ = 0;
  std::vector<uint8_t> used_;    // per record: splatted with weight > 0 this frame (set through atomic_ref)
  int samples_ = 0, first_ = 0;  // G-buffer samples per pixel, and the first one's index
  LargeBuffer<Entry> mixed_;     // [pixel * samples_ + s]
  // The real entries, only where the mixed one is virtual (a few percent):
  // real_[real_index_[k]], kNoEntry where there is none.
  static constexpr uint32_t kNoEntry = UINT32_MAX;
  std::vector<Entry> real_;
  std::vector<uint32_t> real_index_;
  const Entry* RealEntry(size_t k) const { return real_index_[k] == kNoEntry ? nullptr : &real_[real_index_[k]]; }
  std::vector<float> interpolated_;
  std::vector<Eigen::Vector3f> positions_;
  // The records in a world grid, for LookUp: cell -> record indices (in
  // index order), in the first of kGridLevels grids (cells 4x larger at
  // each) where a record overlaps at most 64 cells; larger ones in `wide_`.
  static constexpr int kGridLevels = 4;
  double grid_cell_[kGridLevels] = {};
  std::unordered_map<int64_t, std::vector<uint32_t>> grid_[kGridLevels];
  std::vector<uint32_t> wide_;
  std::atomic<int64_t> lookups_{0}, lookup_misses_{0};
};

// ic's temporal stability on a static scene: each pixel's world point
// (`positions`) is projected into the previous frame; where it lands on a
// pixel that interpolated irradiance at the same point, the relative mean
// absolute change of the interpolated irradiance, sum |E_f - E_f-1| / sum |E_f|.
// NaN: no overlap.
double TemporalChange(const CameraModel& camera, const Rigid3& prev_pose, const std::vector<float>& prev,
                      const std::vector<Eigen::Vector3f>& prev_positions, const std::vector<Eigen::Vector3f>& positions,
                      const std::vector<float>& now);

// The registry's `ic` (render.ic: IcSettings' fields).
std::unique_ptr<RenderMethod> MakeIcMethod(JsonSettings& block, const Scene& scene);

}  // namespace mr
