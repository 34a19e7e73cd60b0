// Error against run time of the rendering methods on one scene (mr-eval
// sweep): each method rendered over a range of quality settings, each render
// compared with the scene's reference over the whole image and over the
// region the virtual objects change, and timed.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "core/json.h"
#include "core/report.h"
#include "scene/scene.h"

namespace mr {

struct SweepOptions {
  std::vector<std::string> methods;  // empty: DefaultSweepMethods()
  // "METHOD.KEY" -> the values it takes, replacing the method's default axis
  // for KEY (MethodInfo::sweep) or adding one.  KEY "spp" is the render's
  // samples per pixel, any other a key of the method's render.<method>
  // block.  The i-th setting of a method takes the i-th value of each of its
  // axes; an axis of one value holds for all.
  std::map<std::string, std::vector<Json>> set;
  int frame_begin = -1, frame_end = -1;  // -1: the scene's
  double diff_scale = 5;
  fs::path out;
  std::string command_line;

  // UsageError naming the flag: --out missing, an unknown method, a
  // --diff-scale that is not positive.
  void Check() const;
};

// The methods' default axes, a line each: "pt.spp=1,4,16,64,256\nic.rays=... ic.spp=...".
std::string SweepDefaultsText();

// Adds `spec` ("METHOD.KEY=v1,v2,...": numbers, true/false or strings) to
// options->set; a UsageError names what is wrong.
void AddSweepAxis(const std::string& spec, SweepOptions* options);

struct SweepRow {
  std::string method, setting;  // e.g. "ic", "rays=256 spp=4"
  double seconds = 0;           // per frame: rendering and per-render preparation, not loading or writing
  double relmse = 0, region_relmse = 0, rmse = 0;
  int frames = 0;
};

// Which run reaches each of pt's errors fastest: for every pt row, the run
// of any method (pt's included) whose error is at most pt's there and
// whose time is least, and pt's time over that run's (the speed-up; 1 where
// pt is itself the fastest).  The error is the region relMSE where the
// rows have one (> 0), else the whole image's.  Empty without pt rows.
// Where pt is the fastest, the nearest miss beside it: of the other
// methods' runs quicker than pt's, the one with the least error (its error
// and time over pt's); none where no other run is quicker.
struct FastestAtError {
  std::string pt_setting;
  double pt_seconds = 0, error = 0;
  std::string method, setting;  // the fastest run at or below pt's error
  double seconds = 0, speedup = 1;
  std::string nearest_method, nearest_setting;  // empty: none
  double nearest_error_ratio = 0, nearest_time_ratio = 0;
};
std::vector<FastestAtError> FastestAtPtErrors(const std::vector<SweepRow>& rows);

// Renders, writes sweep.csv, sweep.json, fastest.csv (FastestAtPtErrors),
// error-vs-time.svg/.png and the
// difference images (|composite - reference| x diff_scale, first frame) in
// options.out; fills `report`.  Throws mr::Error / mr::UsageError.
std::vector<SweepRow> RunSweep(const Scene& scene, const SweepOptions& options, Report* report);

}  // namespace mr
