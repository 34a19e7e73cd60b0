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

#include <string>
#include <vector>

#include "calib/board.h"
#include "calib/corners.h"
#include "camera/camera_model.h"

namespace mr {

struct CalibrationOptions {
  std::string lensmodel = "LENSMODEL_OPENCV8";  // any mrcal model with an intrinsics core
  double focal_px = 0;                           // seed; 0: half the image width
  int min_views = 3;                             // refuse with fewer usable views
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
};

// `detections`: one per photograph, in order (DetectCorners).  Throws
// mr::Error (UsageError for too few views) with a message saying what is missing.
CalibrationResult CalibrateCamera(const BoardSpec& board, std::vector<CornerDetection> detections, int width,
                                  int height, const CalibrationOptions& options);

}  // namespace mr
