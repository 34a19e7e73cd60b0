// Synthetic photographs of a calibration board through a known lens (any
// mrcal model, fish-eye past 180 degrees included): the ground truth of
// mr-calibrate's tests.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "calib/board.h"
#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/image.h"

namespace mr {

struct BoardViewOptions {
  int supersample = 4;       // per pixel edge: the box-filtered image of the board
  double blur_sigma_px = 0;  // Gaussian blur after rendering (defocus)
  double noise_sigma = 0;    // Gaussian noise on [0, 1] values, seeded
  double exposure = 1;       // white paper renders at min(1, 0.9 exposure): > 1.1 clips
  double background = 0.45;  // what is not the board
  uint64_t seed = 1;
};

// The board (its printed squares and a white margin of one square) seen by
// `camera` from `cam_from_board`; one grey channel in [0, 1].
Image RenderBoardView(const BoardSpec& board, const CameraModel& camera, const Rigid3& cam_from_board,
                      const BoardViewOptions& options = {});

// The same for many views through one camera: the camera's ray at every
// supersample of every pixel is unprojected once, here (mrcal's unprojection
// of splined and OPENCV lenses is an iterative solve per point, most of the
// cost of a view).  Render gives the bytes RenderBoardView gives with the
// same options, whose supersample must be this one.
class BoardViewRenderer {
 public:
  BoardViewRenderer(const CameraModel& camera, int supersample);
  Image Render(const BoardSpec& board, const Rigid3& cam_from_board, const BoardViewOptions& options) const;

 private:
  int width_, height_, supersample_;
  std::vector<Eigen::Vector3d> rays_;  // row-major over (W S) x (H S); NaN outside the lens
};

// Board poses for calibration photographs by a camera of about 90 degrees:
// around the axis at 0.3-0.5 m, turned and tilted, their centres spread
// over the field of view.
std::vector<Rigid3> CalibrationBoardPoses(const BoardSpec& board, int n);

// For a fish-eye: board centres at 0, 30, 55 and 78 degrees from the axis
// (five azimuths each, two on the axis), facing the camera from `distance`,
// turned and tilted; corners reach past 90 degrees.
std::vector<Rigid3> FisheyeBoardPoses(const BoardSpec& board, double distance);

// A synthetic calibration set (mr-synth --boards LENS): photographs of
// `board` through a known lens, "pinhole" (640x480), "opencv8" (640x480),
// "fisheye190" (a 190-degree splined stereographic lens, 640x640) or "rig"
// (two OPENCV8 cameras 11 cm apart), or through the camera of a
// .cameramodel file: out/board.json, out/truth/CAM.cameramodel
// and out/photos/CAM-NN.png, with noise, plus three photographs the
// calibration must leave out (blurred, over-exposed, the board half out of
// the frame).  Returns the files written.
std::vector<fs::path> WriteBoardSet(const std::string& lens, const BoardSpec& board, const fs::path& out, uint64_t seed,
                                    const std::string& note);

}  // namespace mr
