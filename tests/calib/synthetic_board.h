// The board of the calibration tests' synthetic photographs.
#pragma once

#include "calib/board.h"

namespace mr::test {

// 8 x 6 inner corners of 30 mm, found by OpenCV (a half-turn symmetric board).
inline BoardSpec SyntheticBoard86() {
  BoardSpec b;
  b.name = "synthetic 8x6";
  b.inner_x = 8;
  b.inner_y = 6;
  b.square_m = 0.03;
  b.detector = "opencv";
  return b;
}

}  // namespace mr::test
