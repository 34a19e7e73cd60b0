// `pt`: differential path tracing, the unbiased reference of mr-render.
//
// I_m (real + virtual) and I_r (real only) come from the same paths: while a
// path meets only real surfaces it is shared, and each next-event estimate
// tests real and virtual blockers separately (I_r uses st_r, I_m uses
// min(st_r, st_v)).  Where the shared path meets a virtual object the real
// path continues alone along the same ray with a real-only ray, with a copy
// of the random stream, as the mixed and real ray types of Differential
// Irradiance Caching.  With no virtual object in a path, I_m and I_r are
// bit-identical, so their difference has no noise there.
#pragma once

#include <cstdint>
#include <vector>

#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/image.h"
#include "core/sampling.h"
#include "render/pixel_accumulator.h"
#include "render/render_scene.h"

namespace mr {

// Every ray a render traces, for benchmarks that replay them through a bare
// Embree loop (single-threaded renders only: the log is not synchronised).
struct RayLog {
  std::vector<Ray> closest, occlusion;
};

struct PathTracerSettings {
  int max_depth = 64;       // bounces; Russian roulette ends most paths long before
  int rr_depth = 3;         // Russian roulette from this bounce on
  uint64_t seed = 0;
  int frame = 0;
  RayLog* ray_log = nullptr;  // benchmarks only
  // Pixels whose camera rays provably meet no geometry are sampled in the
  // first pass only (their I_m - I_r is exactly zero).
  bool skip_environment_pixels = true;
};

struct PathSample {
  Eigen::Vector3d mixed = Eigen::Vector3d::Zero();
  Eigen::Vector3d real = Eigen::Vector3d::Zero();
  bool primary_virtual = false;  // the camera ray's first hit is virtual (mask M)
  int rays = 0;                  // closest-hit and occlusion queries traced
  float first_t = INFINITY;      // distance to the first surface met (infinity: none)
};

class DifferentialPathTracer {
 public:
  DifferentialPathTracer(const RenderScene& scene, const PathTracerSettings& settings)
      : scene_(scene), settings_(settings) {}
  PathSample Trace(const Ray& primary, Pcg32& rng) const {
    return TraceFrom(primary, Eigen::Vector3d::Ones(), 0, 0, rng);
  }
  // The shared differential path from `start` on, as if it had reached
  // there at bounce `depth` with throughput `beta` after a direction chosen
  // with solid-angle pdf `prev_pdf` (0: no MIS on escape).  Rays escaping
  // before bounce `escape_from_depth` count nothing (a method that takes
  // direct light by light sampling alone passes depth + 1).
  PathSample TraceFrom(const Ray& start, Eigen::Vector3d beta, double prev_pdf, int depth, Pcg32& rng,
                       int escape_from_depth = 0) const;
  // Radiance arriving along `ray` in the scene with everything in it
  // (virtual included); `prev_pdf` is the solid-angle pdf that chose the
  // direction (0: no MIS against lights on escape).
  Eigen::Vector3d Radiance(const Ray& ray, double prev_pdf, Pcg32& rng) const {
    int rays = 0;
    return TraceSingle(ray, kMaskAll, Eigen::Vector3d::Ones(), prev_pdf, 0, rng, &rays, 0);
  }
  // Radiance arriving along `ray` in the real scene alone (virtual geometry
  // and lights left out), times beta, from bounce `depth` on.
  Eigen::Vector3d RealRadiance(const Ray& ray, const Eigen::Vector3d& beta, double prev_pdf, int depth, Pcg32& rng,
                               int* rays) const {
    return TraceSingle(ray, kMaskReal, beta, prev_pdf, depth, rng, rays, 0);
  }

 private:
  // One path seeing geometry through `mask`, from `ray` on.
  Eigen::Vector3d TraceSingle(Ray ray, uint32_t mask, Eigen::Vector3d beta, double prev_pdf, int depth,
                              Pcg32& rng, int* rays, int escape_from_depth) const;
  bool Intersect(const Ray& ray, Hit* hit) const {
    if (settings_.ray_log) settings_.ray_log->closest.push_back(ray);
    return scene_.embree().Intersect(ray, hit);
  }
  bool Occluded(const Ray& ray) const {
    if (settings_.ray_log) settings_.ray_log->occlusion.push_back(ray);
    return scene_.embree().Occluded(ray);
  }
  const RenderScene& scene_;
  PathTracerSettings settings_;
};

// What every rendering method produces for a frame, progressively.
class FrameMethod {
 public:
  virtual ~FrameMethod() = default;
  virtual void RenderPass(int spp) = 0;
  virtual Image Mixed() const = 0;               // mean I_m, RGB
  virtual Image Real() const = 0;                // mean I_r, RGB
  virtual Image Mask() const = 0;                // fraction of camera samples whose first hit is virtual, "Y"
  virtual Image DifferenceVariance() const = 0;  // variance of the mean of luminance(I_m - I_r), "Y"
  virtual Image SampleCount() const = 0;         // samples per pixel, "Y"
  virtual int64_t nonfinite_samples() const { return 0; }
  virtual int64_t skipped_pixels() const { return 0; }
};

// Camera sample positions shared by the methods: sample s of pixel i of a
// frame has its own generator, seeded by (seed, frame, s, i), and its
// direction is the bilinear blend of the pixel's unprojected corners at the
// generator's first two numbers.
class CameraSampler {
 public:
  CameraSampler(const CameraModel& camera, const Rigid3& world_from_cam, uint64_t seed, int frame);
  int width() const { return width_; }
  int height() const { return height_; }
  // False for pixels outside the lens's valid region.
  bool PixelValid(int x, int y) const;
  // The generator of sample `s` of pixel (x, y), already advanced past the
  // two numbers that placed the camera ray `ray`.
  Pcg32 Sample(int x, int y, int s, Ray* ray) const;
  // World-space unit directions through the pixel's corners, in order around it.
  void CornerDirections(int x, int y, Eigen::Vector3d c[4]) const;
  const Rigid3& pose() const { return world_from_cam_; }

 private:
  int width_, height_;
  Rigid3 world_from_cam_;
  Eigen::Matrix3d R_;
  std::vector<Eigen::Vector3d> corner_dirs_;  // (W+1) x (H+1) unprojected pixel corners, camera frame
  std::vector<char> corner_ok_;
  uint64_t frame_seed_ = 0;
};

// `pt`.  Renders a frame progressively: each pass adds samples to every
// pixel, each sample with its own generator (CameraSampler), so the result
// does not depend on the thread count or on how the samples are split into
// passes.
class FrameRenderer : public FrameMethod {
 public:
  FrameRenderer(const RenderScene& scene, const CameraModel& camera, const Rigid3& world_from_cam,
                const PathTracerSettings& settings);
  void RenderPass(int spp) override;
  int samples_per_pixel() const { return spp_; }
  int64_t nonfinite_samples() const override { return nonfinite_; }
  int64_t rays_traced() const { return rays_; }
  // Pixels sampled in the first pass only, their difference provably zero.
  int64_t skipped_pixels() const override { return skipped_pixels_; }

  Image Mixed() const override;
  Image Real() const override;
  Image Mask() const override;
  Image DifferenceVariance() const override;
  Image SampleCount() const override;

 private:
  const RenderScene& scene_;
  DifferentialPathTracer tracer_;
  CameraSampler sampler_;
  int width_, height_;
  PixelAccumulator acc_;
  std::vector<char> skip_;   // provably zero difference
  int64_t skipped_pixels_ = 0;
  int spp_ = 0;
  int64_t nonfinite_ = 0;
  int64_t rays_ = 0;
};

}  // namespace mr
