// mr-eval's subcommands over renders (sweep, plate, merge): their flags,
// declared into the jobs' options (jobs/eval_jobs.h).  mr-eval.cpp declares
// the others and runs them.
#pragma once

#include "cli/tool.h"
#include "jobs/eval_jobs.h"

namespace mr_eval {

CLI::App* AddSweep(CLI::App& app, mr::SweepJobOptions& sjo);
CLI::App* AddPlate(CLI::App& app, mr::PlateJobOptions& pj);
CLI::App* AddMerge(CLI::App& app, mr::MergeJobOptions& mj);

}  // namespace mr_eval
