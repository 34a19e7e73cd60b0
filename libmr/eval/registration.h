// Registration in pixels: how far the real room, rendered through a
// frame's pose, sits from the plate (mr-eval plate, per frame), and how far
// an object standing on the room swims against the plate between frames
// (mr-render, per frame).  Both come from dense optical flow on locally
// normalised images (core/optical_flow.h), which compares the rendered
// room and the photograph by their edges and texture.  The method, its
// limits and the figures measured: docs/methods.md, "Registration in
// pixels".
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "camera/pose.h"
#include "core/image.h"
#include "core/json.h"
#include "core/optical_flow.h"

namespace mr {

class CameraModel;
class RenderScene;

struct RegistrationOptions {
  FlowOptions flow;
  int tile_px = 32;      // the tiles the standard error is taken over
  int min_pixels = 200;  // fewer usable pixels: not measurable
};

struct RegistrationResult {
  bool measurable = false;
  std::string why;                                      // when not
  double mean_px = 0, p90_px = 0, stderr_px = 0;        // |displacement| over the usable pixels
  Eigen::Vector2d mean_flow = Eigen::Vector2d::Zero();  // the mean displacement (x right, y down), px
  // The medians (each component's; of |displacement|): what the room's
  // pixels say where something it does not hold (a person walking past)
  // covers part of the plate and its flow's failures pass the checks, as
  // long as they stay fewer than the room's usable pixels.
  double median_px = 0;
  Eigen::Vector2d median_flow = Eigen::Vector2d::Zero();
  int64_t region_pixels = 0, usable_pixels = 0;  // in `where`; textured and consistent of those
  Json ToJson() const;
};

// A frame's registration: the displacement that carries `rendered` (the
// room alone through the frame's pose, any units) onto `plate` (the
// photograph, any units), over the pixels where `where` > 0 (the room's).
// Non-finite pixels are left out.  Images of one size (R G B first, or
// one channel).
RegistrationResult MeasureRegistration(const Image& rendered, const Image& plate, const Image& where,
                                       const RegistrationOptions& options = {});

// The swim of a point that stands on the room: where the poses carry its
// projection (`from` in frame f to `to` in frame f + 1) against where the
// plate's own content there moved (`flow`: MatchImages of the two plate
// frames, at `from`): |to - from - flow(from)| in pixels.  NaN when `from`
// lies outside the image.
double Swim(const FlowField& flow, const Eigen::Vector2d& from, const Eigen::Vector2d& to);

// Pose refinement against the room (issue 40): the room rendered through
// the pose is matched to the plate (DenseMatches, as MeasureRegistration),
// each match a 3D point on the room (the ray through the rendered pixel)
// against the plate pixel it moved to; the pose that projects the points
// onto their plate pixels is found by Gauss-Newton with Huber weights
// (a right-multiplied step in the camera's frame, numeric derivatives
// through CameraModel::Project), and the round repeats from the new pose
// (the flow is surer the smaller the displacement).  The intrinsics stay,
// unless `intrinsics` asks for them in a shared correction.
struct PoseRefineOptions {
  int rounds = 2;
  int max_points = 3000;                                  // matches a round, a regular subsample of the usable ones
  double huber_px = 2.0;                                  // residuals beyond weigh as |r| (the flow's failures)
  double max_rotation_deg = 10, max_translation_m = 0.3;  // a larger step: refused, the input kept
  // mr-eval plate keeps a refinement only where the registration measured
  // after it is lower than before by this fraction (per frame, and over the
  // frames for the shared and smoothed modes): on a capture whose
  // registration is at the measurement's floor (exact poses, textureless
  // walls, shading that differs from the plate's) the fit moves poses that
  // were right (docs/benchmarks.md, "Registration against exact poses").
  double min_improvement = 0.15;
  // SolveCorrection over two or more frames: also the camera's focal
  // length (one scale for fx and fy), shared by the frames, kept only where
  // the matches determine it (the change exceeds 3 standard deviations of
  // its estimate: the Gauss-Newton normal matrix and the matches' weighted
  // residual variance, optimistic where the flow's errors are correlated)
  // and it moves the image's corners by min_intrinsics_px (a change the
  // registration cannot show is not worth a new camera model); otherwise
  // the camera as given.  Not the principal point: with one rotation shared
  // by the frames, its shift is the same image motion to first order (on
  // the Cycles capture it took 4.3 px that the rotation held).
  bool intrinsics = false;
  double min_intrinsics_px = 0.5;
  RegistrationOptions matching;
};

struct PoseRefinement {
  Rigid3 pose;  // refined; the input where not
  bool refined = false;
  std::string why;                             // where not
  int points = 0;                              // matches of the last round
  double rms_before_px = 0, rms_after_px = 0;  // those matches' reprojection RMS (Huber-weighted)
  double rotation_deg = 0, translation_m = 0;  // the step from the input
  // PoseRefineOptions::intrinsics: the focal length's scale
  // (WithIntrinsicsCorrection) and its standard deviation; 1 where not
  // refined (intrinsics_why says why).
  bool intrinsics_refined = false;
  double focal_scale = 1, focal_scale_sigma = 0;
  std::string intrinsics_why;
  Json ToJson() const;
};

// `camera` with fx and fy scaled by `focal_scale` and cx, cy moved by
// `principal_shift_px` (every mrcal lens model begins with fx, fy, cx, cy).
CameraModel WithIntrinsicsCorrection(const CameraModel& camera, double focal_scale,
                                     const Eigen::Vector2d& principal_shift_px);

// One frame's matches: 3D points on the room (X, world) and the plate
// pixels they moved to (u), found from the room rendered through `pose`.
struct RoomMatches {
  Rigid3 pose;
  std::vector<Eigen::Vector3d> X;
  std::vector<Eigen::Vector2d> u;
  std::string why;    // when there are none
  double weight = 1;  // of each of its points against the other groups' (a prior's)
};
// `rendered`: the room alone through `pose`; `where`: > 0 where it covers
// the pixel.
RoomMatches MatchRoom(const Image& rendered, const Image& where, const RenderScene& rs, const CameraModel& camera,
                      const Rigid3& pose, const Image& plate, const PoseRefineOptions& options = {});

// The correction c (in the camera's frame, right-multiplied: each group's
// pose * c) that best projects every group's points onto their plate
// pixels, from `start`.  One group: a frame's own refinement (RefinePose);
// several: one correction shared by the frames (the camera's offset from
// the room's frame: a sensor's depth-to-colour extrinsic, the similarity's
// error), which keeps the frames' motion as registered.  PoseRefinement::pose
// is c; rotation_deg and translation_m are c's; with options.intrinsics and
// two or more frames, the intrinsics' correction too.
PoseRefinement SolveCorrection(const CameraModel& camera, const std::vector<RoomMatches>& groups, const Rigid3& start,
                               const PoseRefineOptions& options = {});

// `render(pose)`: the room alone through `pose` (any units); `room(pose)`:
// > 0 where it covers the pixel (RoomPixels); `rs`: the room, for the
// matches' 3D points (its real geometry).
// `prior`: fixed 3D-2D observations of the frame (COLMAP's points and
// their keypoints) solved with the room's matches in every round, each by
// its weight: they hold the pose where the room's matches leave it free.
PoseRefinement RefinePose(const std::function<Image(const Rigid3&)>& render,
                          const std::function<Image(const Rigid3&)>& room, const RenderScene& rs,
                          const CameraModel& camera, const Rigid3& pose, const Image& plate,
                          const PoseRefineOptions& options = {}, const RoomMatches* prior = nullptr);

// Corrections over a sequence of frames (nullopt: none for that frame)
// averaged with Gaussian weights over the frames around each (sigma in
// frames; rotations by their normalised, sign-aligned quaternion mean,
// translations by their mean): every frame gets one.  At least one must be
// given.
std::vector<Rigid3> SmoothOverTime(const std::vector<std::optional<Rigid3>>& corrections, double sigma);

}  // namespace mr
