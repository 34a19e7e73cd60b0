// `pt`: differential path tracing (render/path_tracer.h) of every pixel,
// the unbiased reference of mr-render.
#pragma once

#include <algorithm>
#include <memory>
#include <vector>

#include "render/method.h"
#include "render/path_tracer.h"
#include "render/pixel_loop.h"

namespace mr {

// Renders a frame progressively: each pass adds samples to every pixel,
// each sample with its own generator (CameraSampler), so the result does not
// depend on the thread count or on how the samples are split into passes.
class PtFrameRenderer : public PixelLoopMethod {
 public:
  PtFrameRenderer(const RenderScene& scene, const CameraModel& camera, const Rigid3& world_from_cam,
                  const PathTracerSettings& settings, const CameraExposure& exposure = {});
  // Pixels sampled in the first pass only, their difference provably zero
  // (found from the second pass on).
  int64_t skipped_pixels() const override;
  // Real points met from virtual surfaces: from the plate or rendered.
  const PlateCounters& plate_counters() const { return tracer_.plate_counters(); }
  // Later passes sample only the pixels whose `only` is non-zero (one per
  // pixel; empty: every pixel again), each continuing its own sample
  // sequence: more samples where a pixel integrates a small bright source
  // (mr-synth's mirror sphere reflecting the sun).
  void RestrictTo(std::vector<char> only) { only_ = std::move(only); }

 private:
  void Shade(const Ray& ray, Sampler& rng, int64_t row, size_t pixel, int sample, PathSample* out) override;
  void ShadeBatch(Batch& batch, int64_t row) override;
  int batch_size() const override { return std::max(1, batch_); }
  bool PixelDone(size_t pixel) const override;
  // Whether every ray through the pixel provably meets no geometry.
  bool ProvablyEnvironment(size_t pixel) const;
  std::vector<char> only_;
  DifferentialPathTracer tracer_;
  int batch_ = 0;  // PathTracerSettings::batch (0: one by one)
  // Pixels whose difference is provably zero are found after their first
  // sample, among those whose first camera ray met nothing (`escaped_`):
  // the proof is tried only where it can hold.  Each pixel's entries are
  // touched by the one thread that shades it.
  enum : char { kUntested, kSkip, kKeep };
  bool skip_possible_ = false;
  Eigen::Vector3d eye_ = Eigen::Vector3d::Zero();
  double far_ = 1;
  std::vector<char> escaped_;
  mutable std::vector<char> skip_;
};

// The registry's `pt`, its settings read from render.pt.
std::unique_ptr<RenderMethod> MakePtMethod(JsonSettings& block, const Scene& scene);

}  // namespace mr
