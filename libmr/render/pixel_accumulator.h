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
  // Samples whose value in the composite was not zero (the object changed
  // the path, or it sees the object).
  int nonzero(size_t i) const { return nonzero_[i]; }
  void Add(size_t i, const Eigen::Vector3d& mixed, const Eigen::Vector3d& real, bool primary_virtual) {
    sum_m_[i] += mixed;
    sum_r_[i] += real;
    const double dl = Luminance(mixed - real);
    sum_d_[i] += dl;
    sum_d2_[i] += dl * dl;
    // What the sample adds to the composite: I_m where it sees the object,
    // else the difference (the plate is constant).
    const double y = primary_virtual ? Luminance(mixed) : dl;
    sum_y_[i] += y;
    sum_y2_[i] += y * y;
    nonzero_[i] += y != 0 ? 1 : 0;
    coverage_[i] += primary_virtual ? 1 : 0;
  }
  // The composite's expected relative squared error from its own noise at
  // pixel i: the variance of the mean of the composite's sample values over
  // (luminance of mean I_m)^2 + 0.01 (relMSE's epsilon; I_m stands for the
  // plate).  Infinite below 2 samples.
  double CompositeRelVariance(size_t i) const;
  Image Mixed() const;
  Image Real() const;
  Image Mask() const;
  Image DifferenceVariance() const;
  Image SampleCount() const;

 private:
  int width_, height_;
  std::vector<Eigen::Vector3d> sum_m_, sum_r_;
  std::vector<double> sum_d_, sum_d2_, sum_y_, sum_y2_, coverage_;
  std::vector<int> count_, nonzero_;
};

// Adaptive sampling (render.adaptive): a pixel stops taking samples once it
// has at least min_spp samples of which at least min_nonzero changed the
// composite, and the largest CompositeRelVariance over it and its eight
// neighbours is at most `threshold` (relMSE).  A variance estimated from
// samples that all agree by chance is not trusted: a pixel the object
// changes through rare paths (its bounce light on the room) sees zeros
// first, and stopping it then loses the change (measured: 6% of the
// object's total change over the image at min_spp 8 without the
// min_nonzero rule).  The neighbourhood keeps a pixel sampling while the
// pixels around it are still noisy.  threshold 0: off.
struct AdaptiveSampling {
  double threshold = 0;
  int min_spp = 16;
  int min_nonzero = 8;
  bool on() const { return threshold > 0; }
};

// Marks in *stopped (one entry per pixel, kept once set) the pixels that
// meet the rule now; pixels with valid[i] == 0 are ignored.  Returns how many
// were newly stopped.
int64_t UpdateAdaptiveStops(const PixelAccumulator& acc, const AdaptiveSampling& a, const std::vector<char>& valid,
                            std::vector<char>* stopped);

}  // namespace mr
