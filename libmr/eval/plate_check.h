// mr-eval plate: the capture chain checked against the plate itself.  For
// every frame of a scene's plate the real room alone (its geometry, its
// albedo, the captured light, the calibrated camera and pose) is rendered,
// the plate's radiometric gains are fitted against it (render/radiometry.h)
// and smoothed over time, and the re-rendering error after the fit is
// measured: over the room, and in the region around the virtual objects,
// where their shadows and bounce light land.  There is no ground truth for
// an inserted object on real video; there is one for the room, and this is
// it.  The gains file it writes is what scene.json's camera.gains names, so
// that mr-render lights the objects in the plate's own units.
#pragma once

#include <string>

#include "core/report.h"
#include "eval/registration.h"
#include "render/radiometry.h"
#include "scene/scene.h"

namespace mr {

struct PlateCheckOptions {
  fs::path out;               // folder: gains.json (and NNNNN-rerender.png with `images`)
  std::string method = "pt";  // renders I_r
  int spp = 16;
  int stride = 1;                        // fit every stride-th frame; the others take their neighbours' gains
  int frame_begin = -1, frame_end = -1;  // -1: the scene's
  GainFitOptions fit;
  GainSmoothing smoothing;
  // Per fitted frame, OUT/NNNNN-rerender.png: the plate | the room rendered
  // at the fitted gain | their signed difference | the pixels fitted.
  bool images = false;
  // > 0: the errors are measured at this gain (every channel and frame: a
  // hand-set exposure) instead of the fitted ones, to compare the two; the
  // fitted gains are still written.
  double at_gain = 0;
  // Non-empty: each fitted frame's pose is refined against the room
  // (eval/registration.h, RefinePose) and every pose of the scene written
  // here (TUM, camera-to-world, one line per frame in frame order: the
  // frames between refined ones take their corrections interpolated);
  // the report gives each frame's registration after.
  fs::path refine_poses;
  PoseRefineOptions refine;
  // true: one correction shared by every frame (pose * c: the camera's
  // offset from the room, which keeps the registered motion and so adds no
  // swim); false: each fitted frame its own (the registration falls
  // further, but the frames' independent errors make the objects swim),
  // smoothed over time by default (docs/benchmarks.md: on the kitchen the
  // smoothed corrections lower the registration most without swim).
  bool refine_shared = false;
  // Non-empty, with refine_shared: the camera's focal length is solved
  // with the shared correction where the frames determine it
  // (PoseRefineOptions::intrinsics), and the camera model written here
  // (the given one where they were not determined or the refinement was
  // undone); the registration after is measured through it.
  fs::path refine_camera;
  // Non-empty: COLMAP's points as a prior in the refinement (mr-register
  // --observations-out: each frame's keypoints and their points in the
  // room's frame), solved with the room's matches of the frame, each
  // observation weighing prior_weight against one match.
  fs::path prior_points;
  double prior_weight = 1;
  // Not shared, > 0: each frame's correction averaged over the fitted
  // frames around it (Gaussian, sigma in fitted frames): --refine-mode smooth.
  double refine_smooth_frames = 2;
  // The pixels registration is measured and refined over: "texture" (every
  // pixel of the room: its texture, edges and shading) or "edges" (only
  // those within edge_band_px of the room's geometric edges, creases and
  // depth steps: where the plate's shading and shadows differ from the
  // render's, as on a sunlit capture with textureless walls).
  std::string register_on = "texture";
  int edge_band_px = 4;
  std::string tool = "mr-eval", command_line;

  // UsageError naming the flag: --out missing, --spp or --stride below 1, an
  // unknown --method, a negative --at-gain or --smooth, --jump-ratio <= 1.
  void Check() const;
};

// The pixels where the region around the virtual objects is measured: those
// within r of the objects' footprint (`mask` > 0.5; r = max(8, sqrt(area /
// pi)) px, the footprint's equivalent radius) and not in it.  One channel.
Image AroundObjects(const Image& mask);

// Throws mr::Error / mr::UsageError (a scene without a plate).
void RunPlateCheck(const Scene& scene, const PlateCheckOptions& options, Report* report);

}  // namespace mr
