// Registration in pixels: how far the real room, rendered through a
// frame's pose, sits from the plate (mr-eval plate, per frame), and how far
// an object standing on the room swims against the plate between frames
// (mr-render, per frame).  Both come from dense optical flow (OpenCV's DIS,
// Kroeger et al. 2016) on locally normalised grey images: each pixel's
// grey value less its neighbourhood's mean, over its neighbourhood's
// standard deviation (Gaussian, sigma 8 px), so that the rendered room and
// the photograph, which differ in exposure, shading and white balance,
// are compared by their edges and texture.  The method, its limits and the
// figures measured: docs/methods.md, "Registration in pixels".
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "core/json.h"

namespace mr {

struct RegistrationOptions {
  // Pixels whose flow forward and back disagree by more than this are
  // left out (occlusions, repeated texture, the flow's failures).
  double consistency_px = 1.0;
  // Pixels whose normalised image's structure tensor (Gaussian, sigma 2 px)
  // has its smaller eigenvalue below this carry no measurable displacement
  // (a flat wall, an edge's direction along itself).
  double min_texture = 0.02;
  int border_px = 4;     // of the measured region, eroded away (silhouettes)
  int tile_px = 32;      // the tiles the standard error is taken over
  int min_pixels = 200;  // fewer usable pixels: not measurable
};

struct RegistrationResult {
  bool measurable = false;
  std::string why;                                      // when not
  double mean_px = 0, p90_px = 0, stderr_px = 0;        // |displacement| over the usable pixels
  Eigen::Vector2d mean_flow = Eigen::Vector2d::Zero();  // the mean displacement (x right, y down), px
  int64_t region_pixels = 0, usable_pixels = 0;         // in `where`; textured and consistent of those
  Json ToJson() const;
};

// A frame's registration: the displacement that carries `rendered` (the
// room alone through the frame's pose, any units) onto `plate` (the
// photograph, any units), over the pixels where `where` > 0 (the room's).
// Non-finite pixels are left out.  Images of one size (R G B first, or
// one channel).
RegistrationResult MeasureRegistration(const Image& rendered, const Image& plate, const Image& where,
                                       const RegistrationOptions& options = {});

// Dense flow from grey image `a` to `b` (the plate at two frames, locally
// normalised as above): per pixel (dx, dy), row-major, width x height.
std::vector<Eigen::Vector2f> PlateFlow(const Image& a, const Image& b);

// The swim of a point that stands on the room: where the poses carry its
// projection (`from` in frame f to `to` in frame f + 1) against where the
// plate's own content there moved (the flow at `from`, bilinear): |to -
// from - flow(from)| in pixels.  NaN when `from` lies outside the image.
double Swim(const std::vector<Eigen::Vector2f>& flow, int width, int height, const Eigen::Vector2d& from,
            const Eigen::Vector2d& to);

}  // namespace mr
