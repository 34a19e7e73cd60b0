// Synthetic photographs of a calibration board through a known lens (any
// mrcal model, fish-eye past 180 degrees included): the ground truth of
// mr-calibrate's tests.
#pragma once

#include <cstdint>

#include "calib/board.h"
#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/image.h"

namespace mr {

struct BoardViewOptions {
  int supersample = 4;         // per pixel edge: the box-filtered image of the board
  double blur_sigma_px = 0;    // Gaussian blur after rendering (defocus)
  double noise_sigma = 0;      // Gaussian noise on [0, 1] values, seeded
  double exposure = 1;         // white paper renders at min(1, 0.9 exposure): > 1.1 clips
  double background = 0.45;    // what is not the board
  uint64_t seed = 1;
};

// The board (its printed squares and a white margin of one square) seen by
// `camera` from `cam_from_board`; one grey channel in [0, 1].
Image RenderBoardView(const BoardSpec& board, const CameraModel& camera, const Rigid3& cam_from_board,
                      const BoardViewOptions& options = {});

}  // namespace mr
