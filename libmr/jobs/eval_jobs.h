// mr-eval's subcommands that measure one thing against its reference, each
// one job: images (compare), trajectories (traj), meshes (mesh), captured
// light maps over time (light), and plots of error tables (plot).  sweep,
// plate and merge are eval/sweep.h, eval/plate_check.h and eval/shards.h.
// Each fills the report and prints its figures on stdout.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/report.h"

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

}  // namespace mr
