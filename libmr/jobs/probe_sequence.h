// mr-probe over time: one world-aligned map per plate frame, from a light
// camera's video or image sequence (fish-eye, static in the room or rigidly
// mounted: its extrinsics orient it), or from the mirror sphere seen in the
// plate itself (its world position known, the camera's pose per frame from
// the scene).  Matching, exposure, filtering and filling:
// probe/light_sequence.h; docs/methods.md, "Light over time".
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/file.h"
#include "core/report.h"
#include "probe/light_sequence.h"
#include "probe/unwrap.h"

namespace mr {

struct ProbeSequenceOptions {
  // A light camera: `light` is a list file ("TIMESTAMP PATH" lines, paths
  // relative to the list, as TUM's rgb.txt), a printf pattern of frame files
  // (frames 0, 1, ... while they exist) or a video; `fisheye` its camera model.
  std::string light;
  fs::path fisheye;
  double fps = 30;         // pattern and video frames: time = index / fps + time_offset
  double time_offset = 0;  // seconds added to the light frames' times
  // The plate's times (a TUM trajectory: its timestamps); the light frame
  // nearest each within max_dt is that plate frame's.  Absent: one map per
  // light frame, numbered as the light frames are.
  std::optional<fs::path> plate_times;
  double max_dt = 0.02;
  // Exposure times per light frame ("FILENAME TIME" or one TIME per line,
  // hdr/exposures_file.h); absent: from each file's metadata where it has
  // them, else 1.  The maps are divided by each frame's time over the first's.
  std::optional<fs::path> exposures;

  // Or the sphere in the plate: the scene's frames and poses, the sphere's
  // centre (world, metres) and radius.
  fs::path scene;
  Eigen::Vector3d sphere_centre = Eigen::Vector3d::Zero();
  double sphere_radius = 0;

  UnwrapOptions unwrap;
  LightFilterOptions filter;
  fs::path out;             // printf pattern of the maps ("env/%05d.exr")
  int begin = 0, end = -1;  // plate frames [begin, end); -1: all
  std::string tool = "mr-probe", command_line;
  void Check() const;
};

// Writes the maps (atomically, each) and fills `report`: per frame the light
// frame taken and its time difference, the exposure, the filter's step,
// what was seen, filled and jumped; frames reusing an earlier map.
void RunProbeSequence(const ProbeSequenceOptions& options, Report* report);

struct LightFrameFile {
  double time = 0;
  fs::path path;  // empty for a video's frames
  int video_index = -1;
};
// The light frames `light` names (see ProbeSequenceOptions::light), in time
// order; errors name the list file and line.
std::vector<LightFrameFile> ListLightFrames(const std::string& light, double fps, double time_offset,
                                            double* video_fps = nullptr);

}  // namespace mr
