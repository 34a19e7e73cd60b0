// mr-register's work: the video's frames registered with COLMAP (or an
// existing text model read), aligned to the room's trajectory and mesh, the
// poses and the camera model written, the alignment's figures printed.
#pragma once

#include <string>
#include <vector>

#include "camera/register.h"
#include "core/report.h"

namespace mr {

struct RegisterJobOptions {
  std::string frames;     // `colmap`: the video's frames (folder, printf pattern or video)
  std::string model_dir;  // `align`: an existing COLMAP text model
  std::string trajectory, truth, out, camera_out, points_out, observations_out;
  std::vector<std::string> meshes;  // merged into one for the mesh alignment
  std::vector<double> initial;      // 16 numbers, row-major [s*R t; 0 0 0 1]; empty: none
  RegisterOptions align;            // --match, --frames, the fit's settings
  ColmapRunOptions colmap;          // --matcher, --overlap, ... (workspace and camera below)
  std::string workspace, camera;
  int attempts = 3;          // COLMAP runs (next seed) until the model fits the trajectory
  std::string command_line;  // for the written camera model's note

  bool run_colmap() const { return !frames.empty(); }
  // UsageError naming the flag at fault: FRAMES and MODEL together or
  // neither, --out, --initial not a similarity, --attempts, and
  // RegisterOptions' and ColmapRunOptions' checks.
  void Check() const;
};

// Runs the job; fills `report` and prints the alignment's figures.
void RunRegister(const RegisterJobOptions& options, Report* report);

}  // namespace mr
