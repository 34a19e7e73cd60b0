// mr-render's work: every frame of a scene rendered with a method,
// composited into its photograph, written as layered EXR + PNG, with a
// report holding timings, what was skipped and the error against the
// reference over time.
#pragma once

#include <optional>
#include <string>

#include "camera/pose.h"
#include "core/report.h"
#include "scene/scene.h"

namespace mr {

struct RenderOptions {
  std::string method;                  // empty: the scene's
  int spp = 0;                         // 0: the scene's
  double time_budget_s = -1;           // < 0: the scene's (0 = none)
  int frame_begin = -1, frame_end = -1;  // -1: the scene's
  std::optional<fs::path> reference;   // overrides the scene's
  fs::path out_dir;                    // empty: the scene's output.dir
  std::string tool = "mr-render", command_line;
};

// Frame `i` of a printf-style pattern ("frames/%05d.exr"), or the path itself
// when it has no conversion.
fs::path FramePath(const fs::path& pattern, int i);

// The camera poses (world_from_cam) of the scene's frames; one identity pose
// when the scene names none.
std::vector<Rigid3> LoadScenePoses(const Scene& scene);

// Renders; fills `report`.  Throws mr::Error / mr::UsageError.
void RunRenderJob(const Scene& scene, const RenderOptions& options, Report* report);

}  // namespace mr
