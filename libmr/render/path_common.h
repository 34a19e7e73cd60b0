// Pieces of a differential path shared by the rendering methods (pt, ic,
// vpl): surface vertices, ray construction, escaped radiance and next-event
// estimation with real/virtual blocker tests.  Internal to libmr/render.
#pragma once

#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "core/math.h"
#include "core/sampling.h"
#include "core/spherical.h"
#include "render/render_scene.h"

namespace mr {

inline double PowerHeuristic(double a, double b) {
  if (std::isinf(a)) return 1;
  const double a2 = a * a, b2 = b * b;
  return a2 + b2 > 0 ? a2 / (a2 + b2) : 0;
}

struct ShadingFrame {
  Eigen::Vector3d t = Eigen::Vector3d::UnitX(), b = Eigen::Vector3d::UnitY(), n = Eigen::Vector3d::UnitZ();
  ShadingFrame() = default;  // the world's axes
  explicit ShadingFrame(const Eigen::Vector3d& normal) : n(normal) { CoordinateSystem(n, &t, &b); }
  Eigen::Vector3d ToLocal(const Eigen::Vector3d& v) const { return {v.dot(t), v.dot(b), v.dot(n)}; }
  Eigen::Vector3d ToWorld(const Eigen::Vector3d& v) const { return v.x() * t + v.y() * b + v.z() * n; }
};

// Ray origins are offset along the normal by 64 float ulps of the largest
// magnitude that entered the hit position: the position itself, the ray's
// origin and the distance travelled (Embree's t carries an error relative to
// those, so a hit near the world origin reached from 1 m away is uncertain
// to ~1e-7 m, not to ulps of its own tiny coordinates).  Local, so the
// offset (and every path) does not depend on what else is in the scene.
inline double OffsetScale(const Eigen::Vector3d& p, const Eigen::Vector3d& origin, double t) {
  const double m = std::max({p.cwiseAbs().maxCoeff(), origin.cwiseAbs().maxCoeff(), t, 1e-3});
  return 64.0 * std::numeric_limits<float>::epsilon() * m;
}

inline Ray MakeRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, uint32_t mask, double tfar = INFINITY) {
  Ray r;
  r.origin = origin.cast<float>();
  r.direction = dir.cast<float>();
  r.mask = mask;
  r.tfar = static_cast<float>(tfar);
  return r;
}

// A shading normal `ns` (unit, on the side of `ng`, the unit geometric
// normal facing wo) bent towards ng where the mirror reflection of wo about
// it would go below the geometric surface (or graze it): then ns is the
// half vector between wo and the reflection turned up to an elevation of
// min(0.01, 0.9 wo.ng) above the surface, as Cycles' "ensure valid
// reflection" does for its normal maps.  Returns ns itself otherwise.
inline Eigen::Vector3d ValidReflectionNormal(const Eigen::Vector3d& ns, const Eigen::Vector3d& ng,
                                             const Eigen::Vector3d& wo) {
  const double q = std::min(0.01, 0.9 * wo.dot(ng));
  const Eigen::Vector3d r = 2 * wo.dot(ns) * ns - wo;
  if (r.dot(ng) >= q) return ns;
  Eigen::Vector3d tangential = r - r.dot(ng) * ng;
  if (!(tangential.norm() > 1e-12)) return ng;
  const Eigen::Vector3d r2 = std::sqrt(1 - q * q) * tangential.normalized() + q * ng;
  const Eigen::Vector3d h = wo + r2;
  return h.norm() > 1e-12 ? Eigen::Vector3d(h.normalized()) : ng;
}

// A surface vertex: position, shading frame facing the incoming ray, BSDF.
// The BSDF is held by value: with vertex-colour albedo it differs from
// point to point (RenderScene::AlbedoAt).
struct PathVertex {
  Eigen::Vector3d p, wo_world;
  double offset = 0;  // along the normal, for rays leaving p
  // The geometric normal facing wo, and where rays that leave p on its
  // side start: offset along it, and moved onto the smooth surface the
  // vertex normals describe where they shade (RenderScene::ShadingNormalAt).
  Eigen::Vector3d ng = Eigen::Vector3d::UnitZ(), origin = Eigen::Vector3d::Zero();
  ShadingFrame frame;                                // z: the shading normal (ng where the geometric normal shades)
  Bsdf bsdf;                                         // black until MakeVertex sets it
  Eigen::Vector3d albedo = Eigen::Vector3d::Zero();  // the diffuse albedo here
  bool vertex_albedo = false;                        // albedo varies over the surface
  const Material* material = nullptr;
  Eigen::Vector3d emission = Eigen::Vector3d::Zero();  // the radiance the surface emits here
  uint32_t geometry_id = 0;
  bool shading_normal = false, mapped = false;  // frame.n is not ng; a normal map bent it
  // The incoming ray's cone here (Ray::cone_width, cone_spread).
  double cone_width = 0, cone_spread = 0;
  // The cone of a ray leaving along a sample of v's BSDF: the width here,
  // the spread grown by the solid angle 1/pdf the sample stands for (its
  // angular width 1/sqrt(pdf), at most 1 radian); a delta sample keeps it.
  void SetCone(const BsdfSample& s, Ray* r) const {
    r->cone_width = static_cast<float>(cone_width);
    r->cone_spread =
        static_cast<float>(cone_spread + (s.delta || !(s.pdf > 0) ? 0.0 : std::min(1.0, 1 / std::sqrt(s.pdf))));
  }
  // What the medium the incoming ray crossed let through (a solid glass's
  // absorption, seen from inside); the caller multiplies its throughput.
  Eigen::Vector3d transmittance = Eigen::Vector3d::Ones();
  // Where a ray leaving in direction wi (world) starts: `origin` on ng's
  // side, just below the surface for a transmitted ray.
  Eigen::Vector3d OriginFor(const Eigen::Vector3d& wi) const {
    return wi.dot(ng) >= 0 ? origin : Eigen::Vector3d(p - ng * offset);
  }
};

inline PathVertex MakeVertex(const RenderScene& scene, const Ray& ray, const Hit& hit) {
  PathVertex v;
  const Eigen::Vector3d d = ray.direction.cast<double>().normalized();
  const Eigen::Vector3d o = ray.origin.cast<double>();
  v.p = o + static_cast<double>(hit.t) * ray.direction.cast<double>();
  v.offset = OffsetScale(v.p, o, static_cast<double>(hit.t) * ray.direction.cast<double>().norm());
  v.cone_width = ray.cone_width + ray.cone_spread * static_cast<double>(hit.t) * ray.direction.cast<double>().norm();
  v.cone_spread = ray.cone_spread;
  Eigen::Vector3d n = scene.WorldNormal(hit);
  const bool back = n.dot(d) > 0;
  if (back) n = -n;  // two-sided: face the incoming ray
  v.ng = n;
  v.wo_world = -d;
  v.origin = v.p + n * v.offset;
  RenderScene::ShadingNormal sn;
  const bool shading = scene.ShadingNormalAt(hit, &sn);
  if (shading) {
    Eigen::Vector3d ns = back ? -sn.n : sn.n;
    if (ns.dot(n) <= 0) ns = -ns;  // vertex normals against the winding: the geometry's side
    v.frame = ShadingFrame(ValidReflectionNormal(ns, n, v.wo_world));
    if (sn.shift.dot(n) > 0) v.origin += sn.shift;
  } else {
    v.frame = ShadingFrame(n);
  }
  v.material = &scene.material(hit.geometry_id);
  v.emission = v.material->emission;
  v.geometry_id = hit.geometry_id;
  v.vertex_albedo = scene.has_varying_albedo(hit.geometry_id);
  if (scene.has_asset_material(hit.geometry_id)) {
    // The ray's cone where it meets the surface, stretched by the incidence.
    const double footprint = v.cone_width / std::max(std::abs(n.dot(d)), 1e-3);
    v.bsdf = scene.AssetBsdfAt(hit, back, footprint, &v.albedo);
    v.emission = scene.AssetEmissionAt(hit, footprint);
    if (back) {  // inside a solid glass: what it absorbed along the way here (Beer-Lambert)
      const Eigen::Vector3d sigma = scene.AssetAbsorption(hit);
      if (sigma.maxCoeff() > 0) v.transmittance = (-sigma * (v.p - o).norm()).array().exp();
    }
    v.vertex_albedo = true;  // the diffuse lobe apart: DiffuseBsdfWith(albedo)
  } else if (v.vertex_albedo) {
    v.albedo = scene.AlbedoAt(hit);
    v.bsdf = scene.BsdfWith(hit.geometry_id, v.albedo);
  } else {
    v.albedo = v.material->albedo;
    v.bsdf = scene.bsdf(hit.geometry_id);
  }
  if (shading) {
    v.shading_normal = true;
    v.mapped = sn.mapped;
    v.bsdf.SetGeometricNormal(v.frame.ToLocal(n), sn.mapped);
  }
  return v;
}

// A lobe of v's material with v's geometric normal (Bsdf::SetGeometricNormal).
inline Bsdf AtVertex(Bsdf b, const PathVertex& v) {
  if (v.shading_normal) b.SetGeometricNormal(v.frame.ToLocal(v.ng), v.mapped);
  return b;
}

// The diffuse lobe alone at v (for methods that treat the lobes apart).
inline Bsdf DiffuseLobe(const RenderScene& scene, const PathVertex& v) {
  return AtVertex(v.vertex_albedo ? scene.DiffuseBsdfWith(v.geometry_id, v.albedo) : scene.diffuse_bsdf(v.geometry_id),
                  v);
}

// Whether v is on a transmissive asset material (glTF's
// KHR_materials_transmission): the scene's per-geometry lobes are the
// asset's mean material's and know no transmission, so methods that treat
// the lobes apart take its BSDF whole as the glossy lobe.  Its diffuse part
// is (1 - transmission) of the base's: none at full transmission.
inline bool TransmissiveAsset(const RenderScene& scene, const PathVertex& v) {
  return v.bsdf.Transmits() && scene.has_asset_material(v.geometry_id);
}

// The glossy lobe alone at v (a transmissive asset's whole BSDF).
inline Bsdf GlossyLobe(const RenderScene& scene, const PathVertex& v) {
  if (TransmissiveAsset(scene, v)) return v.bsdf;
  return AtVertex(scene.glossy_bsdf(v.geometry_id), v);
}

// Whether v has a lobe that methods treating the lobes apart follow by
// BSDF-sampled rays: glossy, or a transmissive asset's.
inline bool HasGlossyLobe(const RenderScene& scene, const PathVertex& v) {
  return v.material->IsGlossy() || TransmissiveAsset(scene, v);
}

// Which emitters a path sees: the environment and real lights exist in both
// I_m and I_r, virtual lights only in I_m.
enum LightSet : unsigned { kRealLights = 1, kVirtualLights = 2, kAllLights = 3 };

inline unsigned LightBit(const LightSource& l) { return l.is_virtual() ? kVirtualLights : kRealLights; }

// The environment along an escaped ray, looked up ahead (in lanes, for a
// batch of paths): what EnvironmentMap::EvalWithPdf gave for its direction.
struct EnvLookup {
  Eigen::Vector3d le = Eigen::Vector3d::Zero();
  double pdf = 0;
};

// The environment's radiance along an escaped ray's unit direction d,
// MIS-weighted against the BSDF pdf that chose it (prev_pdf 0: none).
// `pre`: the lookup for d, made ahead.
inline Eigen::Vector3d EscapedEnvironment(const RenderScene& scene, const Eigen::Vector3d& d, double prev_pdf,
                                          const EnvLookup* pre = nullptr) {
  const EnvironmentMap& env = scene.environment();
  if (env.empty()) return Eigen::Vector3d::Zero();
  double pdf = pre ? pre->pdf : 0.0;
  const Eigen::Vector3d le = pre ? pre->le : env.EvalWithPdf(d, &pdf);
  return le * (prev_pdf > 0 ? PowerHeuristic(prev_pdf, pdf) : 1.0);
}

// What the distant disc lights in `which` add to `L` along an escaped
// ray's unit direction d, each MIS-weighted against prev_pdf.
inline Eigen::Vector3d EscapedDiscs(const RenderScene& scene, const Eigen::Vector3d& d, double prev_pdf, unsigned which,
                                    Eigen::Vector3d L = Eigen::Vector3d::Zero()) {
  if (scene.has_distant_area_light())
    for (const LightSource& l : scene.lights()) {
      if (!(which & LightBit(l))) continue;
      double pdf = 0;
      const Eigen::Vector3d le = l.EvalDistant(d, &pdf);
      if (pdf > 0) L += le * (prev_pdf > 0 ? PowerHeuristic(prev_pdf, pdf) : 1.0);
    }
  return L;
}

// Radiance arriving along an escaped ray from the environment and the
// distant disc lights in `which`, each MIS-weighted against the BSDF pdf
// that chose the direction (prev_pdf 0: seen directly by the camera).
// `pre`: the environment's lookup for the ray's direction, made ahead.
inline Eigen::Vector3d Escaped(const RenderScene& scene, const Ray& ray, double prev_pdf, unsigned which,
                               const EnvLookup* pre = nullptr) {
  const Eigen::Vector3d d = ray.direction.cast<double>().normalized();
  return EscapedDiscs(scene, d, prev_pdf, which,
                      (which & kRealLights) ? EscapedEnvironment(scene, d, prev_pdf, pre) : Eigen::Vector3d::Zero());
}

// Radiance of the area lights in `which` that the ray meets before t_max.
// Without `mis`, counted only on rays next-event estimation never samples:
// the camera's (prev_pdf 0) and those after a delta or transmitted BSDF
// sample (infinite), every other direction towards them being next-event
// estimation's alone (LightSource::Sample, NextEvent's mis_area false).
// With `mis` (pt, whose NextEvent weights its area samples), a BSDF-sampled
// ray counts them too, weighted by the power heuristic against the light's
// solid-angle pdf there, t^2 / (A cos): a glossy surface sees a lamp
// through its own lobe instead of through rare light samples.
inline Eigen::Vector3d AreaLightsSeen(const RenderScene& scene, const Ray& ray, double t_max, double prev_pdf,
                                      unsigned which, bool mis = false) {
  Eigen::Vector3d L = Eigen::Vector3d::Zero();
  const bool unsampled = prev_pdf == 0 || std::isinf(prev_pdf);
  if (!scene.has_area_light() || !(unsampled || mis)) return L;
  const Eigen::Vector3d o = ray.origin.cast<double>();
  const Eigen::Vector3d dir = ray.direction.cast<double>();
  const double len = dir.norm();
  const Eigen::Vector3d d = dir / len;
  double nearest = 0;
  const std::vector<LightSource>& lights = scene.lights();
  const size_t met = scene.NearestAreaLight(o, d, t_max * len, which, &nearest, &L);
  if (met < lights.size() && !unsampled) {
    const Light& l = lights[met].light();
    const double cos_l = -d.dot(l.direction);
    L *= PowerHeuristic(prev_pdf, scene.LightPickProbability(met) * nearest * nearest / (l.Area() * cos_l));
  }
  return L;
}

// A camera ray that meets nothing: what it sees of the environment and the
// distant lights, the virtual lights in I_m only.
inline void AddEscapedCameraRay(const RenderScene& scene, const Ray& ray, Eigen::Vector3d* mixed,
                                Eigen::Vector3d* real) {
  const Eigen::Vector3d e = Escaped(scene, ray, 0, kRealLights);
  *mixed += e + Escaped(scene, ray, 0, kVirtualLights);
  *real += e;
}

// Next-event estimates at `v`: one environment sample and one sample of each
// light.  Calls emit(contribution, shadow ray, is_virtual_light) for each
// unoccluded contribution (times beta: the caller's) still to be tested.  The
// random numbers drawn do not depend on outcomes, so that paths that part at
// a virtual object keep their streams aligned.
// `mis`: weight the environment and disc-light samples against the BSDF's
// pdf (false: light sampling alone, for methods that never count those
// emitters through BSDF-sampled rays at this vertex).  `mis_area`: weight
// the area lights' samples too (the caller counts AreaLightsSeen with mis
// on the BSDF-sampled ray that leaves this vertex: pt).
// An environment sample taken before its vertex was known (in lanes, for a
// batch of paths: DifferentialPathTracer::TraceBatch): what
// EnvironmentMap::Sample gave for the two numbers that the vertex's
// sampler's next Next2D returns.
struct EnvDraw {
  Eigen::Vector3d wi = Eigen::Vector3d::Zero(), le = Eigen::Vector3d::Zero();
  double pdf = 0;
  double u0 = 0, u1 = 0;  // the numbers it was taken for
};

// Whether next-event estimation draws for light l in turn (every light,
// or where one of many local lights is picked, the distant ones).
inline bool DrawnInTurn(const RenderScene& scene, const LightSource& l) {
  return !scene.picks_local_light() || l.light().type == LightType::kDistant;
}

// The draws NextEvent makes at a vertex, in order (Sampler::DrawAhead's
// pattern: 1 a NextDouble, 2 a Next2D); *bsdf_at: how many numbers they
// hold, where the BSDF sample's numbers that follow begin.
inline void NextEventDraws(const RenderScene& scene, std::vector<uint8_t>* pattern, int* bsdf_at) {
  pattern->assign(1, 2);  // the environment's
  const bool pick = scene.picks_local_light();
  for (const LightSource& l : scene.lights())
    if (DrawnInTurn(scene, l)) pattern->push_back(2);
  if (pick) pattern->insert(pattern->end(), {1, 2});
  *bsdf_at = 0;
  for (uint8_t p : *pattern) *bsdf_at += p;
}

// NextEvent's two halves: the environment's sample, each light's.  `pre`:
// the environment's sample taken ahead for this vertex's numbers.
template <class Emit>
void EnvironmentEvent(const RenderScene& scene, const PathVertex& v, Sampler& rng, Emit&& emit, bool mis = true,
                      const EnvDraw* pre = nullptr) {
  const Eigen::Vector3d wo_l = v.frame.ToLocal(v.wo_world);
  const Eigen::Vector3d& origin = v.origin;
  const EnvironmentMap& env = scene.environment();
  {
    const auto [u0, u1] = rng.Next2D();
    Eigen::Vector3d wi;
    double pdf_light = 0;
    if (!env.empty()) {
      MR_DCHECK(!pre || (pre->u0 == u0 && pre->u1 == u1));
      Eigen::Vector3d le;
      if (pre) {
        wi = pre->wi;
        pdf_light = pre->pdf;
        le = pre->le;
      } else {
        le = env.Sample(u0, u1, &wi, &pdf_light);
      }
      const Eigen::Vector3d wi_l = v.frame.ToLocal(wi);
      if (pdf_light > 0 && wi_l.z() > 0) {
        const Eigen::Vector3d f = v.bsdf.Eval(wo_l, wi_l);
        if (f.maxCoeff() > 0) {
          const double w = mis ? PowerHeuristic(pdf_light, v.bsdf.Pdf(wo_l, wi_l)) : 1.0;
          emit(Eigen::Vector3d(f.cwiseProduct(le) * (wi_l.z() * w / pdf_light)), MakeRay(origin, wi, kMaskAll), false);
        }
      }
    }
  }
}

// `pre`: for each light drawn for in turn (every light but the local ones
// one is picked from), its LightSource::SampleAhead value for this vertex's
// numbers (ignored for a light that takes none).
template <class Emit>
void LightEvents(const RenderScene& scene, const PathVertex& v, Sampler& rng, Emit&& emit, bool mis = true,
                 bool mis_area = false, const Eigen::Vector3d* pre = nullptr) {
  const Eigen::Vector3d wo_l = v.frame.ToLocal(v.wo_world);
  const Eigen::Vector3d& origin = v.origin;
  // One light's sample; `pick`: the probability it was chosen with.
  auto sample = [&](const LightSource& l, double pick, double u0, double u1, const Eigen::Vector3d* ahead) {
    LightSample ls;
    if (!l.Sample(v.p, u0, u1, &ls, ahead)) return;
    const Eigen::Vector3d wi_l = v.frame.ToLocal(ls.wi);
    if (wi_l.z() <= 0) return;
    const Eigen::Vector3d f = v.bsdf.Eval(wo_l, wi_l);
    if (f.maxCoeff() <= 0) return;
    const double pdf = ls.pdf * pick;
    const bool weighed = l.light().type == LightType::kArea ? mis && mis_area : mis && !ls.delta;
    const double w = weighed ? PowerHeuristic(pdf, v.bsdf.Pdf(wo_l, wi_l)) : 1.0;
    // A point light's shadow ray stops just short of it.
    const double tfar = std::isinf(ls.distance) ? INFINITY : ls.distance * (1 - 1e-6);
    emit(Eigen::Vector3d(f.cwiseProduct(ls.li) * (wi_l.z() * w / pdf)), MakeRay(origin, ls.wi, kMaskAll, tfar),
         l.is_virtual());
  };
  const bool pick = scene.picks_local_light();
  int drawn = 0;
  for (const LightSource& l : scene.lights()) {
    if (!DrawnInTurn(scene, l)) continue;
    const auto [u0, u1] = rng.Next2D();
    sample(l, 1.0, u0, u1, pre && l.TakesAhead() ? &pre[drawn] : nullptr);
    ++drawn;
  }
  if (pick) {  // many local lights: one, by power
    const double u = rng.NextDouble();
    const auto [u0, u1] = rng.Next2D();
    double prob = 1;
    const size_t i = scene.PickLocalLight(u, &prob);
    sample(scene.lights()[i], prob, u0, u1, nullptr);
  }
}

template <class Emit>
void NextEvent(const RenderScene& scene, const PathVertex& v, Sampler& rng, Emit&& emit, bool mis = true,
               bool mis_area = false, const EnvDraw* pre = nullptr, const Eigen::Vector3d* pre_lights = nullptr) {
  EnvironmentEvent(scene, v, rng, emit, mis, pre);
  LightEvents(scene, v, rng, emit, mis, mis_area, pre_lights);
}

// Whether the segment o + t d, t in [0, tmax], meets any of `boxes`
// (slab test, boxes grown by a relative 1e-4): false proves that no virtual
// object can block it, so its virtual shadow test is not traced.
inline bool SegmentMeetsBoxes(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double tmax,
                              const std::vector<Eigen::AlignedBox3d>& boxes) {
  for (const auto& b : boxes) {
    const Eigen::Vector3d grow = Eigen::Vector3d::Constant(1e-4 * b.diagonal().norm() + 1e-9);
    const Eigen::Vector3d lo = b.min() - grow, hi = b.max() + grow;
    double t0 = 0, t1 = tmax;
    bool miss = false;
    for (int k = 0; k < 3 && !miss; ++k) {
      if (std::abs(d[k]) < 1e-300) {
        miss = o[k] < lo[k] || o[k] > hi[k];
        continue;
      }
      double a = (lo[k] - o[k]) / d[k], c = (hi[k] - o[k]) / d[k];
      if (a > c) std::swap(a, c);
      t0 = std::max(t0, a);
      t1 = std::min(t1, c);
      miss = t0 > t1;
    }
    if (!miss) return true;
  }
  return false;
}

// A real point's light that passed the real blockers, tested against the
// virtual objects: traced only where the shadow segment meets one of their
// bounding boxes (`cull`), since no virtual object can block it elsewhere;
// the answer is the same either way.
enum class VirtualTest { kSkipped, kClear, kBlocked };
// Whether a shadow ray's virtual test must be traced: its segment meets a
// virtual object's bounding box, or `cull` is false.
inline bool VirtualTestNeeded(const RenderScene& scene, const Ray& shadow, bool cull = true) {
  return !cull || SegmentMeetsBoxes(shadow.origin.cast<double>(), shadow.direction.cast<double>(),
                                    std::min(static_cast<double>(shadow.tfar), 1e30), scene.virtual_bounds());
}
inline VirtualTest TestVirtualBlockers(const RenderScene& scene, Ray shadow, bool cull = true) {
  if (!VirtualTestNeeded(scene, shadow, cull)) return VirtualTest::kSkipped;
  shadow.mask = kMaskVirtual;
  return scene.embree().Occluded(shadow) ? VirtualTest::kBlocked : VirtualTest::kClear;
}

// Adds a next-event contribution `c` at a point to the wanted solutions
// through the blocker tests: I_r sees real blockers (st_r), I_m real and
// virtual ones (st_rv = min(st_r, st_v), st_v culled by TestVirtualBlockers);
// a virtual light and a point on a virtual surface exist in I_m only.
// Returns the shadow rays traced.
inline int AddNextEvent(const RenderScene& scene, const Eigen::Vector3d& c, Ray shadow, bool virtual_light,
                        bool x_virtual, bool want_m, bool want_r, Eigen::Vector3d* mixed, Eigen::Vector3d* real) {
  const EmbreeScene& e = scene.embree();
  if (virtual_light || x_virtual || !want_r) {
    if (!want_m) return 0;
    shadow.mask = kMaskAll;
    if (!e.Occluded(shadow)) *mixed += c;
    return 1;
  }
  shadow.mask = kMaskReal;
  if (e.Occluded(shadow)) return 1;
  *real += c;
  if (!want_m) return 1;
  if (scene.has_virtual_geometry()) {
    const VirtualTest t = TestVirtualBlockers(scene, shadow);
    if (t != VirtualTest::kBlocked) *mixed += c;
    return t == VirtualTest::kSkipped ? 1 : 2;
  }
  *mixed += c;
  return 1;
}

// The cones of directions in which the virtual objects can be met from p:
// each object's bounding sphere (RenderScene::virtual_spheres: centre,
// radius; a negative radius is no object) seen from p.  A cone's weight is
// its solid angle; one that p lies inside is the whole hemisphere above the
// shading normal (sampled by cosine), and one wholly below p's horizon is
// left out.  Internal to EnvironmentDifference.
struct VirtualCones {
  struct Cone {
    Eigen::Vector3d axis;
    double cos_max = 1, solid_angle = 0;  // solid_angle 2pi and cos_max -1: p inside
    bool inside = false;
  };
  std::vector<Cone> cones;
  double total = 0;  // the weights' sum

  VirtualCones(const std::vector<Eigen::Vector4d>& spheres, const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
    for (const auto& s : spheres) {
      if (!(s[3] >= 0)) continue;
      const Eigen::Vector3d to = s.head<3>() - p;
      const double r = s[3], d = to.norm();
      Cone c;
      if (!(d > r)) {
        c.axis = n;
        c.cos_max = -1;
        c.solid_angle = kTwoPi;
        c.inside = true;
      } else {
        c.axis = to / d;
        const double s2 = (r / d) * (r / d);
        c.cos_max = std::sqrt(1 - s2);
        c.solid_angle = kTwoPi * s2 / (1 + c.cos_max);  // 2pi (1 - cos_max), without cancellation
        // Below the horizon: the axis's elevation under -theta_max.
        if (c.axis.dot(n) < -std::sqrt(s2)) continue;
      }
      total += c.solid_angle;
      cones.push_back(c);
    }
  }
  // The solid-angle pdf of Sample's direction wi (unit); 0 outside every cone.
  double Pdf(const Eigen::Vector3d& wi, const Eigen::Vector3d& n) const {
    double pdf = 0;
    for (const Cone& c : cones) {
      const double pick = c.solid_angle / total;
      if (c.inside)
        pdf += pick * std::max(0.0, wi.dot(n)) * kInvPi;
      else if (wi.dot(c.axis) >= c.cos_max)
        pdf += pick / c.solid_angle;
    }
    return pdf;
  }
  bool Covers(const Eigen::Vector3d& wi) const {
    for (const Cone& c : cones)
      if (c.inside || wi.dot(c.axis) >= c.cos_max) return true;
    return false;
  }
  // False only where no unit direction w with w.up in [lo, hi] is Covered:
  // a cone about axis a of half-angle t holds w.up from cos(angle(a, up) + t)
  // to cos(angle(a, up) - t), written without trigonometry and widened by
  // 1e-6 (the sine of a near-polar axis is good to 1e-8).
  bool MeetsBand(const Eigen::Vector3d& up, double lo, double hi) const {
    for (const Cone& c : cones) {
      if (c.inside) return true;
      const double ca = c.axis.dot(up), sa = SafeSqrt(1 - ca * ca);
      const double ct = c.cos_max, st = SafeSqrt(1 - ct * ct);
      const double top = ca >= ct ? 1.0 : ca * ct + sa * st;       // the angle to up less t, below 0: the pole
      const double bottom = ca <= -ct ? -1.0 : ca * ct - sa * st;  // the angle plus t, past pi: the other pole
      if (bottom - 1e-6 <= hi && top + 1e-6 >= lo) return true;
    }
    return false;
  }
  // A direction: a cone picked by its weight (u_pick), uniform within it.
  Eigen::Vector3d Sample(double u_pick, double u0, double u1, const ShadingFrame& frame) const {
    size_t k = 0;
    double acc = cones[0].solid_angle / total;
    while (k + 1 < cones.size() && u_pick >= acc) acc += cones[++k].solid_angle / total;
    const Cone& c = cones[k];
    if (c.inside) {
      const auto d = SampleCosineHemisphere(u0, u1);
      return frame.ToWorld(Eigen::Vector3d(d[0], d[1], d[2]));
    }
    const double one_minus = u0 * c.solid_angle / kTwoPi;  // 1 - cos theta, uniform in [0, 1 - cos_max]
    const double cos_t = 1 - one_minus, sin_t = std::sqrt(std::max(0.0, one_minus * (2 - one_minus)));
    const double phi = kTwoPi * u1;
    Eigen::Vector3d t, b;
    CoordinateSystem(c.axis, &t, &b);
    return (sin_t * std::cos(phi) * t + sin_t * std::sin(phi) * b + cos_t * c.axis).normalized();
  }
};

// The difference the virtual objects make to the environment's light that
// a real point's vertex v reflects through v.bsdf, added to *mixed:
//   D = -integral Le f cos V_r (1 - V_v) dw,
// which is zero outside the cones in which the objects can be met.  Two
// samples, combined by the power heuristic: a direction uniform in a cone
// (picked by solid angle; the objects' sky shadow) and one of the
// environment's importance samples (the sun in their shadow; one outside
// every cone counts zero and traces nothing).  Each direction is tested
// against the virtual objects first (a segment to the far side of the
// sphere) and, only where they block it, against the real blockers.  Cones
// narrower than a form factor of 1e-3 are not sampled (the environment's
// sample alone then covers the integral, with its full weight): the sky's
// share there is below the noise, and the sun's is the other sample's.
// Always draws five numbers.  Returns the rays traced.  `cones`: the
// objects' cones seen from v (VirtualCones(scene.virtual_spheres(), v.p,
// v.frame.n)), for a caller that takes several samples at one point; null:
// made here.
inline int64_t EnvironmentDifference(const RenderScene& scene, const PathVertex& v, Sampler& rng,
                                     Eigen::Vector3d* mixed, const VirtualCones* cones = nullptr) {
  const double u_pick = rng.NextDouble();
  const auto uc = rng.Next2D();
  const auto ue = rng.Next2D();
  const EnvironmentMap& env = scene.environment();
  if (env.empty() || !scene.has_virtual_geometry()) return 0;
  std::optional<VirtualCones> made;
  if (!cones) cones = &made.emplace(scene.virtual_spheres(), v.p, v.frame.n);
  const VirtualCones& all = *cones;
  if (all.cones.empty()) return 0;
  constexpr double kMinFormFactor = 1e-3;
  const bool cone_strategy = all.total >= kPi * kMinFormFactor;
  const Eigen::Vector3d wo_l = v.frame.ToLocal(v.wo_world);
  const EmbreeScene& embree = scene.embree();
  int64_t rays = 0;
  auto test = [&](const Eigen::Vector3d& wi, double pdf_this, bool from_cone) {
    const Eigen::Vector3d wi_l = v.frame.ToLocal(wi);
    if (!(wi_l.z() > 0) || !(pdf_this > 0)) return;
    double pdf_env = 0;
    const Eigen::Vector3d le = env.EvalWithPdf(wi, &pdf_env);
    if (!(le.maxCoeff() > 0)) return;
    const Eigen::Vector3d f = v.bsdf.Eval(wo_l, wi_l);
    if (!(f.maxCoeff() > 0)) return;
    const double pdf_cone = cone_strategy ? (from_cone ? pdf_this : all.Pdf(wi, v.frame.n)) : 0.0;
    const double w = from_cone ? PowerHeuristic(pdf_cone, pdf_env) : PowerHeuristic(pdf_env, pdf_cone);
    if (!(w > 0)) return;
    Ray r = MakeRay(v.origin, wi, kMaskVirtual);
    ++rays;
    if (!embree.Occluded(r)) return;
    r.mask = kMaskReal;
    ++rays;
    if (embree.Occluded(r)) return;
    *mixed -= f.cwiseProduct(le) * (wi_l.z() * w / pdf_this);
  };
  if (cone_strategy) {
    const Eigen::Vector3d wi = all.Sample(u_pick, uc[0], uc[1], v.frame);
    test(wi, all.Pdf(wi, v.frame.n), true);
  }
  // The environment's sample counts only inside a cone: where its row's
  // band of latitudes meets none, Covers would say no (MeetsBand), and the
  // row's inversion is all it costs.
  Eigen::Vector3d wi, up;
  double pdf = 0, lo = 0, hi = 0;
  if (!env.SampleBand(ue[0], &up, &lo, &hi) || !all.MeetsBand(up, lo, hi)) return rays;
  env.Sample(ue[0], ue[1], &wi, &pdf);
  if (pdf > 0 && all.Covers(wi)) test(wi, pdf, false);
  return rays;
}

// The light a point's vertex v reflects from emitters it sees directly, for
// the wanted solutions: next-event estimation through v.bsdf, and one
// cosine-sampled ray that counts only the environment and disc lights it
// escapes to, combined by MIS (a sun 1e6 x the sky takes nearly every light
// sample; the sky needs the BSDF's).  v.bsdf must be the diffuse lobe with
// albedo `albedo` (f cos / pdf of the cosine sample).  At a real point that
// wants both solutions the environment's light is traced against the real
// blockers alone, for both, and the difference the virtual objects make to
// it is EnvironmentDifference's (the samples spent where the objects are);
// the lights' and the discs' virtual shadows are `virtual_pass(ray)`'s: how
// much of a real point's mixed light passes the virtual objects along `ray`
// (1 or 0 by shadow ray; vct: a shadow cone).  `shadows`: at such a real
// point the differences the objects make (the lights' virtual shadows and
// EnvironmentDifference) take that many samples, each weighted 1/shadows,
// while the light itself (the same in both solutions) keeps one: the
// extra samples trace rays only where an object can block them.  Returns
// rays traced.
template <class VirtualPass>
int64_t DirectDiffuse(const RenderScene& scene, const PathVertex& v, const Eigen::Vector3d& albedo, bool x_virtual,
                      bool want_m, bool want_r, Sampler& rng, Eigen::Vector3d* mixed, Eigen::Vector3d* real,
                      VirtualPass&& virtual_pass, int shadows = 1) {
  const EmbreeScene& embree = scene.embree();
  int64_t rays = 0;
  // Environment differences apart: a real point, both solutions, objects and an environment.
  const bool apart = !x_virtual && want_m && want_r && scene.has_virtual_geometry() && !scene.environment().empty();
  const int ns = apart ? std::max(1, shadows) : 1;
  auto light = [&](const Eigen::Vector3d& c, Ray shadow, bool virtual_light) {
    if (virtual_light || x_virtual || !want_r || !want_m) {
      rays += AddNextEvent(scene, c, shadow, virtual_light, x_virtual, want_m, want_r, mixed, real);
      return;
    }
    shadow.mask = kMaskReal;
    ++rays;
    if (embree.Occluded(shadow)) return;
    *real += c;
    // The light, and this sample's share 1/ns of the objects' shadow (ns 1:
    // c x pass, written as before so that its bytes stay the same).
    const double pass = virtual_pass(shadow);
    *mixed += c * (ns == 1 ? pass : 1 - (1 - pass) / ns);
  };
  // The other shadows-1 samples of the lights' virtual shadows: the virtual
  // test first, the real one only where an object blocks.  A virtual
  // light's light is I_m's alone: its one sample above.
  auto shadow_only = [&](const Eigen::Vector3d& c, Ray shadow, bool virtual_light) {
    if (virtual_light) return;
    const double pass = virtual_pass(shadow);
    if (!(pass < 1)) return;
    shadow.mask = kMaskReal;
    ++rays;
    if (embree.Occluded(shadow)) return;
    *mixed -= c * ((1 - pass) / ns);
  };
  if (apart) {
    EnvironmentEvent(scene, v, rng, [&](const Eigen::Vector3d& c, Ray shadow, bool) {
      shadow.mask = kMaskReal;
      ++rays;
      if (embree.Occluded(shadow)) return;
      *real += c;
      *mixed += c;
    });
    LightEvents(scene, v, rng, light);
    for (int k = 1; k < ns; ++k) LightEvents(scene, v, rng, shadow_only);
  } else {
    NextEvent(scene, v, rng, light);
  }
  const auto u = rng.Next2D();
  const auto d = SampleCosineHemisphere(u[0], u[1]);
  const double pdf = d[2] * kInvPi;
  if (pdf > 0) {
    Ray sky = MakeRay(v.origin, v.frame.ToWorld(Eigen::Vector3d(d[0], d[1], d[2])), kMaskReal);
    ++rays;
    if (!embree.Occluded(sky)) {  // real blockers stop both solutions
      const Eigen::Vector3d e = albedo.cwiseProduct(Escaped(scene, sky, pdf, kRealLights));
      if (want_r && !x_virtual) *real += e;
      if (want_m && apart) {
        // The environment as it is; the discs, real and virtual, through the virtual objects.
        const Eigen::Vector3d dir = sky.direction.cast<double>().normalized();
        const Eigen::Vector3d e_discs = albedo.cwiseProduct(EscapedDiscs(scene, dir, pdf, kAllLights));
        *mixed += albedo.cwiseProduct(EscapedEnvironment(scene, dir, pdf));
        if (e_discs.maxCoeff() > 0) *mixed += e_discs * virtual_pass(sky);
      } else if (want_m) {
        const double pass = x_virtual || !scene.has_virtual_geometry() ? 1.0 : virtual_pass(sky);
        bool blocked = false;
        if (x_virtual && scene.has_virtual_geometry()) {
          sky.mask = kMaskVirtual;
          ++rays;
          blocked = embree.Occluded(sky);
        }
        if (!blocked) *mixed += e * pass + albedo.cwiseProduct(Escaped(scene, sky, pdf, kVirtualLights)) * pass;
      }
    }
  }
  if (apart && ns == 1) {
    rays += EnvironmentDifference(scene, v, rng, mixed);
  } else if (apart) {
    Eigen::Vector3d diff = Eigen::Vector3d::Zero();
    const VirtualCones cones(scene.virtual_spheres(), v.p, v.frame.n);  // the same for every sample
    for (int k = 0; k < ns; ++k) rays += EnvironmentDifference(scene, v, rng, &diff, &cones);
    *mixed += diff / ns;
  }
  return rays;
}

// DirectDiffuse n times, each weighted 1/n (a method whose indirect light
// costs more than its direct light takes several direct samples per camera
// sample); n 1 is DirectDiffuse itself.  `shadows`: DirectDiffuse's.
// Returns rays traced.
template <class VirtualPass>
int64_t DirectDiffuseSamples(int n, const RenderScene& scene, const PathVertex& v, const Eigen::Vector3d& albedo,
                             bool x_virtual, bool want_m, bool want_r, Sampler& rng, Eigen::Vector3d* mixed,
                             Eigen::Vector3d* real, VirtualPass&& virtual_pass, int shadows = 1) {
  if (n <= 1)
    return DirectDiffuse(scene, v, albedo, x_virtual, want_m, want_r, rng, mixed, real, virtual_pass, shadows);
  int64_t rays = 0;
  for (int k = 0; k < n; ++k) {
    Eigen::Vector3d mk = Eigen::Vector3d::Zero(), rk = Eigen::Vector3d::Zero();
    rays += DirectDiffuse(scene, v, albedo, x_virtual, want_m, want_r, rng, &mk, &rk, virtual_pass, shadows);
    *mixed += mk / n;
    *real += rk / n;
  }
  return rays;
}

}  // namespace mr
