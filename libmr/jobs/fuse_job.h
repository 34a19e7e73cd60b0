// mr-fuse's work: a room reconstructed from an RGB-D recording (tracking,
// TSDF fusion, meshing, de-lit albedo) into OUT/room.ply, OUT/trajectory.txt
// and OUT/fuse-report.json.
#pragma once

#include <string>
#include <vector>

#include "core/report.h"
#include "recon/albedo.h"
#include "recon/fusion.h"
#include "recon/rgbd.h"
#include "recon/tsdf.h"

namespace mr {

struct FuseJobOptions {
  std::string input, out;
  RgbdOpenOptions rgbd;
  FuseOptions fuse;
  MeshOptions mesh;
  AlbedoOptions albedo;
  std::vector<double> intrinsics;       // fx,fy,cx,cy (empty: the recording's)
  std::vector<double> roi;              // xmin,ymin,zmin,xmax,ymax,zmax (empty: none)
  std::string roi_scene;                // a scene whose virtual objects bound the region
  double roi_scale = 2.0;               // their bounding box scaled by this
  std::vector<double> skip_motion;      // MM,DEG (empty: fuse every tracked frame)
  double max_depth = 8.0;               // m
  std::string poses;                    // a TUM trajectory, or "reference"; empty: tracking
  std::string first_pose = "identity";  // or "reference"
  std::string lights, env;              // de-light the albedo by these
  bool no_color = false, no_bilateral = false, no_albedo = false, no_loop_closure = false;

  // UsageError naming the flag at fault: --layout, --intrinsics, --roi and
  // --roi-from together, --roi's corners, --icp-iterations, --skip-motion,
  // --first-pose, and the counts and sizes that must be positive.
  void Check() const;
};

// Runs the job; fills `report` and writes it to OUT/fuse-report.json too.
// A run that tracking loss stopped early still succeeds with what it fused
// (the report's summary.stopped_early says so).  Throws mr::Error naming the
// recording when nothing could be fused or meshed.
void RunFuse(const FuseJobOptions& options, Report* report);

}  // namespace mr
