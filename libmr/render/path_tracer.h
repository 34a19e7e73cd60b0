// `pt`: differential path tracing, the unbiased reference of mr-render.
//
// I_m (real + virtual) and I_r (real only) come from the same paths: while a
// path meets only real surfaces it is shared, and each next-event estimate
// tests real and virtual blockers separately (I_r uses st_r, I_m uses
// min(st_r, st_v)).  Where the shared path meets a virtual object the real
// path continues alone along the same ray with a real-only ray, with a copy
// of the random stream, as the mixed and real ray types of Differential
// Irradiance Caching.  With no virtual object in a path, I_m and I_r are
// bit-identical, so their difference has no noise there.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/image.h"
#include "core/sampling.h"
#include "render/plate_view.h"
#include "render/render_scene.h"

namespace mr {

struct PathVertex;  // render/path_common.h
struct EnvLookup;   // render/path_common.h

// Every ray a render traces, for benchmarks that replay them through a bare
// Embree loop (single-threaded renders only: the log is not synchronised).
struct RayLog {
  std::vector<Ray> closest, occlusion;
};

struct PathTracerSettings {
  int max_depth = 64;  // bounces; Russian roulette ends most paths long before
  int rr_depth = 3;    // Russian roulette from this bounce on
  uint64_t seed = 0;
  int frame = 0;
  RayLog* ray_log = nullptr;  // benchmarks only
  // Pixels whose camera rays provably meet no geometry are sampled in the
  // first pass only (their I_m - I_r is exactly zero).
  bool skip_environment_pixels = true;
  // Reflections of the real room in virtual objects from the plate
  // (PlateView) where it sees the room; `plates` is set per frame.  It also
  // holds the probes (PlateView::probe: the room's own light), taken
  // whether or not plate_reflections is set.
  bool plate_reflections = true;
  PlateViews plates;
  // A real point's light that passed the real blockers is tested against
  // the virtual objects only where its shadow segment meets one of their
  // bounding boxes (SegmentMeetsBoxes): elsewhere no virtual object can
  // block it.  The result is the same either way (tested); false traces
  // every test (tests only).
  bool cull_virtual_shadow_tests = true;
  // Area lights by both strategies, MIS-weighted: next-event samples and
  // BSDF-sampled rays that meet them (AreaLightsSeen's mis), so a glossy
  // surface sees a lamp through its lobe.  false: next-event estimation
  // alone, for methods whose own vertices sample area lights so (ic, vpl)
  // and continue through this tracer.
  bool mis_area_lights = true;
  // Camera paths traced together in batches of up to this many
  // (DifferentialPathTracer::TraceBatch: Embree's stream queries over each
  // bounce's rays and shadow rays); 0: one by one.  The same bytes either
  // way (tested).
  int batch = 256;
};

struct PathSample {
  Eigen::Vector3d mixed = Eigen::Vector3d::Zero();
  Eigen::Vector3d real = Eigen::Vector3d::Zero();
  bool primary_virtual = false;   // the camera ray's first hit is virtual (mask M)
  int rays = 0;                   // closest-hit and occlusion queries traced
  int virtual_tests_skipped = 0;  // virtual shadow tests left out (their segment meets no virtual box)
  float first_t = INFINITY;       // distance to the first surface met (infinity: none)
};

class DifferentialPathTracer {
 public:
  DifferentialPathTracer(const RenderScene& scene, const PathTracerSettings& settings)
      : scene_(scene), settings_(settings), plate_counters_(std::make_shared<PlateCounters>()) {}
  const PlateCounters& plate_counters() const { return *plate_counters_; }
  // Counts its plate lookups in `other`'s counters (a method's tracers, one report).
  void ShareCountersWith(const DifferentialPathTracer& other) { plate_counters_ = other.plate_counters_; }
  const RenderScene& scene() const { return scene_; }
  PathSample Trace(const Ray& primary, Sampler& rng) const {
    return TraceFrom(primary, Eigen::Vector3d::Ones(), 0, 0, rng);
  }
  // Trace(primaries[i], rngs[i]) into out[i] for every i, the same bytes,
  // with the paths' shared part advanced a bounce at a time over all of
  // them: each bounce's rays and its shadow rays go to Embree as streams,
  // the shading stays one path at a time.  A path that meets a virtual
  // object goes on alone from there (TraceSingle).  Any batch size, one
  // included.
  void TraceBatch(std::span<const Ray> primaries, std::span<Sampler> rngs, std::span<PathSample> out) const;
  // The shared differential path from `start` on, as if it had reached
  // there at bounce `depth` with throughput `beta` after a direction chosen
  // with solid-angle pdf `prev_pdf` (0: no MIS on escape).  Rays escaping
  // before bounce `escape_from_depth` count nothing (a method that takes
  // direct light by light sampling alone passes depth + 1).
  PathSample TraceFrom(const Ray& start, Eigen::Vector3d beta, double prev_pdf, int depth, Sampler& rng,
                       int escape_from_depth = 0) const;
  // Radiance arriving along `ray` in the scene with everything in it
  // (virtual included); `prev_pdf` is the solid-angle pdf that chose the
  // direction (0: no MIS against lights on escape).
  Eigen::Vector3d Radiance(const Ray& ray, double prev_pdf, Sampler& rng) const {
    int rays = 0;
    return TraceSingle(ray, kMaskAll, Eigen::Vector3d::Ones(), prev_pdf, 0, rng, &rays, 0);
  }
  // Radiance arriving along `ray` in the real scene alone (virtual geometry
  // and lights left out), times beta, from bounce `depth` on.
  Eigen::Vector3d RealRadiance(const Ray& ray, const Eigen::Vector3d& beta, double prev_pdf, int depth, Sampler& rng,
                               int* rays) const {
    return TraceSingle(ray, kMaskReal, beta, prev_pdf, depth, rng, rays, 0);
  }
  // Radiance arriving along `ray`, which leaves a virtual surface, in the
  // scene with everything in it, times beta: the plate where it sees the
  // real point met (PlateView), else rendered.
  // `escape_from_depth` as TraceFrom's.
  Eigen::Vector3d MixedRadianceFromVirtual(const Ray& ray, const Eigen::Vector3d& beta, double prev_pdf, int depth,
                                           Sampler& rng, int* rays, int escape_from_depth = 0) const {
    return TraceSingle(ray, kMaskAll, beta, prev_pdf, depth, rng, rays, escape_from_depth, true);
  }
  // At real vertex `v`, met at bounce `depth` by a mixed ray leaving a
  // virtual surface: adds to *L beta times the plate's radiance there plus
  // the difference the virtual objects make to the point's light, which the
  // plate cannot show (their shadows and lights, by its next-event
  // estimate; their occlusion of its indirect light and their bounce light,
  // by one shared differential path on from it while depth < max_depth,
  // whose two solutions cancel where it meets no object), and returns true
  // where a plate sees it (PlateView; the plate's path ends there); false,
  // adding nothing, where the room must be rendered (no plate, a glossy
  // surface, unseen or clipped).  Counted either way.
  bool PlateAtRealPoint(const PathVertex& v, const Eigen::Vector3d& beta, int depth, Sampler& rng, int* rays,
                        Eigen::Vector3d* L) const;

 private:
  // One path seeing geometry through `mask`, from `ray` on.
  Eigen::Vector3d TraceSingle(Ray ray, uint32_t mask, Eigen::Vector3d beta, double prev_pdf, int depth, Sampler& rng,
                              int* rays, int escape_from_depth, bool from_virtual = false) const;
  // One bounce of the shared path (TraceFrom's loop body): what `*ray`,
  // having met `hit` (`found`) at bounce `depth`, adds to *out, with each
  // next-event estimate handed to shadow(c, ray, virtual_light), c with the
  // throughput in it, to be tested against the blockers.  Returns true with
  // *ray, *beta and *prev_pdf set where the shared path goes on.
  template <class Shadow>
  bool SharedBounce(Ray* ray, Eigen::Vector3d* beta, double* prev_pdf, bool found, const Hit& hit, int depth,
                    int escape_from_depth, Sampler& rng, PathSample* out, Shadow&& shadow) const;
  // SharedBounce's parts.  SharedHit: what the hit adds before a point is
  // made of it (the lights the ray meets, the sky it escapes to, the paths'
  // parting at a virtual object); true where it meets a real point.
  // SharedEmission: that point's emission; true where it is to be shaded.
  // SharedShade: its next-event estimates and BSDF sample; `ahead`, if
  // given, holds what of them does not depend on the path's earlier
  // choices, for the sampler's coming numbers, computed in lanes for a
  // batch (TraceBatch): the environment's sample, the lights' directions or
  // points, the BSDF's cosine direction.
  struct Ahead;
  // `escaped`: the environment's lookup for a ray that met nothing, made
  // ahead (TraceBatch, in lanes).
  bool SharedHit(const Ray& ray, const Eigen::Vector3d& beta, double prev_pdf, bool found, const Hit& hit, int depth,
                 int escape_from_depth, Sampler& rng, PathSample* out, const EnvLookup* escaped = nullptr) const;
  bool SharedEmission(const PathVertex& v, const Eigen::Vector3d& beta, int depth, PathSample* out) const;
  template <class Shadow>
  bool SharedShade(const PathVertex& v, Ray* ray, Eigen::Vector3d* beta, double* prev_pdf, int depth, Sampler& rng,
                   Shadow&& shadow, const Ahead* ahead = nullptr) const;
  // The lanes of a batch's bounce: each shaded path's draws and what
  // SharedShade computes of them (Ahead) at once (core/lanes.h) into
  // lanes->ahead, one per sampler; `lanes` keeps its buffers between calls.
  struct Lanes;
  void DrawAhead(std::span<Sampler* const> samplers, int depth, Lanes* lanes) const;
  // DrawAhead's part for the lights: Ahead::lights.
  void LightsAhead(Lanes* lanes) const;
  // The environment along a batch's rays that met nothing (hits[k] not
  // valid), looked up in lanes into lanes->escapes.
  template <class Path>
  void LookUpEscapes(const std::vector<Path>& paths, const std::vector<Hit>& hits, Lanes* lanes) const;
  // A batch's shadow rays' two tests and their sums into out, in the order
  // TraceFrom makes them.
  struct PendingShadow;
  void ResolveShadows(std::vector<PendingShadow>& shadows, std::span<PathSample> out) const;
  bool Intersect(const Ray& ray, Hit* hit) const {
    if (settings_.ray_log) settings_.ray_log->closest.push_back(ray);
    return scene_.embree().Intersect(ray, hit);
  }
  bool Occluded(const Ray& ray) const {
    if (settings_.ray_log) settings_.ray_log->occlusion.push_back(ray);
    return scene_.embree().Occluded(ray);
  }
  // The plate's radiance at real point `p` met from a virtual surface
  // (normal `n`, rays leaving it offset by `offset`) from the first plate
  // whose camera sees it unoccluded and unclipped (counted).
  // Then the probes' (PlateView::probe), nearest in direction to `wo` (towards
  // where the ray came from) first.
  bool PlateRadiance(const Eigen::Vector3d& p, const Eigen::Vector3d& n, const Eigen::Vector3d& wo, double offset,
                     Eigen::Vector3d* L, int* rays) const;
  // The same from one plate; *clipped set where the plate sees it clipped.
  bool ViewRadiance(const PlateView& pv, const Eigen::Vector3d& p, const Eigen::Vector3d& n, double offset,
                    Eigen::Vector3d* L, bool* clipped, int* rays) const;
  // The same from one probe: its map in the direction from its centre to
  // `p`, where it sees p unoccluded by real geometry.
  bool ProbeRadiance(const PlateView& pv, const Eigen::Vector3d& p, const Eigen::Vector3d& n, double offset,
                     Eigen::Vector3d* L, int* rays) const;
  const RenderScene& scene_;
  PathTracerSettings settings_;
  std::shared_ptr<PlateCounters> plate_counters_;
};

// The radiance arriving at `centre` from every direction, the scene with
// everything in it: a width x width/2 lat-long map (core/spherical.h), each
// pixel the mean of `spp` paths along its centre direction (a probe's
// truth; area lights are seen exactly).  Deterministic for `seed`.
Image RenderProbeMap(const RenderScene& scene, const Eigen::Vector3d& centre, int width, int spp,
                     const PathTracerSettings& settings, uint64_t seed);

}  // namespace mr
