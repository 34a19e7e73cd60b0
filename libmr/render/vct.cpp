#include "render/vct.h"

#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <cmath>

#include "core/parallel.h"
#include "render/path_common.h"
#include "render/vpl.h"
#include "render/world.h"

namespace mr {

namespace {

using Voxel = VctVolumes::Voxel;

// Sign of a two-sided normal made canonical (largest component positive),
// so that the normals of one plane average to a unit vector.
Eigen::Vector3d Canonical(const Eigen::Vector3d& n) {
  int k = 0;
  n.cwiseAbs().maxCoeff(&k);
  return n[k] < 0 ? Eigen::Vector3d(-n) : n;
}

void AddScaled(Voxel* acc, const Voxel& v, float w) {
  acc->occ_r += w * v.occ_r;
  acc->occ_v += w * v.occ_v;
  acc->n_r += w * v.n_r;
  acc->n_v += w * v.n_v;
  acc->l_m += w * v.l_m;
  acc->l_r += w * v.l_r;
  acc->nl_m += w * v.nl_m;
  acc->nl_r += w * v.nl_r;
}

// How much of a voxel's light leaves towards a cone along d: max(0, -N.d)
// for a coherent lit-side normal N, 1/2 where they disagree.
double Emitting(const Eigen::Vector3f& nl, const Eigen::Vector3f& l, const Eigen::Vector3d& d) {
  const double lum = Luminance(l.x(), l.y(), l.z());
  if (!(lum > 0)) return 1;
  const Eigen::Vector3d n = nl.cast<double>() / lum;
  const double m = std::min(1.0, n.norm());
  return std::clamp(-n.dot(d) + 0.5 * (1 - m), 0.0, 1.0);
}

// How much of a voxel's occupancy faces a cone along d: |n.d| for a coherent
// mean normal, 1 where the normals disagree (|mean| -> 0).
double Facing(const Eigen::Vector3f& n_sum, float occ, const Eigen::Vector3d& d) {
  if (occ <= 0) return 1;
  const Eigen::Vector3d n = n_sum.cast<double>() / occ;
  const double m = std::min(1.0, n.norm());
  return std::clamp(std::abs(n.dot(d)) + 1 - m, 0.0, 1.0);
}

// Parameter interval [t0, t1] of o + t d inside `box`; false when it misses.
bool ClipToBox(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::AlignedBox3d& box, double* t0,
               double* t1) {
  double a = -INFINITY, b = INFINITY;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-300) {
      if (o[k] < box.min()[k] || o[k] > box.max()[k]) return false;
      continue;
    }
    double u = (box.min()[k] - o[k]) / d[k], v = (box.max()[k] - o[k]) / d[k];
    if (u > v) std::swap(u, v);
    a = std::max(a, u);
    b = std::min(b, v);
  }
  *t0 = a;
  *t1 = b;
  return a <= b;
}

// Far-field prefilter half-angles (radians); level 0 is the raw map.
const double kFarHalfAnglesDeg[] = {0, 2.5, 5, 10, 20, 40};

struct Deposit {
  size_t voxel;
  Eigen::Vector3d value;  // reflected power / pi
  Eigen::Vector3d n;      // the lit side's normal
  bool mixed, real;
};

}  // namespace

std::shared_ptr<const VctVolumes> VctVolumes::Build(const RenderScene& scene, const VctSettings& st,
                                                    const VctVolumes* previous, bool objects_moved) {
  const auto start = std::chrono::steady_clock::now();
  auto out = std::make_shared<VctVolumes>();
  out->settings_ = st;
  const EmbreeScene& embree = scene.embree();
  const Eigen::AlignedBox3d scene_box = scene.bounds().cast<double>();
  bool virtual_light = false;
  for (const LightSource& l : scene.lights()) virtual_light = virtual_light || l.is_virtual();

  // The volume: twice the virtual objects' box (the paper's), the scene's
  // box when a virtual light relights all of it or nothing is virtual.
  Eigen::AlignedBox3d box;
  if (virtual_light || !scene.has_virtual_geometry()) {
    box = scene_box;
    out->box_reason_ = virtual_light ? "the scene's bounds: a virtual light relights all of it"
                                     : "the scene's bounds: nothing virtual to centre on";
  } else {
    for (const auto& b : scene.virtual_bounds()) box.extend(b);
    const Eigen::Vector3d c = box.center(), h = box.diagonal();
    box = Eigen::AlignedBox3d(c - h, c + h);
    out->box_reason_ = "twice the virtual objects' bounding box";
  }
  if (box.isEmpty()) box = Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1));
  // The last frame's grid is kept while every virtual object is inside it
  // (and the reason for its bounds is the same): then the real surfaces'
  // voxelisation is still valid.
  bool keep_grid = false;
  if (previous && previous->settings_.resolution == st.resolution && previous->box_reason_ == out->box_reason_) {
    Eigen::AlignedBox3d objects;
    for (const auto& b : scene.virtual_bounds()) objects.extend(b);
    keep_grid = out->box_reason_ != "twice the virtual objects' bounding box" || objects.isEmpty() ||
                previous->box_.contains(objects);
  }
  const int res = std::max(2, st.resolution);
  const double voxel = keep_grid ? previous->levels_[0].size : std::max(box.diagonal().maxCoeff(), 1e-6) / res;
  Level l0;
  l0.size = voxel;
  int dims[3];
  for (int k = 0; k < 3; ++k)
    dims[k] =
        keep_grid ? previous->dims_[k] : std::max(1, static_cast<int>(std::ceil(box.diagonal()[k] / voxel - 1e-9)));
  l0.nx = dims[0];
  l0.ny = dims[1];
  l0.nz = dims[2];
  for (int k = 0; k < 3; ++k) out->dims_[k] = dims[k];
  if (keep_grid) {
    out->box_ = previous->box_;
  } else {
    const Eigen::Vector3d c = box.center(), half = 0.5 * voxel * Eigen::Vector3d(dims[0], dims[1], dims[2]);
    out->box_ = Eigen::AlignedBox3d(c - half, c + half);
  }
  const Eigen::AlignedBox3d& vbox = out->box_;
  const size_t nvox = static_cast<size_t>(l0.nx) * l0.ny * l0.nz;
  auto voxel_of = [&](const Eigen::Vector3d& p, size_t* index) {
    const Eigen::Vector3d u = (p - vbox.min()) / voxel;
    const int x = static_cast<int>(std::floor(u.x())), y = static_cast<int>(std::floor(u.y())),
              z = static_cast<int>(std::floor(u.z()));
    // A point on the box's far faces belongs to the last voxel.
    const int cx = std::min(x, l0.nx - 1), cy = std::min(y, l0.ny - 1), cz = std::min(z, l0.nz - 1);
    if (!u.allFinite() || cx < 0 || cy < 0 || cz < 0 || u.x() > l0.nx + 1e-6 || u.y() > l0.ny + 1e-6 ||
        u.z() > l0.nz + 1e-6)
      return false;
    *index = l0.Index(cx, cy, cz);
    return true;
  };

  // Voxelisation: rays along each axis on a grid of a quarter voxel; every
  // crossing adds its area, h^2 |n_k|, so that over the three axes a patch
  // of area A adds sum_k n_k^2 A = A (per axis weighted by n_k^2).
  std::vector<double>& area_r = out->area_r_;
  std::vector<double>& area_v = out->area_v_;
  std::vector<Eigen::Vector3d>& nsum_r = out->nsum_r_;
  std::vector<Eigen::Vector3d>& nsum_v = out->nsum_v_;
  uint32_t voxelise_mask = kMaskAll;
  std::vector<Eigen::Vector3d>& albedo_r = out->albedo_r_;
  std::vector<Eigen::Vector3d>& albedo_v = out->albedo_v_;
  if (keep_grid) {
    area_r = previous->area_r_;
    nsum_r = previous->nsum_r_;
    albedo_r = previous->albedo_r_;
    if (objects_moved) {
      area_v.assign(nvox, 0);
      nsum_v.assign(nvox, Eigen::Vector3d::Zero());
      albedo_v.assign(nvox, Eigen::Vector3d::Zero());
      voxelise_mask = kMaskVirtual;
      out->voxelised_ = "virtual surfaces only";
    } else {
      area_v = previous->area_v_;
      nsum_v = previous->nsum_v_;
      albedo_v = previous->albedo_v_;
      voxelise_mask = 0;
      out->voxelised_ = "kept";
    }
  } else {
    area_r.assign(nvox, 0);
    area_v.assign(nvox, 0);
    nsum_r.assign(nvox, Eigen::Vector3d::Zero());
    nsum_v.assign(nvox, Eigen::Vector3d::Zero());
    albedo_r.assign(nvox, Eigen::Vector3d::Zero());
    albedo_v.assign(nvox, Eigen::Vector3d::Zero());
  }
  if (voxelise_mask != 0) {
    constexpr int kSub = 4;
    const double h = voxel / kSub;
    for (int k = 0; k < 3; ++k) {
      const int a = (k + 1) % 3, b = (k + 2) % 3;
      const int na = dims[a] * kSub, nb = dims[b] * kSub;
      struct Crossing {
        size_t voxel;
        bool is_virtual;
        double area;
        Eigen::Vector3d n, albedo;
      };
      std::vector<std::vector<Crossing>> hits(static_cast<size_t>(na) * nb);
      ParallelFor(0, static_cast<int64_t>(hits.size()), [&](int64_t j) {
        Eigen::Vector3d o;
        o[a] = vbox.min()[a] + (static_cast<double>(j % na) + 0.5) * h;
        o[b] = vbox.min()[b] + (static_cast<double>(j / na) + 0.5) * h;
        o[k] = vbox.min()[k] - voxel;
        Eigen::Vector3d d = Eigen::Vector3d::Zero();
        d[k] = 1;
        Ray ray = MakeRay(o, d, voxelise_mask, vbox.diagonal()[k] + 2 * voxel);
        Hit hit;
        for (int guard = 0; guard < 4096 && embree.Intersect(ray, &hit); ++guard) {
          const Eigen::Vector3d p = o + static_cast<double>(hit.t) * d;
          const Eigen::Vector3d n = scene.WorldNormal(hit);
          size_t vi;
          if (voxel_of(p, &vi))
            hits[static_cast<size_t>(j)].push_back(
                {vi, hit.is_virtual, h * h * std::abs(n[k]), Canonical(n), scene.AlbedoAt(hit)});
          ray.tnear = std::nextafter(hit.t, INFINITY) + static_cast<float>(1e-4 * voxel);
          hit = Hit();
        }
      });
      for (const auto& list : hits)
        for (const Crossing& c : list) {
          const double w = c.area;  // the area-weighted mean normal
          if (c.is_virtual) {
            area_v[c.voxel] += c.area;
            nsum_v[c.voxel] += w * c.n;
            albedo_v[c.voxel] += w * c.albedo;
          } else {
            area_r[c.voxel] += c.area;
            nsum_r[c.voxel] += w * c.n;
            albedo_r[c.voxel] += w * c.albedo;
          }
        }
      out->voxelisation_rays_ += static_cast<int64_t>(hits.size());
    }
  }

  // Injection: light reflected once (diffusely) by the first surface each
  // ray meets, into the mixed and the real light volumes.
  std::vector<Eigen::Vector3d> phi_m(nvox, Eigen::Vector3d::Zero()), phi_r(nvox, Eigen::Vector3d::Zero());
  std::vector<Eigen::Vector3d> lit_m(nvox, Eigen::Vector3d::Zero()), lit_r(nvox, Eigen::Vector3d::Zero());
  const double spacing = std::max(1e-3, st.injection_spacing) * voxel;
  const double far = (scene_box.isEmpty() ? 0.0 : scene_box.diagonal().norm()) + vbox.diagonal().norm();
  const Eigen::Vector3d centre = vbox.center();
  auto flush = [&](const std::vector<std::vector<Deposit>>& deposits) {
    for (const auto& list : deposits)
      for (const Deposit& d : list) {
        const Eigen::Vector3d nl = Luminance(d.value) * d.n;
        if (d.mixed) phi_m[d.voxel] += d.value, lit_m[d.voxel] += nl;
        if (d.real) phi_r[d.voxel] += d.value, lit_r[d.voxel] += nl;
      }
  };
  // One injection ray: the mixed ray's first hit, and where that is virtual
  // the real ray's behind it.  `power(p, t)`: the power the ray carries to a
  // hit at p, distance t.
  auto inject = [&](const Ray& ray, bool to_mixed, bool to_real, const auto& power, std::vector<Deposit>* list) {
    Hit hit;
    if (!embree.Intersect(ray, &hit)) return;
    const Eigen::Vector3d o = ray.origin.cast<double>(), d = ray.direction.cast<double>();
    auto deposit = [&](const Hit& h, bool m, bool r) {
      const Eigen::Vector3d p = o + static_cast<double>(h.t) * d;
      size_t vi;
      if (!voxel_of(p, &vi)) return;
      const Eigen::Vector3d value = scene.AlbedoAt(h).cwiseProduct(power(p, h.t)) * kInvPi;
      Eigen::Vector3d n = scene.WorldNormal(h);
      if (n.dot(d) > 0) n = -n;
      if (value.allFinite() && value.maxCoeff() > 0) list->push_back({vi, value, n, m, r});
    };
    if (!hit.is_virtual) {
      deposit(hit, to_mixed, to_real);
      return;
    }
    if (to_mixed) deposit(hit, true, false);
    if (!to_real) return;
    Ray real = ray;
    real.mask = kMaskReal;
    Hit rh;
    if (embree.Intersect(real, &rh)) deposit(rh, false, true);
  };
  // Parallel light: a jittered grid of rays over the volume's shadow.
  const std::vector<DirectionalVpl> dirs = DirectionalLights(scene, st.directions, st.seed, centre);
  for (size_t di = 0; di < dirs.size(); ++di) {
    const DirectionalVpl& dl = dirs[di];
    Eigen::Vector3d t, b;
    CoordinateSystem(dl.dir, &t, &b);
    double u0 = INFINITY, u1 = -INFINITY, v0 = INFINITY, v1 = -INFINITY;
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d q = vbox.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)) - centre;
      u0 = std::min(u0, q.dot(t));
      u1 = std::max(u1, q.dot(t));
      v0 = std::min(v0, q.dot(b));
      v1 = std::max(v1, q.dot(b));
    }
    const int nu = std::max(1, static_cast<int>(std::ceil((u1 - u0) / spacing)));
    const int nv = std::max(1, static_cast<int>(std::ceil((v1 - v0) / spacing)));
    const double du = (u1 - u0) / nu, dv = (v1 - v0) / nv;
    const Eigen::Vector3d power = dl.irradiance * du * dv;
    const bool to_real = dl.sets & kLightsReal, to_mixed = dl.sets & kLightsMixed;
    std::vector<std::vector<Deposit>> deposits(static_cast<size_t>(nu) * nv);
    ParallelFor(0, static_cast<int64_t>(deposits.size()), [&](int64_t j) {
      Sampler rng = Sampler::Random(HashCombine(st.seed, 0x766374 + di), static_cast<uint64_t>(j));
      const double u = u0 + (static_cast<double>(j % nu) + rng.NextDouble()) * du;
      const double v = v0 + (static_cast<double>(j / nu) + rng.NextDouble()) * dv;
      const Ray ray = MakeRay(centre + u * t + v * b + far * dl.dir, -dl.dir, kMaskAll);
      inject(
          ray, to_mixed, to_real, [&](const Eigen::Vector3d&, float) { return power; },
          &deposits[static_cast<size_t>(j)]);
    });
    flush(deposits);
    out->injection_rays_ += static_cast<int64_t>(deposits.size());
  }
  // Point and spot lights: a stratified fan over the volume's bounding
  // sphere (the whole sphere when the light is inside it).
  const double radius = 0.5 * vbox.diagonal().norm();
  for (size_t li = 0; li < scene.lights().size(); ++li) {
    const LightSource& l = scene.lights()[li];
    if (l.light().type == LightType::kDistant) continue;
    const Eigen::Vector3d pos = l.light().position;
    const double dist = (centre - pos).norm();
    const bool inside = dist <= radius;
    const double cos_max = inside ? -1.0 : std::sqrt(std::max(0.0, 1 - (radius / dist) * (radius / dist)));
    const double omega = kTwoPi * (1 - cos_max);
    const double reach = inside ? radius : dist;
    int side = static_cast<int>(std::clamp(std::ceil(std::sqrt(omega * reach * reach) / spacing), 16.0, 2048.0));
    // Many lights (more than next-event estimation samples each of): a fan
    // in proportion to the light's share of their power, so that 10,000
    // tiles of a panel cost what the panel would.
    if (scene.picks_local_light())
      side = std::max(2, static_cast<int>(std::ceil(side * std::sqrt(scene.LightPickProbability(li)))));
    const double domega = omega / (static_cast<double>(side) * side);
    Eigen::Vector3d ft, fb;
    const Eigen::Vector3d axis =
        inside ? Eigen::Vector3d(Eigen::Vector3d::UnitY()) : Eigen::Vector3d((centre - pos) / dist);
    CoordinateSystem(axis, &ft, &fb);
    const bool to_real = !l.is_virtual();
    std::vector<std::vector<Deposit>> deposits(static_cast<size_t>(side) * side);
    ParallelFor(0, static_cast<int64_t>(deposits.size()), [&](int64_t j) {
      Sampler rng = Sampler::Random(HashCombine(st.seed, 0x766c74 + li), static_cast<uint64_t>(j));
      const double a = (static_cast<double>(j % side) + rng.NextDouble()) / side;
      const double c = (static_cast<double>(j / side) + rng.NextDouble()) / side;
      const double cos_t = 1 - a * (1 - cos_max), sin_t = SafeSqrt(1 - cos_t * cos_t), phi = kTwoPi * c;
      const Eigen::Vector3d d = cos_t * axis + sin_t * (std::cos(phi) * ft + std::sin(phi) * fb);
      // An area light: each ray's deposit from its own point of it (the
      // fan leaves its centre); point and spot lights ignore the two.
      const double lu = rng.NextDouble(), lv = rng.NextDouble();
      inject(
          MakeRay(pos, d, kMaskAll), true, to_real,
          [&](const Eigen::Vector3d& p, float t) -> Eigen::Vector3d {
            LightSample ls;
            if (!l.Sample(p, lu, lv, &ls) || !(ls.pdf > 0)) return Eigen::Vector3d::Zero();
            return ls.li / ls.pdf * (domega * static_cast<double>(t) * t);
          },
          &deposits[static_cast<size_t>(j)]);
    });
    flush(deposits);
    out->injection_rays_ += static_cast<int64_t>(deposits.size());
  }

  // Level 0: occupancy 1 where geometry is (the paper's), mean normal,
  // radiance = reflected power / (pi area) x occupancy.
  l0.v.assign(nvox, Voxel());
  for (size_t i = 0; i < nvox; ++i) {
    Voxel& v = l0.v[i];
    double ar = area_r[i], av = area_v[i];
    // Light on a surface the axis rays missed: a voxel's worth of area.
    if (ar <= 0 && phi_r[i].maxCoeff() > 0) ar = voxel * voxel;
    if (av <= 0 && ar <= 0 && phi_m[i].maxCoeff() > 0) av = voxel * voxel;
    if (ar > 0) {
      v.occ_r = 1;
      v.n_r = (nsum_r[i] / ar).cast<float>();
      v.l_r = (phi_r[i] / ar).cast<float>();
      v.nl_r = (lit_r[i] / ar).cast<float>();
    }
    if (av > 0) {
      v.occ_v = 1;
      v.n_v = (nsum_v[i] / av).cast<float>();
    }
    if (ar + av > 0) {
      v.l_m = (phi_m[i] / (ar + av)).cast<float>();
      v.nl_m = (lit_m[i] / (ar + av)).cast<float>();
      ++out->occupied_;
    }
  }
  out->levels_.push_back(std::move(l0));
  out->BuildMips();

  // Far field: what a cone leaving the volume sees, path traced from the
  // volume's centre, starting where each ray leaves the volume (what lies
  // inside is in the volumes).  Surfaces' radiance (all bounces) and the
  // sky, kept apart: diffuse cones take the sky by next-event estimation.
  {
    const int w = std::max(8, st.far_field_width), h = w / 2;
    out->far_w_ = w;
    out->far_h_ = h;
    PathTracerSettings ps;
    ps.max_depth = st.max_depth;
    ps.seed = st.seed;
    DifferentialPathTracer tracer(scene, ps);
    std::vector<std::array<Eigen::Vector3f, 4>> raw(static_cast<size_t>(w) * h);
    const int spt = std::max(1, st.far_field_samples);
    ParallelFor(0, static_cast<int64_t>(raw.size()), [&](int64_t i) {
      const int px = static_cast<int>(i % w), py = static_cast<int>(i / w);
      Sampler rng = Sampler::Random(HashCombine(st.seed, 0x666172), static_cast<uint64_t>(i));
      Eigen::Vector3d sm = Eigen::Vector3d::Zero(), sr = sm, km = sm, kr = sm;
      for (int s = 0; s < spt; ++s) {
        const double x = std::clamp(px - 0.5 + rng.NextDouble(), 0.0, w - 1.0);
        const double y = std::clamp(py - 0.5 + rng.NextDouble(), 0.0, h - 1.0);
        const Eigen::Vector3d d = LatLongPixelToDirection({x, y}, w, h);
        double t0, t1;
        const double exit = ClipToBox(centre, d, vbox, &t0, &t1) ? std::max(0.0, t1) : 0.0;
        const Ray ray = MakeRay(centre + exit * d, d, kMaskAll);
        const PathSample p = tracer.TraceFrom(ray, Eigen::Vector3d::Ones(), 0, 0, rng, 1);
        if (std::isinf(p.first_t)) {
          const Eigen::Vector3d e = Escaped(scene, ray, 0, kRealLights);
          km += e + Escaped(scene, ray, 0, kVirtualLights);
          kr += e;
        } else if (p.mixed.allFinite() && p.real.allFinite()) {
          sm += p.mixed;
          sr += p.real;
        }
      }
      const double inv = 1.0 / spt;
      raw[static_cast<size_t>(i)] = {(sm * inv).cast<float>(), (sr * inv).cast<float>(), (km * inv).cast<float>(),
                                     (kr * inv).cast<float>()};
    });
    out->far_field_paths_ = static_cast<int64_t>(raw.size()) * spt;
    // Delta distant lights: their irradiance spread over their texel.
    for (const LightSource& l : scene.lights()) {
      if (l.light().type != LightType::kDistant || !l.light().IsDelta()) continue;
      const Eigen::Vector3d d = l.light().direction.normalized();
      double t0, t1;
      const double exit = ClipToBox(centre, d, vbox, &t0, &t1) ? std::max(0.0, t1) : 0.0;
      if (embree.Occluded(MakeRay(centre + exit * d, d, kMaskAll))) continue;
      const Eigen::Vector2d q = DirectionToLatLongPixel(d, w, h);
      const int px = std::clamp(static_cast<int>(std::lround(q.x())), 0, w - 1);
      const int py = std::clamp(static_cast<int>(std::lround(q.y())), 0, h - 1);
      const Eigen::Vector3f e = (l.light().irradiance / LatLongPixelSolidAngle(px, py, w, h)).cast<float>();
      auto& t = raw[static_cast<size_t>(py) * w + px];
      t[2] += e;
      if (!l.is_virtual()) t[3] += e;
    }
    // Prefiltered levels: the solid-angle-weighted mean over a cone.
    std::vector<Eigen::Vector3d> dir(raw.size());
    std::vector<double> omega(raw.size());
    for (size_t i = 0; i < raw.size(); ++i) {
      dir[i] = LatLongPixelToDirection({static_cast<double>(i % w), static_cast<double>(i / w)}, w, h);
      omega[i] = LatLongPixelSolidAngle(static_cast<int>(i % w), static_cast<int>(i / w), w, h);
    }
    for (double deg : kFarHalfAnglesDeg) {
      out->far_half_angles_.push_back(deg * kDegToRad);
      if (deg == 0) {
        out->far_.push_back(raw);
        continue;
      }
      const double cos_h = std::cos(deg * kDegToRad);
      std::vector<std::array<Eigen::Vector3f, 4>> level(raw.size());
      ParallelFor(0, static_cast<int64_t>(raw.size()), [&](int64_t i) {
        std::array<Eigen::Vector3d, 4> sum;
        sum.fill(Eigen::Vector3d::Zero());
        double wsum = 0;
        for (size_t j = 0; j < raw.size(); ++j) {
          if (dir[static_cast<size_t>(i)].dot(dir[j]) < cos_h && j != static_cast<size_t>(i)) continue;
          for (int c = 0; c < 4; ++c) sum[c] += omega[j] * raw[j][c].cast<double>();
          wsum += omega[j];
        }
        for (int c = 0; c < 4; ++c) level[static_cast<size_t>(i)][c] = (sum[c] / wsum).cast<float>();
      });
      out->far_.push_back(std::move(level));
    }
  }
  if (st.bounces >= 2) out->AddSecondBounce();
  out->build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

void VctVolumes::BuildMips() {
  levels_.resize(1);
  // Mip chain: each voxel the mean of its eight children (missing ones empty).
  while (levels_.back().nx > 1 || levels_.back().ny > 1 || levels_.back().nz > 1) {
    const Level& c = levels_.back();
    Level p;
    p.nx = (c.nx + 1) / 2;
    p.ny = (c.ny + 1) / 2;
    p.nz = (c.nz + 1) / 2;
    p.size = 2 * c.size;
    p.v.assign(static_cast<size_t>(p.nx) * p.ny * p.nz, Voxel());
    ParallelFor(0, p.nz, [&](int64_t z) {
      for (int y = 0; y < p.ny; ++y)
        for (int x = 0; x < p.nx; ++x) {
          Voxel& v = p.v[p.Index(x, y, static_cast<int>(z))];
          for (int k = 0; k < 8; ++k) {
            const int cx = 2 * x + (k & 1), cy = 2 * y + ((k >> 1) & 1), cz = 2 * static_cast<int>(z) + (k >> 2);
            if (cx < c.nx && cy < c.ny && cz < c.nz) AddScaled(&v, c.v[c.Index(cx, cy, cz)], 0.125f);
          }
        }
    });
    levels_.push_back(std::move(p));
  }
}

// Each occupied level-0 voxel gathers the first bounce (the volumes and the
// far field's surfaces) through six diffuse cones on each side of its mean
// normal, weighted as a fragment's, and reflects it with its area-weighted
// albedo: mixed light through the mixed volumes from every surface in it,
// real light through the real ones from its real surfaces.  The side a
// cone gathers from is the side its light leaves towards (the lit-side
// normal).  All voxels gather from the first bounce, then the mips are
// built again.
void VctVolumes::AddSecondBounce() {
  Level& l0 = levels_[0];
  const double voxel = l0.size, half = 30 * kDegToRad, lift = settings_.cone_offset * voxel;
  const double cos60 = 0.5, sin60 = std::sqrt(0.75);
  std::vector<Voxel> add(l0.v.size());
  ParallelFor(0, l0.nz, [&](int64_t zz) {
    const int z = static_cast<int>(zz);
    for (int y = 0; y < l0.ny; ++y)
      for (int x = 0; x < l0.nx; ++x) {
        const size_t i = l0.Index(x, y, z);
        const double ar = area_r_[i], av = area_v_[i];
        const Eigen::Vector3d nsum = nsum_r_[i] + nsum_v_[i];
        if (!(ar + av > 0) || !(nsum.norm() > 1e-6 * (ar + av))) continue;
        const Eigen::Vector3d n0 = nsum.normalized();
        const Eigen::Vector3d centre = box_.min() + voxel * Eigen::Vector3d(x + 0.5, y + 0.5, z + 0.5);
        const Eigen::Vector3d rho_m = (albedo_r_[i] + albedo_v_[i]) / (ar + av);
        const Eigen::Vector3d rho_r = ar > 0 ? Eigen::Vector3d(albedo_r_[i] / ar) : Eigen::Vector3d::Zero();
        Voxel& a = add[i];
        for (const double side : {1.0, -1.0}) {
          const ShadingFrame frame(side * n0);
          Eigen::Vector3d em = Eigen::Vector3d::Zero(), er = em;
          for (int k = 0; k < 6; ++k) {
            Eigen::Vector3d d = frame.n;
            double w = kPi / 4;
            if (k > 0) {
              const double phi = kTwoPi * (k - 1) / 5;
              d = frame.ToWorld(Eigen::Vector3d(sin60 * std::cos(phi), sin60 * std::sin(phi), cos60));
              w = 3 * kPi / 20;
            }
            const ConeResult cr = March(centre + frame.n * lift, d, half, 0.5 * voxel, INFINITY, Cone::kDiffuse);
            em += w * cr.mixed;
            er += w * cr.real;
          }
          const Eigen::Vector3d lm = rho_m.cwiseProduct(em) * kInvPi, lr = rho_r.cwiseProduct(er) * kInvPi;
          a.l_m += lm.cast<float>();
          a.nl_m += (Luminance(lm) * frame.n).cast<float>();
          if (ar > 0) {
            a.l_r += lr.cast<float>();
            a.nl_r += (Luminance(lr) * frame.n).cast<float>();
          }
        }
      }
  });
  for (size_t i = 0; i < l0.v.size(); ++i) {
    l0.v[i].l_m += add[i].l_m;
    l0.v[i].l_r += add[i].l_r;
    l0.v[i].nl_m += add[i].nl_m;
    l0.v[i].nl_r += add[i].nl_r;
  }
  BuildMips();
}

void VctVolumes::FarField(const Eigen::Vector3d& dir, double half_angle, bool sky, Eigen::Vector3d* mixed,
                          Eigen::Vector3d* real) const {
  // Level by aperture (linear between prefilter half-angles), texel bilinear.
  const auto& ha = far_half_angles_;
  size_t k = 0;
  while (k + 1 < ha.size() && ha[k + 1] <= half_angle) ++k;
  const double f = k + 1 < ha.size() ? (half_angle - ha[k]) / (ha[k + 1] - ha[k]) : 0.0;
  const Eigen::Vector2d q = DirectionToLatLongPixel(dir, far_w_, far_h_);
  const double qx = std::clamp(q.x(), 0.0, far_w_ - 1.0), qy = std::clamp(q.y(), 0.0, far_h_ - 1.0);
  const int x0 = std::min(static_cast<int>(qx), far_w_ - 2), y0 = std::min(static_cast<int>(qy), far_h_ - 2);
  const double fx = qx - x0, fy = qy - y0;
  Eigen::Vector3d m = Eigen::Vector3d::Zero(), r = Eigen::Vector3d::Zero();
  for (int lv = 0; lv < 2; ++lv) {
    const double wl = lv == 0 ? 1 - f : f;
    if (wl <= 0) continue;
    const auto& map = far_[k + lv];
    for (int c = 0; c < 4; ++c) {
      const int x = x0 + (c & 1), y = y0 + (c >> 1);
      const double w = wl * ((c & 1) ? fx : 1 - fx) * ((c >> 1) ? fy : 1 - fy);
      const auto& t = map[static_cast<size_t>(y) * far_w_ + x];
      m += w * t[0].cast<double>();
      r += w * t[1].cast<double>();
      if (sky) {
        m += w * t[2].cast<double>();
        r += w * t[3].cast<double>();
      }
    }
  }
  *mixed = m;
  *real = r;
}

VctVolumes::Voxel VctVolumes::Sample(const Eigen::Vector3d& p, double level) const {
  Voxel out;
  const int l0 = static_cast<int>(level);
  const double f = level - l0;
  for (int k = 0; k < 2; ++k) {
    const double wl = k == 0 ? 1 - f : f;
    if (wl <= 0 || l0 + k >= static_cast<int>(levels_.size())) continue;
    const Level& lv = levels_[static_cast<size_t>(l0 + k)];
    const Eigen::Vector3d u = (p - box_.min()) / lv.size - Eigen::Vector3d::Constant(0.5);
    const int x0 = static_cast<int>(std::floor(u.x())), y0 = static_cast<int>(std::floor(u.y())),
              z0 = static_cast<int>(std::floor(u.z()));
    const double fx = u.x() - x0, fy = u.y() - y0, fz = u.z() - z0;
    for (int c = 0; c < 8; ++c) {
      const int x = x0 + (c & 1), y = y0 + ((c >> 1) & 1), z = z0 + (c >> 2);
      if (x < 0 || y < 0 || z < 0 || x >= lv.nx || y >= lv.ny || z >= lv.nz) continue;
      const double w = wl * ((c & 1) ? fx : 1 - fx) * (((c >> 1) & 1) ? fy : 1 - fy) * ((c >> 2) ? fz : 1 - fz);
      AddScaled(&out, lv.v[lv.Index(x, y, z)], static_cast<float>(w));
    }
  }
  return out;
}

ConeResult VctVolumes::March(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double half_angle,
                             double t_start, double t_max, Cone kind) const {
  ConeResult r;
  const double voxel = levels_[0].size;
  const double tan_h = std::tan(std::clamp(half_angle, 0.0, 1.4));
  const double step_scale = kind == Cone::kDiffuse ? 1.0 : 0.5;
  const bool paper = settings_.paper_accumulation;
  const double top = static_cast<double>(levels_.size()) - 1;
  double t0, t1;
  if (ClipToBox(origin, dir, box_, &t0, &t1)) {
    double t = std::max(t_start, t0);
    const double end = std::min(t_max, t1);
    Eigen::Vector3d m = Eigen::Vector3d::Zero(), re = m, de = m;
    double om = 0, orr = 0;
    while (t < end) {
      const double D = std::max(voxel, 2 * t * tan_h);
      const double level = std::min(top, std::log2(D / voxel));
      const Voxel v = Sample(origin + t * dir, level);
      const double step = step_scale * D;
      ++r.steps;
      const double gv = Facing(v.n_v, v.occ_v, dir);
      const double av = std::min(1.0, v.occ_v * gv);
      if (kind == Cone::kShadow) {
        const double a = 1 - std::pow(1 - av, step_scale);
        om += (1 - om) * a;
        if (om > 0.999) break;
        t += step;
        continue;
      }
      const double gr = Facing(v.n_r, v.occ_r, dir);
      const double ar = std::min(1.0, v.occ_r * gr), am = std::min(1.0, ar + av);
      const double em = Emitting(v.nl_m, v.l_m, dir), er = Emitting(v.nl_r, v.l_r, dir);
      // Opacity corrected for the step (a voxel's occupancy is per diameter).
      const double am_s = 1 - std::pow(1 - am, step_scale), ar_s = 1 - std::pow(1 - ar, step_scale);
      const double sm = am > 0 ? am_s / am : step_scale, sr = ar > 0 ? ar_s / ar : step_scale;
      const Eigen::Vector3d cm = v.l_m.cast<double>() * (em * sm), cr = v.l_r.cast<double>() * (er * sr);
      const Eigen::Vector3d cd = v.l_m.cast<double>() * (em * sm) - v.l_r.cast<double>() * (er * sm);
      if (paper) {
        m = m * om + (1 - om) * cm;
        de = de * om + (1 - om) * cd;
        re = re * orr + (1 - orr) * cr;
      } else {
        m += (1 - om) * cm;
        de += (1 - om) * cd;
        re += (1 - orr) * cr;
      }
      om += (1 - om) * am_s;
      orr += (1 - orr) * ar_s;
      if (om > 0.999 && orr > 0.999) break;
      t += step;
    }
    r.mixed = m;
    r.real = re;
    r.delta = de;
    r.occ_mixed = om;
    r.occ_real = orr;
  }
  if (kind != Cone::kShadow && !far_.empty()) {
    Eigen::Vector3d fm, fr;
    FarField(dir, half_angle, kind == Cone::kSpecular, &fm, &fr);
    r.mixed += (1 - r.occ_mixed) * fm;
    r.real += (1 - r.occ_real) * fr;
  }
  return r;
}

void VctVolumes::Describe(Report* report) const {
  const Level& l0 = levels_[0];
  report->SetMetric("vct.volume", box_reason_);
  report->SetMetric("vct.voxels", Json::array({l0.nx, l0.ny, l0.nz}));
  report->SetMetric("vct.voxel_size", l0.size);
  report->SetMetric("vct.mip_levels", static_cast<int64_t>(levels_.size()));
  report->SetMetric("vct.occupied_voxels", occupied_);
  report->SetMetric("vct.voxelisation_rays", voxelisation_rays_);
  report->SetMetric("vct.voxelised", voxelised_);
  report->SetMetric("vct.injection_rays", injection_rays_);
  report->SetMetric("vct.far_field_paths", far_field_paths_);
  report->SetMetric("vct.build_seconds", build_seconds_);
  report->SetMetric("vct.accumulation", settings_.paper_accumulation ? "paper" : "front_to_back");
  report->SetMetric("vct.relight", settings_.split_relighting ? "split" : "delta");
  report->SetMetric("vct.final_gather", settings_.final_gather);
  report->SetMetric("vct.injected_bounces", settings_.bounces);
}

namespace {

// The path tracer behind a transmissive asset (the camera's own bounce was
// vct's: depth 1 on).
PathTracerSettings GlassTracerSettings(const VctSettings& s, const PlateViews& plates) {
  PathTracerSettings p;
  p.max_depth = s.max_depth;
  p.seed = s.seed;
  p.plates = plates;
  return p;
}

}  // namespace

VctFrameRenderer::VctFrameRenderer(const RenderScene& scene, std::shared_ptr<const VctVolumes> volumes,
                                   const CameraModel& camera, const Rigid3& world_from_cam, uint64_t seed, int frame,
                                   const CameraExposure& exposure, const PlateViews& plates)
    : PixelLoopMethod(camera, world_from_cam, seed, frame, exposure),
      scene_(scene),
      vol_(std::move(volumes)),
      glass_tracer_(scene, GlassTracerSettings(vol_->settings(), plates)) {}

void VctFrameRenderer::RenderPass(int spp) {
  rows_.assign(static_cast<size_t>(height()), Counters());
  ShadePixels(spp);
  for (const Counters& c : rows_) counters_ += c;
}

// The glossy lobe at a shaded point v (virtual: xv; cones' origin `origin`): point,
// spot and area lights by next-event estimation, the rest through the
// specular cone, weighted by the lobe's reflectance (one BSDF sample's
// f cos / pdf).
void VctFrameRenderer::ShadeGlossyLobe(const PathVertex& v, bool xv, const Eigen::Vector3d& origin, bool want_m,
                                       bool want_r, Sampler& g, Counters* counters, Eigen::Vector3d* mixed_out,
                                       Eigen::Vector3d* real_out) const {
  const VctVolumes& vol = *vol_;
  const VctSettings& st = vol.settings();
  const double voxel = vol.voxel();
  Counters& c = *counters;
  Eigen::Vector3d& mixed = *mixed_out;
  Eigen::Vector3d& real = *real_out;
  PathVertex vg = v;
  vg.bsdf = GlossyLobe(scene_, v);
  const Eigen::Vector3d wo_l = v.frame.ToLocal(v.wo_world);
  // One local light's sample (an area light's centre), divided by the
  // probability it was picked with.
  auto light_sample = [&](const LightSource& l, double pick) {
    LightSample ls;
    if (!l.Sample(v.p, 0.5, 0.5, &ls)) return;
    const Eigen::Vector3d wi_l = v.frame.ToLocal(ls.wi);
    if (wi_l.z() <= 0) return;
    const Eigen::Vector3d fg = vg.bsdf.Eval(wo_l, wi_l);
    if (fg.maxCoeff() <= 0) return;
    c.rays += AddNextEvent(scene_, Eigen::Vector3d(fg.cwiseProduct(ls.li) * (wi_l.z() / (ls.pdf * pick))),
                           MakeRay(v.origin, ls.wi, kMaskAll, ls.distance * (1 - 1e-6)), l.is_virtual(), xv, want_m,
                           want_r, &mixed, &real);
  };
  if (scene_.picks_local_light()) {  // many lights: one, by power (RenderScene::PickLocalLight)
    double prob = 1;
    const size_t i = scene_.PickLocalLight(g.NextDouble(), &prob);
    light_sample(scene_.lights()[i], prob);
  } else {
    for (const LightSource& l : scene_.lights())
      if (l.light().type != LightType::kDistant) light_sample(l, 1.0);
  }
  BsdfSample bs;
  const double ul = g.NextDouble();
  const auto [u0, u1] = g.Next2D();
  if (!vg.bsdf.Sample(wo_l, ul, u0, u1, &bs) || !(bs.pdf > 0)) return;
  const Eigen::Vector3d beta = bs.f * (std::abs(bs.wi.z()) / bs.pdf);
  if (TransmissiveAsset(scene_, v)) {
    // Glass: a cone along the mirror direction would show it opaque, and
    // the volumes hold no refracted light.  The sampled ray (reflected or
    // refracted) is path-traced, as pt and ic trace it.
    const Eigen::Vector3d wi = v.frame.ToWorld(bs.wi);
    const Ray next = MakeRay(v.OriginFor(wi), wi, kMaskAll);
    ++c.glass_paths;
    int rays = 0;
    if (xv) {
      if (want_m) mixed += glass_tracer_.MixedRadianceFromVirtual(next, beta, bs.pdf, 1, g, &rays);
    } else {
      const PathSample ps = glass_tracer_.TraceFrom(next, beta, bs.pdf, 1, g);
      rays += ps.rays;
      if (want_m) mixed += ps.mixed;
      if (want_r) real += ps.real;
    }
    c.rays += rays;
    return;
  }
  const Eigen::Vector3d refl = (2 * v.frame.n.dot(v.wo_world) * v.frame.n - v.wo_world).normalized();
  const double alpha = v.material->roughness;
  const double half = std::clamp(std::atan(alpha), 0.5 * st.min_specular_aperture_deg * kDegToRad, 45 * kDegToRad);
  const ConeResult cr = vol.March(origin, refl, half, 0.5 * voxel, INFINITY, VctVolumes::Cone::kSpecular);
  ++c.specular_cones;
  c.steps += cr.steps;
  if (xv) {
    if (want_m) mixed += beta.cwiseProduct(cr.mixed);
  } else {
    if (want_r) real += beta.cwiseProduct(cr.real);
    if (want_m)
      mixed += beta.cwiseProduct(cr.real + (st.split_relighting ? Eigen::Vector3d(cr.mixed - cr.real) : cr.delta));
  }
}

void VctFrameRenderer::Shade(const Ray& ray, Sampler& rng, int64_t row, size_t, int, PathSample* out) {
  const EmbreeScene& embree = scene_.embree();
  const VctVolumes& vol = *vol_;
  const VctSettings& st = vol.settings();
  const double voxel = vol.voxel();
  const double lift = st.cone_offset * voxel;
  const double shadow_half = 0.5 * st.shadow_aperture_deg * kDegToRad;
  const double diffuse_half = 30 * kDegToRad;
  const double cos60 = 0.5, sin60 = std::sqrt(0.75);
  const std::vector<Eigen::AlignedBox3d>& vbounds = scene_.virtual_bounds();
  Counters c;
  Eigen::Vector3d mixed = Eigen::Vector3d::Zero(), real = Eigen::Vector3d::Zero();
  bool primary_virtual = false;
  // cones false: no diffuse cones (the final gather takes the indirect
  // light); glossy false: the diffuse lobe only.
  auto shade = [&](const Ray& r, const Hit& hit, bool want_m, bool want_r, Sampler& g, bool cones = true,
                   bool glossy = true) {
    PathVertex v = MakeVertex(scene_, r, hit);
    const bool xv = hit.is_virtual;
    if (want_m) mixed += v.emission;
    if (want_r) real += v.emission;
    if (v.bsdf.IsBlack()) return;
    // Direct light; a real point's virtual shadows by shadow cone.
    PathVertex vd = v;
    vd.bsdf = DiffuseLobe(scene_, v);
    // Camera points (glossy) take VctSettings::direct_samples, those on an
    // object object_direct_samples, and shadow_samples of the objects'
    // shadows; the gather's point one.
    const int n_direct = !glossy ? 1 : xv ? std::max(st.direct_samples, st.object_direct_samples) : st.direct_samples;
    const int n_shadows = glossy ? st.shadow_samples : 1;
    c.rays += DirectDiffuseSamples(
        n_direct, scene_, vd, v.albedo, xv, want_m, want_r, g, &mixed, &real,
        [&](Ray sr) {
          const Eigen::Vector3d o = sr.origin.cast<double>(), d = sr.direction.cast<double>().normalized();
          const double tfar = sr.tfar;
          if (!SegmentMeetsBoxes(o, d, tfar, vbounds)) {
            ++c.shadow_cones_skipped;
            return 1.0;
          }
          ++c.shadow_cones;
          const ConeResult cr = vol.March(o, d, shadow_half, 0.5 * voxel, tfar, VctVolumes::Cone::kShadow);
          c.steps += cr.steps;
          return 1 - cr.occ_mixed;
        },
        n_shadows);
    // Indirect diffuse: six cones, turned about the normal per sample.
    const Eigen::Vector3d origin = v.p + v.frame.n * lift;
    const double phi0 = kTwoPi * g.NextDouble();
    Eigen::Vector3d em = Eigen::Vector3d::Zero(), er = em, ed = em;
    bool reaches = false;
    for (int k = 0; k < (cones ? 6 : 0); ++k) {
      Eigen::Vector3d d = v.frame.n;
      double w = kPi / 4;
      if (k > 0) {
        const double phi = phi0 + kTwoPi * (k - 1) / 5;
        d = v.frame.ToWorld(Eigen::Vector3d(sin60 * std::cos(phi), sin60 * std::sin(phi), cos60));
        w = 3 * kPi / 20;
      }
      const ConeResult cr = vol.March(origin, d, diffuse_half, 0.5 * voxel, INFINITY, VctVolumes::Cone::kDiffuse);
      ++c.diffuse_cones;
      c.steps += cr.steps;
      reaches = reaches || cr.steps > 0;
      em += w * cr.mixed;
      er += w * cr.real;
      ed += w * cr.delta;
    }
    const Eigen::Vector3d f = v.albedo * kInvPi;
    if (xv) {
      if (want_m) mixed += f.cwiseProduct(em);
    } else {
      if (want_r) real += f.cwiseProduct(er);
      if (want_m) mixed += f.cwiseProduct(er + (st.split_relighting ? Eigen::Vector3d(em - er) : ed));
      if (!reaches && cones) ++c.relight_skipped;
    }
    if (glossy && HasGlossyLobe(scene_, v)) ShadeGlossyLobe(v, xv, origin, want_m, want_r, g, &c, &mixed, &real);
  };
  Hit hit;
  ++c.rays;
  if (!embree.Intersect(ray, &hit)) {
    AddEscapedCameraRay(scene_, ray, &mixed, &real);
  } else if (hit.is_virtual) {
    primary_virtual = true;
    Sampler real_rng = rng;
    Ray rr = ray;
    rr.mask = kMaskReal;
    Hit rh;
    ++c.rays;
    if (embree.Intersect(rr, &rh))
      shade(rr, rh, false, true, real_rng);
    else
      real += Escaped(scene_, rr, 0, kRealLights);
    shade(ray, hit, true, false, rng, !st.final_gather);
    if (st.final_gather) {
      // The object's indirect light along VctSettings::gather_rays
      // cosine-sampled rays, each weighted 1/n: the light the point a ray
      // meets sends back, as vct shades that point (direct light sampled,
      // indirect by its cones), its diffuse lobe only: a glossy table's
      // specular cone towards a sun 1e6 x the sky made fireflies of 30 x
      // the truth at 4 spp (the caustic on the object is left out, as the
      // cones left it out).  A ray that escapes adds nothing: DirectDiffuse
      // took the environment.
      const PathVertex v = MakeVertex(scene_, ray, hit);
      const int n = std::max(1, st.gather_rays);
      for (int k = 0; k < n; ++k) {
        const auto u = rng.Next2D();
        const auto d = SampleCosineHemisphere(u[0], u[1]);
        const Ray gr = MakeRay(v.origin, v.frame.ToWorld(Eigen::Vector3d(d[0], d[1], d[2])), kMaskAll);
        Hit gh;
        ++c.rays;
        ++c.gather_rays;
        if (!v.bsdf.IsBlack() && d[2] > 0 && embree.Intersect(gr, &gh)) {
          const Eigen::Vector3d before = mixed;
          mixed.setZero();
          shade(gr, gh, true, false, rng, true, false);
          mixed = before + v.albedo.cwiseProduct(mixed) / n;
        }
      }
    }
  } else {
    shade(ray, hit, true, true, rng);
  }
  out->mixed = mixed;
  out->real = real;
  out->primary_virtual = primary_virtual;
  rows_[static_cast<size_t>(row)] += c;
}

void VctFrameRenderer::Describe(Report* report, int frame) const {
  const std::string k = fmt::format("vct.frames.{}.", frame);
  report->SetMetric(k + "diffuse_cones", counters_.diffuse_cones);
  report->SetMetric(k + "specular_cones", counters_.specular_cones);
  report->SetMetric(k + "shadow_cones", counters_.shadow_cones);
  report->SetMetric(k + "cone_steps", counters_.steps);
  report->SetMetric(k + "rays", counters_.rays);
  report->SetMetric(k + "gather_rays", counters_.gather_rays);
  report->SetMetric(k + "glass_paths", counters_.glass_paths);
  if (counters_.shadow_cones_skipped > 0)
    report->Skip(fmt::format("frame {}: {} shadow cones", frame, counters_.shadow_cones_skipped),
                 "the shadow ray misses every virtual object's bounding box: nothing virtual can block it");
  if (counters_.relight_skipped > 0)
    report->Skip(fmt::format("frame {}: relighting of {} real points", frame, counters_.relight_skipped),
                 "none of their diffuse cones meets the volume: the change they see is taken as zero");
  if (!scene_.has_glossy())
    report->Skip(fmt::format("frame {}: specular cones", frame), "no material has a glossy lobe");
}

namespace {

VctSettings ParseVctSettings(JsonSettings& s, const Scene& scene) {
  VctSettings o;
  s.Integer("resolution", &o.resolution, 2, 1024);
  s.Integer("directions", &o.directions, 1, 1 << 16);
  s.Integer("bounces", &o.bounces, 1, 2);
  s.Integer("direct_samples", &o.direct_samples, 1, 256);
  s.Integer("object_direct_samples", &o.object_direct_samples, 1, 256);
  s.Integer("shadow_samples", &o.shadow_samples, 1, 256);
  s.Number("injection_spacing", &o.injection_spacing, 0.05, 8);
  s.Number("shadow_aperture_deg", &o.shadow_aperture_deg, 0, 90);
  s.Number("min_specular_aperture_deg", &o.min_specular_aperture_deg, 0, 90);
  s.Number("cone_offset", &o.cone_offset, 0, 16);
  s.Choice("accumulation", &o.paper_accumulation, {{"front_to_back", false}, {"paper", true}});
  s.Choice("relight", &o.split_relighting, {{"delta", false}, {"split", true}});
  s.Integer("far_field_width", &o.far_field_width, 8, 1024);
  s.Integer("far_field_samples", &o.far_field_samples, 1, 1 << 16);
  s.Bool("final_gather", &o.final_gather);
  s.Integer("gather_rays", &o.gather_rays, 1, 1024);
  return WithSceneRender(o, scene);
}

class VctMethod : public SettingsMethod<VctSettings> {
 public:
  using SettingsMethod::SettingsMethod;
  void Prepare(const JobContext& job) override {
    volumes_ = VctVolumes::Build(job.rs, st_);
    volumes_->Describe(job.report);
    if (AnyEmissive(job.scene))
      job.report->Warn("vct: emissive surfaces are seen and lit but inject no light into the volumes");
  }
  std::vector<std::string> WorldChanged(const JobContext& job, const WorldChange& change) override {
    if (!volumes_) {
      Prepare(job);
      return {"voxel volumes (voxelised and injected)"};
    }
    volumes_ = VctVolumes::Build(job.rs, st_, volumes_.get(), !change.moved.empty());
    volumes_->Describe(job.report);
    job.report->SetMetric(fmt::format("vct.frames.{}.voxelised", job.frame), volumes_->voxelised());
    return {fmt::format("voxel volumes: light injected, voxelisation {}", volumes_->voxelised())};
  }
  std::unique_ptr<FrameMethod> NewFrame(const FrameContext& f) override {
    return std::make_unique<VctFrameRenderer>(f.rs, volumes_, f.camera, f.world_from_cam, f.seed, f.frame, f.exposure,
                                              f.plates);
  }
  void FrameDone(const FrameMethod& fm, const FrameContext& f, Report* report, Json*) override {
    static_cast<const VctFrameRenderer&>(fm).Describe(report, f.frame);
  }

 private:
  std::shared_ptr<const VctVolumes> volumes_;
};

}  // namespace

std::unique_ptr<RenderMethod> MakeVctMethod(JsonSettings& block, const Scene& scene) {
  return std::make_unique<VctMethod>(ParseVctSettings(block, scene));
}

}  // namespace mr
