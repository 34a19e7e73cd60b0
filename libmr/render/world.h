// The world of a frame: the scene's light and objects where they change
// during the video (per-frame environment maps and lights files, object
// trajectories; docs/formats.md, docs/conventions.md "Object trajectories").
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/json.h"
#include "render/render_scene.h"
#include "scene/scene.h"

namespace mr {

// What differs from the previous frame's world.  Light files are compared
// by content (a per-frame file with the same bytes as the last is no change).
struct WorldChange {
  bool environment = false, lights = false;
  std::vector<std::string> moved;         // virtual objects whose world_from_object changed
  std::vector<std::string> moved_lights;  // virtual lights that moved (`lights` is set too)
  std::vector<std::string> notes;         // e.g. a frame without its own map reusing an earlier one's
  std::string trees;  // where objects moved: the ray-tracing trees rebuilt and kept (EmbreeScene::last_commit)
  bool any() const { return environment || lights || !moved.empty(); }
  std::string Describe() const;  // "environment, lights, bunny moved"
  Json ToJson() const;
};

class WorldTracker {
 public:
  // `rs` holds the world of `frame` (LoadRenderScene(scene, rs, frame)).
  WorldTracker(const Scene& scene, const RenderScene& rs, int frame);
  // Whether anything can change between frames (a per-frame light or a trajectory).
  bool dynamic() const { return dynamic_; }
  // Brings `rs` to the world of frame `f` (any order), changing and
  // committing only what differs.
  WorldChange Advance(int f, RenderScene* rs);

 private:
  struct FileState {
    std::optional<fs::path> path;
    uint64_t hash = 0;
  };
  static FileState Stat(const std::optional<fs::path>& path);
  const Scene& scene_;
  bool dynamic_ = false;
  FileState env_, lights_;
  std::vector<Eigen::Affine3d> poses_;        // of the virtual objects
  std::vector<Eigen::Affine3d> light_poses_;  // of the virtual lights
};

}  // namespace mr
