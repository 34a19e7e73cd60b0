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
  // A placed light whose mirror direction points within this angle (plus
  // the source's angular radius) at a brighter light is that light's
  // reflection (a lamp in a polished counter), not a light.
  double mirror_tolerance_deg = 5;
};

struct PositionReport {
  int positioned = 0, distant = 0;
  double positioned_share = 0, distant_share = 0;  // of the lights' energy
  std::vector<std::string> notes;                  // per light, what became of it
  std::vector<size_t> reflections;                 // lights that are another's reflection: back to the map
  // Per light, the room map's pixels (y * width + x) around a placed lamp
  // that its rectangle does not cover (its glow), with the radiance they
  // take (the blob's border): the light's radiance is less their energy.
  std::vector<std::vector<std::pair<size_t, Eigen::Vector3f>>> fills;
};

// `env`: the map `ex` came from; `lights`: ToLights(ex) (their names and
// notes kept).  Lights without pixels (not blobs) stay as they are.  A
// light landing where a brighter one is mirrored (PositionOptions::
// mirror_tolerance_deg) is listed in report->reflections, not placed.
std::vector<Light> PositionLights(const Image& env, const Extraction& ex, const std::vector<Light>& lights,
                                  const Mesh& room, const PositionOptions& options, PositionReport* report);

struct SkyReport {
  int64_t room_pixels = 0;  // whose rays from the probe's centre meet the room
  double room_share = 0;    // of the map's energy (luminance x solid angle)
};

// The map's directions that leave the room, seen from the probe's centre:
// the map at infinity that goes with the room's own light (scene.json
// lighting.probes, docs/methods.md "The room's own light").  A pixel whose
// ray from the centre meets the room takes the sky's radiance there,
// interpolated along its row (in longitude, around the circle) between the
// nearest pixels that leave the room with all their neighbours (an
// opening's edge pixel holds some of the wall: replaced too); a row with
// none copies the nearest row that has some; a map that sees nothing leave
// the room is black.
Image SkyOnly(const Image& map, const Mesh& room, const Eigen::Vector3d& probe_centre, SkyReport* report);

}  // namespace mr
