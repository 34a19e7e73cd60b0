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
