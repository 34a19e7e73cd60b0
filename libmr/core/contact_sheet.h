// Labelled panels in a grid, for the images people look at first (mr-render's
// review sheets).  Text is drawn with OpenCV's Hershey font, kept out of this
// header.
#pragma once

#include <string>
#include <vector>

#include "core/image.h"

namespace mr {

struct SheetPanel {
  const Image* image = nullptr;  // RGB (or one channel, shown grey) display values in [0, 1]; all panels one size
  std::string label;             // printed in a strip above the panel
};

// The panels left to right, top to bottom, `columns` per row, each under
// its label, on a dark grey ground: an RGB image of display values in
// [0, 1], to be written as 8-bit without further encoding.  Deterministic.
Image ContactSheet(const std::vector<SheetPanel>& panels, int columns);

// A signed difference as a picture: 0.5 + 0.5 d / scale per channel
// (mid-grey: unchanged; brighter: added light; darker: removed), with
// `scale` the largest |d| when `scale` <= 0 (*used receives it).
Image SignedDifferencePanel(const Image& difference, double scale = 0, double* used = nullptr);

}  // namespace mr
