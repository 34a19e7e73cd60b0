// The part every sampled method shares: the camera sampler, the pixel
// accumulator and the loop over pixels and samples.  A method derived from
// PixelLoopMethod implements Shade (one camera sample); RenderPass calls it
// for every valid pixel and sample, in parallel over rows, drops and counts
// non-finite samples, and accumulates the rest.  A method whose pass needs
// more (ic's cache records) overrides RenderPass and calls ShadePixels.
#pragma once

#include <cstdint>
#include <vector>

#include "render/camera_sampler.h"
#include "render/method.h"
#include "render/path_tracer.h"
#include "render/pixel_accumulator.h"

namespace mr {

class PixelLoopMethod : public FrameMethod {
 public:
  void RenderPass(int spp) override { ShadePixels(spp); }
  Image Mixed() const final { return acc_.Mixed(); }
  Image Real() const final { return acc_.Real(); }
  Image Mask() const final { return acc_.Mask(); }
  Image DifferenceVariance() const final { return acc_.DifferenceVariance(); }
  Image SampleCount() const final { return acc_.SampleCount(); }
  int64_t nonfinite_samples() const final { return nonfinite_; }
  bool SetAdaptive(const AdaptiveSampling& a) final {
    adaptive_ = a;
    return true;
  }
  int64_t adaptive_stopped() const final { return adaptive_stopped_; }
  int samples_per_pixel() const { return spp_; }
  // Closest-hit and occlusion queries of the samples (PathSample::rays).
  int64_t rays_traced() const { return rays_; }
  // Virtual shadow tests the samples left out (PathSample::virtual_tests_skipped).
  int64_t virtual_tests_skipped() const { return virtual_tests_skipped_; }

 protected:
  PixelLoopMethod(const CameraModel& camera, const Rigid3& world_from_cam, uint64_t seed, int frame,
                  const CameraExposure& exposure = {});
  // Sample `sample` of pixel `pixel` (in image row `row`) along camera ray
  // `ray` with its generator: fills mixed, real, primary_virtual and rays.
  // Called concurrently for different rows; a row's samples in order.
  virtual void Shade(const Ray& ray, Sampler& rng, int64_t row, size_t pixel, int sample, PathSample* out) = 0;
  // Samples k = 0..n-1 of row `row`, as Shade(rays[k], rngs[k], row,
  // pixels[k], samples[k], &out[k]) one after the other would; a method
  // that traces them together overrides it and batch_size.
  struct Batch {
    std::vector<Ray> rays;
    std::vector<Sampler> rngs;
    std::vector<size_t> pixels;
    std::vector<int> samples;
    std::vector<PathSample> out;
  };
  virtual void ShadeBatch(Batch& batch, int64_t row);
  // Up to how many samples of a row ShadeBatch takes at once (1: each
  // sample shaded before the next pixel is looked at).
  virtual int batch_size() const { return 1; }
  // True for a pixel that needs no more samples (pt: provably no difference).
  virtual bool PixelDone(size_t pixel) const {
    (void)pixel;
    return false;
  }
  // `spp` more samples of every pixel that needs them, numbered after the
  // earlier passes' samples.
  void ShadePixels(int spp);

  const CameraSampler& sampler() const { return sampler_; }
  const PixelAccumulator& accumulator() const { return acc_; }
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  CameraSampler sampler_;
  int width_, height_;
  PixelAccumulator acc_;
  int spp_ = 0;
  int64_t nonfinite_ = 0, rays_ = 0, virtual_tests_skipped_ = 0;
  AdaptiveSampling adaptive_;
  std::vector<char> stopped_;  // by adaptive sampling
  int64_t adaptive_stopped_ = 0;
};

}  // namespace mr
