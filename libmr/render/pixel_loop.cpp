#include "render/pixel_loop.h"

#include <algorithm>
#include <atomic>

#include "core/parallel.h"

namespace mr {

PixelLoopMethod::PixelLoopMethod(const CameraModel& camera, const Rigid3& world_from_cam, uint64_t seed, int frame,
                                 const CameraExposure& exposure)
    : sampler_(camera, world_from_cam, seed, frame, exposure),
      width_(camera.width()),
      height_(camera.height()),
      acc_(width_, height_) {}

void PixelLoopMethod::ShadePixels(int spp) {
  if (adaptive_.on()) {
    const size_t n = static_cast<size_t>(width_) * height_;
    if (stopped_.empty()) stopped_.assign(n, 0);
    std::vector<char> valid(n, 0);
    for (int y = 0; y < height_; ++y)
      for (int x = 0; x < width_; ++x)
        valid[static_cast<size_t>(y) * width_ + x] =
            sampler_.PixelValid(x, y) && !PixelDone(static_cast<size_t>(y) * width_ + x);
    adaptive_stopped_ += UpdateAdaptiveStops(acc_, adaptive_, valid, &stopped_);
  }
  std::atomic<int64_t> nonfinite{0}, rays{0}, culled{0};
  const size_t batch_size = static_cast<size_t>(std::max(1, this->batch_size()));
  ParallelFor(0, height_, [&](int64_t y) {
    int64_t row_rays = 0, row_nonfinite = 0, row_culled = 0;
    Batch b;
    // Shades the samples gathered, then adds them to their pixels in order.
    auto flush = [&] {
      if (b.rays.empty()) return;
      b.out.assign(b.rays.size(), PathSample());
      ShadeBatch(b, y);
      for (size_t k = 0; k < b.out.size(); ++k) {
        const PathSample& ps = b.out[k];
        row_rays += ps.rays;
        row_culled += ps.virtual_tests_skipped;
        if (!ps.mixed.allFinite() || !ps.real.allFinite()) {
          ++row_nonfinite;  // dropped and counted: never NaN in the image
          continue;
        }
        acc_.Add(b.pixels[k], ps.mixed, ps.real, ps.primary_virtual);
      }
      b.rays.clear(), b.rngs.clear(), b.pixels.clear(), b.samples.clear();
    };
    for (int x = 0; x < width_; ++x) {
      const size_t i = static_cast<size_t>(y) * width_ + x;
      if (!sampler_.PixelValid(x, static_cast<int>(y))) continue;  // outside the lens
      if (PixelDone(i) || (!stopped_.empty() && stopped_[i])) continue;
      // After this pixel's earlier samples: a pass restricted to some pixels
      // (PixelDone) leaves the others' sequences where they were.
      const int first = acc_.count(i);
      acc_.Count(i, spp);
      for (int s = first; s < first + spp; ++s) {
        Ray ray;
        b.rngs.push_back(sampler_.Sample(x, static_cast<int>(y), s, &ray));
        b.rays.push_back(ray);
        b.pixels.push_back(i);
        b.samples.push_back(s);
        if (b.rays.size() >= batch_size) flush();
      }
    }
    flush();
    rays += row_rays;
    culled += row_culled;
    nonfinite += row_nonfinite;
  });
  spp_ += spp;
  nonfinite_ += nonfinite.load();
  rays_ += rays.load();
  virtual_tests_skipped_ += culled.load();
}

void PixelLoopMethod::ShadeBatch(Batch& b, int64_t row) {
  for (size_t k = 0; k < b.rays.size(); ++k) Shade(b.rays[k], b.rngs[k], row, b.pixels[k], b.samples[k], &b.out[k]);
}

}  // namespace mr
