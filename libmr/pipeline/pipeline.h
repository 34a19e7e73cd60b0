// mr-pipeline's work: a pipeline file (docs/formats.md "pipeline.json")
// names the raw inputs and the outputs wanted; the planner turns it into the
// stages that the inputs need (each one tool run), leaves out the rest with
// a reason, and the runner runs what is not up to date.
//
// Up to date: each finished stage leaves WORK/.mr-pipeline/STAGE.json with a
// key (a content hash of the tool binary, its arguments and every input
// file) and the content hash of every output.  A stage whose key and outputs
// still match is not re-run; a changed input, option, tool or output re-runs
// it, and what it re-makes re-runs the stages after it when their content
// changes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/file.h"
#include "core/json.h"
#include "core/report.h"

namespace mr {

struct PipelineStage {
  std::string name;               // PipelineStageNames()
  std::string tool;               // mr-calibrate, ...; empty: done by mr-pipeline itself (scene)
  std::vector<std::string> args;  // after the tool's name
  // A file mr-pipeline writes (atomically) just before the tool runs, e.g.
  // the plate's own scene for mr-probe --sphere-in-plate; its content is
  // part of the stage's key.  Empty path: none.
  fs::path writes_first;
  Json writes_first_json;
  std::vector<fs::path> inputs;   // files or folders whose content decides the outputs
  std::vector<fs::path> outputs;  // what the stage makes
  fs::path report;                // the stage's JSON report
  std::string does;               // one line for the plan
  std::string skip;               // non-empty: the stage is left out, and why
};

struct Pipeline {
  fs::path file;  // the pipeline file
  fs::path base;  // its folder: relative paths in it start here
  fs::path work;  // where every output goes
  Json json;
  Json scene;           // the scene.json that the scene stage writes (paths relative to work)
  fs::path fused_room;  // the room mesh mr-fuse makes, if any: its mean albedo goes into scene.json
  // video.refine_poses: the poses the radiometry stage refines (relative to
  // work), which scene.json's camera.poses names (scene-plate.json keeps
  // the registered ones it refines from).
  std::string refined_poses;
  std::vector<PipelineStage> stages;
};

// Reads and validates a pipeline file (unknown keys, missing files and
// contradictions are errors naming the file and key) and plans its stages.
Pipeline PlanPipeline(const fs::path& file);

// The names of every stage, in order.
const std::vector<std::string>& PipelineStageNames();

struct PipelineRunOptions {
  std::string until;               // run up to this stage, leave out the rest
  std::vector<std::string> force;  // re-run these even when up to date
  bool dry_run = false;            // print the plan only
  fs::path bin_dir;                // where the mr tools are; empty: beside mr-pipeline, else PATH
  bool quiet = false;
  int threads = 0;  // > 0: passed to every tool (not part of the up-to-date key: results do not depend on it)

  // UsageError naming the flag: --until or --force naming no stage, a
  // negative --threads.
  void Check() const;
};

// Runs (or, dry_run, describes) the plan; fills `report`: one entry per
// stage under metrics.stages (status ran / up to date / skipped / would run,
// the reason, seconds, and the stage's own report), skipped stages with
// their reasons, and each stage's time.  A failing stage stops the run with
// mr::Error naming the stage, its log and the tool's message; finished
// outputs are kept.
void RunPipeline(const Pipeline& pipeline, const PipelineRunOptions& options, Report* report);

// ContentHash (core/file.h) decides what is up to date.

}  // namespace mr
