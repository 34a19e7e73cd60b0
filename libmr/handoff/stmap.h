// A calibrated lens as ST-maps (the convention of Nuke's STMap node and
// Blender's compositor): an artist renders through a distortion-free
// pinhole and redistorts the render in the compositor.  Each map pixel holds
// the normalised source coordinate (s, t) = ((x + 0.5) / W, 1 - (y + 0.5) / H)
// of the image it reads, (x, y) in mrcal's pixels of that image (0, 0 the
// top-left pixel's centre), so (0, 0) is the source's bottom-left corner and
// (1, 1) its top-right; B and A are 1 where the pixel maps (Blender's Map UV
// node reads B as alpha, as in its UV pass) and 0, with s = t = -1, where it
// does not.  docs/formats.md, "ST-maps"; docs/methods.md.
#pragma once

#include <string>

#include "camera/camera_model.h"
#include "core/image.h"

namespace mr {

struct StMaps {
  // The distortion-free camera to render through: the model's pinhole core,
  // its image grown (overscan) so that it holds every direction the lens
  // sees, within `max_angle_deg` of the axis.
  CameraModel pinhole;
  int overscan_left = 0, overscan_top = 0;  // pixels the pinhole's image adds on each side
  Image undistort;                          // pinhole's size: where each pinhole pixel is in the lens's image
  Image redistort;                          // the lens's size: where each lens pixel is in the pinhole's image
  // The lens's pixels whose ray lies beyond max_angle_deg (a fish-eye past
  // what a pinhole can hold): alpha 0 in `redistort`.
  int64_t unmapped = 0;
  double max_angle_deg = 0;  // the widest angle from the axis the pinhole holds
};

// The maps of `lens`.  Directions more than `max_angle_deg` (< 90) from the
// axis are left out of the pinhole (a fish-eye past 180 degrees maps only
// the part within it).  Deterministic; the lens's rays by libmrcal.
StMaps MakeStMaps(const CameraModel& lens, double max_angle_deg = 80);

}  // namespace mr
