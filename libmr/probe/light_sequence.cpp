#include "probe/light_sequence.h"

#include <algorithm>
#include <cmath>

#include "core/check.h"
#include "core/color.h"
#include "core/error.h"
#include "core/spherical.h"
#include "probe/light_extraction.h"

namespace mr {

TimeMatch MatchLightToPlate(const std::vector<double>& light_times, const std::vector<double>& plate_times,
                            double max_dt, const std::string& light_name, const std::string& plate_name) {
  if (!(max_dt >= 0)) throw UsageError(fmt::format("maximum time difference {} must be >= 0", max_dt));
  auto check = [](const std::vector<double>& t, const std::string& name) {
    if (t.empty()) ThrowErrorAt(FileLoc{name}, "holds no frames");
    for (size_t i = 0; i < t.size(); ++i) {
      if (!std::isfinite(t[i])) ThrowErrorAt(FileLoc{name}, "frame {}'s timestamp is not finite", i);
      if (i > 0 && t[i] < t[i - 1])
        ThrowErrorAt(FileLoc{name}, "timestamps go backwards at frame {} ({:.6f} after {:.6f})", i, t[i], t[i - 1]);
    }
  };
  check(light_times, light_name);
  check(plate_times, plate_name);
  TimeMatch m;
  m.light_of_plate.assign(plate_times.size(), -1);
  for (size_t p = 0; p < plate_times.size(); ++p) {
    const double t = plate_times[p];
    const auto it = std::lower_bound(light_times.begin(), light_times.end(), t);
    int best = -1;
    double best_dt = max_dt;
    for (auto c : {it, it == light_times.begin() ? it : it - 1}) {
      if (c == light_times.end()) continue;
      const double dt = std::abs(*c - t);
      if (dt <= best_dt) {
        // Ties go to the earlier frame: the light at or before the plate's time.
        const int idx = static_cast<int>(c - light_times.begin());
        if (dt < best_dt || best < 0 || idx < best) best = idx;
        best_dt = dt;
      }
    }
    m.light_of_plate[p] = best;
    if (best < 0)
      ++m.unmatched;
    else
      m.max_dt_seen = std::max(m.max_dt_seen, std::abs(light_times[static_cast<size_t>(best)] - t));
  }
  if (m.unmatched == static_cast<int>(plate_times.size()))
    ThrowErrorAt(FileLoc{light_name},
                 "no light frame lies within {:.4f} s of any frame of {}: the light spans {:.4f} to "
                 "{:.4f} s, the plate {:.4f} to {:.4f} s (do the two clocks share an origin?)",
                 max_dt, plate_name, light_times.front(), light_times.back(), plate_times.front(), plate_times.back());
  return m;
}

void LightFilterOptions::Check() const {
  if (!(time_constant_s >= 0) || !std::isfinite(time_constant_s))
    throw UsageError(fmt::format("time constant {} s must be finite and >= 0", time_constant_s));
  if (!(jump_ratio > 1) || !std::isfinite(jump_ratio))
    throw UsageError(fmt::format("jump ratio {} must be > 1", jump_ratio));
  if (!(jump_floor >= 0)) throw UsageError("jump floor must be >= 0");
  if (!(confidence_keep >= 0 && confidence_keep <= 1)) throw UsageError("confidence_keep must be in [0, 1]");
}

LightFilter::LightFilter(const LightFilterOptions& options) : o_(options) { o_.Check(); }

void LightFilter::Restore(const Image& state, double t) {
  if (state.channels() != 4) ThrowError("a light map needs R G B and confidence");
  state_ = state;
  t_ = t;
  started_ = true;
}

namespace {

float Lum(const float* p) { return LuminanceF(p[0], p[1], p[2]); }

bool Finite4(const float* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]) && std::isfinite(p[3]);
}

}  // namespace

Image LightFilter::Add(const Image& map, double t, double exposure, LightFrameReport* report) {
  LightFrameReport r;
  if (map.channels() != 4) ThrowError("a light map needs R G B and confidence");
  if (!(exposure > 0) || !std::isfinite(exposure)) ThrowError("exposure {} must be finite and positive", exposure);
  const int w = map.width(), h = map.height();
  std::vector<double> sa(static_cast<size_t>(h));
  double total_sa = 0;
  for (int y = 0; y < h; ++y) {
    sa[static_cast<size_t>(y)] = LatLongPixelSolidAngle(0, y, w, h);
    total_sa += w * sa[static_cast<size_t>(y)];
  }
  // Seen directions this frame (finite, confidence > 0).
  std::vector<uint8_t> seen(static_cast<size_t>(map.pixel_count()), 0);
  double seen_sa = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float* p = map.data() + (static_cast<size_t>(y) * w + x) * 4;
      const bool s = Finite4(p) && p[3] > 0 && p[0] >= 0 && p[1] >= 0 && p[2] >= 0;
      seen[static_cast<size_t>(y) * w + x] = s;
      seen_sa += s ? sa[static_cast<size_t>(y)] : 0;
    }
  r.seen_fraction = seen_sa / total_sa;

  if (!started_) {
    state_ = Image(w, h, map.channel_names());
    for (int64_t i = 0; i < map.pixel_count(); ++i) {
      const float* p = &map.values()[static_cast<size_t>(i * 4)];
      float* s = &state_.values()[static_cast<size_t>(i * 4)];
      if (!seen[static_cast<size_t>(i)]) continue;  // stays 0, confidence 0
      for (int c = 0; c < 3; ++c) s[c] = static_cast<float>(p[c] / exposure);
      s[3] = p[3];
    }
    started_ = true;
    t_ = t;
    r.exposure = exposure;
    if (report) *report = r;
    return state_;
  }
  if (w != state_.width() || h != state_.height())
    ThrowError("a {}x{} light map after {}x{} ones", w, h, state_.width(), state_.height());
  if (t < t_) ThrowError("light frame at {:.6f} s after one at {:.6f} s: not in time order", t, t_);
  r.alpha = o_.time_constant_s > 0 ? 1 - std::exp(-(t - t_) / o_.time_constant_s) : 1.0;

  // The history's median luminance: the scale of "dark" and of the jump
  // floor (a mean would be the sun's).
  std::vector<float> lums;
  lums.reserve(static_cast<size_t>(state_.pixel_count()));
  for (int64_t i = 0; i < state_.pixel_count(); ++i) {
    const float* s = &state_.values()[static_cast<size_t>(i * 4)];
    if (s[3] > 0) lums.push_back(Lum(s));
  }
  double median = 0;
  if (!lums.empty()) {
    auto mid = lums.begin() + static_cast<long>(lums.size() / 2);
    std::nth_element(lums.begin(), mid, lums.end());
    median = *mid;
  }
  const double floor = o_.jump_floor * median;

  // Directions this frame updates: seen now, and not far less well than before.
  auto usable = [&](int x, int y) {
    const size_t i = static_cast<size_t>(y) * w + x;
    if (!seen[i]) return false;
    const float hist_conf = state_.at(x, y, 3);
    return !(hist_conf > 0 && map.at(x, y, 3) < o_.confidence_keep * hist_conf);
  };

  double k = exposure;
  if (o_.recover_exposure) {
    std::vector<double> ratios;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        if (!usable(x, y) || state_.at(x, y, 3) <= 0) continue;
        const double ls = Lum(state_.data() + (static_cast<size_t>(y) * w + x) * 4),
                     ln = Lum(map.data() + (static_cast<size_t>(y) * w + x) * 4) / exposure;
        if (ls > floor && ln > 0) ratios.push_back(ln / ls);
      }
    if (ratios.size() >= 16) {
      auto mid = ratios.begin() + static_cast<long>(ratios.size() / 2);
      std::nth_element(ratios.begin(), mid, ratios.end());
      if (*mid > 0 && std::isfinite(*mid)) k = exposure * *mid;
    }
  }
  r.exposure = k;

  // Candidate jumps, then those with neighbours that jump too.
  std::vector<uint8_t> cand(static_cast<size_t>(map.pixel_count()), 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!usable(x, y) || state_.at(x, y, 3) <= 0) continue;
      const double ls = Lum(state_.data() + (static_cast<size_t>(y) * w + x) * 4),
                   ln = Lum(map.data() + (static_cast<size_t>(y) * w + x) * 4) / k;
      const double hi = std::max(ls, ln), lo = std::min(ls, ln);
      cand[static_cast<size_t>(y) * w + x] = hi > o_.jump_ratio * lo && hi - lo > floor;
    }
  Image out = state_;
  double new_energy = 0, jump_energy = 0, filled_sa = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      float* s = &out.at(x, y, 0);
      if (!usable(x, y)) {
        filled_sa += s[3] > 0 ? sa[static_cast<size_t>(y)] : 0;
        if (s[3] > 0) new_energy += Lum(s) * sa[static_cast<size_t>(y)];
        continue;
      }
      const float* p = map.data() + (static_cast<size_t>(y) * w + x) * 4;
      bool jump = false;
      if (cand[i]) {
        int n = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int yy = y + dy, xx = (x + dx + w) % w;
            if ((dx || dy) && yy >= 0 && yy < h) n += cand[static_cast<size_t>(yy) * w + xx];
          }
        jump = n >= 2;
      }
      const double ls = Lum(s);
      const double a = jump || s[3] <= 0 ? 1.0 : r.alpha;
      for (int c = 0; c < 3; ++c) s[c] = static_cast<float>(s[c] + a * (p[c] / k - s[c]));
      s[3] = p[3];
      const double ln = Lum(s);
      new_energy += ln * sa[static_cast<size_t>(y)];
      if (jump) jump_energy += std::abs(ln - ls) * sa[static_cast<size_t>(y)];
    }
  r.filled_fraction = filled_sa / total_sa;
  r.jump_fraction = new_energy > 0 ? jump_energy / new_energy : 0;
  r.jump = r.jump_fraction > o_.jump_report_fraction;
  state_ = out;
  t_ = t;
  if (report) *report = r;
  return out;
}

}  // namespace mr

namespace mr {

LightMapError CompareLightMaps(const Image& estimate, const Image& reference) {
  if (estimate.channels() < 3 || reference.channels() < 3) ThrowError("light maps need R G B");
  const bool has_conf = estimate.channels() >= 4;
  Image ref = Image::Rgb(reference.width(), reference.height());
  Image est = Image::Rgb(estimate.width(), estimate.height());
  for (int y = 0; y < estimate.height(); ++y)
    for (int x = 0; x < estimate.width(); ++x)
      for (int c = 0; c < 3; ++c) est.at(x, y, c) = estimate.at(x, y, c);
  double seen_e = 0, all_e = 0, est_e = 0;
  for (int y = 0; y < reference.height(); ++y)
    for (int x = 0; x < reference.width(); ++x) {
      const Eigen::Vector3d d = LatLongPixelToDirection(Eigen::Vector2d(x, y), reference.width(), reference.height());
      const Eigen::Vector2d q = DirectionToLatLongPixel(d, estimate.width(), estimate.height());
      const int ex = std::clamp(static_cast<int>(std::lround(q.x())), 0, estimate.width() - 1);
      const int ey = std::clamp(static_cast<int>(std::lround(q.y())), 0, estimate.height() - 1);
      const bool seen = !has_conf || estimate.at(ex, ey, 3) > 0;
      const double sa = LatLongPixelSolidAngle(x, y, reference.width(), reference.height());
      const double l = LuminanceF(reference.at(x, y, 0), reference.at(x, y, 1), reference.at(x, y, 2));
      all_e += l * sa;
      if (!seen) continue;
      seen_e += l * sa;
      for (int c = 0; c < 3; ++c) ref.at(x, y, c) = reference.at(x, y, c);
    }
  for (int y = 0; y < estimate.height(); ++y)
    for (int x = 0; x < estimate.width(); ++x)
      est_e += LuminanceF(est.at(x, y, 0), est.at(x, y, 1), est.at(x, y, 2)) *
               LatLongPixelSolidAngle(x, y, estimate.width(), estimate.height());
  LightMapError e;
  const std::vector<Eigen::Vector3d> normals = SphereNormals(256);
  e.e_est = MapIrradiance(est, normals);
  e.e_ref = MapIrradiance(ref, normals);
  double d2 = 0, r2 = 0;
  for (size_t i = 0; i < normals.size(); ++i) {
    d2 += (e.e_est[i] - e.e_ref[i]) * (e.e_est[i] - e.e_ref[i]);
    r2 += e.e_ref[i] * e.e_ref[i];
  }
  e.irradiance_rel_rms = r2 > 0 ? std::sqrt(d2 / r2) : 0;
  e.energy_ratio = seen_e > 0 ? est_e / seen_e : 0;
  e.unseen_energy_fraction = all_e > 0 ? 1 - seen_e / all_e : 0;
  return e;
}

double LightFlicker(const LightMapError& a, const LightMapError& b) {
  MR_CHECK(a.e_est.size() == b.e_est.size() && a.e_ref.size() == b.e_ref.size());
  double d2 = 0, r2 = 0;
  for (size_t i = 0; i < b.e_ref.size(); ++i) {
    const double d = (b.e_est[i] - a.e_est[i]) - (b.e_ref[i] - a.e_ref[i]);
    d2 += d * d;
    r2 += b.e_ref[i] * b.e_ref[i];
  }
  return r2 > 0 ? std::sqrt(d2 / r2) : 0;
}

}  // namespace mr
