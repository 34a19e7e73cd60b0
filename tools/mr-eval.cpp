// mr-eval: image comparison, and plots of error tables (error against time or count).
#include <spdlog/spdlog.h>

#include <fmt/ranges.h>

#include "cli/tool.h"
#include "eval/sweep.h"
#include "jobs/eval_jobs.h"
#include "render/method.h"

namespace {

CLI::App* AddCompare(CLI::App& app, mr::CompareJobOptions& co) {
  CLI::App* cmp =
      app.add_subcommand("compare",
                         "RMSE, relative MSE, PSNR and SSIM of A against the reference B (metric definitions in\n"
                         "docs/formats.md), over the image or the pixels where --region is > 0. EXR renders are\n"
                         "compared by their composite layer.");
  cmp->fallthrough();  // --report, --threads ... after the subcommand
  cmp->add_option("A", co.estimate, "Estimate (image, or mr-render EXR)")->required()->check(CLI::ExistingFile);
  cmp->add_option("B", co.reference, "Reference")->required()->check(CLI::ExistingFile);
  cmp->add_option("--region", co.region, "One-channel image: compare where > 0")->check(CLI::ExistingFile);
  cmp->add_option("--diff", co.diff, "Write |A - B| x scale (e.g. diff.png or diff.exr)");
  cmp->add_option("--scale", co.scale, "Scale of the difference image")->default_val(10)->check(mr::kPositive);
  return cmp;
}

CLI::App* AddPlot(CLI::App& app, mr::PlotJobOptions& pjo) {
  CLI::App* plot =
      app.add_subcommand("plot",
                         "Plots columns of a CSV table (mr-lights --sweep, bench/lights_render.sh, ...) as an SVG:\n"
                         "one line per value of --group, log axes unless --linear-x/--linear-y.");
  plot->fallthrough();
  plot->add_option("table", pjo.table, "CSV with a header line")->required()->check(CLI::ExistingFile);
  plot->add_option("--x", pjo.x, "Column on the x axis")->required();
  plot->add_option("--y", pjo.y, "Column on the y axis")->required();
  plot->add_option("--group", pjo.group, "Column whose values name the lines");
  plot->add_option("--title", pjo.title, "Title");
  plot->add_option("--out", pjo.out, "SVG to write")->required();
  plot->add_flag("--linear-x", pjo.linear_x, "Linear x axis");
  plot->add_flag("--linear-y", pjo.linear_y, "Linear y axis");
  return plot;
}

CLI::App* AddLightError(CLI::App& app, mr::LightErrorJobOptions& lo) {
  CLI::App* light = app.add_subcommand(
      "light",
      "Captured light maps against the true ones, per frame (printf patterns): the relative RMS error of the\n"
      "diffuse irradiance they give at 256 normals (the reference over the directions the capture saw), the\n"
      "energy ratio, the share of the reference's energy the capture did not see, and the flicker: the error\n"
      "of the frame-to-frame change of the irradiance against the reference's change.");
  light->fallthrough();
  light->add_option("ESTIMATE", lo.estimate, "Captured maps (env/%05d.exr)")->required();
  light->add_option("REFERENCE", lo.reference, "True maps (a pattern, or one map for every frame)")->required();
  light->add_option("--frames", lo.frames, "Frames 0 to N-1 (0: while the estimate's exist)")
      ->default_val(0)
      ->check(mr::kNonNegative);
  return light;
}

CLI::App* AddTrajectory(CLI::App& app, mr::TrajectoryJobOptions& to) {
  CLI::App* traj = app.add_subcommand(
      "traj",
      "Absolute and relative trajectory error of ESTIMATE against REFERENCE, as TUM's evaluate_ate.py\n"
      "and evaluate_rpe.py define them: poses associated by timestamp (nearest, at most --max-dt apart),\n"
      "ATE = RMSE of camera-centre distances after Horn's rigid alignment (no scale); RPE over all pairs\n"
      "--delta apart (translation RMSE in metres per delta, rotation RMSE in degrees). Pose files: TUM\n"
      "text, or a 7-Scenes folder (frame-NNNNNN.pose.txt; timestamps = frame numbers).");
  traj->fallthrough();
  traj->add_option("ESTIMATE", to.estimate, "Estimated trajectory")->required()->check(CLI::ExistingPath);
  traj->add_option("REFERENCE", to.reference, "Reference trajectory")->required()->check(CLI::ExistingPath);
  traj->add_option("--max-dt", to.max_dt, "Association: largest time difference")->default_val(0.02);
  traj->add_option("--delta", to.delta, "RPE time step (timestamp units)")->default_val(1.0);
  return traj;
}

CLI::App* AddMesh(CLI::App& app, mr::MeshJobOptions& meo) {
  CLI::App* mesh = app.add_subcommand(
      "mesh",
      "Surface distances between MESH and REFERENCE from area-uniform samples: accuracy (estimate to\n"
      "reference), completeness (reference to estimate), exact point-to-triangle distances capped at\n"
      "--cutoff; the fractions within --threshold and their F-score.");
  mesh->fallthrough();
  mesh->add_option("MESH", meo.estimate, "Estimated mesh")->required()->check(CLI::ExistingFile);
  mesh->add_option("REFERENCE", meo.reference, "Reference mesh")->required()->check(CLI::ExistingFile);
  mesh->add_option("--threshold", meo.threshold, "Distance counted as correct (m)")->default_val(0.01);
  mesh->add_option("--cutoff", meo.cutoff, "Distances are capped here (m)")->default_val(0.1);
  mesh->add_option("--samples", meo.samples, "Samples per surface")->default_val(200000);
  mesh->add_option("--region", meo.region, "Only samples inside xmin,ymin,zmin,xmax,ymax,zmax")
      ->delimiter(',')
      ->expected(6);
  return mesh;
}

CLI::App* AddSweep(CLI::App& app, mr::SweepJobOptions& sjo) {
  mr::SweepOptions& so = sjo.sweep;
  sjo.methods = fmt::format("{}", fmt::join(mr::DefaultSweepMethods(), ","));
  CLI::App* sweep = app.add_subcommand(
      "sweep",
      "Error against run time: renders SCENE with each method over a range of quality settings, compares\n"
      "each render with the scene's reference (relMSE over the image and over the region the objects\n"
      "change), times it, and writes sweep.csv, sweep.json, error-vs-time[-region].svg/.png and\n"
      "diff/METHOD-SETTING.png (|composite - reference| x --diff-scale, first frame) into --out.");
  sweep->fallthrough();
  sweep->add_option("SCENE", sjo.scene, "scene.json with a reference (mr-synth writes one)")
      ->required()
      ->check(CLI::ExistingFile);
  sweep->add_option("--methods", sjo.methods, "Comma-separated: " + mr::RenderMethodNames())->default_val(sjo.methods);
  sweep->add_option("--out", so.out, "Output folder")->required();
  sweep
      ->add_option("--set", sjo.set,
                   "METHOD.KEY=V1,V2,...: the values KEY takes (spp, or a key of render.METHOD), replacing\n"
                   "the method's default axis; the i-th setting takes the i-th value of each axis (one value:\n"
                   "all). The defaults:\n" +
                       mr::SweepDefaultsText())
      ->take_all();
  // The flags of earlier versions, as --set.
  for (const auto& [flag, key] : std::vector<std::pair<std::string, std::string>>{{"pt-spp", "pt.spp"},
                                                                                  {"ic-rays", "ic.rays"},
                                                                                  {"ic-spp", "ic.spp"},
                                                                                  {"vpl-paths", "vpl.paths"},
                                                                                  {"vpl-spp", "vpl.spp"},
                                                                                  {"vct-resolution", "vct.resolution"},
                                                                                  {"vct-spp", "vct.spp"},
                                                                                  {"prt-spp", "prt.spp"}})
    sweep->add_option("--" + flag, sjo.old_flags[key], "= --set " + key + "=L");
  sweep->add_option("--frames", sjo.frames, "Frame range BEGIN:END (default: the scene's)");
  sweep->add_option("--diff-scale", so.diff_scale, "Scale of the difference images")->default_val(5);
  return sweep;
}

CLI::App* AddPlate(CLI::App& app, mr::PlateJobOptions& pj) {
  mr::PlateCheckOptions& po_plate = pj.plate;
  CLI::App* plate = app.add_subcommand(
      "plate",
      "The plate's radiometric fit and the capture chain's error on real frames: renders the real room\n"
      "alone (geometry, albedo, captured light, camera and poses) for each frame of SCENE's plate, fits\n"
      "the per-channel gain that takes the render to the plate over the pixels showing the room (clipped\n"
      "and outlying pixels left out; standard error by a delete-one-tile jackknife), smooths the gains\n"
      "over time without crossing exposure jumps, and reports the re-rendering error after the fit\n"
      "(relMSE, SSIM, and relMSE around the virtual objects). Writes OUT/gains.json, which scene.json's\n"
      "camera.gains names so that mr-render lights the objects in the plate's units (docs/radiometry.md).");
  plate->fallthrough();
  plate->add_option("SCENE", pj.scene, "scene.json with a plate (camera.frames)")->required()->check(CLI::ExistingFile);
  plate->add_option("--out", po_plate.out, "Output folder")->required();
  plate->add_option("--method", po_plate.method, "Method that renders the room: " + mr::RenderMethodNames())
      ->default_val("pt");
  plate->add_option("--spp", po_plate.spp, "Samples per pixel of the room's render")
      ->default_val(16)
      ->check(CLI::Range(1, 1 << 20));
  plate->add_option("--stride", po_plate.stride, "Fit every Nth frame; the others take their neighbours' gains")
      ->default_val(1)
      ->check(CLI::Range(1, 1 << 20));
  plate->add_option("--frames", pj.frames, "Frame range BEGIN:END (default: the scene's)");
  plate
      ->add_option("--smooth", po_plate.smoothing.time_constant,
                   "Time constant of the gains' smoothing in frames (Gaussian; 0: none)")
      ->default_val(3)
      ->check(CLI::Range(0.0, 1e6));
  plate
      ->add_option("--jump-ratio", po_plate.smoothing.jump_ratio,
                   "Gains of neighbouring frames differing by more than this ratio (and 4 standard errors)\n"
                   "are an exposure jump, which smoothing does not cross")
      ->default_val(1.15)
      ->check(CLI::Range(1.0001, 1e6));
  plate
      ->add_option("--at-gain", po_plate.at_gain,
                   "Measure the errors at this gain (all channels and frames: a hand-set exposure) instead of\n"
                   "the fitted ones, to compare the two; the fitted gains are still written")
      ->check(mr::kPositive);
  plate->add_flag("--images", po_plate.images,
                  "Write OUT/NNNNN-rerender.png per fitted frame: plate | room rendered at the gain | difference |\n"
                  "pixels compared");
  return plate;
}

CLI::App* AddMerge(CLI::App& app, mr::MergeJobOptions& mj) {
  mr::ShardMergeOptions& mo = mj.merge;
  CLI::App* merge = app.add_subcommand(
      "merge",
      "Merges the reports of mr-render shards (mr-render --frames A:B, one per machine or job) into one\n"
      "report (--report): frames in order, timings summed, error figures averaged over frames as one run\n"
      "averages them; with --video, the composites of every shard's EXR frames in frame order as one video.\n"
      "Refuses shards of different scenes or methods and overlapping ranges; a frame range that no shard\n"
      "rendered is an error unless --allow-gaps. See docs/cluster.md.");
  merge->fallthrough();
  merge->add_option("REPORTS", mj.reports, "Shard reports (mr-render --report)")->required()->check(CLI::ExistingFile);
  merge->add_option("--video", mj.video, "Video to write (.mp4, .avi, or .mkv: FFV1, lossless)");
  merge->add_option("--fps", mo.fps, "Frames per second of the video (default: the plate's, else 30)")
      ->check(mr::kPositive);
  merge->add_flag("--allow-gaps", mo.allow_gaps, "Merge even when some frames were rendered by no shard");
  return merge;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app;
  mr::ConfigureApp(app, "mr-eval", "Evaluates renders against references.",
                   "  mr-eval compare render/00000.exr capture/truth/00000.exr --diff diff.png --scale 10 "
                   "--report compare.json");
  app.require_subcommand(1);
  mr::CompareJobOptions co;
  mr::PlotJobOptions pjo;
  mr::LightErrorJobOptions lo;
  mr::TrajectoryJobOptions to;
  mr::MeshJobOptions meo;
  mr::SweepJobOptions sjo;
  mr::PlateJobOptions pj;
  mr::MergeJobOptions mj;
  CLI::App* cmp = AddCompare(app, co);
  CLI::App* plot = AddPlot(app, pjo);
  CLI::App* light = AddLightError(app, lo);
  CLI::App* traj = AddTrajectory(app, to);
  CLI::App* mesh = AddMesh(app, meo);
  CLI::App* sweep = AddSweep(app, sjo);
  CLI::App* plate = AddPlate(app, pj);
  CLI::App* merge = AddMerge(app, mj);
  return mr::RunTool("mr-eval", app, argc, argv, [&] {
    mr::Report* report = &mr::ToolReport();
    const std::string command_line = report->ToJson().value("command_line", "");
    sjo.command_line = pj.command_line = command_line;
    if (merge->parsed()) mr::RunMerge(mj, report);
    if (plate->parsed()) mr::RunPlate(pj, report);
    if (sweep->parsed()) mr::RunSweepJob(sjo, report);
    if (light->parsed()) mr::RunLightError(lo, report);
    if (traj->parsed()) mr::RunTrajectoryError(to, report);
    if (mesh->parsed()) mr::RunMeshError(meo, report);
    if (plot->parsed()) mr::RunPlot(pjo, report);
    if (cmp->parsed()) mr::RunCompare(co, report);
    return mr::kExitOk;
  });
}
