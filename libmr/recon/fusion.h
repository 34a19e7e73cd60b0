// mr-fuse's pipeline: per frame, read and check depth, build the pyramid,
// track against the model's raycast, fuse, look for a loop, and at the end
// mesh the volume.
//
// Leaves out what the room does not need, and says so per frame: frames
// with (almost) no valid depth are neither tracked nor fused; frames that
// moved less than the skip thresholds since the last fused frame and see
// (almost) no new surface are tracked but not fused (and reuse the last raycast);
// blocks outside --roi are never allocated.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "camera/trajectory.h"
#include "core/report.h"
#include "recon/loop_closure.h"
#include "recon/rgbd.h"
#include "recon/tracking.h"
#include "recon/tsdf.h"

namespace mr {

struct FuseOptions {
  TsdfOptions tsdf;
  PyramidOptions pyramid;
  IcpOptions icp;
  DepthReadOptions depth;                 // range limits; the scale is always the sequence's
  int first = 0, count = -1, stride = 1;  // frames first, first+stride, ... (count -1: all)
  std::optional<Trajectory> poses;        // fuse with these (matched by timestamp), no tracking
  double min_valid_fraction = 0.05;       // frames with fewer valid depth pixels are skipped
  double skip_translation_m = 0.0;        // 0: fuse every tracked frame
  double skip_rotation_deg = 0.0;
  double skip_new_block_fraction = 0.02;  // "no new surface": new blocks / blocks in view
  int max_lost = 10;                      // consecutive lost frames before the run stops (keeping what it fused)
  // Loss relative to the recording's recent good frames (see TrackIcp for
  // the absolute limits).
  double loss_rms_factor = 2.0, loss_inlier_factor = 0.5;
  bool use_color = true;
  // The model is raycast at this pyramid level (0: full resolution; 1: half,
  // a quarter of the rays, for speed), but never below 320 pixels across.
  int raycast_level = 1;
  // The prediction (and the prior of weak directions): "velocity" (constant
  // velocity) or "static" (the previous pose, as KinectFusion).
  std::string motion_model = "velocity";
  Rigid3 first_pose;  // world_from_cam of the first frame when tracking
  // Loop closure while tracking (recon/loop_closure.h): when a loop closes,
  // every pose so far moves with the pose graph and the model tracking uses
  // is fused again from the keyframes ...
  LoopOptions loop;
  // ... where the loop moved the current frame by more than this (else
  // tracking goes on against the old model); at the end, after any loop,
  // the output volume is fused again from every fused frame.
  double loop_refuse_m = 0.01, loop_refuse_deg = 0.5;
  // With a region of interest (tsdf.roi on the output volume) and tracking,
  // the camera is tracked against a whole-room volume of this voxel size
  // (0: the output's): coarser saves memory, at some accuracy.
  double tracking_voxel = 0;
  int preview_every = 0;  // > 0: the model's raycast, shaded, every N frames ...
  fs::path preview_dir;   // ... as preview_dir/NNNNNN.png
};

struct FrameRecord {
  int index = 0;
  double timestamp = 0;
  std::string status;  // first | tracked | relocalised | lost | given | no_depth
  bool fused = false;
  std::string note;  // why not fused / why lost
  int64_t valid_depth = 0, rejected_depth = 0;
  double icp_rms = 0, inlier_ratio = 0, condition = 0;
  double free_space_ratio = 0;  // of its points, those in space the model saw empty
  int64_t color_pixels = 0;     // in the photometric term (0: not used)
  double color_rms = 0;         // its intensity residual
  int weak_directions = 0, iterations = 0;
  int64_t new_blocks = 0;
  double seconds = 0;
  double t_read = 0, t_pyramid = 0, t_track = 0, t_fuse = 0, t_raycast = 0;  // seconds per part
  double t_loop = 0;                                                         // loop search, pose graph and re-fusion
};

struct FuseResult {
  Trajectory trajectory;  // tracked (or given) frames, camera-to-world
  std::vector<FrameRecord> frames;
  int64_t peak_bytes = 0;
  bool stopped_early = false;
  std::string stop_reason;
  double suspect_scale = 0;       // SuggestDepthScale's answer on the first frames
  std::vector<LoopRecord> loops;  // accepted loop edges
  int keyframes = 0, loop_candidates = 0;
  int refused_frames = 0;           // frames fused again after loops closed (all closures together)
  double final_refuse_seconds = 0;  // the output volume fused again at the end
};

using FrameCallback = std::function<void(const FrameRecord&)>;

// Runs over `seq`, filling `volume`.  Throws mr::Error naming the file on
// unreadable input; tracking failures are recorded, not thrown.
FuseResult Fuse(const RgbdSequence& seq, const FuseOptions& options, TsdfVolume* volume,
                const FrameCallback& on_frame = {});

// The per-frame table and summary into `report` (fuse-report.json).
void ReportFusion(const FuseResult& r, Report* report);

}  // namespace mr
