// mr-pipeline: the whole chain from one pipeline file, leaving out what the
// inputs do not need and what is already up to date.
#include <cstdio>

#include "cli/tool.h"
#include "core/error.h"
#include "pipeline/pipeline.h"

int main(int argc, char** argv) {
  CLI::App app;
  std::string file, bin_dir;
  mr::PipelineRunOptions o;
  mr::ConfigureApp(app, "mr-pipeline",
                   "Runs the mr tools in order from PIPELINE.json (docs/formats.md), which names the raw inputs\n"
                   "(board photographs or a camera model; probe photographs or an environment map; an RGB-D\n"
                   "recording or room meshes; the video, its poses or a COLMAP model; the virtual objects) and the\n"
                   "outputs wanted. Stages: calibrate, sphere, hdr, probe, fuse, register, plate_probe, lights,\n"
                   "formfactor, scene, radiometry, render, sweep. A stage the inputs do not need is left out with its\n"
                   "reason; a stage whose\n"
                   "inputs, options, tool and outputs are unchanged since its last run (content hashes kept in\n"
                   "WORK/.mr-pipeline/) is not re-run. Each stage's log is WORK/logs/STAGE.log and its report\n"
                   "WORK/reports/STAGE.json; --report aggregates them. A failing stage stops the run naming the\n"
                   "stage, the tool's message and the log; finished outputs are kept.",
                   "  mr-pipeline capture/pipeline.json --dry-run\n"
                   "  mr-pipeline capture/pipeline.json --until fuse\n"
                   "  mr-pipeline capture/pipeline.json --force render --report pipeline-report.json");
  app.add_option("pipeline", file, "Pipeline file (docs/formats.md)")->required()->check(CLI::ExistingFile);
  app.add_option("--until", o.until, "Run the stages up to this one and leave out the rest");
  app.add_option("--force", o.force, "Re-run this stage even when it is up to date (repeatable)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app.add_flag("--dry-run", o.dry_run, "Print the plan: each stage run, up to date, or skipped, with the reason");
  app.add_option("--bin", bin_dir, "Folder of the mr tools (default: beside mr-pipeline, else PATH)");
  return mr::RunTool("mr-pipeline", app, argc, argv, [&] {
    o.bin_dir = bin_dir;
    o.quiet = app.count("--quiet") > 0;
    if (app.count("--threads") > 0) o.threads = app.get_option("--threads")->as<int>();
    const mr::Pipeline p = mr::PlanPipeline(file);
    mr::RunPipeline(p, o, &mr::ToolReport());
    if (!o.dry_run && !o.quiet) std::printf("outputs in %s (scene.json, render/, reports/, logs/)\n", p.work.c_str());
    return mr::kExitOk;
  });
}
