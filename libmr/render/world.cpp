#include "render/world.h"

#include <fmt/format.h>

#include "core/hash.h"

namespace mr {

std::string WorldChange::Describe() const {
  std::string s;
  auto add = [&](const std::string& t) { s += (s.empty() ? "" : ", ") + t; };
  if (environment) add("environment map");
  if (lights) add("lights");
  for (const std::string& m : moved) add(m + " moved");
  for (const std::string& m : moved_lights) add(m + " moved");
  return s;
}

Json WorldChange::ToJson() const {
  Json j = {{"environment", environment}, {"lights", lights}, {"moved", moved}};
  if (!moved_lights.empty()) j["moved_lights"] = moved_lights;
  if (!notes.empty()) j["notes"] = notes;
  if (!trees.empty()) j["trees"] = trees;
  return j;
}

WorldTracker::FileState WorldTracker::Stat(const std::optional<fs::path>& path) {
  return FileState{path, path ? ContentHash(*path) : 0};
}

WorldTracker::WorldTracker(const Scene& scene, const RenderScene& rs, int frame) : scene_(scene) {
  (void)rs;
  dynamic_ =
      scene.lighting.environment_per_frame || scene.lighting.environment_video || scene.lighting.lights_per_frame;
  for (const SceneVirtualLight& l : scene.virtual_lights) {
    dynamic_ = dynamic_ || !l.keyframes.empty();
    light_poses_.push_back(PoseAt(l.keyframes, l.world_from_object, frame));
  }
  for (const SceneVirtual& v : scene.virtuals) {
    dynamic_ = dynamic_ || !v.keyframes.empty();
    poses_.push_back(v.WorldFromObjectAt(frame));
  }
  if (scene.lighting.environment_per_frame || scene.lighting.environment_video)
    env_ = FileState{EnvironmentAt(scene, frame), EnvironmentKey(scene, frame)};
  if (scene.lighting.lights_per_frame) lights_ = Stat(LightsAt(scene, frame));
}

WorldChange WorldTracker::Advance(int f, RenderScene* rs) {
  WorldChange c;
  if (!dynamic_) return c;
  auto file = [&](bool per_frame, const char* what, auto at, FileState* state, auto load) {
    if (!per_frame) return false;
    int from = f;
    const FileState now = Stat(at(scene_, f, &from));
    if (from != f) c.notes.push_back(fmt::format("frame {} has no {} of its own: frame {}'s", f, what, from));
    const bool changed = now.hash != state->hash;  // another file with the same bytes is no change
    if (changed) load(scene_, *now.path, rs);
    *state = now;
    return changed;
  };
  if (scene_.lighting.environment_per_frame || scene_.lighting.environment_video) {
    int from = f;
    const uint64_t key = EnvironmentKey(scene_, f, &from);
    if (from != f)
      c.notes.push_back(fmt::format("frame {} has no environment map of its own: {}frame {}'s", f,
                                    scene_.lighting.environment_video ? "the video's last, " : "", from));
    c.environment = key != env_.hash;  // another map with the same content is no change
    if (c.environment) LoadEnvironment(scene_, f, rs);
    env_.hash = key;
  }
  // The lights: the file's when it changed, the virtual lights' when one moved.
  bool lights_moved = false;
  for (size_t i = 0; i < scene_.virtual_lights.size(); ++i) {
    const SceneVirtualLight& l = scene_.virtual_lights[i];
    const Eigen::Affine3d t = PoseAt(l.keyframes, l.world_from_object, f);
    if (t.matrix() == light_poses_[i].matrix()) continue;
    light_poses_[i] = t;
    lights_moved = true;
    c.moved_lights.push_back(l.name);
  }
  c.lights = file(
      scene_.lighting.lights_per_frame, "lights file",
      [](const Scene& s, int g, int* from) { return LightsAt(s, g, from); }, &lights_,
      [&](const Scene& s, const fs::path& p, RenderScene* r) { LoadLights(s, p, f, r); });
  if (lights_moved && !c.lights) LoadLights(scene_, LightsAt(scene_, f), f, rs);
  c.lights = c.lights || lights_moved;
  for (size_t i = 0; i < scene_.virtuals.size(); ++i) {
    const SceneVirtual& v = scene_.virtuals[i];
    if (v.keyframes.empty()) continue;
    const Eigen::Affine3d t = v.WorldFromObjectAt(f);
    if (t.matrix() == poses_[i].matrix()) continue;
    rs->SetVirtualTransform(i, t);
    poses_[i] = t;
    c.moved.push_back(v.name);
  }
  if (c.any()) rs->Commit();
  if (!c.moved.empty()) c.trees = rs->embree().last_commit();
  return c;
}

}  // namespace mr
