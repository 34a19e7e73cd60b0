// mr-lights' work: light sources from a lat-long environment map (or one
// map per frame, each light keeping its name over time), the residual map
// they leave, and the irradiance error; or the error against the number of
// lights for every method (the sweep).
#pragma once

#include <string>
#include <vector>

#include "core/report.h"
#include "probe/light_extraction.h"

namespace mr {

struct LightsJobOptions {
  std::string env;       // a map, or a printf pattern of one per frame
  std::string out;       // lights.json (a pattern with a pattern of maps)
  std::string residual;  // empty: none (a pattern with a pattern of maps)
  int residual_width = 64;
  int normals = 1024;     // directions for the irradiance error
  double match_deg = 10;  // over time: a light this near one of the last frame keeps its name
  ExtractOptions extract;
  // Lights where they are (blobs): the room's mesh and the probe's centre in
  // the map's frame (the world, for mr-probe's maps); empty: all at infinity.
  std::string room;
  std::vector<double> probe_at;  // X,Y,Z metres
  // A placed light this near (degrees, plus the source's radius) the mirror
  // direction of a brighter light is its reflection (PositionOptions).
  double mirror_tolerance_deg = 5;
  // With `room`: the residual at full size, lights taken out (what the probe
  // saw of the room: scene.json lighting.probes' map; a pattern with a
  // pattern of maps); empty: none.  With `room` the residual keeps only the
  // directions that leave the room (SkyOnly).
  std::string room_map;
  // The sweep: every method at every count, into a CSV table and an SVG plot.
  bool sweep = false;
  std::vector<std::string> methods = {"median-cut", "variance-cut", "importance", "blobs"};
  std::string counts = "1,2,4,8,16,32,64,128,256,512,1024";
  std::string table, plot;
  std::string command_line;  // written into lights.json and the residual

  // UsageError naming the flag at fault (--out, --sweep, --residual-width,
  // the patterns, --counts, --room without --probe-at or blobs, and
  // ExtractOptions::Check's).
  void Check() const;
  bool over_time() const { return env.find('%') != std::string::npos; }
};

// Runs the job; fills `report`.  Throws mr::Error naming the file at fault.
// A sweep prints its table on stdout.
void RunLights(const LightsJobOptions& options, Report* report);

// The number N of a light named "lightN" (mr-lights' names); -1 for any
// other name.
int LightNumber(const std::string& name);

}  // namespace mr
