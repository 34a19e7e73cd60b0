// mr-render's work: every frame of a scene rendered with a method,
// composited into its photograph, written as layered EXR + PNG, with a
// report holding timings, what was skipped and the error against the
// reference over time.
#pragma once

#include <optional>
#include <string>

#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/report.h"
#include "scene/frames.h"
#include "scene/scene.h"

namespace mr {

class RenderScene;

struct RenderOptions {
  std::string method;                    // empty: the scene's
  int spp = 0;                           // 0: the scene's
  double time_budget_s = -1;             // < 0: the scene's (0 = none)
  int frame_begin = -1, frame_end = -1;  // -1: the scene's
  std::optional<fs::path> reference;     // overrides the scene's
  fs::path out_dir;                      // empty: the scene's output.dir
  // Keep the frames an earlier run of the same settings completed (their
  // files present, with the same provenance) and render from the first
  // missing one, as a shard starting there: the outputs equal one
  // uninterrupted run's (ic's, whose cache carries across frames, those of
  // such a shard; its report warns).
  bool resume = false;
  std::string tool = "mr-render", command_line;

  // UsageError naming the flag: an unknown --method, negative --spp, a
  // frame range that is not 0 <= A < B.
  void Check() const;
};

// Renders; fills `report`.  Throws mr::Error / mr::UsageError.
void RunRenderJob(const Scene& scene, const RenderOptions& options, Report* report);

// What a job over a scene's frames loads first, shared by mr-render and
// mr-eval plate: the camera, the poses and the render scene (timed as
// "load"), the frame range [begin, end) (-1: the scene's; an empty range is
// a UsageError) and every input of every frame in it, checked before the
// first frame ("check inputs"; warnings into the report and the log).
struct JobInputs {
  CameraModel camera;
  std::vector<Rigid3> poses;
  int begin = 0, end = 0;
};
JobInputs LoadJobInputs(const Scene& scene, int frame_begin, int frame_end, RenderScene* rs, Report* report);

}  // namespace mr
