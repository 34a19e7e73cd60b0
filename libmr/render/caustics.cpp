#include "render/caustics.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/hash.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "core/spherical.h"
#include "light/light_source.h"
#include "render/path_common.h"
#include "render/render_scene.h"

namespace mr {

namespace {

// One emitter's photons: where each starts and what it carries.
struct Source {
  int light = -1;    // index into scene.lights(); -1: the environment
  double power = 0;  // luminance flux towards the target sphere, roughly
  int64_t first = 0, count = 0;
  uint64_t stream = 0;
};

// A uniform direction in the cone from `from` that the sphere (c, r)
// subtends (the whole sphere of directions from inside it), its pdf.
Eigen::Vector3d TowardsSphere(const Eigen::Vector3d& from, const Eigen::Vector3d& c, double r, double u0, double u1,
                              double* pdf) {
  const Eigen::Vector3d to = c - from;
  const double d = to.norm();
  if (!(d > r)) {
    const auto s = SampleUniformSphere(u0, u1);
    *pdf = kUniformSpherePdf;
    return {s[0], s[1], s[2]};
  }
  const double cos_max = SafeSqrt(1 - (r / d) * (r / d));
  const double cz = 1 - u0 * (1 - cos_max), sz = SafeSqrt(1 - cz * cz), phi = kTwoPi * u1;
  const Eigen::Vector3d axis = to / d;
  Eigen::Vector3d t, b;
  CoordinateSystem(axis, &t, &b);
  *pdf = 1 / (kTwoPi * (1 - cos_max));
  return (cz * axis + sz * (std::cos(phi) * t + std::sin(phi) * b)).normalized();
}

double SolidAngleOf(const Eigen::Vector3d& from, const Eigen::Vector3d& c, double r) {
  const double d = (c - from).norm();
  return d > r ? kTwoPi * (1 - SafeSqrt(1 - (r / d) * (r / d))) : 4 * kPi;
}

// The emitters with their share of the photons: half in proportion to the
// flux they send towards the target sphere, half evenly (as vpl's paths).
std::vector<Source> Sources(const RenderScene& scene, int photons, const Eigen::Vector3d& c, double r) {
  std::vector<Source> out;
  const double disc = kPi * r * r;
  if (!scene.environment().empty() && scene.environment().LuminanceIntegral() > 0)
    out.push_back({-1, scene.environment().LuminanceIntegral() * disc, 0, 0, 0x656e76ULL});
  for (size_t i = 0; i < scene.lights().size(); ++i) {
    const Light& l = scene.lights()[i].light();
    double p = 0;
    switch (l.type) {
      case LightType::kPoint:
      case LightType::kSpot:
        p = Luminance(l.intensity) * SolidAngleOf(l.position, c, r);
        break;
      case LightType::kDistant:
        p = Luminance(l.irradiance) * disc;
        break;
      case LightType::kArea:
        p = Luminance(l.radiance) * l.Area() * SolidAngleOf(l.position, c, r);
        break;
    }
    if (p > 0) out.push_back({static_cast<int>(i), p, 0, 0, HashString(l.name)});
  }
  double total = 0;
  for (const Source& s : out) total += s.power;
  int64_t first = 0;
  for (Source& s : out) {
    const double share = 0.5 * s.power / total + 0.5 / static_cast<double>(out.size());
    s.first = first;
    s.count = std::max<int64_t>(1, std::llround(share * photons));
    first += s.count;
  }
  return out;
}

}  // namespace

int64_t CausticMap::Key(int64_t x, int64_t y, int64_t z) const {
  return static_cast<int64_t>(
      HashCombine(HashCombine(static_cast<uint64_t>(x), static_cast<uint64_t>(y)), static_cast<uint64_t>(z)));
}

CausticMap CausticMap::Build(const RenderScene& scene, const CausticSettings& st, const Eigen::Vector3d& centre,
                             double radius) {
  CausticMap map;
  if (st.photons <= 0) {
    map.skipped_ = "vpl.caustic_photons is 0";
    return map;
  }
  if (!(radius > 0)) {
    map.skipped_ = "the scene has no virtual object to receive them";
    return map;
  }
  if (!scene.has_glossy_real()) {
    map.skipped_ = "no real surface is glossy: none can reflect light into the objects";
    return map;
  }
  const double reach = radius * std::max(1.0, st.reach);
  const std::vector<Source> sources = Sources(scene, st.photons, centre, reach);
  if (sources.empty()) return map;
  const int64_t n = sources.back().first + sources.back().count;
  std::vector<std::vector<Photon>> stored(static_cast<size_t>(n));
  std::vector<char> reflected(static_cast<size_t>(n), 0);
  const Eigen::AlignedBox3d bounds = scene.bounds().cast<double>();
  const double far = (bounds.isEmpty() ? 1.0 : bounds.diagonal().norm()) + (centre - bounds.center()).norm() + reach;
  ParallelFor(0, n, [&](int64_t j) {
    size_t si = 0;
    while (j >= sources[si].first + sources[si].count) ++si;
    const Source& src = sources[si];
    Sampler rng =
        Sampler::Random(HashCombine(HashCombine(st.seed, 0x636175), src.stream), static_cast<uint64_t>(j - src.first));
    const double u0 = rng.NextDouble(), u1 = rng.NextDouble(), u2 = rng.NextDouble(), u3 = rng.NextDouble();
    const double count = static_cast<double>(src.count);
    Eigen::Vector3d origin, dir, flux;
    // Parallel light through the target sphere's disc, from `towards`.
    auto from_disc = [&](const Eigen::Vector3d& towards, const Eigen::Vector3d& irradiance) {
      Eigen::Vector3d t, b;
      CoordinateSystem(towards, &t, &b);
      const double rr = reach * std::sqrt(u2), phi = kTwoPi * u3;
      origin = centre + far * towards + rr * (std::cos(phi) * t + std::sin(phi) * b);
      dir = -towards;
      flux = irradiance * (kPi * reach * reach / count);
    };
    if (src.light < 0) {
      double pdf = 0;
      Eigen::Vector3d w;
      const Eigen::Vector3d L = scene.environment().Sample(u0, u1, &w, &pdf);
      if (!(pdf > 0)) return;
      from_disc(w, L / pdf);
    } else {
      const LightSource& ls = scene.lights()[static_cast<size_t>(src.light)];
      const Light& l = ls.light();
      LightSample s;
      if (l.type == LightType::kDistant) {
        if (!ls.Sample(centre, u0, u1, &s)) return;
        from_disc(s.wi, s.li / s.pdf);
      } else {
        double pdf_point = 1;  // area lights: a uniform point of the light
        origin = l.position;
        if (l.type == LightType::kArea) {
          if (!ls.Sample(l.position + l.direction, u0, u1, &s)) return;
          origin = l.position + l.direction + s.distance * s.wi;
          pdf_point = 1 / l.Area();
        }
        double pdf = 0;
        dir = TowardsSphere(origin, centre, reach, u2, u3, &pdf);
        if (l.type == LightType::kArea) {
          const double cos_l = dir.dot(l.direction);
          if (!(cos_l > 0)) return;
          flux = l.radiance * (cos_l / (pdf * pdf_point * count));
        } else {
          if (!ls.Sample(origin + dir, 0, 0, &s)) return;  // the intensity towards dir (spot falloff)
          flux = s.li / (pdf * count);
        }
      }
    }
    if (!(flux.maxCoeff() > 0) || !flux.allFinite()) return;
    // The first surface: real and glossy, its glossy lobe reflecting the
    // photon on; the object it then meets stores it.
    Ray ray = MakeRay(origin, dir, kMaskAll);
    Hit hit;
    if (!scene.embree().Intersect(ray, &hit) || hit.is_virtual) return;
    const PathVertex v = MakeVertex(scene, ray, hit);
    if (!v.material || !v.material->IsGlossy()) return;
    const Bsdf glossy = GlossyLobe(scene, v);
    BsdfSample bs;
    const double ul = rng.NextDouble();
    const auto [a, b] = rng.Next2D();
    if (!glossy.Sample(v.frame.ToLocal(v.wo_world), ul, a, b, &bs) || !(bs.pdf > 0)) return;
    const Eigen::Vector3d wi = v.frame.ToWorld(bs.wi);
    flux = flux.cwiseProduct(bs.f) * (std::abs(bs.wi.z()) / bs.pdf);
    if (!(flux.maxCoeff() > 0) || !flux.allFinite()) return;
    reflected[static_cast<size_t>(j)] = 1;
    Ray out = MakeRay(v.OriginFor(wi), wi, kMaskAll);
    Hit h2;
    if (!scene.embree().Intersect(out, &h2) || !h2.is_virtual) return;
    const PathVertex y = MakeVertex(scene, out, h2);
    stored[static_cast<size_t>(j)].push_back({y.p, -wi, y.frame.n, flux});
  });
  map.sent_ = n;
  map.reflected_ = std::accumulate(reflected.begin(), reflected.end(), int64_t{0});
  std::vector<Photon> all;
  for (auto& s : stored) all.insert(all.end(), s.begin(), s.end());
  if (all.empty()) return map;
  // The gather radius: `neighbours` photons in it, were they spread over
  // the bounding sphere's surface.
  const double area = 4 * kPi * radius * radius;
  map.radius_ =
      std::clamp(std::sqrt(st.neighbours * area / (kPi * static_cast<double>(all.size()))), radius / 50, radius / 3);
  map.cell_ = map.radius_;
  // Sorted by cell (then by their order, so the sums are the same every run).
  std::vector<std::pair<int64_t, uint32_t>> keyed(all.size());
  for (size_t i = 0; i < all.size(); ++i) {
    const Eigen::Vector3d g = (all[i].p / map.cell_).array().floor();
    keyed[i] = {map.Key(static_cast<int64_t>(g.x()), static_cast<int64_t>(g.y()), static_cast<int64_t>(g.z())),
                static_cast<uint32_t>(i)};
  }
  std::sort(keyed.begin(), keyed.end());
  for (size_t i = 0; i < keyed.size(); ++i) {
    if (i == 0 || keyed[i].first != keyed[i - 1].first) {
      map.cell_keys_.push_back(keyed[i].first);
      map.cell_begin_.push_back(static_cast<uint32_t>(i));
    }
    map.photons_.push_back(all[keyed[i].second]);
  }
  map.cell_begin_.push_back(static_cast<uint32_t>(keyed.size()));
  return map;
}

Eigen::Vector3d CausticMap::Radiance(const Eigen::Vector3d& p, const ShadingFrame& frame, const Bsdf& bsdf,
                                     const Eigen::Vector3d& wo_l) const {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  if (photons_.empty()) return sum;
  const Eigen::Vector3d g = (p / cell_).array().floor();
  const double r2 = radius_ * radius_;
  // Cone filter: weight (1 - d / r), normalised over the disc by 3 / (pi r^2).
  const double norm = 3 / (kPi * r2);
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int64_t key =
            Key(static_cast<int64_t>(g.x()) + dx, static_cast<int64_t>(g.y()) + dy, static_cast<int64_t>(g.z()) + dz);
        const auto it = std::lower_bound(cell_keys_.begin(), cell_keys_.end(), key);
        if (it == cell_keys_.end() || *it != key) continue;
        const size_t c = static_cast<size_t>(it - cell_keys_.begin());
        for (uint32_t i = cell_begin_[c]; i < cell_begin_[c + 1]; ++i) {
          const Photon& ph = photons_[i];
          const double d2 = (ph.p - p).squaredNorm();
          if (d2 >= r2 || ph.n.dot(frame.n) < 0.5) continue;  // another side or a sharp fold
          const Eigen::Vector3d wi_l = frame.ToLocal(ph.wi);
          if (!(wi_l.z() > 0)) continue;
          sum += bsdf.Eval(wo_l, wi_l).cwiseProduct(ph.flux) * ((1 - std::sqrt(d2) / radius_) * norm);
        }
      }
  return sum;
}

void CausticMap::Describe(Report* report) const {
  report->SetMetric("vpl.caustics.photons_sent", sent_);
  report->SetMetric("vpl.caustics.photons_reflected", reflected_);
  report->SetMetric("vpl.caustics.photons_stored", static_cast<int64_t>(photons_.size()));
  report->SetMetric("vpl.caustics.radius_m", radius_);
  if (!skipped_.empty()) report->Skip("caustic photons", skipped_);
}

}  // namespace mr
