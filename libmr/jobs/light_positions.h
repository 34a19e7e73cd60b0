// Lights where they are in the room: a light found in a probe's map
// (mr-lights' blobs) whose directions, traced from the probe's centre into
// the room's mesh, land on it becomes an area light there (a rectangle
// fitted to the surface its core covers, emitting the radiance that sends
// the probe the light it saw) instead of a disc at infinity.  The method
// and its limits: docs/methods.md, "Lights where they are".
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "geometry/mesh.h"
#include "light/lights_file.h"
#include "probe/light_extraction.h"

namespace mr {

struct PositionOptions {
  Eigen::Vector3d probe_centre = Eigen::Vector3d::Zero();  // world, metres (the map's directions are world)
  double min_hit_share = 0.5;  // of a light's energy whose rays meet the room: less stays distant
  double offset_m = 0.01;      // the area light stands this far off the surface, into the room
};

struct PositionReport {
  int positioned = 0, distant = 0;
  double positioned_share = 0, distant_share = 0;  // of the lights' energy
  std::vector<std::string> notes;                  // per light, what became of it
};

// `env`: the map `ex` came from; `lights`: ToLights(ex) (their names and
// notes kept).  Lights without pixels (not blobs) stay as they are.
std::vector<Light> PositionLights(const Image& env, const Extraction& ex, const std::vector<Light>& lights,
                                  const Mesh& room, const PositionOptions& options, PositionReport* report);

}  // namespace mr
