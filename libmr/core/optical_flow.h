// Dense optical flow between two images of one scene that differ in
// exposure, shading and white balance (a rendered room and its plate; two
// plate frames): OpenCV's DIS (Kroeger et al. 2016) on locally normalised
// grey images, each pixel's grey value (smoothed over 1 px) less its
// neighbourhood's mean over its neighbourhood's standard deviation
// (Gaussian, sigma 8 px), so that
// they are compared by their edges and texture.  Which pixels' flow is a
// measurement: textured in both images (the structure tensor's smaller
// eigenvalue) and consistent forward and back.  Registration in pixels
// (eval/registration.h) and the objects' swim (mr-render) stand on it.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"

namespace mr {

struct FlowOptions {
  // Pixels whose flow forward and back disagree by more than this are
  // left out (occlusions, repeated texture, the flow's failures).
  double consistency_px = 1.0;
  // Pixels whose normalised image's structure tensor (Gaussian, sigma 2 px)
  // has its smaller eigenvalue below this carry no measurable displacement
  // (a flat wall, an edge's direction along itself).
  double min_texture = 0.005;  // a texture of wavelength ~60 px
  int border_px = 4;           // of the measured region, eroded away (silhouettes)
};

struct FlowField {
  int width = 0, height = 0;
  std::vector<Eigen::Vector2f> flow;             // a to b, per pixel (dx, dy), row-major
  std::vector<Eigen::Vector2i> usable;           // the pixels (x, y) whose flow is a measurement
  int64_t region_pixels = 0, textured = 0;       // in `where`; of those, textured in both
  Eigen::Vector2f At(double x, double y) const;  // bilinear, clamped to the image
  // The median of the usable pixels' flow within `radius` px of (x, y)
  // (each component's); false when fewer than `min_pixels` are there.
  bool MedianNear(double x, double y, double radius, int min_pixels, Eigen::Vector2f* out) const;
};

// The flow from `a` to `b` (one size; R G B first or one channel; any
// units) over the pixels where `where` > 0 (null: all); non-finite pixels
// are left out.
FlowField MatchImages(const Image& a, const Image& b, const Image* where, const FlowOptions& options = {});

}  // namespace mr
