// The per-pixel sums every rendering method keeps: mean I_m and I_r, the
// fraction of camera samples whose first hit is virtual (mask M), and the
// variance of the mean of luminance(I_m - I_r).  Each pixel is written by
// one thread only.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "light/environment.h"

namespace mr {

class PixelAccumulator {
 public:
  PixelAccumulator(int width, int height);
  int width() const { return width_; }
  int height() const { return height_; }
  // Counts `n` samples for pixel i before they are added (a non-finite
  // sample is counted but not added: never NaN in the image).
  void Count(size_t i, int n) { count_[i] += n; }
  int count(size_t i) const { return count_[i]; }
  void Add(size_t i, const Eigen::Vector3d& mixed, const Eigen::Vector3d& real, bool primary_virtual) {
    sum_m_[i] += mixed;
    sum_r_[i] += real;
    const double dl = Luminance(mixed - real);
    sum_d_[i] += dl;
    sum_d2_[i] += dl * dl;
    coverage_[i] += primary_virtual ? 1 : 0;
  }
  Image Mixed() const;
  Image Real() const;
  Image Mask() const;
  Image DifferenceVariance() const;
  Image SampleCount() const;

 private:
  int width_, height_;
  std::vector<Eigen::Vector3d> sum_m_, sum_r_;
  std::vector<double> sum_d_, sum_d2_, coverage_;
  std::vector<int> count_;
};

}  // namespace mr
