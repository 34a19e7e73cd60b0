#include "render/irradiance_cache.h"
#include "core/check.h"

#include <spdlog/spdlog.h>

#include <atomic>
#include <cmath>
#include <unordered_map>

#include "core/hash.h"
#include "core/parallel.h"
#include "render/path_common.h"
#include "render/world.h"

namespace mr {

namespace {

PathTracerSettings TracerSettings(const IcSettings& s) {
  PathTracerSettings p;
  p.mis_area_lights = false;  // its own vertices sample area lights by next-event estimation alone
  p.max_depth = s.max_depth;
  p.seed = s.seed;
  return p;
}

// The glossy lobe's path: glossy_depth bounces, at most max_depth.
PathTracerSettings GlossyTracerSettings(const IcSettings& s, const PlateViews& plates) {
  PathTracerSettings p = TracerSettings(s);
  p.plate_reflections = s.plate_reflections;
  p.plates = plates;
  if (s.glossy_depth >= 0) p.max_depth = std::min(p.max_depth, s.glossy_depth);
  return p;
}

// Tabellion & Lamorlette's weight of record r at (p, n); <= 0: no contribution.
// `inv_normal` is 1 / sqrt(1 - cos(normal_deg)).
double Weight(const IcRecord& r, const Eigen::Vector3d& p, const Eigen::Vector3d& n, double inv_accuracy,
              double inv_normal) {
  const double eps_p = (p - r.p).norm() / r.r;
  const double eps_n = SafeSqrt(1 - std::min(1.0, n.dot(r.n))) * inv_normal;
  return 1 - inv_accuracy * std::max(eps_p, eps_n);
}

// Record r's irradiance extrapolated to (p, n) along its gradients: E_m, E_r.
std::pair<Eigen::Vector3d, Eigen::Vector3d> Extrapolated(const IcRecord& r, const Eigen::Vector3d& p,
                                                         const Eigen::Vector3d& n) {
  const Eigen::Vector3d turn = r.n.cross(n), move = p - r.p;
  return {r.e_mixed + r.rot_mixed * turn + r.trans_mixed * move, r.e_real + r.rot_real * turn + r.trans_real * move};
}

}  // namespace

IrradianceCache::IrradianceCache(const RenderScene& scene, const IcSettings& settings)
    : scene_(scene), settings_(settings), tracer_(scene, TracerSettings(settings)) {
  UpdateSpheres();
}

void IrradianceCache::UpdateSpheres() {
  spheres_.clear();
  for (const Eigen::Vector4d& s : scene_.virtual_spheres())
    if (s[3] >= 0) spheres_.push_back(s);  // not an object scaled to nothing
  virtual_light_ = false;
  for (const LightSource& l : scene_.lights()) virtual_light_ = virtual_light_ || l.is_virtual();
}

namespace {

// Whether p is within the form factor bound `threshold` of any sphere.
bool NearSpheres(const std::vector<Eigen::Vector4d>& spheres, const Eigen::Vector3d& p, double threshold) {
  for (const auto& s : spheres) {
    const double d2 = (p - s.head<3>()).squaredNorm(), r2 = s[3] * s[3];
    if (d2 <= r2 || r2 / d2 >= threshold) return true;  // the sphere's form factor bound
  }
  return false;
}

}  // namespace

bool IrradianceCache::InInfluence(const Eigen::Vector3d& p) const {
  if (!settings_.photograph || virtual_light_ || settings_.influence_threshold <= 0) return true;
  return NearSpheres(spheres_, p, settings_.influence_threshold);
}

std::string IrradianceCache::WorldChanged(const WorldChange& c) {
  const std::vector<Eigen::Vector4d> old = spheres_;
  const bool old_virtual_light = virtual_light_;
  UpdateSpheres();
  // Records on virtual surfaces moved with them: dropped (made again where
  // needed).
  size_t dropped = 0;
  if (!c.moved.empty()) {
    const size_t before = records_.size();
    std::erase_if(records_, [](const IcRecord& r) { return r.on_virtual; });
    dropped = before - records_.size();
  }
  if (c.environment || c.lights) {
    for (IcRecord& r : records_) r.stale = true;
    invalidated_ += static_cast<int64_t>(records_.size() + dropped);
    return fmt::format("irradiance cache: {}the {} records re-evaluated in place (new light)",
                       dropped > 0 ? fmt::format("{} records on moved objects dropped, ", dropped) : "",
                       records_.size());
  }
  if (c.moved.empty()) return "";
  // Real records that can see an object where it was or where it is now are
  // re-evaluated; the others cannot have changed.
  // The objects that moved: those whose bounding sphere changed (all of
  // them when their number did: one scaled to nothing).
  std::vector<Eigen::Vector4d> reach;
  if (old.size() != spheres_.size()) {
    reach = old;
    reach.insert(reach.end(), spheres_.begin(), spheres_.end());
  } else {
    for (size_t i = 0; i < old.size(); ++i)
      if (old[i] != spheres_[i]) reach.insert(reach.end(), {old[i], spheres_[i]});
  }
  const bool all = !settings_.photograph || virtual_light_ || old_virtual_light || settings_.influence_threshold <= 0;
  int64_t stale = 0;
  for (IcRecord& r : records_)
    if (all || NearSpheres(reach, r.p, settings_.influence_threshold)) {
      r.stale = true;
      ++stale;
    }
  invalidated_ += stale + static_cast<int64_t>(dropped);
  return fmt::format(
      "irradiance cache: {} records on virtual surfaces dropped, {} within the objects' reach "
      "re-evaluated, {} kept",
      dropped, stale, static_cast<int64_t>(records_.size()) - stale);
}

namespace {

// Ward & Heckbert's gradients from an M x N stratification of the cosine-
// weighted hemisphere (sin^2 theta in M strata, phi in N), local frame:
// L[j + M k] the radiance of stratum (j, k), R its ray's hit distance
// (infinity: escaped).  The rotational gradient is pi/(MN) sum tan(theta_j)
// v(phi) L with theta_j the stratum's centre (the sample's own theta would
// give tan an infinite variance at the horizon) and v(phi) = (-sin, cos, 0):
// for L = a + b d.w it gives (2 pi / 3) b (z x d), exactly what turning the
// normal changes.  The translational gradient sums, over the strata's
// boundaries, the projected solid angle each boundary sweeps as the point
// moves (over the nearer of the two hits beside it) times the radiance
// difference across it: 2 pi / N sin th cos^2 th / R across a theta
// boundary, (sin th+ - sin th-) / R across a phi boundary (Krivanek &
// Gautron's form; Ward & Heckbert's (cos th- - cos th+) / sin th_c lacks
// the projection's cos th).  docs/methods.md, "ic".
void WardHeckbertGradients(const std::vector<Eigen::Vector3d>& L, const std::vector<double>& R, int M, int N,
                           Eigen::Matrix3d* rot, Eigen::Matrix3d* trans) {
  rot->setZero();
  trans->setZero();
  auto theta_at = [&](double q) { return std::asin(std::sqrt(std::clamp(q / M, 0.0, 1.0))); };
  for (int k = 0; k < N; ++k) {
    const double phi = kTwoPi * (k + 0.5) / N, phi_minus = kTwoPi * k / N;
    const Eigen::Vector3d u(std::cos(phi), std::sin(phi), 0), v(-std::sin(phi), std::cos(phi), 0);
    const Eigen::Vector3d v_minus(-std::sin(phi_minus), std::cos(phi_minus), 0);
    const int k_prev = (k + N - 1) % N;
    for (int j = 0; j < M; ++j) {
      const Eigen::Vector3d& l = L[static_cast<size_t>(j + M * k)];
      const double th_c = theta_at(j + 0.5), th_minus = theta_at(j), th_plus = theta_at(j + 1);
      *rot += (std::tan(th_c) * kPi / (M * N)) * l * v.transpose();
      // Across the theta boundary below (j - 1 to j), in direction u.
      if (j > 0) {
        const double r = std::min(R[static_cast<size_t>(j + M * k)], R[static_cast<size_t>(j - 1 + M * k)]);
        if (std::isfinite(r) && r > 0) {
          const double c = std::cos(th_minus);
          *trans += (kTwoPi / N * std::sin(th_minus) * c * c / r) * (l - L[static_cast<size_t>(j - 1 + M * k)]) *
                    u.transpose();
        }
      }
      // Across the phi boundary before (k - 1 to k), in direction v_minus.
      if (N > 1) {
        const double r = std::min(R[static_cast<size_t>(j + M * k)], R[static_cast<size_t>(j + M * k_prev)]);
        if (std::isfinite(r) && r > 0)
          *trans += ((std::sin(th_plus) - std::sin(th_minus)) / r) * (l - L[static_cast<size_t>(j + M * k_prev)]) *
                    v_minus.transpose();
      }
    }
  }
}

// Limits a gradient so that within `radius` it changes no channel by more
// than that channel's value (a first-order step past zero is noise, and
// would make light negative).
void ClampGradient(const Eigen::Vector3d& e, double radius, Eigen::Matrix3d* g) {
  for (int c = 0; c < 3; ++c) {
    const double change = g->row(c).norm() * radius, most = std::max(0.0, e[c]);
    if (!std::isfinite(change))
      g->row(c).setZero();  // a hit at a vanishing distance: no usable slope
    else if (change > most)
      g->row(c) *= change > 0 ? most / change : 0.0;
  }
}

}  // namespace

void IrradianceCache::Evaluate(IcRecord* r, int frame, const DifferentialPathTracer* from_virtual) const {
  // Cosine-distributed directions in M x N strata of (sin^2 theta, phi)
  // (N ~ pi M, as Ward & Heckbert advise), the rest random; the record's
  // own stream.
  Sampler rng = Sampler::Random(HashCombine(settings_.seed, 0x6963), r->index);
  const int n = RaysFor(*r);
  const int M = std::max(1, static_cast<int>(std::lround(std::sqrt(n / kPi))));
  const int N = std::max(1, n / M);
  const int strata = M * N;
  const ShadingFrame frame_n(r->n);
  const double offset = OffsetScale(r->p, r->p, 0);
  const Eigen::Vector3d origin = r->p + r->n * offset;
  Eigen::Vector3d em = Eigen::Vector3d::Zero(), er = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> lm(static_cast<size_t>(strata)), lr(static_cast<size_t>(strata));
  std::vector<double> dist(static_cast<size_t>(strata), INFINITY);
  double r_hit = INFINITY;
  for (int k = 0; k < n; ++k) {
    double u0 = rng.NextDouble(), u1 = rng.NextDouble();
    if (k < strata) {
      u0 = (k % M + u0) / M;
      u1 = (k / M + u1) / N;
    }
    const double sin_t = std::sqrt(u0), phi = kTwoPi * u1;
    const Eigen::Vector3d d(sin_t * std::cos(phi), sin_t * std::sin(phi), SafeSqrt(1 - u0));
    const Ray ray = MakeRay(origin, frame_n.ToWorld(d), kMaskAll);
    // Bounce 1 onwards of a differential path; escapes of the first segment
    // are direct light (the pixel's next-event estimate).
    const double pdf = d.z() * kInvPi;
    PathSample ps;
    if (r->on_virtual && from_virtual) {  // the plate's or a probe's radiance where the room is met
      int nr = 0;
      Hit first;
      Ray probe_ray = ray;
      if (scene_.embree().Intersect(probe_ray, &first)) ps.first_t = first.t;
      ps.mixed = from_virtual->MixedRadianceFromVirtual(ray, Eigen::Vector3d::Ones(), pdf, 1, rng, &nr, 2);
    } else {
      ps = tracer_.TraceFrom(ray, Eigen::Vector3d::Ones(), pdf, 1, rng, 2);
    }
    if (!ps.mixed.allFinite() || !ps.real.allFinite()) ps.mixed = ps.real = Eigen::Vector3d::Zero();
    em += ps.mixed;
    er += ps.real;
    if (k < strata) {
      lm[static_cast<size_t>(k)] = ps.mixed;
      lr[static_cast<size_t>(k)] = ps.real;
      dist[static_cast<size_t>(k)] = ps.first_t;
    }
    r_hit = std::min(r_hit, static_cast<double>(ps.first_t));
  }
  r->e_mixed = em * (kPi / n);
  r->e_real = er * (kPi / n);
  r->r_hit = r_hit;
  r->evaluated_frame = frame;
  r->rot_mixed.setZero();
  r->rot_real.setZero();
  r->trans_mixed.setZero();
  r->trans_real.setZero();
  if (settings_.gradients && M >= 2 && N >= 3) {
    // Local gradients (rows: channels) turned into world vectors.
    const Eigen::Matrix3d to_world = (Eigen::Matrix3d() << frame_n.ToWorld(Eigen::Vector3d::UnitX()),
                                      frame_n.ToWorld(Eigen::Vector3d::UnitY()), r->n)
                                         .finished();
    Eigen::Matrix3d rot, trans;
    WardHeckbertGradients(lm, dist, M, N, &rot, &trans);
    r->rot_mixed = rot * to_world.transpose();
    r->trans_mixed = trans * to_world.transpose();
    WardHeckbertGradients(lr, dist, M, N, &rot, &trans);
    r->rot_real = rot * to_world.transpose();
    r->trans_real = trans * to_world.transpose();
  }
}

void IrradianceCache::ClampGradients(IcRecord* r) const {
  // Within the record's reach (accuracy x R_i) and its normal cone (the
  // weight's 10-degree bound, sin 10 deg as the rotation's size).
  const double reach = settings_.accuracy * r->r,
               turn = std::sin(settings_.accuracy * settings_.normal_deg * kDegToRad);
  ClampGradient(r->e_mixed, reach, &r->trans_mixed);
  ClampGradient(r->e_real, reach, &r->trans_real);
  ClampGradient(r->e_mixed, turn, &r->rot_mixed);
  ClampGradient(r->e_real, turn, &r->rot_real);
}

void IrradianceCache::Describe(Report* report) const {
  report->SetMetric("ic.records", static_cast<int64_t>(records_.size()));
  report->SetMetric("ic.records_created", created_);
  report->SetMetric("ic.records_reevaluated", reevaluated_);
  report->SetMetric("ic.record_rays", record_rays_);
  report->SetMetric("ic.miss_passes", passes_);
  report->SetMetric("ic.rays_per_record", settings_.rays);
  report->SetMetric("ic.rays_per_object_record", std::max(settings_.rays, settings_.object_rays));
  report->SetMetric("ic.accuracy", settings_.accuracy);
  report->SetMetric("ic.t_max", settings_.t_max);
  report->SetMetric("ic.records_evicted", evicted_);
  report->SetMetric("ic.records_invalidated", invalidated_);
}

IcFrameRenderer::IcFrameRenderer(const RenderScene& scene, IrradianceCache* cache, const CameraModel& camera,
                                 const Rigid3& world_from_cam, uint64_t seed, int frame, const CameraExposure& exposure,
                                 const PlateViews& plates)
    : PixelLoopMethod(camera, world_from_cam, seed, frame, exposure),
      scene_(scene),
      cache_(cache),
      camera_(camera),
      glossy_tracer_(scene, GlossyTracerSettings(cache->settings(), plates)),
      frame_(frame) {
  if (plates.empty()) return;
  PathTracerSettings p = TracerSettings(cache->settings());
  p.plate_reflections = cache->settings().plate_reflections;
  p.plates = plates;
  virtual_tracer_ = std::make_unique<DifferentialPathTracer>(scene, p);
  virtual_tracer_->ShareCountersWith(glossy_tracer_);
}

void IcFrameRenderer::Splat(size_t index, int64_t y0, int64_t y1) {
  const IcRecord& r = cache_->records_[index];
  bool used = false;
  // The record's influence sphere (weight > 0 within accuracy x R_i) projected
  // into the image; a sphere around or behind the camera covers every pixel.
  const double rho = cache_->settings_.accuracy * r.r;
  const Rigid3& pose = sampler().pose();
  const Eigen::Vector3d pc = pose.rotation.conjugate() * (r.p - pose.translation);
  const double dist = pc.norm();
  int x0 = 0, x1 = width() - 1, ya = static_cast<int>(y0), yb = static_cast<int>(y1) - 1;
  Eigen::Vector2d q;
  // Only for a pinhole at one instant: with a shutter or a lens the samples'
  // rays leave from other points than the frame's pose, and a record made
  // for one of them can project elsewhere (bounding it by the frame's
  // projection would leave that sample a miss for ever).
  if (!sampler().exposure().any() && dist > rho && camera_.Project(pc, &q) && q.allFinite()) {
    const int cx = static_cast<int>(std::clamp(std::round(q.x()), 0.0, width() - 1.0));
    const int cy = static_cast<int>(std::clamp(std::round(q.y()), 0.0, height() - 1.0));
    Eigen::Vector3d c[4];
    sampler().CornerDirections(cx, cy, c);
    const double pixel_angle = std::max(1e-9, std::acos(std::clamp(c[0].dot(c[2]), -1.0, 1.0)) / std::sqrt(2.0));
    const double rpx = std::asin(std::min(1.0, rho / dist)) / pixel_angle * 1.25 + 2;
    // Clamped as doubles first: a point near the camera plane projects far out.
    auto px = [](double v, int hi) { return static_cast<int>(std::clamp(v, -1.0, static_cast<double>(hi) + 1)); };
    x0 = std::max(0, px(std::floor(q.x() - rpx), width()));
    x1 = std::min(width() - 1, px(std::ceil(q.x() + rpx), width()));
    ya = std::max(ya, px(std::floor(q.y() - rpx), height()));
    yb = std::min(yb, px(std::ceil(q.y() + rpx), height()));
  }
  const double inv_a = 1 / cache_->settings_.accuracy;
  const double inv_n = 1 / std::sqrt(1 - std::cos(cache_->settings_.normal_deg * kDegToRad));
  // Points farther than the record's reach (accuracy x R_i, widened by a
  // relative 1e-6 so that rounding cannot drop a point Weight would take)
  // get no weight: rejected without Weight's square roots.
  const double reach = cache_->settings_.accuracy * r.r * (1 + 1e-6), reach2 = reach * reach;
  for (int y = ya; y <= yb; ++y)
    for (int x = x0; x <= x1; ++x)
      for (int s = 0; s < samples_; ++s) {
        const size_t k = (static_cast<size_t>(y) * width() + x) * samples_ + s;
        // The mixed entry: virtual records on virtual points, real ones on real.
        Entry& m = mixed_[k];
        if (m.valid && m.is_virtual == r.on_virtual && (m.p - r.p).squaredNorm() <= reach2) {
          const Eigen::Vector3d mn = m.n.cast<double>();
          const double w = Weight(r, m.p, mn, inv_a, inv_n);
          if (w > 0) {
            const auto [em, er] = Extrapolated(r, m.p, mn);
            m.w += static_cast<float>(w);
            m.sum_m += (w * em).cast<float>();
            m.sum_r += (w * er).cast<float>();
            used = true;
          }
        }
        if (r.on_virtual || !m.is_virtual || real_index_[k] == kNoEntry) continue;
        Entry& e = real_[real_index_[k]];
        if (e.valid && (e.p - r.p).squaredNorm() <= reach2) {  // the real point behind a virtual one
          const Eigen::Vector3d en = e.n.cast<double>();
          const double w = Weight(r, e.p, en, inv_a, inv_n);
          if (w > 0) {
            e.w += static_cast<float>(w);
            e.sum_r += (w * Extrapolated(r, e.p, en).second).cast<float>();
            used = true;
          }
        }
      }
  if (used) std::atomic_ref<uint8_t>(used_[index]).store(1, std::memory_order_relaxed);
}

void IcFrameRenderer::SplatAll(const std::vector<size_t>& which) {
  // Bands of rows in parallel; each band visits every record.
  const int64_t band = 8, bands = (height() + band - 1) / band;
  ParallelFor(0, bands, [&](int64_t b) {
    const int64_t y0 = b * band, y1 = std::min<int64_t>(height(), y0 + band);
    for (size_t i : which) Splat(i, y0, y1);
  });
  splatted_ += static_cast<int64_t>(which.size());
}

// G-buffer: the first hits of each camera sample's mixed ray and, where it
// meets a virtual object, of its real ray (a second pass, into real_).
void IcFrameRenderer::BuildGBuffer(int spp) {
  const EmbreeScene& embree = scene_.embree();
  const size_t n = static_cast<size_t>(width()) * height() * spp;
  mixed_.Reserve(n);  // untouched: the pass below writes every entry
  std::atomic<int64_t> outside{0};
  auto gbuffer = [&](bool real_pass) {
    ParallelFor(0, height(), [&](int64_t y) {
      for (int x = 0; x < width(); ++x) {
        if (!sampler().PixelValid(x, static_cast<int>(y))) {
          if (!real_pass)
            for (int s = 0; s < spp; ++s) mixed_[(static_cast<size_t>(y) * width() + x) * spp + s].Clear();
          continue;
        }
        Eigen::Vector3d c[4];
        sampler().CornerDirections(x, static_cast<int>(y), c);
        const double pixel_angle = std::acos(std::clamp(c[0].dot(c[2]), -1.0, 1.0)) / std::sqrt(2.0);
        for (int s = 0; s < spp; ++s) {
          const size_t k = (static_cast<size_t>(y) * width() + x) * spp + s;
          if (real_pass && real_index_[k] == kNoEntry) continue;
          Ray ray;
          sampler().Sample(x, static_cast<int>(y), first_ + s, &ray);
          ray.mask = real_pass ? kMaskReal : kMaskAll;
          Entry* e = real_pass ? &real_[real_index_[k]] : &mixed_[k];
          e->Clear();
          Hit hit;
          if (!embree.Intersect(ray, &hit)) continue;
          const PathVertex v = MakeVertex(scene_, ray, hit);
          e->p = v.p;
          e->n = v.frame.n.cast<float>();
          e->footprint = static_cast<float>(hit.t * pixel_angle);
          e->valid = true;
          e->is_virtual = hit.is_virtual;
          e->needed = hit.is_virtual || cache_->InInfluence(v.p);
          if (!e->needed) outside.fetch_add(1);
        }
      }
    });
  };
  gbuffer(false);
  real_index_.assign(n, kNoEntry);
  uint32_t behind = 0;
  for (size_t k = 0; k < n; ++k)
    if (mixed_[k].is_virtual) real_index_[k] = behind++;
  real_.resize(behind);
  for (Entry& e : real_) e.Clear();
  gbuffer(true);
  outside_influence_ = outside.load();
}

// Records no frame has used for evict_after frames go; records due for
// re-evaluation (t_max frames old, or the world changed) are evaluated;
// then every record is splatted.
void IcFrameRenderer::RefreshRecords() {
  const IcSettings& st = cache_->settings_;
  if (st.evict_after > 0) {
    const size_t before = cache_->records_.size();
    std::erase_if(cache_->records_, [&](const IcRecord& r) { return frame_ - r.used_frame > st.evict_after; });
    evicted_ = static_cast<int64_t>(before - cache_->records_.size());
    cache_->evicted_ += evicted_;
  }
  used_.assign(cache_->records_.size(), 0);
  {
    std::vector<size_t> due;
    for (size_t i = 0; i < cache_->records_.size(); ++i)
      if (frame_ - cache_->records_[i].evaluated_frame >= st.t_max || cache_->records_[i].stale) due.push_back(i);
    ParallelFor(0, static_cast<int64_t>(due.size()), [&](int64_t j) {
      IcRecord* r = &cache_->records_[due[static_cast<size_t>(j)]];
      cache_->Evaluate(r, frame_, virtual_tracer_.get());
      cache_->ClampGradients(r);
    });
    reevaluated_ = static_cast<int64_t>(due.size());
    cache_->reevaluated_ += reevaluated_;
    for (size_t i : due) pass_record_rays_ += cache_->RaysFor(cache_->records_[i]);
    std::vector<size_t> all(cache_->records_.size());
    for (size_t i = 0; i < all.size(); ++i) all[i] = i;
    SplatAll(all);
  }
}

// Miss detection: per tile, the first needed sample of zero weight gets a
// record; passes repeat until none is left.
void IcFrameRenderer::AddRecordsWhereMissing() {
  const IcSettings& st = cache_->settings_;
  const size_t n = static_cast<size_t>(width()) * height() * samples_;
  const int tile = st.tile;
  const int tiles_x = (width() + tile - 1) / tile, tiles_y = (height() + tile - 1) / tile;
  std::vector<int64_t> resume(static_cast<size_t>(tiles_x) * tiles_y, 0);
  // A spatial hash of the records for neighbour clamping.
  const double cell = [&] {
    double f = 0;
    int64_t c = 0;
    for (size_t k = 0; k < n; ++k)
      if (mixed_[k].valid) f += mixed_[k].footprint, ++c;
    return std::max(1e-6, c > 0 ? 2 * st.max_spacing_px * f / c : 1.0);
  }();
  // The grids hold what the clamp reads of each record, side by side in
  // memory (a record is 400 bytes).
  struct Near {
    Eigen::Vector3d p;
    double r_hit;
    bool on_virtual;
  };
  auto near = [&](size_t i) {
    const IcRecord& o = cache_->records_[i];
    return Near{o.p, o.r_hit, o.on_virtual};
  };
  std::unordered_map<int64_t, std::vector<Near>> grid;
  auto key = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d g = (p / cell).array().floor();
    return (static_cast<int64_t>(g.x()) * 73856093) ^ (static_cast<int64_t>(g.y()) * 19349663) ^
           (static_cast<int64_t>(g.z()) * 83492791);
  };
  // A grid 8 times finer, for a record whose clamping ball is small: only a
  // record j closer than min(R_i, r_max) can change the clamped radius
  // (0.5 r_hit_j + |x_i - x_j| is at least the distance), and on dense
  // records (a reconstructed room's noisy surfaces) the coarse cells around
  // hold thousands each.  The same records decide: the same radii.
  const double fine = cell / 8;
  struct CellKey {
    int64_t x, y, z;
    bool operator==(const CellKey&) const = default;
  };
  struct CellHash {
    size_t operator()(const CellKey& k) const {
      return static_cast<size_t>(
          HashCombine(HashCombine(static_cast<uint64_t>(k.x), static_cast<uint64_t>(k.y)), static_cast<uint64_t>(k.z)));
    }
  };
  std::unordered_map<CellKey, std::vector<Near>, CellHash> fine_grid;
  auto fine_key = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d g = (p / fine).array().floor();
    return CellKey{static_cast<int64_t>(g.x()), static_cast<int64_t>(g.y()), static_cast<int64_t>(g.z())};
  };
  for (size_t i = 0; i < cache_->records_.size(); ++i) {
    grid[key(cache_->records_[i].p)].push_back(near(i));
    fine_grid[fine_key(cache_->records_[i].p)].push_back(near(i));
  }
  for (;;) {
    std::vector<IcRecord> fresh(resume.size());
    std::vector<char> made(resume.size(), 0);
    ParallelFor(0, static_cast<int64_t>(resume.size()), [&](int64_t t) {
      const int tx = static_cast<int>(t % tiles_x), ty = static_cast<int>(t / tiles_x);
      const int w = std::min(tile, width() - tx * tile), h = std::min(tile, height() - ty * tile);
      const int64_t total = static_cast<int64_t>(w) * h * samples_ * 2;
      for (int64_t& j = resume[static_cast<size_t>(t)]; j < total; ++j) {
        const int64_t s2 = j % (samples_ * 2), px = j / (samples_ * 2);
        const int x = tx * tile + static_cast<int>(px % w), y = ty * tile + static_cast<int>(px / w);
        const size_t k = (static_cast<size_t>(y) * width() + x) * samples_ + static_cast<size_t>(s2 / 2);
        if (s2 % 2 == 1 && real_index_[k] == kNoEntry) continue;
        const Entry& e = s2 % 2 == 0 ? mixed_[k] : real_[real_index_[k]];
        if (!e.valid || !e.needed || e.w > 0) continue;
        if (s2 % 2 == 1 && !mixed_[k].is_virtual) continue;
        IcRecord r;
        r.p = e.p;
        r.n = e.n.cast<double>();
        r.on_virtual = e.is_virtual;
        // The clamps bound the influence radius (accuracy x R_i) in pixels.
        r.r_min = st.min_spacing_px * e.footprint / st.accuracy;
        r.r_max = st.max_spacing_px * e.footprint / st.accuracy;
        fresh[static_cast<size_t>(t)] = r;
        made[static_cast<size_t>(t)] = 1;
        break;
      }
    });
    std::vector<size_t> added;
    for (size_t t = 0; t < fresh.size(); ++t)
      if (made[t]) {
        fresh[t].index = cache_->next_index_++;
        fresh[t].used_frame = frame_;
        added.push_back(cache_->records_.size());
        cache_->records_.push_back(fresh[t]);
        used_.push_back(0);
      }
    if (added.empty()) break;
    ++miss_passes_;
    ParallelFor(0, static_cast<int64_t>(added.size()), [&](int64_t j) {
      cache_->Evaluate(&cache_->records_[added[static_cast<size_t>(j)]], frame_, virtual_tracer_.get());
    });
    // R_i: half the least hit distance (Tabellion & Lamorlette), clamped by
    // the neighbours (R_i <= R_j + |x_i - x_j|) and to the pixel limits.
    for (size_t i : added) {
      IcRecord& r = cache_->records_[i];
      double ri = 0.5 * r.r_hit;
      const double ball = std::min(ri, r.r_max);  // the records that can clamp r lie closer
      auto clamp_by = [&](const std::vector<Near>& records) {
        for (const Near& o : records)
          if (o.on_virtual == r.on_virtual) ri = std::min(ri, 0.5 * o.r_hit + (o.p - r.p).norm());
      };
      if (ball <= 2 * fine) {  // within one coarse cell's reach: the fine cells the ball meets
        const CellKey lo = fine_key(r.p - Eigen::Vector3d::Constant(ball));
        const CellKey hi = fine_key(r.p + Eigen::Vector3d::Constant(ball));
        for (int64_t z = lo.z; z <= hi.z; ++z)
          for (int64_t y = lo.y; y <= hi.y; ++y)
            for (int64_t x = lo.x; x <= hi.x; ++x)
              if (auto it = fine_grid.find(CellKey{x, y, z}); it != fine_grid.end()) clamp_by(it->second);
      } else {
        // Neighbours within 2 cells (a far record, with a wide footprint, is
        // clamped by its near neighbours only: the search stays bounded).
        const int reach = static_cast<int>(std::min(2.0, std::ceil(ball / cell)));
        const Eigen::Vector3d g = (r.p / cell).array().floor();
        for (int dz = -reach; dz <= reach; ++dz)
          for (int dy = -reach; dy <= reach; ++dy)
            for (int dx = -reach; dx <= reach; ++dx) {
              const Eigen::Vector3d q =
                  (g + Eigen::Vector3d(dx, dy, dz)) * cell + Eigen::Vector3d::Constant(0.5 * cell);
              if (auto it = grid.find(key(q)); it != grid.end()) clamp_by(it->second);
            }
      }
      r.r = std::clamp(ri, r.r_min, r.r_max);
      cache_->ClampGradients(&r);
      grid[key(r.p)].push_back(near(i));
      fine_grid[fine_key(r.p)].push_back(near(i));
    }
    new_records_ += static_cast<int64_t>(added.size());
    for (size_t i : added) pass_record_rays_ += cache_->RaysFor(cache_->records_[i]);
    SplatAll(added);
  }
}

void IcFrameRenderer::RenderPass(int spp) {
  const IcSettings& st = cache_->settings_;
  samples_ = spp;
  first_ = samples_per_pixel();
  const ScopedTimer gbuffer_timer(nullptr, "");
  BuildGBuffer(spp);
  gbuffer_s_ += gbuffer_timer.Seconds();
  const ScopedTimer records_timer(nullptr, "");
  pass_record_rays_ = 0;
  RefreshRecords();
  AddRecordsWhereMissing();
  cache_->created_ += new_records_;
  cache_->passes_ += miss_passes_;
  cache_->record_rays_ += pass_record_rays_;

  records_s_ += records_timer.Seconds();
  const ScopedTimer shade_timer(nullptr, "");
  interpolated_.assign(static_cast<size_t>(width()) * height(), NAN);
  positions_.assign(static_cast<size_t>(width()) * height(), Eigen::Vector3f::Constant(NAN));
  if (st.glossy_cache && scene_.has_glossy()) BuildGrid();  // else no glossy ray looks records up
  ShadePixels(spp);
  shade_s_ += shade_timer.Seconds();
  // Splatted or looked up with weight > 0.
  for (size_t i = 0; i < used_.size(); ++i)
    if (used_[i]) cache_->records_[i].used_frame = frame_;
}

int64_t IcFrameRenderer::ShadePoint(const PathVertex& v, bool xv, bool want_m, bool want_r, const Eigen::Vector3d& e_m,
                                    const Eigen::Vector3d& e_r, int depth, const Eigen::Vector3d& beta, Sampler& g,
                                    Eigen::Vector3d* mixed_out, Eigen::Vector3d* real_out) {
  int64_t rays = 0;
  Eigen::Vector3d mixed = Eigen::Vector3d::Zero(), real = Eigen::Vector3d::Zero();
  auto done = [&] {
    *mixed_out += beta.cwiseProduct(mixed);
    *real_out += beta.cwiseProduct(real);
    return rays;
  };
  if (want_m) mixed += v.emission;
  if (want_r) real += v.emission;
  if (v.bsdf.IsBlack()) return done();
  const bool glossy = HasGlossyLobe(scene_, v);
  PathVertex vd = v;
  vd.bsdf = DiffuseLobe(scene_, v);
  // A camera point on an object takes IcSettings::object_direct_samples,
  // one on the room shadow_samples of the objects' shadows.
  const int n_direct = depth == 0 && xv ? cache_->settings().object_direct_samples : 1;
  const int n_shadows = depth == 0 ? cache_->settings().shadow_samples : 1;
  rays += DirectDiffuseSamples(
      n_direct, scene_, vd, v.albedo, xv, want_m, want_r, g, &mixed, &real,
      [&](Ray sr) {
        const VirtualTest t = TestVirtualBlockers(scene_, sr);
        rays += t != VirtualTest::kSkipped;
        return t == VirtualTest::kBlocked ? 0.0 : 1.0;
      },
      n_shadows);
  const Eigen::Vector3d f = v.albedo * kInvPi;
  if (want_m) mixed += f.cwiseProduct(e_m);
  if (want_r) real += f.cwiseProduct(e_r);
  if (!glossy) return done();
  PathVertex vg = v;
  vg.bsdf = GlossyLobe(scene_, v);
  NextEvent(scene_, vg, g, [&](const Eigen::Vector3d& c, Ray shadow, bool vl) {
    rays += AddNextEvent(scene_, c, shadow, vl, xv, want_m, want_r, &mixed, &real);
  });
  const IcSettings& st = cache_->settings();
  const int glossy_depth = st.glossy_depth < 0 ? st.max_depth : std::min(st.glossy_depth, st.max_depth);
  if (depth >= glossy_depth) return done();  // next-event light only from here
  // The lobe's rays: glossy_rays at a camera point (splitting), one deeper.
  const int n = depth == 0 ? std::max(1, st.glossy_rays) : 1;
  for (int k = 0; k < n; ++k) {
    BsdfSample bs;
    const double ul = g.NextDouble();
    const auto [u0, u1] = g.Next2D();
    if (!vg.bsdf.Sample(v.frame.ToLocal(v.wo_world), ul, u0, u1, &bs)) continue;
    const Eigen::Vector3d b = bs.f * (std::abs(bs.wi.z()) / (bs.pdf * n));
    const Ray next = MakeRay(v.OriginFor(v.frame.ToWorld(bs.wi)), v.frame.ToWorld(bs.wi), kMaskAll);
    if (xv && !want_r) {  // the mixed path from a virtual surface: the plate where it sees
      int nr = 0;
      mixed += glossy_tracer_.MixedRadianceFromVirtual(next, b, bs.pdf, depth + 1, g, &nr);
      rays += nr;
    } else if (st.glossy_cache) {
      rays += Continue(next, want_m, want_r, depth + 1, b, bs.pdf, g, &mixed, &real);
    } else if (want_r && !want_m) {
      int nr = 0;
      real += glossy_tracer_.RealRadiance(next, b, bs.pdf, depth + 1, g, &nr);
      rays += nr;
    } else {
      PathSample ps = glossy_tracer_.TraceFrom(next, b, bs.pdf, depth + 1, g);
      rays += ps.rays;
      mixed += ps.mixed;
      if (want_r) real += ps.real;
    }
  }
  return done();
}

int64_t IcFrameRenderer::Continue(Ray ray, bool want_m, bool want_r, int depth, const Eigen::Vector3d& beta,
                                  double prev_pdf, Sampler& g, Eigen::Vector3d* mixed, Eigen::Vector3d* real) {
  ray.mask = want_m ? kMaskAll : kMaskReal;
  Hit hit;
  int64_t rays = 1;
  if (!scene_.embree().Intersect(ray, &hit)) {
    const Eigen::Vector3d e = beta.cwiseProduct(Escaped(scene_, ray, prev_pdf, kRealLights));
    if (want_r) *real += e;
    if (want_m) *mixed += e + beta.cwiseProduct(Escaped(scene_, ray, prev_pdf, kVirtualLights));
    return rays;
  }
  if (hit.is_virtual && want_r) {  // the paths part: the real one behind the object
    Sampler real_rng = g;
    rays += Continue(ray, false, true, depth, beta, prev_pdf, real_rng, mixed, real);
    want_r = false;
  }
  const PathVertex v = MakeVertex(scene_, ray, hit);
  // The indirect diffuse light here: the records', or miss_rays paths.
  Eigen::Vector3d e_m = Eigen::Vector3d::Zero(), e_r = Eigen::Vector3d::Zero();
  if (!v.bsdf.IsBlack() && !LookUp(v.p, v.frame.n, hit.is_virtual, &e_m, &e_r) &&
      (hit.is_virtual || cache_->InInfluence(v.p))) {
    ++lookup_misses_;
    const int n = std::max(1, cache_->settings_.miss_rays);
    for (int k = 0; k < n; ++k) {
      const auto u = g.Next2D();
      const auto d = SampleCosineHemisphere(u[0], u[1]);
      const double pdf = d[2] * kInvPi;
      if (!(pdf > 0)) continue;
      const Ray r = MakeRay(v.origin, v.frame.ToWorld(Eigen::Vector3d(d[0], d[1], d[2])), kMaskAll);
      // Bounce 1 onwards, first-segment escapes left out (the direct light's), as a record's ray.
      const PathSample ps = cache_->tracer_.TraceFrom(r, Eigen::Vector3d::Ones(), pdf, 1, g, 2);
      rays += ps.rays;
      if (ps.mixed.allFinite() && ps.real.allFinite()) {
        e_m += (kPi / n) * ps.mixed;
        e_r += (kPi / n) * ps.real;
      }
    }
  }
  rays += ShadePoint(v, hit.is_virtual, want_m, want_r, e_m, e_r, depth, beta, g, mixed, real);
  return rays;
}

namespace {

int64_t CellKey(int64_t x, int64_t y, int64_t z) { return (x * 73856093) ^ (y * 19349663) ^ (z * 83492791); }

}  // namespace

void IcFrameRenderer::BuildGrid() {
  for (auto& g : grid_) g.clear();
  wide_.clear();
  const auto& records = cache_->records_;
  const double a = cache_->settings_.accuracy;
  std::vector<double> reach;
  reach.reserve(records.size());
  for (const IcRecord& r : records) reach.push_back(a * r.r);
  if (reach.empty()) return;
  std::vector<double> sorted = reach;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  for (int l = 0; l < kGridLevels; ++l) grid_cell_[l] = std::max(1e-6, 2 * sorted[sorted.size() / 2]) * (1 << (2 * l));
  for (size_t i = 0; i < records.size(); ++i) {
    bool placed = false;
    for (int l = 0; l < kGridLevels && !placed; ++l) {
      const Eigen::Vector3d lo = ((records[i].p.array() - reach[i]) / grid_cell_[l]).floor();
      const Eigen::Vector3d hi = ((records[i].p.array() + reach[i]) / grid_cell_[l]).floor();
      const Eigen::Vector3d cells = hi - lo + Eigen::Vector3d::Ones();
      if (!cells.allFinite() || cells.prod() > 64) continue;
      for (int64_t x = static_cast<int64_t>(lo.x()); x <= static_cast<int64_t>(hi.x()); ++x)
        for (int64_t y = static_cast<int64_t>(lo.y()); y <= static_cast<int64_t>(hi.y()); ++y)
          for (int64_t z = static_cast<int64_t>(lo.z()); z <= static_cast<int64_t>(hi.z()); ++z) {
            // Two cells of one record can share a key: listed once.
            std::vector<uint32_t>& list = grid_[l][CellKey(x, y, z)];
            if (list.empty() || list.back() != i) list.push_back(static_cast<uint32_t>(i));
          }
      placed = true;
    }
    if (!placed) wide_.push_back(static_cast<uint32_t>(i));
  }
}

bool IcFrameRenderer::LookUp(const Eigen::Vector3d& p, const Eigen::Vector3d& n, bool on_virtual, Eigen::Vector3d* e_m,
                             Eigen::Vector3d* e_r) {
  ++lookups_;
  const double inv_a = 1 / cache_->settings_.accuracy;
  const double inv_n = 1 / std::sqrt(1 - std::cos(cache_->settings_.normal_deg * kDegToRad));
  double w_sum = 0;
  Eigen::Vector3d sum_m = Eigen::Vector3d::Zero(), sum_r = Eigen::Vector3d::Zero();
  auto visit = [&](uint32_t i) {
    const IcRecord& r = cache_->records_[i];
    if (r.on_virtual != on_virtual) return;
    const double w = Weight(r, p, n, inv_a, inv_n);
    if (!(w > 0)) return;
    const auto [em, er] = Extrapolated(r, p, n);
    w_sum += w;
    sum_m += w * em;
    sum_r += w * er;
    std::atomic_ref<uint8_t>(used_[i]).store(1, std::memory_order_relaxed);
  };
  for (int l = 0; l < kGridLevels; ++l) {
    const Eigen::Vector3d c = (p / grid_cell_[l]).array().floor();
    if (!c.allFinite()) continue;
    const auto it =
        grid_[l].find(CellKey(static_cast<int64_t>(c.x()), static_cast<int64_t>(c.y()), static_cast<int64_t>(c.z())));
    if (it != grid_[l].end())
      for (uint32_t i : it->second) visit(i);
  }
  for (uint32_t i : wide_) visit(i);
  if (!(w_sum > 0)) return false;
  *e_m = sum_m / w_sum;
  *e_r = sum_r / w_sum;
  return true;
}

void IcFrameRenderer::Shade(const Ray& ray, Sampler& rng, int64_t, size_t pi, int sample, PathSample* out) {
  const EmbreeScene& embree = scene_.embree();
  const size_t k = pi * static_cast<size_t>(samples_) + static_cast<size_t>(sample - first_);
  int64_t row_rays = 0;
  Eigen::Vector3d mixed = Eigen::Vector3d::Zero(), real = Eigen::Vector3d::Zero();
  bool primary_virtual = false;
  // One camera point for the wanted solutions: emission, direct light,
  // cached indirect diffuse light, and the glossy lobe's path.
  auto shade = [&](const Ray& r, const Hit& hit, bool want_m, bool want_r, const Eigen::Vector3d& e_m,
                   const Eigen::Vector3d& e_r, Sampler& g) {
    row_rays += ShadePoint(MakeVertex(scene_, r, hit), hit.is_virtual, want_m, want_r, e_m, e_r, 0,
                           Eigen::Vector3d::Ones(), g, &mixed, &real);
  };
  const Entry& me = mixed_[k];
  Hit hit;
  ++row_rays;
  if (!embree.Intersect(ray, &hit)) {
    AddEscapedCameraRay(scene_, ray, &mixed, &real);
  } else if (hit.is_virtual) {
    primary_virtual = true;
    const Entry* re = RealEntry(k);
    Sampler real_rng = rng;
    Ray rr = ray;
    rr.mask = kMaskReal;
    Hit rh;
    ++row_rays;
    if (embree.Intersect(rr, &rh)) {
      const Eigen::Vector3d er =
          re && re->w > 0 ? Eigen::Vector3d((re->sum_r / re->w).cast<double>()) : Eigen::Vector3d::Zero();
      shade(rr, rh, false, true, Eigen::Vector3d::Zero(), er, real_rng);
    } else {
      real += Escaped(scene_, rr, 0, kRealLights);
    }
    const Eigen::Vector3d em = me.w > 0 ? Eigen::Vector3d((me.sum_m / me.w).cast<double>()) : Eigen::Vector3d::Zero();
    shade(ray, hit, true, false, em, Eigen::Vector3d::Zero(), rng);
    if (sample == first_) interpolated_[pi] = static_cast<float>(Luminance(em));
  } else {
    // A real point: E_m and E_r interpolated with the same weights, so
    // that their difference is the interpolated differential irradiance.
    const double inv = me.w > 0 ? 1 / static_cast<double>(me.w) : 0;
    const Eigen::Vector3d em = me.sum_m.cast<double>() * inv, er = me.sum_r.cast<double>() * inv;
    shade(ray, hit, true, true, em, er, rng);
    if (sample == first_) interpolated_[pi] = static_cast<float>(Luminance(em - er));
  }
  if (sample == first_ && me.valid) positions_[pi] = me.p.cast<float>();
  out->mixed = mixed;
  out->real = real;
  out->primary_virtual = primary_virtual;
  out->rays = static_cast<int>(row_rays);
}

void IcFrameRenderer::Describe(Report* report, int frame) const {
  const std::string k = fmt::format("ic.frames.{}.", frame);
  report->SetMetric(k + "records_created", new_records_);
  report->SetMetric(k + "records_reevaluated", reevaluated_);
  report->SetMetric(k + "records_splatted", splatted_);
  report->SetMetric(k + "records_evicted", evicted_);
  report->SetMetric(k + "records", static_cast<int64_t>(cache_->records_.size()));
  report->SetMetric(k + "records_on_objects", std::count_if(cache_->records_.begin(), cache_->records_.end(),
                                                            [](const IcRecord& r) { return r.on_virtual; }));
  report->SetMetric(k + "miss_passes", miss_passes_);
  report->SetMetric(k + "pixel_rays", rays_traced());
  report->SetMetric(k + "glossy_lookups", lookups_.load());
  report->SetMetric(k + "glossy_lookup_misses", lookup_misses_.load());
  report->SetMetric(k + "seconds_gbuffer", gbuffer_s_);
  report->SetMetric(k + "seconds_records", records_s_);
  report->SetMetric(k + "seconds_shade", shade_s_);
  if (reevaluated_ == 0 && frame > 0)
    report->Skip(fmt::format("frame {}: record re-evaluation", frame),
                 "no record is t_max frames old: the records of earlier frames are reused as they are");
  if (outside_influence_ > 0)
    report->Skip(fmt::format("frame {}: cache records for {} G-buffer samples", frame, outside_influence_),
                 fmt::format("real points where the virtual objects' form factor bound is below {}: their indirect "
                             "difference is taken as zero",
                             cache_->settings_.influence_threshold));
}

double TemporalChange(const CameraModel& camera, const Rigid3& prev_pose, const std::vector<float>& prev,
                      const std::vector<Eigen::Vector3f>& prev_positions, const std::vector<Eigen::Vector3f>& positions,
                      const std::vector<float>& now) {
  double diff = 0, sum = 0;
  const int w = camera.width(), h = camera.height();
  for (size_t i = 0; i < now.size(); ++i) {
    if (!std::isfinite(now[i]) || !positions[i].allFinite()) continue;
    const Eigen::Vector3d pc = prev_pose.rotation.conjugate() * (positions[i].cast<double>() - prev_pose.translation);
    Eigen::Vector2d q;
    if (!camera.Project(pc, &q) || !q.allFinite()) continue;
    if (!(q.x() > -0.5 && q.y() > -0.5 && q.x() < w - 0.5 && q.y() < h - 0.5)) continue;
    const long x = std::lround(q.x()), y = std::lround(q.y());
    if (x < 0 || y < 0 || x >= w || y >= h) continue;
    const size_t j = static_cast<size_t>(y) * w + x;
    const float p = prev[j];
    // The same surface (not one hidden in the previous frame): within 1% of the distance.
    if (!std::isfinite(p) || !((prev_positions[j] - positions[i]).norm() < 0.01 * pc.norm())) continue;
    diff += std::abs(now[i] - p);
    sum += std::abs(now[i]);
  }
  return sum > 0 ? diff / sum : NAN;
}

namespace {

IcSettings ParseIcSettings(JsonSettings& s, const Scene& scene) {
  IcSettings o;
  s.Integer("rays", &o.rays, 1, 1 << 24);
  s.Integer("object_rays", &o.object_rays, 1, 1 << 24);
  s.Number("accuracy", &o.accuracy, 1e-3, 10);
  s.Number("min_spacing_px", &o.min_spacing_px, 0.1, 1e4);
  s.Number("max_spacing_px", &o.max_spacing_px, 0.1, 1e5);
  s.Integer("t_max", &o.t_max, 1, 1 << 20);
  s.Integer("evict_after", &o.evict_after, 0, 1 << 20);
  s.Integer("tile", &o.tile, 1, 1024);
  s.Number("influence_threshold", &o.influence_threshold, 0, 1);
  s.Integer("glossy_depth", &o.glossy_depth, -1, 64);
  s.Bool("glossy_cache", &o.glossy_cache);
  s.Integer("miss_rays", &o.miss_rays, 1, 1 << 16);
  s.Integer("glossy_rays", &o.glossy_rays, 1, 1024);
  s.Integer("object_direct_samples", &o.object_direct_samples, 1, 256);
  s.Integer("shadow_samples", &o.shadow_samples, 1, 256);
  s.Bool("plate_reflections", &o.plate_reflections);
  s.Bool("gradients", &o.gradients);
  s.Number("normal_deg", &o.normal_deg, 1, 90);
  if (o.min_spacing_px > o.max_spacing_px) s.Node("min_spacing_px").Fail("is larger than max_spacing_px");
  return WithSceneRender(o, scene);
}

class IcMethod : public SettingsMethod<IcSettings> {
 public:
  using SettingsMethod::SettingsMethod;
  void Prepare(const JobContext& job) override {
    st_.photograph = job.photograph;
    cache_ = std::make_unique<IrradianceCache>(job.rs, st_);
    if (job.frame_begin > 0)
      job.report->Warn(
          fmt::format("ic: the cache starts empty at frame {} (records carry over between frames), so "
                      "frames of this shard differ from an unsharded run within ic's accuracy",
                      job.frame_begin));
  }
  std::vector<std::string> WorldChanged(const JobContext& job, const WorldChange& change) override {
    if (!cache_) {
      Prepare(job);
      return {"irradiance cache (made)"};
    }
    const std::string what = cache_->WorldChanged(change);
    return what.empty() ? std::vector<std::string>{} : std::vector<std::string>{what};
  }
  std::unique_ptr<FrameMethod> NewFrame(const FrameContext& f) override {
    return std::make_unique<IcFrameRenderer>(f.rs, cache_.get(), f.camera, f.world_from_cam, f.seed, f.frame,
                                             f.exposure, f.plates);
  }
  void FrameDone(const FrameMethod& fm, const FrameContext& f, Report* report, Json* fj) override {
    const auto& ic = static_cast<const IcFrameRenderer&>(fm);
    ic.Describe(report, f.frame);
    if (Json c = PlateCountersJson(ic.plate_counters()); !c.is_null()) (*fj)["plate_reflections"] = std::move(c);
    if (!prev_irradiance_.empty()) {
      const double change =
          TemporalChange(f.camera, prev_pose_, prev_irradiance_, prev_positions_, ic.positions(), ic.interpolated());
      (*fj)["temporal_change"] = change;
      report->SetMetric(fmt::format("ic.frames.{}.temporal_change", f.frame), change);
    }
    prev_irradiance_ = ic.interpolated();
    prev_positions_ = ic.positions();
    prev_pose_ = f.world_from_cam;
  }
  void Finish(Report* report) override {
    if (cache_) cache_->Describe(report);
  }
  bool TakesPlateReflections() const override { return st_.plate_reflections; }

 private:
  std::unique_ptr<IrradianceCache> cache_;
  // The temporal figure: the previous frame's interpolated irradiance.
  std::vector<float> prev_irradiance_;
  std::vector<Eigen::Vector3f> prev_positions_;
  Rigid3 prev_pose_;
};

}  // namespace

std::unique_ptr<RenderMethod> MakeIcMethod(JsonSettings& block, const Scene& scene) {
  return std::make_unique<IcMethod>(ParseIcSettings(block, scene));
}

}  // namespace mr
