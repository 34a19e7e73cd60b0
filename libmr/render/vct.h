// `vct`: delta global illumination by voxel cone tracing (Thöner & Kuijper
// 2016, ../shared/papers/delta-gi-voxel-cone-tracing.txt), on the CPU.
//
// Four volumes cover twice the virtual objects' bounding box (cubic voxels,
// `resolution` along its longest side; the whole scene when a virtual light
// relights it), stored interleaved, one record per voxel:
//  - the light volume: the light that real and virtual surfaces reflect once
//    (diffuse), injected from ray-traced equivalents of reflective shadow
//    maps: a grid of parallel rays per environment or distant-light
//    direction (vpl's DirectionalLights: half importance-sampled, half
//    uniform, balance heuristic) and a fan of rays per point or spot light;
//  - the real light volume, the same injection into the real geometry
//    alone; the delta volume is their difference, negative where the object
//    takes light away (the paper's relighting volume);
//  - two visibility volumes, real and virtual: occupancy (1 where geometry
//    is, voxelised by rays along the three axes) and average normal.
// Light is stored as radiance premultiplied by occupancy, so that the 3D mip
// chains (box filter, 2x2x2) hold the fraction of occupied sub-voxels and
// their mean light.  A cone reads the level whose voxel matches its
// diameter, quadrilinearly, and accumulates front to back,
//   light += (1 - occ_acc) light_local occ_local,  occ_acc += (1 - occ_acc) occ_local,
// with occ_local scaled by how squarely the voxel's average normal faces the
// cone (a wall seen edge-on hides little) and light_local by how much its lit
// sides face the cone (the mean normal of the lit sides: a wall lit from
// behind sends nothing; the paper's voxels are isotropic, which leaks the
// lit side of an object through to its shadow).  `paper_accumulation` uses the
// paper's literal rule, light_acc = light_acc occ_acc + light_local occ_local (1 - occ_acc).
//
// A fragment traces six diffuse cones (60 degrees; weights pi/4 along the
// normal, 3 pi/20 for the five at 60 degrees from it, summing to pi), a
// specular cone along the mirror direction whose aperture follows the
// roughness, and shadow cones.  A virtual fragment reads the light volume
// through both visibility volumes (I_m).  A real fragment reads the real
// light volume through the real visibility volume (I_r) and adds the
// relighting: the mixed cone minus the real one ("split", the default), or
// the paper's delta volume through both visibility volumes ("delta"), which
// leaves out the real light the object hides from the fragment (the bunny
// room's umbra: 1.2 units too bright of 5.5; docs/benchmarks.md).  Beyond the volume a cone sees the far field: the radiance of
// the surfaces (and, for specular cones, the sky) around the volume, path
// traced once from its centre and prefiltered to the cone's aperture.
// Direct light is next-event estimation as in ic, except that the virtual
// objects' shadows on real fragments come from a shadow cone through the
// virtual visibility volume.  Glossy lobes take point and spot lights by
// next-event estimation and everything else through the specular cone.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "camera/camera_model.h"
#include "core/report.h"
#include "render/path_tracer.h"

namespace mr {

struct VctSettings {
  int resolution = 32;              // voxels along the volume's longest side
  int directions = 64;              // environment directions injected
  double injection_spacing = 0.5;   // injection ray spacing, voxels
  double shadow_aperture_deg = 2;   // shadow cone, full angle
  double min_specular_aperture_deg = 1;  // specular cone, full angle at roughness 0
  bool paper_accumulation = false;
  bool split_relighting = true;     // false: the paper's delta volume (see docs/benchmarks.md)
  int far_field_width = 64;         // lat-long far field, width (height: half)
  int far_field_samples = 16;       // paths per far-field texel
  double cone_offset = 1.0;         // cone origins lifted off the surface, voxels
  int max_depth = 5;                // far-field paths
  uint64_t seed = 0;
};

// What one cone gathered: light of the mixed (I_m), real (I_r) and delta
// solutions and the occlusion each accumulated.
struct ConeResult {
  Eigen::Vector3d mixed = Eigen::Vector3d::Zero(), real = Eigen::Vector3d::Zero(), delta = Eigen::Vector3d::Zero();
  double occ_mixed = 0, occ_real = 0;
  int steps = 0;
};

class VctVolumes {
 public:
  struct Voxel {
    float occ_r = 0, occ_v = 0;                 // occupancy (fraction of sub-voxels)
    Eigen::Vector3f n_r = Eigen::Vector3f::Zero(), n_v = Eigen::Vector3f::Zero();  // mean normal x occupancy
    Eigen::Vector3f l_m = Eigen::Vector3f::Zero(), l_r = Eigen::Vector3f::Zero();  // radiance x occupancy
    // Mean normal of the lit sides (facing the light), weighted by
    // reflected light, x luminance(l): light leaves a voxel towards where
    // its lit surfaces face.
    Eigen::Vector3f nl_m = Eigen::Vector3f::Zero(), nl_r = Eigen::Vector3f::Zero();
  };
  struct Level {
    int nx = 0, ny = 0, nz = 0;
    double size = 0;  // voxel edge, world units
    std::vector<Voxel> v;
    size_t Index(int x, int y, int z) const { return (static_cast<size_t>(z) * ny + y) * nx + x; }
  };

  static std::shared_ptr<const VctVolumes> Build(const RenderScene& scene, const VctSettings& settings);
  const VctSettings& settings() const { return settings_; }
  const Eigen::AlignedBox3d& box() const { return box_; }
  double voxel() const { return levels_.empty() ? 0 : levels_[0].size; }
  const std::vector<Level>& levels() const { return levels_; }
  double build_seconds() const { return build_seconds_; }

  // What a cone reads: diffuse cones the light volumes and, beyond them, the
  // far field's surfaces (steps of one diameter, as the paper's); specular
  // cones also the far field's sky (half-diameter steps); shadow cones the
  // virtual visibility volume alone (occ_mixed; half-diameter steps).
  enum class Cone { kDiffuse, kSpecular, kShadow };
  // Marches a cone of half-angle `half_angle` (radians) from `origin` along
  // unit `dir`, from `t_start` to `t_max` along it.
  ConeResult March(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double half_angle, double t_start,
                   double t_max, Cone kind) const;
  // The far field along `dir` prefiltered to a cone of half-angle `half_angle`.
  void FarField(const Eigen::Vector3d& dir, double half_angle, bool sky, Eigen::Vector3d* mixed,
                Eigen::Vector3d* real) const;
  void Describe(Report* report) const;

 private:
  Voxel Sample(const Eigen::Vector3d& p, double level) const;
  VctSettings settings_;
  Eigen::AlignedBox3d box_;
  std::vector<Level> levels_;
  // Far field: lat-long maps per prefilter level; [level][texel] of
  // {surface mixed, surface real, sky mixed, sky real}.
  int far_w_ = 0, far_h_ = 0;
  std::vector<double> far_half_angles_;
  std::vector<std::vector<std::array<Eigen::Vector3f, 4>>> far_;
  double build_seconds_ = 0;
  std::string box_reason_;
  int64_t injection_rays_ = 0, voxelisation_rays_ = 0, far_field_paths_ = 0, occupied_ = 0;
};

class VctFrameRenderer : public FrameMethod {
 public:
  VctFrameRenderer(const RenderScene& scene, std::shared_ptr<const VctVolumes> volumes, const CameraModel& camera,
                   const Rigid3& world_from_cam, uint64_t seed, int frame);
  void RenderPass(int spp) override;
  Image Mixed() const override { return acc_.Mixed(); }
  Image Real() const override { return acc_.Real(); }
  Image Mask() const override { return acc_.Mask(); }
  Image DifferenceVariance() const override { return acc_.DifferenceVariance(); }
  Image SampleCount() const override { return acc_.SampleCount(); }
  int64_t nonfinite_samples() const override { return nonfinite_; }
  void Describe(Report* report, int frame) const;

  struct Counters {
    int64_t diffuse_cones = 0, specular_cones = 0, shadow_cones = 0, shadow_cones_skipped = 0, steps = 0, rays = 0,
            relight_skipped = 0;
  };
  const Counters& counters() const { return counters_; }

 private:
  const RenderScene& scene_;
  std::shared_ptr<const VctVolumes> vol_;
  CameraSampler sampler_;
  int width_, height_;
  PixelAccumulator acc_;
  int spp_ = 0;
  int64_t nonfinite_ = 0;
  Counters counters_;
};

}  // namespace mr
