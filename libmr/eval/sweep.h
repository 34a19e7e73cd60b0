// Error against run time of the rendering methods on one scene (mr-eval
// sweep): each method rendered over a range of quality settings, each render
// compared with the scene's reference over the whole image and over the
// region the virtual objects change, and timed.
#pragma once

#include <string>
#include <vector>

#include "core/report.h"
#include "scene/scene.h"

namespace mr {

struct SweepOptions {
  std::vector<std::string> methods = {"pt", "ic", "vpl", "vct"};
  std::vector<int> pt_spp = {1, 4, 16, 64, 256};
  // ic and vpl: the i-th setting takes the i-th rays/paths and spp (one spp
  // value: the same for all), since their per-pixel part needs samples too.
  std::vector<int> ic_rays = {32, 64, 128, 256};
  std::vector<int> ic_spp = {4, 8, 16, 32};
  std::vector<int> vpl_paths = {64, 128, 256, 512};
  std::vector<int> vpl_spp = {2, 4, 8, 16};
  // vct: voxels along the volume's longest side, paired with spp as above.
  std::vector<int> vct_resolution = {32, 64, 128};
  std::vector<int> vct_spp = {4};
  std::vector<int> prt_spp = {1, 4, 16};
  int frame_begin = -1, frame_end = -1;  // -1: the scene's
  double diff_scale = 5;
  fs::path out;
  std::string command_line;
};

struct SweepRow {
  std::string method, setting;  // e.g. "ic", "rays=256 spp=4"
  double seconds = 0;            // per frame: rendering and per-render preparation, not loading or writing
  double relmse = 0, region_relmse = 0, rmse = 0;
  int frames = 0;
};

// Renders, writes sweep.csv, sweep.json, error-vs-time.svg/.png and the
// difference images (|composite - reference| x diff_scale, first frame) in
// options.out; fills `report`.  Throws mr::Error / mr::UsageError.
std::vector<SweepRow> RunSweep(const Scene& scene, const SweepOptions& options, Report* report);

}  // namespace mr
