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
#include "core/json.h"

namespace mr {

struct CalibrationOptions {
  std::string lensmodel = "LENSMODEL_OPENCV8";  // any mrcal model with an intrinsics core
  double focal_px = 0;                           // seed; 0: half the image width
  int min_views = 3;                             // refuse with fewer usable views
};

// The projection uncertainty of a solved camera, as mrcal computes it: the
// observation noise (the inlier residuals' RMS per coordinate) propagated
// through the solve's Jacobian to the intrinsics and the board poses,
// Var(b) = s^2 (J'J)^-1 J_obs' J_obs (J'J)^-1, and from them to the
// projection of a fixed point: a point given in the camera frame is carried
// into each board's frame with the solution, back with perturbed poses, and
// averaged (mrcal's "mean frames" reference), then projected with perturbed
// intrinsics.  Points at infinity (directions); derivatives by central
// differences.
class ProjectionUncertainty {
 public:
  ProjectionUncertainty(std::string lensmodel, std::vector<double> intrinsics, std::vector<double> frames_rt,
                        Eigen::MatrixXd var_state);
  // The worst-direction standard deviation (px) of the projection of the
  // direction that pixel q sees.
  double StdevPx(const Eigen::Vector2d& q, const CameraModel& model) const;

 private:
  Eigen::Vector2d ProjectPerturbed(const Eigen::Vector3d& dir_cam, const Eigen::VectorXd& state) const;
  std::string lensmodel_;
  std::vector<double> intrinsics_, frames_rt_;
  Eigen::MatrixXd var_;
};

struct CalibrationView {
  CornerDetection detection;
  bool used = false;
  std::string reason;         // why not used
  double rms_px = 0;          // after the solve, over its inlier corners
  int outliers = 0;
};

struct CalibrationResult {
  CameraModel model;
  std::vector<CalibrationView> views;
  double rms_px = 0;          // over all inlier corners, of the residual's length (mrcal's own
                              // figure is per coordinate: sqrt(2) smaller)
  double worst_px = 0;        // largest inlier residual
  int corners = 0, outliers = 0;
  std::vector<std::string> stages;  // what was solved, with its RMS
  double noise_px = 0;              // the observation noise assumed by the uncertainty (per coordinate)
  // The solved problem in mrcal's terms (lensmodel, imagersize, intrinsics,
  // frames_rt_toref, observations_board (N x ny x nx x 3, weight < 0 for
  // outliers), spacing): what python3-mrcal needs to check the solution.
  Json problem;
  std::shared_ptr<const ProjectionUncertainty> uncertainty;
};

// `detections`: one per photograph, in order (DetectCorners).  Throws
// mr::Error (UsageError for too few views) with a message saying what is missing.
CalibrationResult CalibrateCamera(const BoardSpec& board, std::vector<CornerDetection> detections, int width,
                                  int height, const CalibrationOptions& options);

}  // namespace mr
