// The objects' swim against the plate (issue 40): an object standing on
// the room must move in the composite exactly as the table under it moves
// in the plate.  Per rendered frame after the first, for each virtual
// object that stands still in the world: its contact point (the centroid
// of its vertices within 1% of its height of its lowest, along the world's
// up) projected through the previous and this frame's poses, against the
// plate's own motion there (dense flow between the two plates,
// core/optical_flow.h; the median of the measurable flow within 24 px of
// the contact point): |moved by the poses - moved in the plate| in pixels.  With exact poses it is the flow's error
// (~0.1 px); pose errors that change from frame to frame show as swim.  docs/methods.md, "Registration in pixels".
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/image.h"
#include "core/json.h"
#include "scene/scene.h"

namespace mr {

class SwimMeter {
 public:
  // Reads the virtual objects' meshes (their vertices, in their own frame).
  SwimMeter(const Scene& scene, const CameraModel& camera);
  // Frame f's plate (any units) and pose: the swim since the last frame
  // given, if it was f - 1 (null otherwise, and for the first): an object
  // entry {name: px} (NaN-free: an object whose contact point leaves the
  // image or that moved in the world is left out).
  Json Frame(int f, const Rigid3& world_from_cam, const Image& plate);
  // Over the frames: per object the RMS and the largest swim, px.
  Json Summary() const;
  bool any() const { return !objects_.empty(); }

 private:
  struct Object {
    std::string name;
    const SceneVirtual* v;
    std::vector<Eigen::Vector3d> vertices;
    std::vector<double> swims;
    int unmeasured = 0;  // frame steps where the plate's flow around it was not measurable
  };
  std::optional<Eigen::Vector2d> Contact(const Object& o, int f, const Rigid3& world_from_cam) const;

  const Scene& scene_;
  const CameraModel& camera_;
  Eigen::Vector3d up_;
  std::vector<Object> objects_;
  int last_frame_ = -2;
  Image last_plate_;
  Rigid3 last_pose_;
};

}  // namespace mr
