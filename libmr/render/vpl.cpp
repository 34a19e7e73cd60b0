#include "render/vpl.h"
#include "core/check.h"

#include <spdlog/spdlog.h>

#include <atomic>
#include <bit>
#include <chrono>
#include <unordered_set>

#include "core/hash.h"
#include "core/parallel.h"

namespace mr {

namespace {

uint32_t MaskOf(uint8_t sets) { return sets == kLightsReal ? kMaskReal : kMaskAll; }

struct Emitter {
  int light = -1;  // -1: the environment
  double power = 0;
  int first = 0, paths = 0;  // its share of the light paths: [first, first + paths)
  uint64_t stream = 0;       // its random streams' key: the light's name, so that a light keeps its paths
  double select = 0;         // the probability that a path is this emitter's
};

// With more emitters than paths (10,000 area lights, 1024 paths) a fixed
// share of at least one path each cannot be given: each path then draws
// its emitter from the mixture instead.
bool EmittersDrawn(const std::vector<Emitter>& emitters, const VplSettings& st) {
  return emitters.size() > static_cast<size_t>(std::max(0, st.paths));
}

}  // namespace

std::vector<DirectionalVpl> DirectionalLights(const RenderScene& scene, int directions, uint64_t seed,
                                              const Eigen::Vector3d& centre) {
  std::vector<DirectionalVpl> out;
  const EnvironmentMap& env = scene.environment();
  // Directional VPLs: the environment (half by its importance, half
  // uniformly, weighted by the balance heuristic over the two), disc lights
  // by their cones, delta distant lights exactly.
  const int nd = std::max(1, directions);
  if (!env.empty()) {
    const int n1 = (nd + 1) / 2, n2 = nd / 2;
    Sampler rng = Sampler::Random(HashCombine(seed, 0x646972), 0);
    for (int k = 0; k < nd; ++k) {
      Eigen::Vector3d dir;
      double pdf = 0;
      const double u = rng.NextDouble(), u1 = rng.NextDouble();
      if (k < n1) {
        env.Sample((k + u) / n1, u1, &dir, &pdf);
      } else {
        const auto d = SampleUniformSphere((k - n1 + u) / n2, u1);
        dir = Eigen::Vector3d(d[0], d[1], d[2]);
      }
      const double p_env = env.Pdf(dir);
      const double denom = n1 * p_env + n2 * kUniformSpherePdf;
      if (!(denom > 0)) continue;
      const Eigen::Vector3d L = env.Eval(dir);
      if (L.maxCoeff() <= 0) continue;
      out.push_back({dir, L / denom, kLightsBoth});
    }
  }
  for (size_t i = 0; i < scene.lights().size(); ++i) {
    const LightSource& l = scene.lights()[i];
    if (l.light().type != LightType::kDistant) continue;
    const uint8_t sets = l.is_virtual() ? kLightsMixed : kLightsBoth;
    const int n = l.light().IsDelta() ? 1 : std::max(1, nd / 4);
    Sampler rng = Sampler::Random(HashCombine(seed, 0x646973), i);
    for (int k = 0; k < n; ++k) {
      LightSample ls;
      const double u0 = (k + rng.NextDouble()) / n, u1 = rng.NextDouble();
      if (!l.Sample(centre, u0, u1, &ls)) continue;
      out.push_back({ls.wi, ls.li / (ls.pdf * n), sets});
    }
  }

  return out;
}

namespace {

// The disc parallel light enters the scene through: the scene's bounding
// sphere, and the virtual objects' (radius 0: none), a stratum of its own.
struct PathDisc {
  Eigen::Vector3d centre;
  double radius = 0;
  Eigen::Vector3d object_centre;
  double object_radius = 0;
};

// The emitters (the environment, then the lights) with their share of the
// light paths.
std::vector<Emitter> Emitters(const RenderScene& scene, const VplSettings& st, double radius) {
  const EnvironmentMap& env = scene.environment();
  std::vector<Emitter> emitters;
  if (!env.empty() && env.LuminanceIntegral() > 0)
    emitters.push_back({-1, env.LuminanceIntegral() * kPi * radius * radius});
  for (size_t i = 0; i < scene.lights().size(); ++i) {
    const Light& l = scene.lights()[i].light();
    double p = 0;
    switch (l.type) {
      case LightType::kPoint:
        p = Luminance(l.intensity) * kFourPi;
        break;
      case LightType::kSpot:
        p = Luminance(l.intensity) * kTwoPi * (1 - std::cos(l.cone_deg * kDegToRad));
        break;
      case LightType::kDistant:
        p = Luminance(l.irradiance) * kPi * radius * radius;
        break;
      case LightType::kArea:
        p = Luminance(l.radiance) * kPi * l.Area();
        break;
    }
    if (p > 0) emitters.push_back({static_cast<int>(i), p});
  }
  // Emitters are chosen by a defensive mixture: half in proportion to power,
  // half uniformly, so that a dim virtual lamp beside a bright sky still gets
  // paths (all of its light is difference); the flux divides by the mixture.
  double power = 0;
  for (const auto& e : emitters) power += e.power;
  MR_CHECK(emitters.empty() || power > 0);  // only emitters with power are listed
  for (auto& e : emitters) e.power = 0.5 * e.power / power + 0.5 / static_cast<double>(emitters.size());
  // Each emitter's share of the paths is fixed (largest remainder, at least
  // one each while paths last), and its paths draw from its own streams,
  // keyed by the light's name: when the world changes between frames, a
  // path whose emitter and surfaces did not change is the same path (the
  // VPL stays where it was; only its flux scales with the share), which
  // keeps the frames coherent (docs/methods.md, "vpl").
  if (EmittersDrawn(emitters, st)) {
    for (auto& e : emitters) {
      e.select = e.power;
      e.stream = e.light < 0 ? 0x656e76ULL : HashString(scene.lights()[static_cast<size_t>(e.light)].light().name);
    }
    return emitters;
  }
  {
    int given = 0;
    std::vector<std::pair<double, size_t>> rest;
    for (size_t i = 0; i < emitters.size(); ++i) {
      const double want = st.paths * emitters[i].power;
      emitters[i].paths = std::min(st.paths - given, std::max(1, static_cast<int>(std::floor(want))));
      given += emitters[i].paths;
      rest.emplace_back(-(want - std::floor(want)), i);
    }
    std::sort(rest.begin(), rest.end());
    for (size_t r = 0; given < st.paths && !rest.empty(); r = (r + 1) % rest.size(), ++given)
      ++emitters[rest[r].second].paths;
    int first = 0;
    for (auto& e : emitters) {
      e.first = first;
      first += e.paths;
      e.stream = e.light < 0 ? 0x656e76ULL : HashString(scene.lights()[static_cast<size_t>(e.light)].light().name);
      e.select = static_cast<double>(e.paths) / st.paths;
    }
  }
  MR_CHECK(emitters.empty() || emitters.back().first + emitters.back().paths == st.paths);  // every path has one
  return emitters;
}

// Where light path j of emitter `em` starts: its origin, direction, flux and
// light sets; false when it carries nothing or falls in the other stratum.
bool StartLightPath(const RenderScene& scene, const VplSettings& st, const Emitter& em, const PathDisc& disc,
                    Sampler& rng, Eigen::Vector3d* origin_out, Eigen::Vector3d* dir_out, Eigen::Vector3d* flux_out,
                    uint8_t* sets_out) {
  const EnvironmentMap& env = scene.environment();
  const Eigen::Vector3d& centre = disc.centre;
  const Eigen::Vector3d& object_centre = disc.object_centre;
  const double radius = disc.radius, object_radius = disc.object_radius;
  constexpr double kObjectStratum = 0.5;
  const double p_select = em.select;  // flux / (p_select paths): with a fixed share, / em.paths
  Eigen::Vector3d& origin = *origin_out;
  Eigen::Vector3d& dir = *dir_out;
  Eigen::Vector3d& flux = *flux_out;
  uint8_t& sets = *sets_out;
  const double u0 = rng.NextDouble(), u1 = rng.NextDouble(), u3 = rng.NextDouble(), u4 = rng.NextDouble();
  sets = kLightsBoth;
  // Parallel light (the environment, distant lights) enters through a
  // disc covering the scene, in two strata: the disc of the virtual
  // objects' bounding sphere (chosen with probability f) and the rest of
  // the scene's disc (points inside the objects' disc are dropped there),
  // so that light paths meet the objects, whose VPLs (mixed-only and ir)
  // carry the difference, however small they are in the room.
  const double u5 = rng.NextDouble();
  bool dropped = false;
  auto from_disc = [&](const Eigen::Vector3d& towards, const Eigen::Vector3d& irradiance) {
    Eigen::Vector3d t, b;
    CoordinateSystem(towards, &t, &b);
    const bool object_stratum = object_radius > 0 && u5 < kObjectStratum;
    const double rad = object_stratum ? object_radius : radius;
    const double p_stratum = object_radius > 0 ? (object_stratum ? kObjectStratum : 1 - kObjectStratum) : 1.0;
    const Eigen::Vector3d c = object_stratum ? object_centre : centre;
    const double r = rad * std::sqrt(u3), phi = kTwoPi * u4;
    origin = c + (radius + (c - centre).norm()) * towards + r * (std::cos(phi) * t + std::sin(phi) * b);
    dir = -towards;
    if (!object_stratum && object_radius > 0) {
      const Eigen::Vector3d q = object_centre - origin;
      dropped = (q - q.dot(dir) * dir).norm() < object_radius;  // the other stratum's
    }
    flux = irradiance * (kPi * rad * rad / (p_select * p_stratum * st.paths));
  };
  if (em.light < 0) {
    double pdf = 0;
    Eigen::Vector3d w;
    const Eigen::Vector3d L = env.Sample(u0, u1, &w, &pdf);
    if (!(pdf > 0)) return false;
    from_disc(w, L / pdf);
  } else {
    const LightSource& ls = scene.lights()[static_cast<size_t>(em.light)];
    const Light& l = ls.light();
    sets = l.is_virtual ? kLightsMixed : kLightsBoth;
    if (l.type == LightType::kDistant) {
      LightSample s;
      if (!ls.Sample(centre, u0, u1, &s)) return false;
      from_disc(s.wi, s.li / s.pdf);
    } else if (l.type == LightType::kArea) {
      // A uniform point of it (the sample seen from a point on its normal
      // gives it), a cosine-weighted direction: flux L pi A per path.
      LightSample s;
      if (!ls.Sample(l.position + l.direction, u0, u1, &s)) return false;
      origin = l.position + l.direction + s.distance * s.wi;
      const auto c = SampleCosineHemisphere(u3, u4);
      Eigen::Vector3d t, b;
      CoordinateSystem(l.direction, &t, &b);
      dir = (c[0] * t + c[1] * b + c[2] * l.direction).normalized();
      flux = l.radiance * (kPi * l.Area() / (p_select * st.paths));
    } else {
      double pdf;
      if (l.type == LightType::kPoint) {
        const auto d = SampleUniformSphere(u0, u1);
        dir = Eigen::Vector3d(d[0], d[1], d[2]);
        pdf = kUniformSpherePdf;
      } else {  // uniform in the cone
        const double cos_max = std::cos(l.cone_deg * kDegToRad);
        const double c = 1 - u0 * (1 - cos_max), s = SafeSqrt(1 - c * c), phi = kTwoPi * u1;
        Eigen::Vector3d t, b;
        CoordinateSystem(l.direction, &t, &b);
        dir = (c * l.direction + s * (std::cos(phi) * t + std::sin(phi) * b)).normalized();
        pdf = 1 / (kTwoPi * (1 - cos_max));
      }
      LightSample s;  // the intensity towards dir, with the spot's falloff (at unit distance)
      if (!ls.Sample(l.position + dir, 0, 0, &s)) return false;
      origin = l.position;
      flux = s.li / (pdf * p_select * st.paths);
    }
  }
  return !dropped;
}

// Lightcuts' trees, one per light set, over the VPLs that light something.
void BuildTrees(const std::vector<Vpl>& vpls, double diag, std::vector<VplTree>* trees) {
  for (const uint8_t sets : {kLightsBoth, kLightsMixed, kLightsReal}) {
    std::vector<int> idx;
    for (size_t i = 0; i < vpls.size(); ++i) {
      const Vpl& v = vpls[i];
      // A VPL whose every bound is zero (a black surface) lights nothing.
      if (v.sets == sets && Luminance(v.flux.cwiseProduct(v.bsdf.DiffuseBound() + v.bsdf.GlossyBound(v.wi_local))) > 0)
        idx.push_back(static_cast<int>(i));
    }
    if (!idx.empty()) trees->emplace_back(vpls, std::move(idx), sets, diag);
  }
}

}  // namespace

std::shared_ptr<const VplSet> VplSet::Build(const RenderScene& scene, const VplSettings& st) {
  const auto t0 = std::chrono::steady_clock::now();
  auto out = std::make_shared<VplSet>();
  out->settings_ = st;
  const Eigen::AlignedBox3d box = scene.bounds().cast<double>();
  const double diag = box.isEmpty() ? 1.0 : std::max(1e-6, box.diagonal().norm());
  const Eigen::Vector3d centre =
      box.isEmpty() ? Eigen::Vector3d(Eigen::Vector3d::Zero()) : Eigen::Vector3d(box.center());
  const double radius = 0.5 * diag * 1.001;
  out->clamp_ = st.clamp_distance > 0 ? st.clamp_distance : 0.02 * diag;
  if (st.fixed_directions) out->directional_ = DirectionalLights(scene, st.directions, st.seed, centre);

  const std::vector<Emitter> emitters = Emitters(scene, st, radius);
  const int max_vpl_depth = st.max_depth - 2;  // a VPL at depth k ends a path of k + 2 surfaces
  // The virtual objects' bounding sphere (radius 0: none).
  Eigen::AlignedBox3d objects;
  for (const auto& b : scene.virtual_bounds()) objects.extend(b);
  const PathDisc disc{centre, radius, objects.isEmpty() ? centre : Eigen::Vector3d(objects.center()),
                      objects.isEmpty() ? 0.0 : 0.5 * objects.diagonal().norm()};
  if (!emitters.empty() && st.paths > 0 && max_vpl_depth >= 0) {
    std::vector<std::vector<Vpl>> per_path(static_cast<size_t>(st.paths));
    std::atomic<int64_t> below{0};
    const EmbreeScene& embree = scene.embree();
    const bool drawn = EmittersDrawn(emitters, st);
    std::vector<double> cdf;  // drawn: the mixture's running sums
    for (const Emitter& e : emitters) cdf.push_back((cdf.empty() ? 0.0 : cdf.back()) + e.select);
    ParallelFor(0, st.paths, [&](int64_t j) {
      size_t ei = 0;
      if (drawn) {
        const double u = Sampler::Random(HashCombine(st.seed, 0x706963), static_cast<uint64_t>(j)).NextDouble();
        ei = std::min(static_cast<size_t>(std::upper_bound(cdf.begin(), cdf.end(), u * cdf.back()) - cdf.begin()),
                      emitters.size() - 1);
      } else {
        while (ei + 1 < emitters.size() && j >= emitters[ei].first + emitters[ei].paths) ++ei;
      }
      const Emitter& em = emitters[ei];
      if (!drawn && em.paths == 0) return;
      Sampler rng = Sampler::Random(HashCombine(HashCombine(st.seed, 0x76706c), em.stream),
                                    static_cast<uint64_t>(drawn ? j : j - em.first));
      Eigen::Vector3d origin, dir, flux;
      uint8_t sets = kLightsBoth;
      if (!StartLightPath(scene, st, em, disc, rng, &origin, &dir, &flux, &sets)) return;
      // Walks a light path, leaving a VPL at each surface; where a shared
      // path meets a virtual object the real-only path goes on behind it.
      std::vector<Vpl>& vs = per_path[static_cast<size_t>(j)];
      const double flux0 = flux.maxCoeff();
      const std::function<void(Ray, uint8_t, Eigen::Vector3d, int, Sampler&)> walk =
          [&](Ray ray, uint8_t path_sets, Eigen::Vector3d phi, int depth, Sampler& g) {
            for (; depth <= max_vpl_depth; ++depth) {
              ray.mask = MaskOf(path_sets);
              Hit hit;
              if (!embree.Intersect(ray, &hit)) return;
              if (hit.is_virtual && path_sets == kLightsBoth) {
                Sampler real_rng = g;
                walk(ray, kLightsReal, phi, depth, real_rng);  // ir VPLs
                path_sets = kLightsMixed;
              }
              const PathVertex v = MakeVertex(scene, ray, hit);
              if (Luminance(phi) > 0) {
                Vpl p;
                p.p = v.origin;
                p.frame = v.frame;
                p.wi_local = v.frame.ToLocal(v.wo_world);
                p.flux = phi;
                p.bsdf = v.bsdf;
                p.diffuse = DiffuseLobe(scene, v);
                p.sets = path_sets;
                p.on_virtual = hit.is_virtual;
                p.depth = depth;
                vs.push_back(p);
              }
              if (v.bsdf.IsBlack() || depth == max_vpl_depth) return;
              BsdfSample s;
              const double ul = g.NextDouble(), a = g.NextDouble(), b = g.NextDouble();
              if (!v.bsdf.Sample(v.frame.ToLocal(v.wo_world), ul, a, b, &s)) return;
              phi = phi.cwiseProduct(s.f) * (std::abs(s.wi.z()) / s.pdf);
              const double q = std::min(1.0, phi.maxCoeff() / flux0);
              if (g.NextDouble() >= q) {
                if (q > 0) below.fetch_add(1);
                return;
              }
              phi /= q;
              ray = MakeRay(v.OriginFor(v.frame.ToWorld(s.wi)), v.frame.ToWorld(s.wi), MaskOf(path_sets));
            }
          };
      walk(MakeRay(origin, dir, MaskOf(sets)), sets, flux, 0, rng);
    });
    for (auto& v : per_path) out->vpls_.insert(out->vpls_.end(), v.begin(), v.end());
    out->paths_ended_below_ = below.load();
  }
  if (st.cut_error > 0 && out->vpls_.size() >= static_cast<size_t>(st.cut_min_vpls))
    BuildTrees(out->vpls_, diag, &out->trees_);
  CausticSettings cs;
  cs.photons = st.caustic_photons;
  cs.seed = HashCombine(st.seed, 0x63617573);
  out->caustics_ = CausticMap::Build(scene, cs, disc.object_centre, disc.object_radius);
  out->build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

void VplSet::Describe(Report* report) const {
  int64_t shared = 0, mixed = 0, real = 0, on_virtual = 0;
  for (const Vpl& v : vpls_) {
    shared += v.sets == kLightsBoth;
    mixed += v.sets == kLightsMixed;
    real += v.sets == kLightsReal;
    on_virtual += v.on_virtual;
  }
  report->SetMetric("vpl.paths", settings_.paths);
  report->SetMetric("vpl.vpls", static_cast<int64_t>(vpls_.size()));
  report->SetMetric("vpl.shared", shared);
  report->SetMetric("vpl.mixed_only", mixed);
  report->SetMetric("vpl.real_only_ir", real);
  report->SetMetric("vpl.on_virtual", on_virtual);
  report->SetMetric("vpl.directional", static_cast<int64_t>(directional_.size()));
  report->SetMetric("vpl.clamp_distance_m", clamp_);
  report->SetMetric("vpl.compensate", settings_.compensate);
  caustics_.Describe(report);
  report->SetMetric("vpl.final_gather", settings_.final_gather);
  report->SetMetric("vpl.fixed_directions", settings_.fixed_directions);
  if (!settings_.fixed_directions)
    report->Skip("directional VPLs", "the direct light is sampled at every shading point (vpl.fixed_directions off)");
  report->SetMetric("vpl.cut_error", settings_.cut_error);
  report->SetMetric("vpl.max_cut", settings_.max_cut);
  int64_t tree_nodes = 0;
  for (const VplTree& t : trees_) tree_nodes += static_cast<int64_t>(t.size());
  report->SetMetric("vpl.tree_nodes", tree_nodes);
  report->SetMetric("vpl.cut_min_vpls", settings_.cut_min_vpls);
  if (settings_.cut_error > 0 && trees_.empty())
    report->Skip("light trees (lightcuts)",
                 fmt::format("{} VPLs, fewer than vpl.cut_min_vpls = {}: testing each costs less than clustering",
                             vpls_.size(), settings_.cut_min_vpls));
  report->SetMetric("vpl.build_seconds", build_seconds_);
  report->SetMetric("vpl.paths_ended_by_roulette", paths_ended_below_);
}

// ---------------------------------------------------------------------------
// Shading.

namespace {

struct Accum {
  Eigen::Vector3d mixed = Eigen::Vector3d::Zero(), real = Eigen::Vector3d::Zero();
  Eigen::Vector3d bias_m = Eigen::Vector3d::Zero(), bias_r = Eigen::Vector3d::Zero();
  bool primary_virtual = false;
  VplFrameRenderer::Counters c;
};

struct Contribution {
  Eigen::Vector3d value, bias, dir;
  double tfar;
  uint8_t sets;
};

// The cuts made at a pixel's first camera sample, reused by its later
// samples of the same pass at points of the same surface facing the same
// way (VplSettings::reuse_cuts).  One per thread; a pixel's samples of a
// pass run on one thread, in order, so reuse does not depend on threads.
struct CutCache {
  struct Cut {
    uint32_t geometry = 0;
    uint8_t wanted = 0;
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    std::vector<std::pair<int, int>> nodes;  // (tree, node) of the cut
    std::vector<double> share;               // each cluster's share of the cut's light at the first sample
  };
  const void* owner = nullptr;
  int64_t pass = -1;
  size_t pixel = SIZE_MAX;
  std::vector<Cut> cuts;
  // Starts the pixel's samples: forgets every cut made elsewhere.
  void Begin(const void* o, int64_t p, size_t px) {
    if (o != owner || p != pass || px != pixel) cuts.clear();
    owner = o;
    pass = p;
    pixel = px;
  }
};

// Reused cuts: a cluster with less than kRouletteShare of the first
// sample's light is tested with probability share / kRouletteShare, at
// least kRouletteFloor (one that was shadowed then may not be now).
constexpr double kRouletteShare = 0.01, kRouletteFloor = 0.25;

class VplShader {
 public:
  // `plate`: the plate at real points met from virtual surfaces (null: none).
  // `cuts`: the pixel's cuts to reuse at the camera's points (null: none).
  VplShader(const RenderScene& scene, const VplSet& set, const DifferentialPathTracer* plate = nullptr,
            CutCache* cuts = nullptr)
      : scene_(scene), set_(set), st_(set.settings()), plate_(plate), cuts_(cuts) {
    clamp2_ = set.clamp_distance() * set.clamp_distance();
  }

  // Radiance along `ray` (times beta) for the wanted solutions; `from_virtual`:
  // the ray leaves a virtual surface.
  void ShadeRay(Ray ray, bool want_m, bool want_r, int depth, double prev_pdf, const Eigen::Vector3d& beta,
                Sampler& rng, Accum* acc, bool from_virtual = false) const {
    ray.mask = want_m ? kMaskAll : kMaskReal;
    Hit hit;
    ++acc->c.rays;
    if (!scene_.embree().Intersect(ray, &hit)) {
      const Eigen::Vector3d e = beta.cwiseProduct(Escaped(scene_, ray, prev_pdf, kRealLights));
      if (want_m) acc->mixed += e + beta.cwiseProduct(Escaped(scene_, ray, prev_pdf, kVirtualLights));
      if (want_r) acc->real += e;
      return;
    }
    if (plate_ && from_virtual && want_m && !want_r && !hit.is_virtual) {
      int rays = 0;
      const bool taken = plate_->PlateAtRealPoint(MakeVertex(scene_, ray, hit), beta, depth, rng, &rays, &acc->mixed);
      acc->c.shadow_rays += rays;
      if (taken) return;
    }
    if (hit.is_virtual) {
      if (depth == 0) acc->primary_virtual = true;
      if (want_r) {
        Sampler real_rng = rng;
        ShadeRay(ray, false, true, depth, prev_pdf, beta, real_rng, acc);
      }
      ShadeAt(MakeVertex(scene_, ray, hit), true, true, false, depth, beta, rng, acc, true);
      return;
    }
    ShadeAt(MakeVertex(scene_, ray, hit), false, want_m, want_r, depth, beta, rng, acc, true);
  }

 private:
  void Add(Accum* acc, bool m, bool r, const Eigen::Vector3d& c) const {
    if (m) acc->mixed += c;
    if (r) acc->real += c;
  }

  void ShadeAt(const PathVertex& v, bool x_virtual, bool want_m, bool want_r, int depth, const Eigen::Vector3d& beta,
               Sampler& rng, Accum* acc, bool emission) const {
    if (emission) Add(acc, want_m, want_r, beta.cwiseProduct(v.emission));
    if (v.bsdf.IsBlack()) return;
    const bool split = HasGlossyLobe(scene_, v) && depth < st_.glossy_depth;
    const bool gather = st_.final_gather && x_virtual && depth == 0;
    if (!split) {
      Gather(v, v.bsdf, HasGlossyLobe(scene_, v), x_virtual, want_m, want_r, beta, rng, acc, depth == 0, !gather);
      if (gather) FinalGathers(v, v.bsdf, beta, rng, acc);
    } else {
      // Diffuse lobe by VPLs; glossy lobe by next-event estimation and one
      // BSDF-sampled ray, gathered where it lands.
      const Bsdf diffuse = DiffuseLobe(scene_, v);
      const Bsdf& glossy = GlossyLobe(scene_, v);
      Gather(v, diffuse, false, x_virtual, want_m, want_r, beta, rng, acc, depth == 0, !gather);
      if (gather) FinalGathers(v, diffuse, beta, rng, acc);
      PathVertex g = v;
      g.bsdf = glossy;
      NextEvent(scene_, g, rng, [&](const Eigen::Vector3d& c, Ray shadow, bool virtual_light) {
        acc->c.shadow_rays += AddNextEvent(scene_, beta.cwiseProduct(c), shadow, virtual_light, x_virtual, want_m,
                                           want_r, &acc->mixed, &acc->real);
      });
      BsdfSample s;
      const double ul = rng.NextDouble();
      const auto [u0, u1] = rng.Next2D();
      if (glossy.Sample(v.frame.ToLocal(v.wo_world), ul, u0, u1, &s)) {
        const Eigen::Vector3d b = beta.cwiseProduct(s.f) * (std::abs(s.wi.z()) / s.pdf);
        ShadeRay(MakeRay(v.OriginFor(v.frame.ToWorld(s.wi)), v.frame.ToWorld(s.wi), kMaskAll), want_m, want_r,
                 depth + 1, s.pdf, b, rng, acc, x_virtual);
      }
    }
    if (st_.compensate && depth == 0 && !gather) Compensate(v, x_virtual, want_m, want_r, beta, rng, acc);
  }

  // VplSettings::gather_rays final gathers, each weighted 1/n.
  void FinalGathers(const PathVertex& v, const Bsdf& bsdf, const Eigen::Vector3d& beta, Sampler& rng,
                    Accum* acc) const {
    const int n = std::max(1, st_.gather_rays);
    for (int i = 0; i < n; ++i) FinalGather(v, bsdf, beta / n, rng, acc);
  }

  // The indirect light at virtual point v (I_m only) through `bsdf` along
  // one sampled ray: at a real point the plate sees, its radiance and the
  // objects' shadows there (PlateAtRealPoint, as pt); elsewhere the light
  // the VPLs give the point met, as at a camera ray's point.  A ray that
  // escapes adds nothing: Gather took the environment's direct light at v
  // (sampled, or the fixed directional VPLs), as it does without the gather.
  void FinalGather(const PathVertex& v, const Bsdf& bsdf, const Eigen::Vector3d& beta, Sampler& rng, Accum* acc) const {
    BsdfSample s;
    const double ul = rng.NextDouble();
    const auto [u0, u1] = rng.Next2D();
    if (!bsdf.Sample(v.frame.ToLocal(v.wo_world), ul, u0, u1, &s)) return;
    const Eigen::Vector3d b = beta.cwiseProduct(s.f) * (std::abs(s.wi.z()) / s.pdf);
    const Ray ray = MakeRay(v.OriginFor(v.frame.ToWorld(s.wi)), v.frame.ToWorld(s.wi), kMaskAll);
    Hit hit;
    ++acc->c.gather_rays;
    if (!scene_.embree().Intersect(ray, &hit)) return;
    const PathVertex y = MakeVertex(scene_, ray, hit);
    if (plate_ && !hit.is_virtual) {
      int rays = 0;
      const bool taken = plate_->PlateAtRealPoint(y, b, 1, rng, &rays, &acc->mixed);
      acc->c.shadow_rays += rays;
      if (taken) return;
    }
    // The point reflects the direct light (sampled) and the VPLs' light
    // through its diffuse lobe only.  Through a glossy lobe both are
    // caustics that one ray a sample finds only by chance: the sun's
    // (which the caustic photons carry instead) and a bright VPL's, such as
    // one on the object mirrored back at it by a glossy table (a sample of
    // 190 x the pixel on the main job's dynamic capture).  docs/methods.md,
    // "vpl", measures the bias.
    if (y.bsdf.IsBlack()) return;
    Gather(y, DiffuseLobe(scene_, y), false, hit.is_virtual, true, false, b, rng, acc, false);
  }

  // Kollig & Keller's correction: the light that reaches v from surfaces
  // closer than the clamp distance, weighted by the part the clamp removed
  // (1 - d²/clamp²), along one cosine-sampled ray.
  void Compensate(const PathVertex& v, bool x_virtual, bool want_m, bool want_r, const Eigen::Vector3d& beta,
                  Sampler& rng, Accum* acc) const {
    const auto u = rng.Next2D();
    const auto d = SampleCosineHemisphere(u[0], u[1]);
    const Eigen::Vector3d dir = v.frame.ToWorld(Eigen::Vector3d(d[0], d[1], d[2]));
    const Eigen::Vector3d albedo = DiffuseAlbedo(v);  // f cos / pdf of the diffuse lobe
    auto one = [&](uint32_t mask, bool m, bool r) {
      Ray ray = MakeRay(v.origin, dir, mask, set_.clamp_distance());
      Hit hit;
      ++acc->c.compensation_rays;
      if (!scene_.embree().Intersect(ray, &hit)) return;
      const double t = hit.t;
      const double w = std::max(0.0, 1 - t * t / clamp2_);
      if (w <= 0) return;
      if (hit.is_virtual && !m) return;
      Accum sub;
      Sampler g = rng;
      const PathVertex y = MakeVertex(scene_, ray, hit);
      ShadeAt(y, hit.is_virtual, m, r && !hit.is_virtual, 1, beta.cwiseProduct(albedo) * w, g, &sub, false);
      if (m) acc->mixed += sub.mixed;
      if (r) acc->real += sub.real;
      acc->c.shadow_rays += sub.c.shadow_rays;
    };
    if (x_virtual || !want_r) {
      one(kMaskAll, true, false);
    } else if (!want_m) {
      one(kMaskReal, false, true);
    } else {
      // Both from one mixed ray unless it meets a virtual object first.
      Ray probe = MakeRay(v.origin, dir, kMaskAll, set_.clamp_distance());
      Hit hit;
      if (scene_.embree().Intersect(probe, &hit) && hit.is_virtual) {
        one(kMaskAll, true, false);
        one(kMaskReal, false, true);
      } else {
        one(kMaskAll, true, true);
      }
    }
  }

  Eigen::Vector3d DiffuseAlbedo(const PathVertex& v) const { return v.albedo; }
  uint32_t Id(const PathVertex& v) const { return v.geometry_id; }

  // The light at v through `bsdf` (its glossy lobe too where `glossy`):
  // the direct light, sampled here (DirectDiffuse, as ic and vct) or from
  // the fixed directional VPLs (VplSettings::fixed_directions), and the
  // VPLs' (point_vpls false: the direct light only; a final gather takes the
  // rest).
  void Gather(const PathVertex& v, const Bsdf& bsdf, bool glossy, bool x_virtual, bool want_m, bool want_r,
              const Eigen::Vector3d& beta, Sampler& rng, Accum* acc, bool measure_bias, bool point_vpls = true) const {
    double direct = 0;  // the direct light's luminance here (lightcuts' error is relative to the whole)
    if (!st_.fixed_directions) {
      Eigen::Vector3d m = Eigen::Vector3d::Zero(), r = Eigen::Vector3d::Zero();
      PathVertex vd = v;
      vd.bsdf = DiffuseLobe(scene_, v);
      // At a camera point several samples of the direct light: they cost a
      // fraction of the VPLs' gather (VplSettings::direct_samples; on an
      // object object_direct_samples; shadow_samples of the objects' shadows).
      const int n_direct = !measure_bias ? 1
                           : x_virtual   ? std::max(st_.direct_samples, st_.object_direct_samples)
                                         : st_.direct_samples;
      const int n_shadows = measure_bias ? st_.shadow_samples : 1;
      acc->c.shadow_rays += DirectDiffuseSamples(
          n_direct, scene_, vd, v.albedo, x_virtual, want_m, want_r, rng, &m, &r,
          [&](Ray sr) {
            const VirtualTest t = TestVirtualBlockers(scene_, sr);
            if (t == VirtualTest::kSkipped) {
              ++acc->c.virtual_tests_skipped;
              return 1.0;
            }
            ++acc->c.shadow_rays;
            return t == VirtualTest::kBlocked ? 0.0 : 1.0;
          },
          n_shadows);
      if (glossy) {  // light sampling alone: no BSDF-sampled ray of this lobe counts the emitters
        PathVertex vg = v;
        vg.bsdf = GlossyLobe(scene_, v);
        NextEvent(
            scene_, vg, rng,
            [&](const Eigen::Vector3d& c, Ray shadow, bool virtual_light) {
              acc->c.shadow_rays += AddNextEvent(scene_, c, shadow, virtual_light, x_virtual, want_m, want_r, &m, &r);
            },
            false);
      }
      acc->mixed += beta.cwiseProduct(m);
      acc->real += beta.cwiseProduct(r);
      direct = std::max(Luminance(m), Luminance(r));
    }
    if (x_virtual && want_m && !set_.caustics().empty())
      acc->mixed += beta.cwiseProduct(set_.caustics().Radiance(v.p, v.frame, bsdf, v.frame.ToLocal(v.wo_world)));
    thread_local std::vector<Contribution> list;
    list.clear();
    const Eigen::Vector3d wo_l = v.frame.ToLocal(v.wo_world);
    const Eigen::Vector3d origin = v.origin;
    // Which sets matter here: a virtual point exists in I_m only.
    const uint8_t wanted = static_cast<uint8_t>((want_m ? kLightsMixed : 0) | (want_r && !x_virtual ? kLightsReal : 0));
    double total = 0;
    auto push = [&](const Eigen::Vector3d& value, const Eigen::Vector3d& bias, const Eigen::Vector3d& dir, double tfar,
                    uint8_t sets) {
      if (!(sets & wanted)) return;
      const double l = Luminance(value);
      if (!(l > 0)) return;
      total += l;
      list.push_back({value, bias, dir, tfar, sets});
    };
    for (const DirectionalVpl& d : set_.directional()) {  // empty unless fixed_directions
      const Eigen::Vector3d wi = v.frame.ToLocal(d.dir);
      if (wi.z() <= 0) continue;
      push(bsdf.Eval(wo_l, wi).cwiseProduct(d.irradiance) * wi.z(), Eigen::Vector3d::Zero(), d.dir, INFINITY, d.sets);
    }
    for (const LightSource& l : scene_.lights()) {
      if (!st_.fixed_directions) break;
      if (l.light().type == LightType::kDistant) continue;  // directional VPLs
      LightSample ls;
      if (!l.Sample(v.p, 0.5, 0.5, &ls)) continue;  // an area light: its centre
      const Eigen::Vector3d wi = v.frame.ToLocal(ls.wi);
      if (wi.z() <= 0) continue;
      push(bsdf.Eval(wo_l, wi).cwiseProduct(ls.li) * wi.z(), Eigen::Vector3d::Zero(), ls.wi, ls.distance * (1 - 1e-6),
           l.is_virtual() ? kLightsMixed : kLightsBoth);
    }
    const bool cuts = !set_.trees().empty();
    if (point_vpls && cuts)
      Lightcut(v, bsdf, wo_l, origin, want_m, want_r && !x_virtual, direct, beta, measure_bias, x_virtual, rng, acc);
    for (const Vpl& p : set_.vpls()) {
      if (!point_vpls || cuts) break;
      if (!(p.sets & wanted)) continue;
      Unshadowed u;
      if (!Unshadow(p, origin, v.frame, bsdf, Caustic(x_virtual, p), wo_l, &u)) continue;
      const double g = 1 / std::max(u.d2, clamp2_);
      push(u.e * g, measure_bias ? Eigen::Vector3d(u.e * (1 / u.d2 - g)) : Eigen::Vector3d::Zero(), u.dir,
           u.dist * (1 - 1e-5), p.sets);
    }
    if (list.empty()) return;
    const double cut = st_.drop_threshold * total / static_cast<double>(list.size());
    for (const Contribution& c : list) {
      if (Luminance(c.value) < cut) {
        ++acc->c.dropped;
        continue;
      }
      const bool m = want_m && (c.sets & kLightsMixed), r = want_r && !x_virtual && (c.sets & kLightsReal);
      const auto [seen_m, seen_r] = Visible(origin, c.dir, c.tfar, m, r, acc);
      const Eigen::Vector3d value = beta.cwiseProduct(c.value), bias = beta.cwiseProduct(c.bias);
      if (seen_m) {
        acc->mixed += value;
        acc->bias_m += bias;
      }
      if (seen_r) {
        acc->real += value;
        acc->bias_r += bias;
      }
    }
  }

  // Whether the segment from `origin` along `dir` to tfar is clear in I_m
  // and in I_r (each asked only where wanted).  A shared contribution at a
  // real point is tested against the real scene first (st_r), then, if the
  // segment meets a virtual object's box, against the virtual objects (st_v).
  std::pair<bool, bool> Visible(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double tfar, bool m, bool r,
                                Accum* acc) const {
    Ray shadow = MakeRay(origin, dir, kMaskAll, tfar);
    if (m && r) {
      shadow.mask = kMaskReal;
      ++acc->c.shadow_rays;
      if (scene_.embree().Occluded(shadow)) return {false, false};
      if (scene_.has_virtual_geometry()) {
        if (SegmentMeetsBoxes(origin, dir, std::min(tfar, 1e30), scene_.virtual_bounds())) {
          shadow.mask = kMaskVirtual;
          ++acc->c.shadow_rays;
          if (scene_.embree().Occluded(shadow)) return {false, true};
        } else {
          ++acc->c.virtual_tests_skipped;
        }
      }
      return {true, true};
    }
    if (m) {
      shadow.mask = kMaskAll;
      ++acc->c.shadow_rays;
      return {!scene_.embree().Occluded(shadow), false};
    }
    if (r) {
      shadow.mask = kMaskReal;
      ++acc->c.shadow_rays;
      return {false, !scene_.embree().Occluded(shadow)};
    }
    return {false, false};
  }

  // A VPL's unclamped, unshadowed light at the point (origin, frame, BSDF
  // `bsdf` seen from wo_l) before the 1/d^2 term: e = flux fy fx cos_x
  // cos_y; false where it is zero (behind either surface).
  struct Unshadowed {
    Eigen::Vector3d e, dir;  // dir: unit, from the point to the VPL
    double d2 = 0, dist = 0;
  };
  // Whether VPL p, seen from a point (x_virtual: of a virtual object), is
  // taken through its diffuse lobe alone: light that reached a real
  // surface straight from an emitter and reaches a virtual point by that
  // surface's glossy lobe is the caustic the photons carry (CausticMap).
  bool Caustic(bool x_virtual, const Vpl& p) const {
    return x_virtual && !set_.caustics().empty() && p.depth == 0 && !p.on_virtual;
  }
  static bool Unshadow(const Vpl& p, const Eigen::Vector3d& origin, const ShadingFrame& frame, const Bsdf& bsdf,
                       bool diffuse_only, const Eigen::Vector3d& wo_l, Unshadowed* u) {
    Eigen::Vector3d d = p.p - origin;
    const double d2 = d.squaredNorm();
    if (!(d2 > 0)) return false;
    const double dist = std::sqrt(d2);
    d /= dist;
    const double cos_x = d.dot(frame.n), cos_y = -d.dot(p.frame.n);
    if (cos_x <= 0 || cos_y <= 0) return false;
    const Eigen::Vector3d fx = bsdf.Eval(wo_l, frame.ToLocal(d));
    if (fx.maxCoeff() <= 0) return false;
    const Bsdf& fy = diffuse_only ? p.diffuse : p.bsdf;
    u->e = p.flux.cwiseProduct(fy.Eval(p.wi_local, p.frame.ToLocal(-d))).cwiseProduct(fx) * (cos_x * cos_y);
    u->dir = d;
    u->d2 = d2;
    u->dist = dist;
    return true;
  }

  // One VPL's light at the point (origin, frame n, BSDF `bsdf` seen from
  // wo_l), shadowed, for I_m and I_r; with the clamp's bias where asked.
  struct VplLight {
    Eigen::Vector3d m = Eigen::Vector3d::Zero(), r = Eigen::Vector3d::Zero();
    Eigen::Vector3d bias_m = Eigen::Vector3d::Zero(), bias_r = Eigen::Vector3d::Zero();
  };
  VplLight OneVpl(const Vpl& p, const Eigen::Vector3d& origin, const ShadingFrame& frame, const Bsdf& bsdf,
                  bool at_virtual, const Eigen::Vector3d& wo_l, bool m, bool r, bool measure_bias, Accum* acc) const {
    VplLight out;
    m = m && (p.sets & kLightsMixed);
    r = r && (p.sets & kLightsReal);
    if (!m && !r) return out;
    Unshadowed u;
    if (!Unshadow(p, origin, frame, bsdf, Caustic(at_virtual, p), wo_l, &u) || !(u.e.maxCoeff() > 0)) return out;
    const Eigen::Vector3d& e = u.e;
    const double d2 = u.d2, g = 1 / std::max(d2, clamp2_);
    const auto [seen_m, seen_r] = Visible(origin, u.dir, u.dist * (1 - 1e-5), m, r, acc);
    const Eigen::Vector3d bias = measure_bias ? Eigen::Vector3d(e * (1 / d2 - g)) : Eigen::Vector3d::Zero();
    if (seen_m) {
      out.m = e * g;
      out.bias_m = bias;
    }
    if (seen_r) {
      out.r = e * g;
      out.bias_r = bias;
    }
    return out;
  }

  // The VPLs' light at v through the light trees (lightcuts, Walter et al.
  // 2005): the cut starts at each tree's root, each cluster estimated by its
  // representative's shadowed light times the cluster's weight over the
  // representative's (unbiased over the representative's draw), and the
  // cluster with the largest error bound is split while that bound exceeds
  // cut_error of the point's estimated light (`direct`: the light already
  // gathered there, the VPLs' estimate added) and the cut holds fewer than
  // max_cut clusters.  A child keeps its parent's representative's value
  // when it has the same one (one shadow test fewer).
  void Lightcut(const PathVertex& v, const Bsdf& bsdf, const Eigen::Vector3d& wo_l, const Eigen::Vector3d& origin,
                bool m, bool r, double direct, const Eigen::Vector3d& beta, bool measure_bias, bool at_virtual,
                Sampler& rng, Accum* acc) const {
    struct Cluster {
      int tree, node, leaf;  // leaf: the node of its representative
      double scale;
      VplLight rep;
    };
    struct Entry {  // the heap's: by error bound
      double err;
      int slot;
      bool operator<(const Entry& o) const { return err < o.err || (err == o.err && slot < o.slot); }
    };
    thread_local std::vector<Cluster> clusters;
    thread_local std::vector<Entry> heap;
    clusters.clear();
    heap.clear();
    const Eigen::Vector3d dx = bsdf.DiffuseBound(), gx = bsdf.GlossyBound(wo_l);
    const uint8_t wanted = static_cast<uint8_t>((m ? kLightsMixed : 0) | (r ? kLightsReal : 0));
    Eigen::Vector3d total_m = Eigen::Vector3d::Zero(), total_r = Eigen::Vector3d::Zero();
    // Each cluster's representative is drawn afresh here, in proportion to
    // the VPLs' weights (VplTree::SampleLeaf), from a stream of its own that
    // takes one number of the path's: a coarse cut's error is then noise
    // that falls with the samples, not one draw shared by every point of
    // the frame (Walter et al. fix one representative per node).  A child
    // that holds its parent's representative keeps it, and its value.
    Sampler pick = Sampler::Random(std::bit_cast<uint64_t>(rng.NextDouble()), 0x6c63);
    auto add = [&](int ti, int node, const Cluster* parent) {
      const VplTree& t = set_.trees()[static_cast<size_t>(ti)];
      const VplCluster& c = t.node(node);
      double err = 0;
      if (!c.leaf()) {
        const Eigen::Vector3d bound = t.Bound(node, v.p, v.frame.t, v.frame.b, v.frame.n, dx, gx, clamp2_);
        if (!(bound.maxCoeff() > 0)) return;  // no light of the cluster reaches v
        err = Luminance(bound);
      }
      const int leaf = parent ? parent->leaf : t.SampleLeaf(node, pick.NextDouble());
      const int vpl = t.node(leaf).rep;
      Cluster k{ti, node, leaf, c.weight / t.weight(vpl), {}};
      k.rep = parent ? parent->rep
                     : OneVpl(set_.vpls()[static_cast<size_t>(vpl)], origin, v.frame, bsdf, at_virtual, wo_l, m, r,
                              measure_bias, acc);
      total_m += k.rep.m * k.scale;
      total_r += k.rep.r * k.scale;
      clusters.push_back(k);
      if (err > 0) {
        heap.push_back({err, static_cast<int>(clusters.size()) - 1});
        std::push_heap(heap.begin(), heap.end());
      }
    };
    auto credit = [&](const VplLight& l, double scale) {  // a cluster's estimate, added
      acc->mixed += beta.cwiseProduct(l.m) * scale;
      acc->real += beta.cwiseProduct(l.r) * scale;
      acc->bias_m += beta.cwiseProduct(l.bias_m) * scale;
      acc->bias_r += beta.cwiseProduct(l.bias_r) * scale;
    };
    ++acc->c.cut_points;
    // At a camera point (measure_bias: depth 0), the pixel's earlier cut on
    // the same surface facing the same way (within about 25 degrees).
    CutCache::Cut* reuse = nullptr;
    if (cuts_ && measure_bias && st_.reuse_cuts)
      for (CutCache::Cut& k : cuts_->cuts)
        if (k.geometry == v.geometry_id && k.wanted == wanted && k.n.dot(v.frame.n) > 0.9) reuse = &k;
    if (reuse) {
      ++acc->c.cuts_reused;
      for (const VplTree& t : set_.trees())
        if (t.sets() & wanted) acc->c.cut_vpls += static_cast<int64_t>((t.size() + 1) / 2);
      acc->c.cut_clusters += static_cast<int64_t>(reuse->nodes.size());
      for (size_t j = 0; j < reuse->nodes.size(); ++j) {
        const auto [ti, node] = reuse->nodes[j];
        // A cluster that carried little of the first sample's light is
        // tested with probability q and weighted 1/q (unbiased).
        const double q = std::clamp(reuse->share[j] / kRouletteShare, kRouletteFloor, 1.0);
        if (q < 1 && rng.NextDouble() >= q) continue;
        const VplTree& t = set_.trees()[static_cast<size_t>(ti)];
        const int vpl = t.node(t.SampleLeaf(node, pick.NextDouble())).rep;
        const double scale = t.node(node).weight / t.weight(vpl) / q;
        credit(OneVpl(set_.vpls()[static_cast<size_t>(vpl)], origin, v.frame, bsdf, at_virtual, wo_l, m, r,
                      measure_bias, acc),
               scale);
      }
      return;
    }
    for (size_t ti = 0; ti < set_.trees().size(); ++ti) {
      const VplTree& t = set_.trees()[ti];
      if (!(t.sets() & wanted)) continue;
      acc->c.cut_vpls += static_cast<int64_t>((t.size() + 1) / 2);
      add(static_cast<int>(ti), t.root(), nullptr);
    }
    // Clusters split are zeroed in place (scale 0): the cut is what remains.
    const auto max_cut = static_cast<size_t>(std::max(1, st_.max_cut));
    size_t cut_size = clusters.size();
    while (!heap.empty() && cut_size < max_cut &&
           heap.front().err > st_.cut_error * (direct + std::max(Luminance(total_m), Luminance(total_r)))) {
      std::pop_heap(heap.begin(), heap.end());
      const int slot = heap.back().slot;
      heap.pop_back();
      const Cluster k = clusters[static_cast<size_t>(slot)];
      clusters[static_cast<size_t>(slot)].scale = 0;
      total_m -= k.rep.m * k.scale;
      total_r -= k.rep.r * k.scale;
      const VplTree& t = set_.trees()[static_cast<size_t>(k.tree)];
      const VplCluster& c = t.node(k.node);
      const size_t before = clusters.size();
      const bool first = k.leaf < c.child[1];  // preorder: the representative is under child[0]
      add(k.tree, c.child[0], first ? &k : nullptr);
      add(k.tree, c.child[1], first ? nullptr : &k);
      cut_size += clusters.size() - before;
      --cut_size;
    }
    acc->c.cut_clusters += static_cast<int64_t>(cut_size);
    CutCache::Cut* keep = nullptr;
    if (cuts_ && measure_bias && st_.reuse_cuts && cuts_->cuts.size() < 4) {
      keep = &cuts_->cuts.emplace_back();
      keep->geometry = v.geometry_id;
      keep->wanted = wanted;
      keep->n = v.frame.n;
    }
    for (const Cluster& k : clusters) {
      if (k.scale == 0) continue;
      if (keep) {
        keep->nodes.emplace_back(k.tree, k.node);
        const double total = std::max(Luminance(total_m), Luminance(total_r));
        keep->share.push_back(total > 0 ? std::max(Luminance(k.rep.m), Luminance(k.rep.r)) * k.scale / total : 0.0);
      }
      credit(k.rep, k.scale);
    }
  }

  const RenderScene& scene_;
  const VplSet& set_;
  const VplSettings& st_;
  const DifferentialPathTracer* plate_;
  CutCache* cuts_;
  double clamp2_ = 0;
};

PathTracerSettings PlateTracerSettings(const VplSettings& s, const PlateViews& plates) {
  PathTracerSettings p;
  p.mis_area_lights = false;  // its own vertices sample area lights by next-event estimation alone
  p.max_depth = s.max_depth;  // the difference path on from a plate's point (PlateAtRealPoint)
  p.plate_reflections = s.plate_reflections;
  p.plates = plates;
  return p;
}

}  // namespace

VplFrameRenderer::VplFrameRenderer(const RenderScene& scene, std::shared_ptr<const VplSet> vpls,
                                   const CameraModel& camera, const Rigid3& world_from_cam, uint64_t seed, int frame,
                                   const CameraExposure& exposure, const PlateViews& plates)
    : PixelLoopMethod(camera, world_from_cam, seed, frame, exposure),
      scene_(scene),
      set_(std::move(vpls)),
      plate_tracer_(scene, PlateTracerSettings(set_->settings(), plates)) {
  const size_t n = static_cast<size_t>(width()) * height();
  for (auto* v : {&bias_m_, &bias_r_, &lum_m_, &lum_r_}) v->assign(n, 0);
}

void VplFrameRenderer::RenderPass(int spp) {
  ++pass_;
  rows_.assign(static_cast<size_t>(height()), Counters());
  ShadePixels(spp);
  for (const Counters& c : rows_) counters_ += c;
}

void VplFrameRenderer::Shade(const Ray& ray, Sampler& rng, int64_t row, size_t i, int, PathSample* out) {
  Counters& rc = rows_[static_cast<size_t>(row)];
  Accum acc;
  thread_local CutCache cuts;
  cuts.Begin(this, pass_, i);
  VplShader(scene_, *set_, &plate_tracer_, &cuts).ShadeRay(ray, true, true, 0, 0, Eigen::Vector3d::Ones(), rng, &acc);
  Counters c = acc.c;
  c.rays += acc.c.shadow_rays + acc.c.compensation_rays + acc.c.gather_rays;  // every ray the sample traced
  rc += c;
  out->mixed = acc.mixed;
  out->real = acc.real;
  out->primary_virtual = acc.primary_virtual;
  if (!acc.mixed.allFinite() || !acc.real.allFinite()) return;  // dropped by the loop
  bias_m_[i] += Luminance(acc.bias_m);
  bias_r_[i] += Luminance(acc.bias_r);
  lum_m_[i] += Luminance(acc.mixed);
  lum_r_[i] += Luminance(acc.real);
}

namespace {
double Ratio(const std::vector<double>& a, const std::vector<double>& b) {
  double sa = 0, sb = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    sa += a[i];
    sb += b[i];
  }
  return sb > 0 ? sa / sb : 0;
}
}  // namespace

// With compensation on, the clamped energy is added back: what is reported
// is then the energy the clamp removed before compensation.
double VplFrameRenderer::clamp_bias_mixed() const { return Ratio(bias_m_, lum_m_); }
double VplFrameRenderer::clamp_bias_real() const { return Ratio(bias_r_, lum_r_); }

void VplFrameRenderer::Describe(Report* report, int frame) const {
  const std::string k = fmt::format("vpl.frames.{}.", frame);
  report->SetMetric(k + "clamp_bias_mixed", clamp_bias_mixed());
  report->SetMetric(k + "clamp_bias_real", clamp_bias_real());
  report->SetMetric(k + "rays", counters_.rays);
  report->SetMetric(k + "shadow_rays", counters_.shadow_rays);
  report->SetMetric(k + "dropped_vpl_tests", counters_.dropped);
  report->SetMetric(k + "virtual_tests_skipped", counters_.virtual_tests_skipped);
  report->SetMetric(k + "compensation_rays", counters_.compensation_rays);
  report->SetMetric(k + "gather_rays", counters_.gather_rays);
  if (counters_.cut_points > 0) {
    report->SetMetric(k + "cut_points", counters_.cut_points);
    report->SetMetric(k + "mean_cut", static_cast<double>(counters_.cut_clusters) / counters_.cut_points);
    report->SetMetric(k + "mean_vpls_per_cut", static_cast<double>(counters_.cut_vpls) / counters_.cut_points);
    report->SetMetric(k + "cuts_reused", counters_.cuts_reused);
    report->Skip(fmt::format("frame {}: {} of {} VPL shadow tests", frame, counters_.cut_vpls - counters_.cut_clusters,
                             counters_.cut_vpls),
                 fmt::format("lightcuts: each cluster of a cut is tested through one representative, the cut refined "
                             "until no cluster's error bound exceeds {} of the point's light (vpl.cut_error; 0 tests "
                             "every VPL)",
                             set_->settings().cut_error));
  }
  if (counters_.dropped > 0)
    report->Skip(fmt::format("frame {}: {} VPL shadow tests", frame, counters_.dropped),
                 fmt::format("their unshadowed contribution was below {} of the mean one at the point (bias at most "
                             "that fraction of the point's unshadowed light)",
                             set_->settings().drop_threshold));
  if (counters_.virtual_tests_skipped > 0)
    report->Skip(fmt::format("frame {}: {} virtual blocker tests", frame, counters_.virtual_tests_skipped),
                 "the shadow segment misses every virtual object's bounding box: st_v = 1 exactly");
}

namespace {

VplSettings ParseVplSettings(JsonSettings& s, const Scene& scene) {
  VplSettings o;
  s.Integer("paths", &o.paths, 0, 1 << 26);
  s.Integer("directions", &o.directions, 1, 1 << 20);
  s.Bool("fixed_directions", &o.fixed_directions);
  s.Integer("glossy_depth", &o.glossy_depth, 0, 64);
  s.Number("clamp_distance", &o.clamp_distance, 0, 1e9);
  s.Number("drop_threshold", &o.drop_threshold, 0, 1);
  s.Bool("compensate", &o.compensate);
  s.Bool("plate_reflections", &o.plate_reflections);
  s.Bool("final_gather", &o.final_gather);
  s.Integer("gather_rays", &o.gather_rays, 1, 1024);
  s.Integer("caustic_photons", &o.caustic_photons, 0, 1 << 26);
  s.Number("cut_error", &o.cut_error, 0, 1);
  s.Integer("max_cut", &o.max_cut, 1, 1 << 24);
  s.Integer("cut_min_vpls", &o.cut_min_vpls, 0, 1 << 30);
  s.Bool("reuse_cuts", &o.reuse_cuts);
  s.Integer("direct_samples", &o.direct_samples, 1, 256);
  s.Integer("object_direct_samples", &o.object_direct_samples, 1, 256);
  s.Integer("shadow_samples", &o.shadow_samples, 1, 256);
  return WithSceneRender(o, scene);
}

class VplMethod : public SettingsMethod<VplSettings> {
 public:
  using SettingsMethod::SettingsMethod;
  void Prepare(const JobContext& job) override {
    vpls_ = VplSet::Build(job.rs, st_);
    vpls_->Describe(job.report);
    if (AnyEmissive(job.scene))
      job.report->Warn(
          "vpl: emissive surfaces are seen but light nothing (VPLs leave the environment and lights.json's lights "
          "only)");
  }
  std::vector<std::string> WorldChanged(const JobContext& job, const WorldChange&) override {
    const std::shared_ptr<const VplSet> old = vpls_;
    Prepare(job);
    if (!old) return {"VPL set"};
    // How many VPLs are where they were: their paths did not change.
    auto key = [](const Eigen::Vector3d& p) {
      return HashCombine(HashCombine(std::bit_cast<uint64_t>(p.x()), std::bit_cast<uint64_t>(p.y())),
                         std::bit_cast<uint64_t>(p.z()));
    };
    std::unordered_set<uint64_t> before;
    for (const Vpl& v : old->vpls()) before.insert(key(v.p));
    int64_t kept = 0;
    for (const Vpl& v : vpls_->vpls()) kept += before.count(key(v.p)) > 0;
    job.report->SetMetric(fmt::format("vpl.frames.{}.vpls_in_place", job.frame), kept);
    return {fmt::format("VPL set re-traced: {} of {} VPLs where they were (same paths)", kept, vpls_->vpls().size())};
  }
  std::unique_ptr<FrameMethod> NewFrame(const FrameContext& f) override {
    return std::make_unique<VplFrameRenderer>(f.rs, vpls_, f.camera, f.world_from_cam, f.seed, f.frame, f.exposure,
                                              f.plates);
  }
  void FrameDone(const FrameMethod& fm, const FrameContext& f, Report* report, Json* fj) override {
    const auto& v = static_cast<const VplFrameRenderer&>(fm);
    v.Describe(report, f.frame);
    (*fj)["clamp_bias_mixed"] = v.clamp_bias_mixed();
    (*fj)["clamp_bias_real"] = v.clamp_bias_real();
    if (Json c = PlateCountersJson(v.plate_counters()); !c.is_null()) (*fj)["plate_reflections"] = std::move(c);
  }
  bool TakesPlateReflections() const override { return st_.plate_reflections; }

 private:
  std::shared_ptr<const VplSet> vpls_;
};

}  // namespace

std::unique_ptr<RenderMethod> MakeVplMethod(JsonSettings& block, const Scene& scene) {
  return std::make_unique<VplMethod>(ParseVplSettings(block, scene));
}

}  // namespace mr
