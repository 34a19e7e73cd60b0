// Synthetic RGB-D recordings of a RenderScene's real geometry, with a
// Kinect-like sensor model, written in the TUM RGB-D layout.
//
// Depth noise (Nguyen, Izadi & Lovell 2012, Kinect v1): axial sigma
// 0.0012 + 0.0019 (z - 0.4)^2 m, growing as theta^2 / (pi/2 - theta)^2 at
// grazing angles; depth quantised through disparity in 1/8 pixel steps
// at the sensor's native resolution (z = f b / d, f = 585 px, baseline 7.5 cm) and stored at 5000 units per metre.  No
// return outside [min_m, max_m], beyond grazing_deg, on one side of depth
// edges (the projector's shadow), with probability dark_dropout on dark
// surfaces (albedo luminance below 0.1) and glossy_dropout on glossy ones.
#pragma once

#include <vector>

#include "camera/trajectory.h"
#include "core/report.h"
#include "recon/rgbd.h"
#include "render/render_scene.h"

namespace mr {

struct DepthSensorModel {
  bool noise = true, quantise = true, holes = true;
  double baseline_m = 0.075;
  double native_fx = 585;  // the sensor's focal length in its own pixels (disparity steps)
  double min_m = 0.4, max_m = 4.5;
  double grazing_deg = 80;
  double edge_jump = 0.05;  // relative depth step that casts a shadow
  double dark_dropout = 0.5, glossy_dropout = 0.3;
};

// Depth in metres (0 = no return) of the real geometry seen from world_from_cam.
DepthMap RenderDepth(const RenderScene& scene, const PinholeIntrinsics& K, const Rigid3& world_from_cam,
                     const DepthSensorModel& sensor, uint64_t seed);

struct RgbdSynthOptions {
  PinholeIntrinsics K{290, 290, 159.5, 119.5, 320, 240};
  DepthSensorModel sensor;
  int color_spp = 4;      // path-traced colour (real paths); 0: no colour images
  double exposure = 1.0;  // colour = clamp(radiance * exposure), 8-bit sRGB
  uint64_t seed = 1;
  std::vector<int> blank_frames;  // frames whose depth holds no valid pixel (a sensor dropout)
};

// Writes dir/{rgb,depth}/, rgb.txt, depth.txt, groundtruth.txt (the path,
// camera-to-world), depth.cameramodel (pinhole) and truth.json (sensor model,
// exposure).  Timestamps are i / 30 s.
void WriteRgbdSequence(const fs::path& dir, const RenderScene& scene, const Trajectory& path,
                       const RgbdSynthOptions& options, Report* report);

// A hand-held scan: the camera circles `target` at `radius` and `height`,
// sweeping `arc_deg` over `frames` frames with a small wobble, looking at it.
Trajectory ScanPath(int frames, const Eigen::Vector3d& target, double radius, double height, double arc_deg,
                    double start_deg = -90);

// world_from_cam looking from eye at target, camera y down (+y world up).
Rigid3 LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target);

}  // namespace mr
