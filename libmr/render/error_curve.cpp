#include "render/error_curve.h"

#include <cmath>

#include <fmt/format.h>

#include "core/error.h"
#include "core/image_metrics.h"

namespace mr {

Image ChangedRegion(const Image& ref, const Image& photo) {
  Image region = Image::Gray(ref.width(), ref.height());
  for (int y = 0; y < ref.height(); ++y)
    for (int x = 0; x < ref.width(); ++x)
      for (int c = 0; c < 3; ++c)
        if (ref.at(x, y, c) != photo.at(x, y, c)) region.at(x, y, 0) = 1;
  return region;
}

TruthNoise EstimateTruthNoise(const Image& mixed_half, const Image& real_half, const Image& mixed, const Image& real,
                              int n_half, int n) {
  if (n_half <= 0 || n_half >= n) throw Error(fmt::format("truth noise: {} of {} samples is not a part", n_half, n));
  const double n1 = n_half, n2 = n - n_half, k = n1 * n2 / (static_cast<double>(n) * n);
  double sum = 0, sum_region = 0;
  int64_t values = 0, region_values = 0;
  for (int y = 0; y < mixed.height(); ++y)
    for (int x = 0; x < mixed.width(); ++x) {
      bool changed = false;
      double e = 0;
      for (int c = 0; c < 3; ++c) {
        const double t = mixed.at(x, y, c), d = t - real.at(x, y, c);
        const double d_half = static_cast<double>(mixed_half.at(x, y, c)) - real_half.at(x, y, c);
        const double d_b = (n * d - n1 * d_half) / n2;
        changed |= mixed.at(x, y, c) != real.at(x, y, c);
        const double r = (d_half - d_b) * (d_half - d_b) / (t * t + kRelMseEpsilon);
        if (std::isfinite(r)) e += r;
      }
      sum += e;
      values += 3;
      if (changed) {
        sum_region += e;
        region_values += 3;
      }
    }
  TruthNoise noise;
  noise.relmse = values ? k * sum / values : 0;
  noise.region_relmse = region_values ? k * sum_region / region_values : 0;
  return noise;
}

FrameError MeasureFrame(const Image& composite, const Image& reference, const Image* region) {
  const ImageMetrics m = CompareImages(composite, reference);
  FrameError e;
  e.rmse = m.rmse;
  e.relmse = m.relmse;
  e.region_relmse = region ? CompareImages(composite, reference, region).relmse : m.relmse;
  return e;
}

double MeasureFlicker(const Image& composite, const Image& previous_composite, const Image& reference,
                      const Image& previous_reference, const Image* region) {
  double sum = 0;
  int64_t n = 0;
  for (int y = 0; y < reference.height(); ++y)
    for (int x = 0; x < reference.width(); ++x) {
      if (region && !(region->at(x, y, 0) > 0)) continue;
      for (int c = 0; c < 3; ++c) {
        const double t = reference.at(x, y, c);
        const double d = (static_cast<double>(composite.at(x, y, c)) - previous_composite.at(x, y, c)) -
                         (t - previous_reference.at(x, y, c));
        if (!std::isfinite(d)) continue;
        sum += d * d / (t * t + kRelMseEpsilon);
        ++n;
      }
    }
  return n > 0 ? sum / static_cast<double>(n) : 0.0;
}

void ErrorCurve::Checkpoint(double seconds, int spp, const FrameError& e) {
  frame_.push_back({{"seconds", seconds}, {"spp", spp}, {"relmse", e.relmse}, {"region_relmse", e.region_relmse}});
}

Json ErrorCurve::EndFrame(const FrameError& e) {
  sum_rmse_ += e.rmse;
  sum_relmse_ += e.relmse;
  sum_region_ += e.region_relmse;
  ++frames_;
  for (size_t k = 0; k < frame_.size(); ++k) {
    if (sum_.size() <= k)
      sum_.push_back(
          {{"seconds", 0.0}, {"spp", frame_[k]["spp"]}, {"relmse", 0.0}, {"region_relmse", 0.0}, {"frames", 0}});
    for (const char* key : {"seconds", "relmse", "region_relmse"})
      sum_[k][key] = sum_[k][key].get<double>() + frame_[k][key].get<double>();
    sum_[k]["frames"] = sum_[k]["frames"].get<int>() + 1;
  }
  Json out = frame_;
  frame_ = Json::array();
  return out;
}

Json ErrorCurve::MeanCurve() const {
  Json curve = Json::array();
  for (const Json& c : sum_) {
    const int nf = c["frames"].get<int>();
    curve.push_back({{"seconds", c["seconds"].get<double>() / nf},
                     {"spp", c["spp"]},
                     {"relmse", c["relmse"].get<double>() / nf},
                     {"region_relmse", c["region_relmse"].get<double>() / nf}});
  }
  return curve;
}

}  // namespace mr
