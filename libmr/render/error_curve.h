// A render's error against its reference as samples accumulate: the
// checkpoints of each frame, and their mean over the frames (the report's
// "curve", what mr-eval sweep and the benchmarks plot).
#pragma once

#include <optional>
#include <vector>

#include "core/image.h"
#include "core/json.h"

namespace mr {

// Where the reference differs from the photograph: the region the virtual
// objects change (1) and the rest (0).
Image ChangedRegion(const Image& reference, const Image& photo);

struct FrameError {
  double rmse = 0, relmse = 0, region_relmse = 0;  // region: the whole image when there is no region
};
FrameError MeasureFrame(const Image& composite, const Image& reference, const Image* region);

// Flicker: the error of the composite's frame-to-frame change against the
// reference's, relMSE-normalised by the reference, over `region` (the
// union of the two frames' changed regions; null: the whole image):
// mean ((C_f - C_f-1) - (T_f - T_f-1))^2 / (T_f^2 + 0.01).  A method whose
// frames each carry independent error e flickers by about 2e; one whose
// error repeats from frame to frame (a cache kept) by less.
double MeasureFlicker(const Image& composite, const Image& previous_composite, const Image& reference,
                      const Image& previous_reference, const Image* region);

// The noise of a converged differential render (the truth mr-synth writes),
// from the same render stopped halfway: (mixed_half, real_half) after the
// first n_half samples per pixel, (mixed, real) after all n.  What scoring
// sees of the truth is its difference D = mixed - real (the photograph is
// the real part, so it cancels), so the noise is that of D: with D_b the
// second part's mean, (n D - n_half D_half) / (n - n_half), the expected
// (D_half - D_b)^2 is sigma^2 (1/n_half + 1/(n - n_half)) and the truth's
// own variance sigma^2 / n is that times n_half (n - n_half) / n^2.  Both
// figures are relMSE-normalised by the truth (mixed), as every error they
// bound: `relmse` over the image, `region_relmse` over ChangedRegion.  An
// estimator's error against this truth cannot fall below them: a method at
// relMSE e is really at about e - noise.  Needs 0 < n_half < n.
struct TruthNoise {
  double relmse = 0, region_relmse = 0;
};
TruthNoise EstimateTruthNoise(const Image& mixed_half, const Image& real_half, const Image& mixed, const Image& real,
                              int n_half, int n);

class ErrorCurve {
 public:
  // A checkpoint of the current frame.
  void Checkpoint(double seconds, int spp, const FrameError& e);
  // The current frame's checkpoints as JSON; starts the next frame.
  Json EndFrame(const FrameError& final_error);
  int frames() const { return frames_; }
  // Means over the frames: rmse, relmse, region_relmse and the curve, for the report.
  double mean_rmse() const { return sum_rmse_ / frames_; }
  double mean_relmse() const { return sum_relmse_ / frames_; }
  double mean_region_relmse() const { return sum_region_ / frames_; }
  Json MeanCurve() const;

 private:
  Json frame_ = Json::array();
  std::vector<Json> sum_;
  double sum_rmse_ = 0, sum_relmse_ = 0, sum_region_ = 0;
  int frames_ = 0;
};

}  // namespace mr
