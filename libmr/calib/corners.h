// Calibration-board corners in photographs: mrgingham for boards that use it
// (square grids), OpenCV's findChessboardCornersSB for other chessboards and
// its aruco module for ChArUco, with a per-image verdict.
//
// Pixel convention: the centre of the top-left pixel is (0, 0) (mrcal's and
// OpenCV's).  Corners come in board order (row-major, x fastest, as
// BoardSpec::ObjectPoints), each with the index of its board corner.
//
// A chessboard whose squares repeat under a half turn (inner-corner counts
// both even or both odd; square ones also under a quarter turn) cannot say
// which way up it is: among the orderings its symmetry allows, mr takes the
// one whose corner 0 lies nearest the image's top-left corner, and says so
// in `order`.  Views in which the board is turned more than 90 degrees from
// upright get a consistent but wrong order: keep the board's top up.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/board.h"
#include "core/image.h"

namespace mr {

struct CornerDetection {
  std::string image;  // the file, for reports
  bool found = false;
  std::string reason;                   // why not (found == false), or a note
  std::vector<Eigen::Vector2d> pixels;  // detected corners
  std::vector<int> ids;                 // their board-corner indices
  std::string detector;                 // "mrgingham", "opencv-sb", "opencv-charuco"
  std::string order;                    // how the corner order was fixed, for symmetric boards
  double sharpness_px = 0;              // OpenCV's estimate of the edge width (chessboards), 0 if not measured
  double saturated_fraction = 0;        // of pixels at the top code value
};

// Quality limits: an image is rejected (with the reason) when more than
// `max_saturated` of its pixels are clipped and the board is not found, or
// when the board is found but its edges are blurrier than `max_sharpness_px`.
struct CornerOptions {
  double max_saturated = 0.25;
  double max_sharpness_px = 6.0;
};

// `gray`: one channel, display values in [0, 1] (8-bit photographs as read).
CornerDetection DetectCorners(const Image& gray, const BoardSpec& board, const std::string& name,
                              const CornerOptions& options = {});

// The orderings of the board's corners that its symmetry allows, as index
// permutations (identity first).
std::vector<std::vector<int>> BoardSymmetries(const BoardSpec& board);

}  // namespace mr
