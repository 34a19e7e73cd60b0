#include "render/path_tracer.h"

#include "render/path_common.h"

#include <atomic>
#include <cmath>

#include "core/check.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/spherical.h"

namespace mr {

bool DifferentialPathTracer::PlateRadiance(const Eigen::Vector3d& p, const Eigen::Vector3d& n,
                                           const Eigen::Vector3d& wo, double offset, Eigen::Vector3d* L,
                                           int* rays) const {
  bool clipped = false;
  const PlateViews& views = settings_.plates;
  if (settings_.plate_reflections)
    for (size_t i = 0; i < views.size(); ++i)
      if (!views[i].probe && ViewRadiance(views[i], p, n, offset, L, &clipped, rays)) {
        ++plate_counters_->from_plate;
        if (i > 0) ++plate_counters_->from_other_frames;
        return true;
      }
  // The probes, nearest in direction first (a handful: selection; the
  // views are at most kMaxPlateViews).
  uint64_t tried = 0;
  for (;;) {
    size_t best = views.size();
    double best_cos = -2;
    for (size_t i = 0; i < views.size(); ++i) {
      if (!views[i].probe || (tried >> i & 1)) continue;
      const double c = (views[i].probe_centre - p).normalized().dot(wo);
      if (c > best_cos) best_cos = c, best = i;
    }
    if (best == views.size()) break;
    tried |= uint64_t{1} << best;
    if (ProbeRadiance(views[best], p, n, offset, L, rays)) {
      ++plate_counters_->from_probe;
      return true;
    }
  }
  ++plate_counters_->rendered;
  if (clipped) ++plate_counters_->clipped;  // a clipped highlight: its true radiance is unknown, render it
  return false;
}

bool DifferentialPathTracer::ProbeRadiance(const PlateView& pv, const Eigen::Vector3d& p, const Eigen::Vector3d& n,
                                           double offset, Eigen::Vector3d* L, int* rays) const {
  const Eigen::Vector3d to_probe = pv.probe_centre - p;
  const double dist = to_probe.norm();
  if (!(dist > 1e-6) || n.dot(to_probe) <= 0) return false;  // the probe sees the surface's other side
  Ray r = MakeRay(p + n * offset, to_probe / dist, kMaskReal, dist * (1 - 1e-6));
  ++*rays;
  if (Occluded(r)) return false;
  *L = pv.probe->Eval(-to_probe / dist);
  return L->allFinite();
}

bool DifferentialPathTracer::ViewRadiance(const PlateView& pv, const Eigen::Vector3d& p, const Eigen::Vector3d& n,
                                          double offset, Eigen::Vector3d* L, bool* clipped, int* rays) const {
  if (!pv.radiance) return false;
  const Eigen::Vector3d eye = pv.world_from_cam.translation;
  const Eigen::Vector3d to_eye = eye - p;
  const double dist = to_eye.norm();
  if (!(dist > 0) || n.dot(to_eye) <= 0) return false;  // the plate sees the surface's other side
  Eigen::Vector2d q;
  if (!pv.camera->Project(pv.world_from_cam.Inverse() * p, &q) || !q.allFinite()) return false;
  const Image& img = *pv.radiance;
  if (q.x() < 0 || q.y() < 0 || q.x() > img.width() - 1 || q.y() > img.height() - 1) return false;
  // Unoccluded: nothing real between the plate's camera and the point.
  Ray r = MakeRay(p + n * offset, to_eye / dist, kMaskReal, dist * (1 - 1e-6));
  ++*rays;
  if (Occluded(r)) return false;
  const int x0 = static_cast<int>(q.x()), y0 = static_cast<int>(q.y());
  const int x1 = std::min(x0 + 1, img.width() - 1), y1 = std::min(y0 + 1, img.height() - 1);
  if (pv.clipped && (pv.clipped->at(x0, y0, 0) > 0 || pv.clipped->at(x1, y0, 0) > 0 || pv.clipped->at(x0, y1, 0) > 0 ||
                     pv.clipped->at(x1, y1, 0) > 0)) {
    *clipped = true;
    return false;
  }
  const double fx = q.x() - x0, fy = q.y() - y0;
  for (int c = 0; c < 3; ++c)
    (*L)[c] = (1 - fy) * ((1 - fx) * img.at(x0, y0, c) + fx * img.at(x1, y0, c)) +
              fy * ((1 - fx) * img.at(x0, y1, c) + fx * img.at(x1, y1, c));
  return L->allFinite();
}

bool DifferentialPathTracer::PlateAtRealPoint(const PathVertex& v, const Eigen::Vector3d& beta, int depth, Sampler& rng,
                                              int* rays, Eigen::Vector3d* L) const {
  if (settings_.plates.empty()) return false;
  // The real room as the plate shows it (emitted and reflected light
  // together), where the plate sees it and the surface is diffuse (a glossy
  // one sends other light towards the object than towards the plate's
  // camera: rendered).
  if (v.material->IsGlossy()) {
    ++plate_counters_->rendered;
    return false;
  }
  Eigen::Vector3d plate;
  if (!PlateRadiance(v.p, v.frame.n, v.wo_world, v.offset, &plate, rays)) return false;
  *L += beta.cwiseProduct(plate);
  // What the plate cannot show: the virtual objects' shadows on the point
  // and their lights, from its next-event estimate (the direct part of the
  // difference the objects make there).
  NextEvent(
      scene_, v, rng,
      [&](const Eigen::Vector3d& c, Ray shadow, bool virtual_light) {
        ++*rays;
        if (virtual_light) {
          shadow.mask = kMaskAll;
          if (!Occluded(shadow)) *L += beta.cwiseProduct(c);
          return;
        }
        shadow.mask = kMaskReal;
        if (Occluded(shadow)) return;
        ++*rays;
        shadow.mask = kMaskVirtual;
        if (Occluded(shadow)) *L -= beta.cwiseProduct(c);
      },
      true, settings_.mis_area_lights);
  // The rest of the difference: the objects' occlusion of the point's
  // indirect light and of the sky's BSDF-sampled share, and the light they
  // bounce onto it.  Without it the plate's light is too bright where an
  // object stands close (the table-top's contact with the floor: +4%, a
  // region relMSE floor of 1.2e-4 against Cycles; docs/methods.md).
  if (depth < settings_.max_depth) {
    BsdfSample s;
    const double ul = rng.NextDouble();
    const auto [u0, u1] = rng.Next2D();
    if (v.bsdf.Sample(v.frame.ToLocal(v.wo_world), ul, u0, u1, &s)) {
      const Eigen::Vector3d b = beta.cwiseProduct(s.f) * (std::abs(s.wi.z()) / s.pdf);
      const PathSample ps = TraceFrom(MakeRay(v.OriginFor(v.frame.ToWorld(s.wi)), v.frame.ToWorld(s.wi), kMaskAll), b,
                                      s.pdf, depth + 1, rng);
      *rays += ps.rays;
      if (ps.mixed.allFinite() && ps.real.allFinite()) *L += ps.mixed - ps.real;
    }
  }
  return true;
}

Eigen::Vector3d DifferentialPathTracer::TraceSingle(Ray ray, uint32_t mask, Eigen::Vector3d beta, double prev_pdf,
                                                    int depth, Sampler& rng, int* rays, int escape_from_depth,
                                                    bool from_virtual) const {
  Eigen::Vector3d L = Eigen::Vector3d::Zero();
  ray.mask = mask;
  const unsigned lights = mask == kMaskReal ? kRealLights : kAllLights;  // a real path sees no virtual light
  const bool use_plate = mask == kMaskAll && !settings_.plates.empty();
  // from_virtual: the ray leaves a virtual surface; refracted: through it
  bool refracted = false;
  for (;; ++depth) {
    Hit hit;
    ++*rays;
    const bool found = Intersect(ray, &hit);
    if (depth >= escape_from_depth)
      L += beta.cwiseProduct(
          AreaLightsSeen(scene_, ray, found ? hit.t : INFINITY, prev_pdf, lights, settings_.mis_area_lights));
    if (!found) {
      if (depth >= escape_from_depth) L += beta.cwiseProduct(Escaped(scene_, ray, prev_pdf, lights));
      break;
    }
    PathVertex v = MakeVertex(scene_, ray, hit);
    beta = beta.cwiseProduct(v.transmittance);
    if (use_plate && from_virtual && !hit.is_virtual) {
      const bool taken = PlateAtRealPoint(v, beta, depth, rng, rays, &L);
      if (refracted) {
        ++plate_counters_->through_glass;
        if (taken) ++plate_counters_->through_glass_from_plate;
      }
      if (taken) break;
    }
    from_virtual = hit.is_virtual;
    L += beta.cwiseProduct(v.emission);
    if (depth >= settings_.max_depth || v.bsdf.IsBlack()) break;
    NextEvent(
        scene_, v, rng,
        [&](const Eigen::Vector3d& c, Ray shadow, bool virtual_light) {
          if (virtual_light && !(lights & kVirtualLights)) return;
          shadow.mask = mask;
          ++*rays;
          if (!Occluded(shadow)) L += beta.cwiseProduct(c);
        },
        true, settings_.mis_area_lights);
    BsdfSample s;
    const double ul = rng.NextDouble();
    const auto [u0, u1] = rng.Next2D();
    if (!v.bsdf.Sample(v.frame.ToLocal(v.wo_world), ul, u0, u1, &s)) break;
    beta = beta.cwiseProduct(s.f) * (std::abs(s.wi.z()) / s.pdf);
    // A transmitted direction is one next-event estimation never samples
    // (it tests the light on the near side only): no MIS weight against it.
    prev_pdf = s.wi.z() < 0 || s.delta ? INFINITY : s.pdf;
    refracted = s.wi.z() < 0 || s.delta;
    if (depth + 1 >= settings_.rr_depth) {
      const double q = std::min(1.0, beta.maxCoeff());
      if (rng.NextDouble() >= q) break;
      beta /= q;
    }
    const Eigen::Vector3d wi = v.frame.ToWorld(s.wi);
    ray = MakeRay(v.OriginFor(wi), wi, mask);
    v.SetCone(s, &ray);
  }
  return L;
}

struct DifferentialPathTracer::Ahead {
  EnvDraw env;
  Eigen::Vector3d cosine = Eigen::Vector3d::Zero();
  const Eigen::Vector3d* lights = nullptr;  // LightEvents' `pre`
  bool has_env = false, has_cosine = false;
};

bool DifferentialPathTracer::SharedHit(const Ray& ray, const Eigen::Vector3d& beta, double prev_pdf, bool found,
                                       const Hit& hit, int depth, int escape_from_depth, Sampler& rng, PathSample* out,
                                       const EnvLookup* escaped) const {
  if (depth >= escape_from_depth && (!found || !hit.is_virtual)) {  // (a virtual hit parts the paths below)
    const Eigen::Vector3d a = beta.cwiseProduct(
        AreaLightsSeen(scene_, ray, found ? hit.t : INFINITY, prev_pdf, kRealLights, settings_.mis_area_lights));
    out->mixed += a;
    out->real += a;
    if (scene_.has_virtual())
      out->mixed += beta.cwiseProduct(
          AreaLightsSeen(scene_, ray, found ? hit.t : INFINITY, prev_pdf, kVirtualLights, settings_.mis_area_lights));
  }
  if (!found) {
    if (depth < escape_from_depth) return false;
    const Eigen::Vector3d c = beta.cwiseProduct(Escaped(scene_, ray, prev_pdf, kRealLights, escaped));
    out->mixed += c;
    out->real += c;
    if (scene_.has_virtual()) out->mixed += beta.cwiseProduct(Escaped(scene_, ray, prev_pdf, kVirtualLights));
    return false;
  }
  if (hit.is_virtual) {
    // The paths part: the real one continues behind the object with a copy
    // of the random stream, the mixed one goes on from the object.
    if (depth == 0) out->primary_virtual = true;
    Sampler real_rng = rng;
    out->real += TraceSingle(ray, kMaskReal, beta, prev_pdf, depth, real_rng, &out->rays, escape_from_depth);
    out->mixed += TraceSingle(ray, kMaskAll, beta, prev_pdf, depth, rng, &out->rays, escape_from_depth);
    return false;
  }
  return true;  // a real vertex shared by both paths
}

bool DifferentialPathTracer::SharedEmission(const PathVertex& v, const Eigen::Vector3d& beta, int depth,
                                            PathSample* out) const {
  const Eigen::Vector3d e = beta.cwiseProduct(v.emission);
  out->mixed += e;
  out->real += e;
  return depth < settings_.max_depth && !v.bsdf.IsBlack();
}

template <class Shadow>
bool DifferentialPathTracer::SharedShade(const PathVertex& v, Ray* ray, Eigen::Vector3d* beta, double* prev_pdf,
                                         int depth, Sampler& rng, Shadow&& shadow, const Ahead* ahead) const {
  NextEvent(
      scene_, v, rng,
      [&](const Eigen::Vector3d& c, const Ray& r, bool virtual_light) {
        shadow(Eigen::Vector3d(beta->cwiseProduct(c)), r, virtual_light);
      },
      true, settings_.mis_area_lights, ahead && ahead->has_env ? &ahead->env : nullptr,
      ahead ? ahead->lights : nullptr);
  BsdfSample s;
  const double ul = rng.NextDouble();
  const auto [u0, u1] = rng.Next2D();
  if (!v.bsdf.Sample(v.frame.ToLocal(v.wo_world), ul, u0, u1, &s,
                     ahead && ahead->has_cosine ? &ahead->cosine : nullptr))
    return false;
  *beta = beta->cwiseProduct(s.f) * (std::abs(s.wi.z()) / s.pdf);
  *prev_pdf = s.pdf;
  if (depth + 1 >= settings_.rr_depth) {
    const double q = std::min(1.0, beta->maxCoeff());
    if (rng.NextDouble() >= q) return false;
    *beta /= q;
  }
  *ray = MakeRay(v.OriginFor(v.frame.ToWorld(s.wi)), v.frame.ToWorld(s.wi), kMaskAll);
  v.SetCone(s, ray);
  return true;
}

template <class Shadow>
bool DifferentialPathTracer::SharedBounce(Ray* ray, Eigen::Vector3d* beta, double* prev_pdf, bool found, const Hit& hit,
                                          int depth, int escape_from_depth, Sampler& rng, PathSample* out,
                                          Shadow&& shadow) const {
  if (!SharedHit(*ray, *beta, *prev_pdf, found, hit, depth, escape_from_depth, rng, out)) return false;
  const PathVertex v = MakeVertex(scene_, *ray, hit);
  return SharedEmission(v, *beta, depth, out) && SharedShade(v, ray, beta, prev_pdf, depth, rng, shadow);
}

struct DifferentialPathTracer::Lanes {
  std::vector<EnvLookup> escapes;  // per escaped ray
  std::vector<int> escape_of;      // per path: its index in escapes, or -1
  std::vector<Eigen::Vector3d> escape_dirs;
  std::vector<Ahead> ahead;
  std::vector<uint8_t> pattern;
  std::vector<double> values, e0, e1, c0, c1, x, y, z, pdf;
  std::vector<size_t> lane;
  std::vector<const double*> u;                       // per lane: its sampler's values ahead
  std::vector<const LightSource*> drawn;              // the lights drawn for in turn
  std::vector<Eigen::Vector3d> wi, le, light_values;  // light_values: lane j's lights at j * (lights drawn)
};

void DifferentialPathTracer::DrawAhead(std::span<Sampler* const> samplers, int depth, Lanes* lanes) const {
  Lanes& l = *lanes;
  const size_t n = samplers.size();
  l.ahead.assign(n, Ahead());
  // The numbers SharedShade draws, in its order: next-event estimation's
  // (the environment's pair, then a pair for each light drawn for in turn),
  // the BSDF sample's (lobe, then the pair), Russian roulette's.
  int bsdf_at = 0;
  NextEventDraws(scene_, &l.pattern, &bsdf_at);
  l.pattern.insert(l.pattern.end(), {1, 2});
  if (depth + 1 >= settings_.rr_depth) l.pattern.push_back(1);
  if (bsdf_at + 4 > 32) return;  // many distant lights: drawn as they go
  Sampler::DrawAhead(samplers, l.pattern, &l.values);
  // The lanes' inputs: the environment's pair first, the BSDF's pair after its lobe number.
  l.lane.clear();
  l.u.clear();
  for (auto* v : {&l.e0, &l.e1, &l.c0, &l.c1}) v->clear();
  for (size_t k = 0; k < n; ++k) {
    const double* u = samplers[k]->Ahead(0);
    if (!u) continue;  // an independent sampler: draws as it goes
    l.lane.push_back(k);
    l.u.push_back(u);
    l.e0.push_back(u[0]);
    l.e1.push_back(u[1]);
    l.c0.push_back(u[bsdf_at + 1]);
    l.c1.push_back(u[bsdf_at + 2]);
  }
  const size_t m = l.lane.size();
  for (auto* v : {&l.x, &l.y, &l.z, &l.pdf}) v->resize(m);
  l.wi.resize(m);
  l.le.resize(m);
  const EnvironmentMap& env = scene_.environment();
  if (!env.empty()) env.Sample(m, l.e0.data(), l.e1.data(), l.wi.data(), l.le.data(), l.pdf.data());
  SampleCosineHemisphere(m, l.c0.data(), l.c1.data(), l.x.data(), l.y.data(), l.z.data());
  for (size_t j = 0; j < m; ++j) {
    Ahead& a = l.ahead[l.lane[j]];
    a.has_env = !env.empty();
    if (a.has_env) a.env = {l.wi[j], l.le[j], l.pdf[j], l.e0[j], l.e1[j]};
    a.has_cosine = true;
    a.cosine = Eigen::Vector3d(l.x[j], l.y[j], l.z[j]);
  }
  LightsAhead(lanes);
}

void DifferentialPathTracer::LightsAhead(Lanes* lanes) const {
  Lanes& l = *lanes;
  const size_t m = l.lane.size();
  // The lights drawn for in turn, each with its pair after the environment's (NextEventDraws).
  std::vector<const LightSource*>& drawn = l.drawn;
  drawn.clear();
  for (const LightSource& s : scene_.lights())
    if (DrawnInTurn(scene_, s)) drawn.push_back(&s);
  const size_t nl = drawn.size();
  if (nl == 0 || m == 0) return;
  l.light_values.resize(m * nl);
  for (size_t i = 0; i < nl; ++i) {
    if (!drawn[i]->TakesAhead()) continue;
    for (size_t j = 0; j < m; ++j) {
      l.e0[j] = l.u[j][2 + 2 * i];
      l.e1[j] = l.u[j][3 + 2 * i];
    }
    drawn[i]->SampleAhead(m, l.e0.data(), l.e1.data(), l.x.data(), l.y.data(), l.z.data());
    for (size_t j = 0; j < m; ++j) l.light_values[j * nl + i] = Eigen::Vector3d(l.x[j], l.y[j], l.z[j]);
  }
  for (size_t j = 0; j < m; ++j) l.ahead[l.lane[j]].lights = &l.light_values[j * nl];
}

template <class Path>
void DifferentialPathTracer::LookUpEscapes(const std::vector<Path>& paths, const std::vector<Hit>& hits,
                                           Lanes* lanes) const {
  Lanes& l = *lanes;
  l.escape_of.assign(paths.size(), -1);
  l.escape_dirs.clear();
  const EnvironmentMap& env = scene_.environment();
  if (env.empty()) return;
  for (size_t k = 0; k < paths.size(); ++k)
    if (!hits[k].valid()) {
      l.escape_of[k] = static_cast<int>(l.escape_dirs.size());
      l.escape_dirs.push_back(paths[k].ray.direction.template cast<double>().normalized());  // as Escaped's
    }
  const size_t n = l.escape_dirs.size();
  l.escapes.resize(n);
  l.le.resize(n);
  l.pdf.resize(n);
  env.EvalWithPdf(n, l.escape_dirs.data(), l.le.data(), l.pdf.data());
  for (size_t j = 0; j < n; ++j) l.escapes[j] = {l.le[j], l.pdf[j]};
}

PathSample DifferentialPathTracer::TraceFrom(const Ray& start, Eigen::Vector3d beta, double prev_pdf, int start_depth,
                                             Sampler& rng, int escape_from_depth) const {
  PathSample out;
  Ray ray = start;
  ray.mask = kMaskAll;
  const bool virtual_geometry = scene_.has_virtual_geometry();
  // A light that reaches the point past the real blockers counts in I_r;
  // past the virtual ones too (st_rv = min(st_r, st_v)), in I_m.  A virtual
  // light counts in I_m only, blocked by anything.
  auto shadow = [&](const Eigen::Vector3d& c, Ray r, bool virtual_light) {
    ++out.rays;
    if (virtual_light) {
      if (!Occluded(r)) out.mixed += c;
      return;
    }
    r.mask = kMaskReal;
    if (Occluded(r)) return;
    out.real += c;
    if (virtual_geometry) {
      const VirtualTest t = TestVirtualBlockers(scene_, r, settings_.cull_virtual_shadow_tests);
      (t == VirtualTest::kSkipped ? out.virtual_tests_skipped : out.rays) += 1;
      if (t == VirtualTest::kBlocked) return;
    }
    out.mixed += c;
  };
  for (int depth = start_depth;; ++depth) {
    Hit hit;
    ++out.rays;
    const bool found = Intersect(ray, &hit);
    if (depth == start_depth) out.first_t = hit.t;
    if (!SharedBounce(&ray, &beta, &prev_pdf, found, hit, depth, escape_from_depth, rng, &out, shadow)) return out;
  }
}

// A next-event estimate waiting for its blocker tests in a batch.
struct DifferentialPathTracer::PendingShadow {
  Ray ray;
  Eigen::Vector3d c;  // with the path's throughput in it
  uint32_t path = 0;  // its index in the batch
  bool virtual_light = false;
  bool real_clear = false, mixed_clear = false;  // the tests' outcomes
};

void DifferentialPathTracer::ResolveShadows(std::vector<PendingShadow>& shadows, std::span<PathSample> out) const {
  const size_t n = shadows.size();
  if (n == 0) return;
  const EmbreeScene& embree = scene_.embree();
  // First the real blockers (every blocker for a virtual light), as TraceFrom's shadow test.
  std::vector<Ray> rays(n);
  for (size_t i = 0; i < n; ++i) {
    rays[i] = shadows[i].ray;
    if (!shadows[i].virtual_light) rays[i].mask = kMaskReal;
    ++out[shadows[i].path].rays;
  }
  std::vector<char> occluded(n);
  if (settings_.ray_log)
    settings_.ray_log->occlusion.insert(settings_.ray_log->occlusion.end(), rays.begin(), rays.end());
  embree.Occluded(rays, occluded);
  // Then the virtual ones, where the real ones let the light through and a
  // virtual object can be met.
  std::vector<Ray> virtual_rays;
  std::vector<size_t> tested;
  const bool virtual_geometry = scene_.has_virtual_geometry();
  for (size_t i = 0; i < n; ++i) {
    PendingShadow& sh = shadows[i];
    sh.real_clear = !occluded[i] && !sh.virtual_light;
    sh.mixed_clear = !occluded[i];
    if (!sh.real_clear || !virtual_geometry) continue;
    if (!VirtualTestNeeded(scene_, rays[i], settings_.cull_virtual_shadow_tests)) {
      ++out[sh.path].virtual_tests_skipped;
      continue;
    }
    ++out[sh.path].rays;
    tested.push_back(i);
    virtual_rays.push_back(rays[i]);
    virtual_rays.back().mask = kMaskVirtual;
  }
  if (!virtual_rays.empty()) {
    if (settings_.ray_log)
      settings_.ray_log->occlusion.insert(settings_.ray_log->occlusion.end(), virtual_rays.begin(), virtual_rays.end());
    occluded.resize(virtual_rays.size());
    embree.Occluded(virtual_rays, occluded);
    for (size_t j = 0; j < tested.size(); ++j)
      if (occluded[j]) shadows[tested[j]].mixed_clear = false;
  }
  // The sums, each path's in its own order.
  for (const PendingShadow& sh : shadows) {
    if (sh.real_clear) out[sh.path].real += sh.c;
    if (sh.mixed_clear) out[sh.path].mixed += sh.c;
  }
}

void DifferentialPathTracer::TraceBatch(std::span<const Ray> primaries, std::span<Sampler> rngs,
                                        std::span<PathSample> out) const {
  MR_CHECK(rngs.size() == primaries.size() && out.size() == primaries.size());
  struct Path {
    Ray ray;
    Eigen::Vector3d beta = Eigen::Vector3d::Ones();
    double prev_pdf = 0;
    uint32_t index = 0;
  };
  std::vector<Path> paths(primaries.size()), going_on;
  for (size_t i = 0; i < primaries.size(); ++i) {
    paths[i].ray = primaries[i];
    paths[i].ray.mask = kMaskAll;
    paths[i].index = static_cast<uint32_t>(i);
    out[i] = PathSample();
  }
  std::vector<Ray> rays;
  std::vector<Hit> hits;
  std::vector<PendingShadow> shadows;
  std::vector<size_t> shaded;
  std::vector<Sampler*> samplers;
  thread_local Lanes lanes;  // its buffers kept from batch to batch
  for (int depth = 0; !paths.empty(); ++depth) {
    rays.resize(paths.size());
    hits.assign(paths.size(), Hit());
    for (size_t k = 0; k < paths.size(); ++k) rays[k] = paths[k].ray;
    if (settings_.ray_log)
      settings_.ray_log->closest.insert(settings_.ray_log->closest.end(), rays.begin(), rays.end());
    scene_.embree().Intersect(rays, hits);
    going_on.clear();
    shadows.clear();
    // The environment where rays met nothing, looked up in lanes.
    LookUpEscapes(paths, hits, &lanes);
    // What each hit adds before shading; the points to shade.
    shaded.clear();
    for (size_t k = 0; k < paths.size(); ++k) {
      Path& p = paths[k];
      PathSample& o = out[p.index];
      ++o.rays;
      if (depth == 0) o.first_t = hits[k].t;
      const EnvLookup* escaped = lanes.escape_of[k] >= 0 ? &lanes.escapes[lanes.escape_of[k]] : nullptr;
      if (SharedHit(p.ray, p.beta, p.prev_pdf, hits[k].valid(), hits[k], depth, 0, rngs[p.index], &o, escaped))
        shaded.push_back(k);
    }
    // Their draws and what is computed of them in lanes (for every real
    // point: one the BSDF or the depth ends draws none).
    samplers.clear();
    for (size_t k : shaded)
      if (depth < settings_.max_depth) samplers.push_back(&rngs[paths[k].index]);
    DrawAhead(samplers, depth, &lanes);
    for (size_t j = 0; j < shaded.size(); ++j) {
      Path& p = paths[shaded[j]];
      auto queue = [&](const Eigen::Vector3d& c, const Ray& r, bool virtual_light) {
        shadows.push_back({r, c, p.index, virtual_light});
      };
      Sampler& rng = rngs[p.index];
      const PathVertex v = MakeVertex(scene_, p.ray, hits[shaded[j]]);
      if (SharedEmission(v, p.beta, depth, &out[p.index]) &&
          SharedShade(v, &p.ray, &p.beta, &p.prev_pdf, depth, rng, queue,
                      j < lanes.ahead.size() ? &lanes.ahead[j] : nullptr))
        going_on.push_back(p);
      rng.DropAhead();  // what a path that ended did not draw
    }
    ResolveShadows(shadows, out);
    paths.swap(going_on);
  }
}

Image RenderProbeMap(const RenderScene& scene, const Eigen::Vector3d& centre, int width, int spp,
                     const PathTracerSettings& settings, uint64_t seed) {
  const int W = width, H = width / 2;
  Image env = Image::Rgb(W, H);
  const DifferentialPathTracer pt(scene, settings);
  ParallelFor(0, H, [&](int64_t y) {
    for (int x = 0; x < W; ++x) {
      const Eigen::Vector3d d = LatLongPixelToDirection(Eigen::Vector2d(x, y), W, H);
      Eigen::Vector3d L = Eigen::Vector3d::Zero();
      for (int s = 0; s < spp; ++s) {
        Sampler rng = Sampler::Random(seed, static_cast<uint64_t>((y * W + x) * spp + s));
        L += pt.Radiance(MakeRay(centre, d, kMaskAll), 0, rng) / spp;
      }
      for (int c = 0; c < 3; ++c) env.at(x, static_cast<int>(y), c) = static_cast<float>(L[c]);
    }
  });
  return env;
}

}  // namespace mr
