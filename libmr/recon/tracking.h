// KinectFusion's camera tracking: a filtered depth pyramid with vertex and
// normal maps, and point-to-plane ICP with projective data association
// against the model's raycast (frame to model), coarse to fine; optionally
// with a photometric term against the previous frame's intensity, as in
// RGB-D odometry (Steinbrücker et al. 2011) and ElasticFusion.
//
// The 6x6 normal equations are examined before every step: their
// eigenvalues, with rotations scaled by the scene's depth so that both
// halves are in metres, give a condition number, and directions the data
// leaves unconstrained (a flat wall: two translations and the rotation about
// its normal) are held to the motion prior (constant velocity) instead of
// drifting on noise.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "camera/pose.h"
#include "recon/rgbd.h"
#include "recon/tsdf.h"

namespace mr {

struct FramePyramid {
  std::vector<PinholeIntrinsics> K;  // per level, 0 = full resolution
  std::vector<DepthMap> depth;       // filtered, metres
  std::vector<PointMaps> maps;       // camera frame
  // Linear luminance per level (depth's size; 2x2 means), empty without
  // colour; NaN where the colour is clipped.
  std::vector<std::vector<float>> intensity;
  int64_t valid = 0;  // valid depth pixels at level 0
};

struct PyramidOptions {
  int levels = 3;
  bool bilateral = true;
  double sigma_space_px = 4.5, sigma_depth_m = 0.03;  // KinectFusion's filter
  double max_depth_jump = 0.05;                       // relative: normals across larger jumps are invalid
};

// Depth (0 = invalid) to a pyramid; halving keeps pixels within 3 sigma_depth
// of the block's first valid one (no averaging across edges).
// Level 0's depth: the bilateral filter (when options.bilateral), keeping
// holes holes.
DepthMap FilterDepth(const DepthMap& depth, const PyramidOptions& options);

// `color` (linear RGB, depth's size; may be null) gives the intensity levels.
FramePyramid BuildPyramid(const DepthMap& depth, const PinholeIntrinsics& K, const PyramidOptions& options,
                          const Image* color = nullptr);

struct IcpOptions {
  std::vector<int> iterations = {10, 5, 4};  // per level, finest first
  double max_distance = 0.10;                // metres, association gate (finest level; x2 per coarser level)
  double max_angle_deg = 30;                 // normal agreement gate
  double huber = 0.01;                       // metres
  double weak_eigen_ratio = 1e-3;            // eigenvalue / largest below this: unconstrained
  // Tracking is lost when the result has fewer inliers than this fraction
  // of valid pixels, a larger RMS residual, or moves farther than the
  // limits from the prediction.
  double min_inlier_ratio = 0.15, max_rms = 0.03, max_jump_m = 0.3, max_jump_deg = 30;
  // ... or more than this fraction of its points land in space the model
  // saw empty (nearer than its surface along the model camera's ray by
  // free_space_margin): a wrong pose whose residual and inliers look right.
  double max_free_space = 0.1, free_space_margin = 0.1;
  // The photometric term (used only when TrackIcp is given a previous
  // frame): "weak" adds it to a step only where depth alone leaves a weak
  // direction (a flat wall), "always" to every step, "off" never.  Measured
  // on 7-Scenes, whose colour is not registered to its depth, "always" made
  // the per-frame drift worse (docs/benchmarks.md).
  std::string color_term = "weak";
  // Its weight against the point-to-plane term (metres against linear
  // intensity in [0, 1]); Open3D's hybrid odometry weighs them 0.968 : 0.032.
  double color_weight = 0.033;
  double color_huber = 0.05;      // intensity
  double color_occlusion = 0.05;  // metres: pixels whose depth disagrees with the previous frame's are left out
};

// The previous frame for the photometric term: its pyramid (intensity and
// depth) and its pose.
struct PhotometricTarget {
  const FramePyramid* frame = nullptr;
  Rigid3 world_from_cam;
};

struct IcpResult {
  Rigid3 world_from_cam;
  double rms = 0;           // metres, point-to-plane, inliers at level 0
  double inlier_ratio = 0;  // associated / valid pixels at level 0
  double condition = 0;     // largest / smallest eigenvalue (scaled)
  int weak_directions = 0;  // held to the prior
  // The weak directions of the last step: orthonormal in the scaled
  // increment space x_s = x / weak_scale (x = (omega, t) about the camera
  // centre).  RemoveWeak takes them out of a velocity so that noise in them
  // is not carried into the next prediction.
  std::vector<Eigen::Matrix<double, 6, 1>> weak_basis;
  Eigen::Matrix<double, 6, 1> weak_scale = Eigen::Matrix<double, 6, 1>::Ones();
  Eigen::Matrix<double, 6, 1> RemoveWeak(const Eigen::Matrix<double, 6, 1>& x) const {
    Eigen::Matrix<double, 6, 1> xs = x.cwiseQuotient(weak_scale);
    for (const auto& v : weak_basis) xs -= v * v.dot(xs);
    return xs.cwiseProduct(weak_scale);
  }
  int iterations = 0;
  double free_space_ratio = 0;  // of the points landing on the model, those in its free space
  int64_t color_pixels = 0;     // pixels in the photometric term at level 0 (0: not used)
  double color_rms = 0;         // their intensity residual
  bool ok = false;              // passed the loss tests
  std::string failure;          // why not
};

// `model` holds world-frame maps raycast from `model_pose` with intrinsics
// `model_K`; `guess` is the prediction (also the motion prior).
// With `photo` (and intensity in both pyramids), each step adds the
// photometric normal equations, weighted by options.color_weight.
IcpResult TrackIcp(const FramePyramid& frame, const PointMaps& model, const PinholeIntrinsics& model_K,
                   const Rigid3& model_pose, const Rigid3& guess, const IcpOptions& options,
                   const PhotometricTarget* photo = nullptr);

// The increment xi = (omega, t) about the camera centre c: world points
// move as p' = exp(omega) (p - c) + c + t.  Rotations about the camera
// rather than the world origin keep the 6x6 system's rotation and
// translation blocks decoupled wherever the room's origin is.
Rigid3 ApplyIncrement(const Eigen::Matrix<double, 6, 1>& xi, const Rigid3& world_from_cam);
// The increment that takes `from` to `to`.
Eigen::Matrix<double, 6, 1> IncrementBetween(const Rigid3& from, const Rigid3& to);

}  // namespace mr
