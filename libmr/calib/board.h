// Calibration boards: definitions (calib/boards/*.json) and printable SVGs.
//
// A board's object points are in the board frame: origin at the first inner
// corner, x along rows, y along columns, z = 0 on the board, metres.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/file.h"
#include "core/image.h"
#include "core/json.h"

namespace mr {

struct BoardSpec {
  std::string name;
  std::string type = "chessboard";     // "chessboard" or "charuco"
  int inner_x = 0, inner_y = 0;        // inner corners per row and per column
  double square_m = 0;                 // square side, metres
  double marker_m = 0;                 // ChArUco marker side, metres
  std::string dictionary;              // ChArUco: OpenCV ArUco dictionary name
  std::string detector = "mrgingham";  // "mrgingham" or "opencv"

  int squares_x() const { return inner_x + 1; }
  int squares_y() const { return inner_y + 1; }
  // Inner-corner positions, row-major (x fastest), metres, z = 0.
  std::vector<Eigen::Vector3d> ObjectPoints() const;
};

BoardSpec ParseBoard(const Json& j, const std::string& name);
BoardSpec ReadBoard(const fs::path& path);
Json BoardToJson(const BoardSpec& b);

// The printed page of BoardSvg at 100 %, millimetres (width, height).
std::pair<double, double> BoardPageMm(const BoardSpec& b, double margin_mm);
// The smallest ISO A sheet (A4 up to A0) that holds w x h mm either way
// up ("A4", "A3", ...); empty when none does.
std::string SmallestIsoA(double w_mm, double h_mm);

// An SVG of the board at its physical size (width/height in mm), with a white
// quiet zone of `margin_m` around it and a caption giving the size to check
// the print with a ruler.  Chessboards are vector rectangles; ChArUco boards
// embed OpenCV's drawing as a lossless PNG at `charuco_pixels_per_mm`,
// placed at the board's exact size.
std::string BoardSvg(const BoardSpec& b, double margin_m = 0.01, double charuco_pixels_per_mm = 20);

// ChArUco through OpenCV's aruco module (calib/charuco.cpp): the board as
// drawn by OpenCV (1 = white), the board's physical size at `pixels_per_mm`.
Image CharucoImage(const BoardSpec& b, double pixels_per_mm);
std::string EncodePng8(const Image& gray);

struct CharucoDetection {
  int markers = 0;                       // ArUco markers found
  std::vector<int> ids;                  // ChArUco corner ids found
  std::vector<Eigen::Vector2d> corners;  // their pixels (mr convention)
};
// Detects the board's markers and interpolates its chessboard corners.
CharucoDetection DetectCharuco(const BoardSpec& b, const Image& gray);

}  // namespace mr
