// One frame's plate as a view the render can look up (docs/methods.md,
// "The plate in reflections").
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/image.h"
#include "core/json.h"

namespace mr {

// The plate as the mixed paths see it (docs/methods.md, "The plate in
// reflections"): where a ray leaving a virtual surface meets a real one
// that the plate's camera sees unoccluded, the plate's radiance there (in
// the render's units) is what arrives, instead of the rendered room's.
// One frame's view; PlateViews lists the frame's own first, then its
// neighbours' (nearest first): the first that sees the point is taken.
struct PlateView {
  const Image* radiance = nullptr;  // null: none
  // One channel, > 0 where the plate clipped (its value is a lower bound:
  // rendered instead); null: none clipped.
  const Image* clipped = nullptr;
  const CameraModel* camera = nullptr;
  Rigid3 world_from_cam;
};
using PlateViews = std::vector<PlateView>;

// How often the mixed paths took the plate's radiance, and how often a real
// point met from a virtual surface was seen by no plate (rendered).
struct PlateCounters {
  std::atomic<int64_t> from_plate{0}, rendered{0};
  std::atomic<int64_t> from_other_frames{0};  // of `from_plate`: a neighbour's plate (the frame's own does not see it)
  std::atomic<int64_t> clipped{0};            // of `rendered`: a plate clipped there
  // Of all: real points met through a refraction (a virtual glass), and of
  // those, the ones the plate gave.
  std::atomic<int64_t> through_glass{0}, through_glass_from_plate{0};
};

// A frame report's `plate_reflections` entry; null when no real point was
// met from a virtual surface.
inline Json PlateCountersJson(const PlateCounters& c) {
  const int64_t total = c.from_plate + c.rendered;
  if (total == 0) return nullptr;
  return {{"from_plate", c.from_plate.load()},
          {"from_other_frames", c.from_other_frames.load()},
          {"rendered", c.rendered.load()},
          {"rendered_clipped", c.clipped.load()},
          {"share", static_cast<double>(c.from_plate) / static_cast<double>(total)},
          {"through_glass", c.through_glass.load()},
          {"through_glass_share",
           c.through_glass > 0 ? static_cast<double>(c.through_glass_from_plate) / static_cast<double>(c.through_glass)
                               : 0.0}};
}

}  // namespace mr
