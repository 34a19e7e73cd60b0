#include "render/pixel_accumulator.h"

#include <algorithm>
#include <cmath>

namespace mr {

PixelAccumulator::PixelAccumulator(int width, int height) : width_(width), height_(height) {
  const size_t n = static_cast<size_t>(width) * height;
  sum_m_.assign(n, Eigen::Vector3d::Zero());
  sum_r_.assign(n, Eigen::Vector3d::Zero());
  sum_d_.assign(n, 0);
  sum_d2_.assign(n, 0);
  sum_y_.assign(n, 0);
  sum_y2_.assign(n, 0);
  coverage_.assign(n, 0);
  count_.assign(n, 0);
  nonzero_.assign(n, 0);
}

namespace {
Image MeanImage(const std::vector<Eigen::Vector3d>& sum, int w, int h, const std::vector<int>& count) {
  Image img = Image::Rgb(w, h);
  for (size_t i = 0; i < sum.size(); ++i) {
    const double inv = count[i] > 0 ? 1.0 / count[i] : 0.0;
    for (int c = 0; c < 3; ++c) img.values()[3 * i + static_cast<size_t>(c)] = static_cast<float>(sum[i][c] * inv);
  }
  return img;
}
}  // namespace

Image PixelAccumulator::Mixed() const { return MeanImage(sum_m_, width_, height_, count_); }
Image PixelAccumulator::Real() const { return MeanImage(sum_r_, width_, height_, count_); }

Image PixelAccumulator::Mask() const {
  Image img = Image::Gray(width_, height_);
  for (size_t i = 0; i < coverage_.size(); ++i)
    img.values()[i] = count_[i] > 0 ? static_cast<float>(coverage_[i] / count_[i]) : 0.f;
  return img;
}

Image PixelAccumulator::DifferenceVariance() const {
  Image img = Image::Gray(width_, height_);
  for (size_t i = 0; i < sum_d_.size(); ++i) {
    const double n = count_[i];
    if (n < 2) continue;
    const double mean = sum_d_[i] / n;
    const double var = std::max(0.0, (sum_d2_[i] / n - mean * mean)) * n / (n - 1);
    img.values()[i] = static_cast<float>(var / n);  // variance of the mean
  }
  return img;
}

double PixelAccumulator::CompositeRelVariance(size_t i) const {
  const double n = count_[i];
  if (n < 2) return INFINITY;
  const double mean = sum_y_[i] / n;
  const double var_mean = std::max(0.0, sum_y2_[i] / n - mean * mean) / (n - 1);
  const double l = Luminance(Eigen::Vector3d(sum_m_[i] / n));
  return var_mean / (l * l + 0.01);
}

int64_t UpdateAdaptiveStops(const PixelAccumulator& acc, const AdaptiveSampling& a, const std::vector<char>& valid,
                            std::vector<char>* stopped) {
  const int w = acc.width(), h = acc.height();
  std::vector<double> e(static_cast<size_t>(w) * h, 0.0);
  for (size_t i = 0; i < e.size(); ++i)
    e[i] = valid[i] && !(*stopped)[i]
               ? (acc.count(i) >= a.min_spp && acc.nonzero(i) >= a.min_nonzero ? acc.CompositeRelVariance(i) : INFINITY)
               : 0.0;
  int64_t newly = 0;
  std::vector<char> next = *stopped;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (!valid[i] || (*stopped)[i] || acc.count(i) < a.min_spp || acc.nonzero(i) < a.min_nonzero) continue;
      double worst = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
          worst = std::max(worst, e[static_cast<size_t>(yy) * w + xx]);
        }
      if (worst <= a.threshold) {
        next[i] = 1;
        ++newly;
      }
    }
  *stopped = std::move(next);
  return newly;
}

Image PixelAccumulator::SampleCount() const {
  Image img = Image::Gray(width_, height_);
  for (size_t i = 0; i < count_.size(); ++i) img.values()[i] = static_cast<float>(count_[i]);
  return img;
}

}  // namespace mr
