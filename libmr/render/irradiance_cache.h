// `ic`: differential irradiance caching (Kán & Kaufmann 2013,
// ../shared/papers/differential-irradiance-caching.txt), offline on the CPU.
//
// Indirect diffuse light comes from a linear cache of records.  Each record
// holds the mixed and the real indirect irradiance at its point, E_m and E_r,
// integrated from `rays` cosine-distributed mixed rays that are followed as
// differential paths (pt's: real and mixed ray types, several bounces in one
// pass; the first segment's escape to the environment is direct light and is
// left to the pixel), and R_i, the least distance those rays met, clamped
// so that the record's influence radius (accuracy x R_i) spans
// [min_spacing_px, max_spacing_px] pixels where it was made, and by its
// neighbours (R_i <= R_j + |x_i - x_j|, Křivánek et al. 2006).
//
// Records are splatted into the frame's G-buffer with the weight of
// Tabellion & Lamorlette (2004), w_i(x) = 1 - max(eps_p, eps_n) / accuracy,
// eps_p = |x - x_i| / R_i, eps_n = sqrt(1 - n.n_i) / sqrt(1 - cos 10°):
// mixed irradiance where the first hit is virtual, mixed and real (so their
// difference) where it is real.  Misses are found in the splat buffer:
// tiles are scanned for a G-buffer sample of zero accumulated weight, one
// record is made per tile and pass, and passes repeat until every sample is
// covered.  Direct light (next-event estimation and a cosine-sampled ray that
// counts only the environment it sees, combined by MIS, with the blocker
// tests st_r and st_v) and glossy lobes (a BSDF-sampled differential path,
// as in pt) are traced per camera sample.
//
// Over a video the records stay in world space: a frame splats every record
// made by earlier frames, adds records only where it finds misses, and
// re-evaluates a record t_max frames after its last evaluation with the same
// random numbers, so that a static scene does not flicker.
#pragma once

#include <cstdint>
#include <vector>

#include "camera/camera_model.h"
#include "core/report.h"
#include "render/path_tracer.h"

namespace mr {

struct IcSettings {
  int rays = 256;
  double accuracy = 0.3;
  double min_spacing_px = 2, max_spacing_px = 32;  // influence radius (accuracy x R_i) clamp, pixels
  int t_max = 8;
  int tile = 16;
  // Records are not made at real points where the virtual objects' bounding
  // spheres subtend a form factor below this (and no virtual light exists):
  // there the indirect difference is taken as zero.  Only with a photograph.
  double influence_threshold = 1e-3;
  bool photograph = true;  // I_c is given: real pixels need only I_m - I_r
  int max_depth = 5;
  uint64_t seed = 0;
};

struct IcRecord {
  Eigen::Vector3d p, n;
  Eigen::Vector3d e_mixed = Eigen::Vector3d::Zero(), e_real = Eigen::Vector3d::Zero();
  double r_hit = 0;          // least distance the record's rays met
  double r = 0;              // R_i after the clamps
  double r_min = 0, r_max = 0;  // the pixel clamps, world units
  bool on_virtual = false;
  int evaluated_frame = 0;
  uint64_t index = 0;        // its random stream
};

// The records, kept across the frames of a render.
class IrradianceCache {
 public:
  IrradianceCache(const RenderScene& scene, const IcSettings& settings);
  const IcSettings& settings() const { return settings_; }
  const std::vector<IcRecord>& records() const { return records_; }
  // Integrates E_m, E_r and R_i at the record's point with its own stream.
  void Evaluate(IcRecord* record, int frame) const;
  // Whether a real point can see a change of indirect light (form factor bound).
  bool InInfluence(const Eigen::Vector3d& p) const;
  void Describe(Report* report) const;

 private:
  friend class IcFrameRenderer;
  const RenderScene& scene_;
  IcSettings settings_;
  DifferentialPathTracer tracer_;
  std::vector<IcRecord> records_;
  std::vector<Eigen::Vector4d> spheres_;  // virtual bounding spheres (centre, radius)
  bool virtual_light_ = false;
  int64_t created_ = 0, reevaluated_ = 0, record_rays_ = 0, passes_ = 0;
};

class IcFrameRenderer : public FrameMethod {
 public:
  IcFrameRenderer(const RenderScene& scene, IrradianceCache* cache, const CameraModel& camera,
                  const Rigid3& world_from_cam, uint64_t seed, int frame);
  void RenderPass(int spp) override;
  Image Mixed() const override { return acc_.Mixed(); }
  Image Real() const override { return acc_.Real(); }
  Image Mask() const override { return acc_.Mask(); }
  Image DifferenceVariance() const override { return acc_.DifferenceVariance(); }
  Image SampleCount() const override { return acc_.SampleCount(); }
  int64_t nonfinite_samples() const override { return nonfinite_; }
  // Indirect irradiance the frame interpolated (luminance, per pixel, first
  // sample; NaN where nothing was interpolated), for the temporal figure.
  const std::vector<float>& interpolated() const { return interpolated_; }
  const std::vector<Eigen::Vector3f>& positions() const { return positions_; }
  void Describe(Report* report, int frame) const;

 private:
  struct Entry {  // one G-buffer sample: the first hit of a mixed or a real camera ray
    Eigen::Vector3d p, n;
    double footprint = 0;  // world size of a pixel there
    bool valid = false, is_virtual = false, needed = false;
    double w = 0;
    Eigen::Vector3d sum_m = Eigen::Vector3d::Zero(), sum_r = Eigen::Vector3d::Zero();  // sums of w E_m, w E_r
  };
  void Splat(const IcRecord& r, int64_t first_row, int64_t last_row);
  void SplatAll(const std::vector<size_t>& records);

  const RenderScene& scene_;
  IrradianceCache* cache_;
  CameraModel camera_;  // a copy: renderers may outlive the caller's model
  CameraSampler sampler_;
  int width_, height_, frame_;
  PixelAccumulator acc_;
  int spp_ = 0;
  int64_t nonfinite_ = 0, new_records_ = 0, reevaluated_ = 0, splatted_ = 0, miss_passes_ = 0,
          outside_influence_ = 0, rays_ = 0;
  int samples_ = 0;                 // G-buffer samples per pixel
  std::vector<Entry> mixed_, real_;  // [pixel * samples_ + s]
  std::vector<float> interpolated_;
  std::vector<Eigen::Vector3f> positions_;
};

}  // namespace mr
