// Intrinsic calibration of one camera from photographs of a board, solved by
// libmrcal's optimiser (mrcal_optimize) with the seeding done here in C++:
//
//  1. corners in every photograph (calib/corners.h), each kept or rejected
//     with its reason;
//  2. a seed: a stereographic lens of focal `focal_px` (or half the image
//     width) centred on the image; each board pose from the seed's rays by
//     OpenCV's solvePnP on the rays within 75 degrees of the axis;
//  3. mrcal solves the stereographic core and the board poses, then the
//     requested model's core with its distortions at zero, then everything
//     with mrcal's regularisation and outlier rejection.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/board.h"
#include "calib/corners.h"
#include "camera/camera_model.h"
#include "camera/pose.h"

namespace mr {

struct CalibrationOptions {
  std::string lensmodel = "LENSMODEL_OPENCV8";  // any mrcal model with an intrinsics core
  double focal_px = 0;                          // seed; 0: half the image width
  int min_views = 3;                            // refuse with fewer usable views

  // UsageError naming the flag: an unknown --lensmodel or one without an
  // intrinsics core, a negative --focal, --min-views below 1.
  void Check() const;
};

// The projection uncertainty of a solved camera, as mrcal computes it: the
// observation noise (the inlier residuals' RMS per coordinate) propagated
// through the solve's Jacobian to the intrinsics, the extrinsics and the
// board poses, Var(b) = s^2 (J'J)^-1 J_obs' J_obs (J'J)^-1, and from them to
// the projection of a fixed point: a point given in the camera frame is
// carried into the reference frame and each board's frame with the solution,
// back with perturbed poses and averaged (mrcal's "mean frames" reference),
// then into the camera with perturbed extrinsics and projected with perturbed
// intrinsics.  Points at infinity (directions); derivatives by central
// differences.
class ProjectionUncertainty {
 public:
  // `state`: the solution in physical units, laid out as mrcal's state
  // vector; `var`: its covariance.  The offsets locate this camera's
  // intrinsics, its extrinsics (-1: the reference camera) and the F frames.
  struct Layout {
    int intrinsics = 0, n_intrinsics = 0, extrinsics = -1, frames = 0, n_frames = 0;
  };
  ProjectionUncertainty(std::string lensmodel, Eigen::VectorXd state, Eigen::MatrixXd var, Layout layout);
  // The worst-direction standard deviation (px) of the projection of the
  // direction that pixel q sees.
  double StdevPx(const Eigen::Vector2d& q, const CameraModel& model) const;

 private:
  Eigen::Vector2d ProjectPerturbed(const Eigen::Vector3d& dir_cam, const Eigen::VectorXd& state) const;
  std::string lensmodel_;
  Eigen::VectorXd state_;
  Eigen::MatrixXd var_;
  Layout layout_;
  std::vector<Eigen::Index> used_;  // the state elements the projection depends on
};

struct CalibrationView {
  CornerDetection detection;
  bool used = false;
  std::string reason;  // why not used
  double rms_px = 0;   // after the solve, over its inlier corners
  int outliers = 0;
  Rigid3 cam_from_board;  // solved pose, for used views
};

struct CalibrationResult {
  // The camera; in a rig, with its extrinsics (cam_from_ref, the reference
  // being camera 0).  It carries mrcal's optimisation inputs, so that
  // mrcal's tools (mrcal-show-residuals, mrcal-show-projection-uncertainty)
  // accept the written file.
  CameraModel model;
  std::vector<CalibrationView> views;
  double rms_px = 0;    // over all inlier corners, of the residual's length (mrcal's own
                        // figure is per coordinate: sqrt(2) smaller)
  double worst_px = 0;  // largest inlier residual
  int corners = 0, outliers = 0;
  std::vector<std::string> stages;  // what was solved, with its RMS
  double noise_px = 0;              // the observation noise assumed by the uncertainty (per coordinate)
  std::shared_ptr<const ProjectionUncertainty> uncertainty;
};

// `detections`: one per photograph, in order (DetectCorners).  Throws
// mr::Error (UsageError for too few views) with a message saying what is missing.
CalibrationResult CalibrateCamera(const BoardSpec& board, std::vector<CornerDetection> detections, int width,
                                  int height, const CalibrationOptions& options);

// The board's pose in a calibrated camera's frame from one photograph's
// corners (solvePnP on the corners' rays through the lens).  Throws
// mr::Error naming the photograph when the board was not found.
Rigid3 BoardPose(const BoardSpec& board, const CameraModel& camera, const CornerDetection& detection);

// The world a board lying flat, printed side up, defines (docs/formats.md,
// probe.json): origin at its first inner corner, +x along its rows, +y up
// (out of the printed side), +z along its columns.  From the board's pose
// in a camera to the camera's pose in that world.
Rigid3 WorldFromCamByFlatBoard(const Rigid3& cam_from_board);

struct RigCalibrationResult {
  std::vector<CalibrationResult> cameras;  // camera 0 is the reference
  // Per camera, Var(rt_cam_fromref) (mrcal's extrinsics: Rodrigues r then
  // t, metres) from the joint solve; zero for camera 0.
  std::vector<Eigen::Matrix<double, 6, 6>> extrinsics_covariance;
  std::vector<std::string> stages;
  int instants = 0;         // instants at which at least one camera saw the board
  int shared_instants = 0;  // ... at least two
  double rms_px = 0, noise_px = 0;
};

// Two or more cameras photographing the board at the same instants:
// detections[c][i] is camera c's photograph at instant i (every camera has
// the same number).  One lens model for every camera (mrcal's restriction).
// Each camera is first calibrated alone (CalibrateCamera); the extrinsics are
// seeded from the board poses of the instants both cameras saw; then mrcal
// solves the intrinsics, the extrinsics and the board poses jointly.
// Refused, with the reason, when a camera shares no instant with camera 0.
RigCalibrationResult CalibrateRig(const BoardSpec& board, std::vector<std::vector<CornerDetection>> detections,
                                  const std::vector<Eigen::Vector2i>& sizes, const CalibrationOptions& options);

}  // namespace mr
