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
#include "light/environment.h"

namespace mr {

// The plate as the mixed paths see it (docs/methods.md, "The plate in
// reflections"): where a ray leaving a virtual surface meets a real one
// that the plate's camera sees unoccluded, the plate's radiance there (in
// the render's units) is what arrives, instead of the rendered room's.
// One frame's view; PlateViews lists the frame's own first, then its
// neighbours' (nearest first): the first that sees the point is taken.
//
// Or a light probe (`probe` set; docs/methods.md, "The room's own light"):
// the lat-long map a probe centred at `probe_centre` saw, in the render's
// units with the lights mr-lights took out of it (their light comes from
// lights.json), is the radiance of the real point it sees in that
// direction (Debevec 1998's light-based model of the distant scene, on the
// room's real geometry).  Probes come after the plates; of those that see
// the point, the one whose direction from it is nearest the ray's is
// taken.
struct PlateView {
  const Image* radiance = nullptr;  // null: none
  // One channel, > 0 where the plate clipped (its value is a lower bound:
  // rendered instead); null: none clipped.
  const Image* clipped = nullptr;
  const CameraModel* camera = nullptr;
  Rigid3 world_from_cam;
  const EnvironmentMap* probe = nullptr;  // a probe instead of a camera
  Eigen::Vector3d probe_centre = Eigen::Vector3d::Zero();
};
using PlateViews = std::vector<PlateView>;
inline constexpr size_t kMaxPlateViews = 64;  // plates and probes together

// How often the mixed paths took the plate's radiance, and how often a real
// point met from a virtual surface was seen by no plate (rendered).
struct PlateCounters {
  std::atomic<int64_t> from_plate{0}, rendered{0};
  std::atomic<int64_t> from_probe{0};         // the room's radiance from a probe (no plate sees the point)
  std::atomic<int64_t> from_other_frames{0};  // of `from_plate`: a neighbour's plate (the frame's own does not see it)
  std::atomic<int64_t> clipped{0};            // of `rendered`: a plate clipped there
  // Of all: real points met through a refraction (a virtual glass), and of
  // those, the ones the plate gave.
  std::atomic<int64_t> through_glass{0}, through_glass_from_plate{0};
};

// A frame report's `plate_reflections` entry; null when no real point was
// met from a virtual surface.
inline Json PlateCountersJson(const PlateCounters& c) {
  const int64_t total = c.from_plate + c.from_probe + c.rendered;
  if (total == 0) return nullptr;
  return {{"from_plate", c.from_plate.load()},
          {"from_probe", c.from_probe.load()},
          {"from_other_frames", c.from_other_frames.load()},
          {"rendered", c.rendered.load()},
          {"rendered_clipped", c.clipped.load()},
          {"share", static_cast<double>(c.from_plate) / static_cast<double>(total)},
          {"probe_share", static_cast<double>(c.from_probe) / static_cast<double>(total)},
          {"through_glass", c.through_glass.load()},
          {"through_glass_share",
           c.through_glass > 0 ? static_cast<double>(c.through_glass_from_plate) / static_cast<double>(c.through_glass)
                               : 0.0}};
}

}  // namespace mr
