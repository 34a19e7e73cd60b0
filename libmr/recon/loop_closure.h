// Loop closure for frame-to-model tracking: keyframes, loops found among
// keyframes near the tracked pose and verified by ICP, and a pose graph
// (Ceres) that spreads the loop's error over the keyframes between.
//
// Every tracked frame hangs from the latest keyframe at the time (its pose
// relative to that keyframe is kept), so that when the graph moves the
// keyframes every frame moves with its own.  A frame becomes a keyframe
// when it has moved keyframe_translation_m or turned keyframe_rotation_deg
// from the last one; keyframes keep their depth's point maps at one
// pyramid level, in their own camera frame.
//
// A new keyframe looks for loops among keyframes at least min_frame_gap
// frames older whose tracked pose is within search_radius_m and
// search_angle_deg (after drift, the same place is where the tracker thinks
// it is give or take the drift).  Each candidate, nearest first, is aligned
// by point-to-plane ICP from the tracked relative pose with wide gates; it
// is accepted only if ICP converges with enough inliers, a small residual
// and no weak direction (a loop edge along a direction the geometry leaves
// free would pull the graph along noise).
//
// The graph: nodes are the keyframes' poses (the first held fixed), edges
// the relative poses between consecutive keyframes as tracked and the
// accepted loops, each residual (translation, 2 x quaternion vector) divided
// by sigma_t and sigma_r: odometry and loop edges weigh alike, so the loop's
// error is spread evenly along the path (docs/methods.md).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "camera/pose.h"
#include "recon/tracking.h"

namespace mr {

struct LoopOptions {
  bool enabled = true;  // Fuse's switch; a LoopCloser always looks
  double keyframe_translation_m = 0.10, keyframe_rotation_deg = 10;
  int min_frame_gap = 60;  // a loop joins keyframes at least this many frames apart
  double search_radius_m = 0.5, search_angle_deg = 30;
  int max_candidates = 3;          // keyframes tried per new keyframe
  int relocalise_candidates = 10;  // keyframes tried for a lost frame (the nearest are the recent ones)
  // ICP starts from the best-agreeing of a grid of poses around the tracked
  // one: translations every seed_step_m within search_radius_m, rotations
  // of 0 and +-seed_angle_deg about each axis.
  double seed_step_m = 0.1, seed_angle_deg = 3;
  int model_level = 1;  // pyramid level of the keyframes' stored maps
  // Verification of a candidate (level 0 figures of the final ICP pose).
  double max_rms = 0.03, min_inlier_ratio = 0.3;
  // ICP from each seed; the best-agreeing result is refused when another,
  // elsewhere, agrees with more than this fraction of its points.
  double uniqueness = 0.9;
  // A measured loop is accepted when measurements from `confirmations`
  // other keyframes among the last `window` agree with it this closely.
  double consistency_m = 0.015, consistency_deg = 1;
  int confirmations = 2, window = 5;
  double sigma_t = 0.01, sigma_r_deg = 0.5;  // every edge's standard deviation
};

struct LoopRecord {
  int frame = 0, keyframe_frame = 0;            // the frames it joins (sequence indices)
  Rigid3 measured;                              // keyframe_from_frame, as ICP found it
  double rms = 0, inlier_ratio = 0;             // the verifying ICP's figures
  double correction_m = 0, correction_deg = 0;  // how far the graph moved the new keyframe
  double seconds = 0;
};

class LoopCloser {
 public:
  explicit LoopCloser(const LoopOptions& options);
  ~LoopCloser();
  LoopCloser(const LoopCloser&) = delete;
  LoopCloser& operator=(const LoopCloser&) = delete;

  // A tracked frame (`frame`: its index in the sequence) with its pose in
  // the current (corrected) world.  Returns true when a loop closed: every
  // pose given so far has changed (pose(k)), the last one included.
  bool Add(int frame, const FramePyramid& pyramid, const Rigid3& world_from_cam);

  // A frame tracking lost, placed against the keyframes within the search
  // radius and angle of `near` (the last good pose), nearest first, as a
  // loop is measured (seeded ICP, unique) but without confirmation: its
  // world pose and the keyframe's frame, or nothing.  The caller checks it
  // against the model before trusting it.
  std::optional<std::pair<Rigid3, int>> Relocalise(const FramePyramid& pyramid, const Rigid3& near);

  // The corrected pose of the k-th frame given to Add.
  Rigid3 pose(size_t k) const;
  size_t size() const;
  int keyframes() const;
  bool IsKeyframe(int frame) const;
  int candidates_tried() const { return tried_; }
  const std::vector<LoopRecord>& loops() const { return loops_; }

 private:
  struct Impl;
  struct Pending;
  std::optional<Pending> Measure(int id, int k, const FramePyramid& pyramid);
  bool Consistent(const Pending& p, const Pending& q) const;
  void Accept(const std::vector<Pending>& loops);
  LoopOptions options_;
  std::vector<LoopRecord> loops_;
  int tried_ = 0;
  std::unique_ptr<Impl> impl_;
};

// Relative pose residual weighting and Ceres' solve, exposed for tests: the
// keyframe poses `nodes` (node 0 held fixed) adjusted so that nodes[a]^-1 *
// nodes[b] agrees with each edge's measurement.
struct PoseEdge {
  int a = 0, b = 0;
  Rigid3 b_in_a;  // a_from_b measured
};
void OptimisePoseGraph(std::vector<Rigid3>* nodes, const std::vector<PoseEdge>& edges, double sigma_t,
                       double sigma_r_rad);

}  // namespace mr
