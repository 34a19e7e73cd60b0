// mr-eval's subcommands, each one job: images (compare), trajectories
// (traj), meshes (mesh), captured light maps over time (light), plots of
// error tables (plot), and over renders: the error-against-time sweep
// (eval/sweep.h), the plate's radiometric fit (eval/plate_check.h) and the
// merge of shards (eval/shards.h).  Each fills the report and prints its
// figures on stdout.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/report.h"
#include "eval/plate_check.h"
#include "eval/shards.h"
#include "eval/sweep.h"

namespace mr {

struct CompareJobOptions {
  std::string estimate, reference;  // images, or mr-render EXRs (their composite)
  std::string region;               // one channel: compare where > 0 (empty: everywhere)
  std::string diff;                 // write |A - B| x scale here (empty: none)
  double scale = 10;
  void Check() const;  // UsageError naming the flag
};
void RunCompare(const CompareJobOptions& options, Report* report);

struct TrajectoryJobOptions {
  std::string estimate, reference;  // TUM files or 7-Scenes folders
  double max_dt = 0.02;             // association: largest time difference
  double delta = 1.0;               // RPE's time step
  void Check() const;
};
void RunTrajectoryError(const TrajectoryJobOptions& options, Report* report);

struct MeshJobOptions {
  std::string estimate, reference;
  double threshold = 0.01, cutoff = 0.1;  // m
  int64_t samples = 200000;               // per surface
  std::vector<double> region;             // xmin,ymin,zmin,xmax,ymax,zmax (empty: everywhere)
  void Check() const;
};
void RunMeshError(const MeshJobOptions& options, Report* report);

struct LightErrorJobOptions {
  std::string estimate, reference;  // printf patterns (the reference may be one map)
  int frames = 0;                   // 0: while the estimate's maps exist
  void Check() const;
};
void RunLightError(const LightErrorJobOptions& options, Report* report);

struct PlotJobOptions {
  std::string table, x, y, group, title, out;
  bool linear_x = false, linear_y = false;
  void Check() const;
};
void RunPlot(const PlotJobOptions& options, Report* report);

struct SweepJobOptions {
  std::string scene;             // with a reference
  std::string methods;           // comma-separated (empty: DefaultSweepMethods())
  std::string frames;            // BEGIN:END (empty: the scene's)
  std::vector<std::string> set;  // METHOD.KEY=V1,V2,... (AddSweepAxis)
  // The flags of earlier versions: "pt.spp" -> "V1,V2" from --pt-spp; taken
  // before `set`, which overrides them.
  std::map<std::string, std::string> old_flags;
  SweepOptions sweep;  // --out, --diff-scale
  std::string command_line;
  void Check() const;  // UsageError naming the flag, and SweepOptions::Check's
};
// Prints the table of methods and settings with their time and error.
void RunSweepJob(const SweepJobOptions& options, Report* report);

struct PlateJobOptions {
  std::string scene;   // with a plate
  std::string frames;  // BEGIN:END (empty: the scene's)
  PlateCheckOptions plate;
  std::string command_line;
  void Check() const;  // UsageError naming the flag, and PlateCheckOptions::Check's
};
// Prints the gains file and the re-rendering error after the fit.
void RunPlate(const PlateJobOptions& options, Report* report);

struct MergeJobOptions {
  std::vector<std::string> reports;  // shard reports (mr-render --report)
  std::string video;                 // empty: none
  ShardMergeOptions merge;           // --fps, --allow-gaps
  void Check() const;                // ShardMergeOptions::Check's
};
// Prints the shards and frames merged and their relMSE.
void RunMerge(const MergeJobOptions& options, Report* report);

}  // namespace mr
