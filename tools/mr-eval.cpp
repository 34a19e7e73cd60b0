// mr-eval: renders, trajectories, meshes and light maps against their
// references, plots of error tables; the subcommands over renders (sweep,
// plate, merge) declare their flags in mr-eval-renders.cpp.
#include "cli/tool.h"
#include "jobs/eval_jobs.h"
#include "mr-eval-renders.h"

namespace {

CLI::App* AddCompare(CLI::App& app, mr::CompareJobOptions& co) {
  CLI::App* cmp =
      app.add_subcommand("compare",
                         "RMSE, relative MSE, PSNR and SSIM of A against the reference B (metric definitions in\n"
                         "docs/formats.md), over the image or the pixels where --region is > 0. EXR renders are\n"
                         "compared by their composite layer. --region is a mask (the objects' coverage);\n"
                         "mr-render's region_relmse is over where the reference differs from the plate\n"
                         "(objects, shadows and the light they send the room), a larger region: the two differ.");
  cmp->fallthrough();  // --report, --threads ... after the subcommand
  cmp->add_option("A", co.estimate, "Estimate (image, or mr-render EXR)")->required()->check(CLI::ExistingFile);
  cmp->add_option("B", co.reference, "Reference")->required()->check(CLI::ExistingFile);
  cmp->add_option("--region", co.region,
                  "Mask: a one-layer image (its first channel) or an mr-render EXR (its mask layer); compare where > 0")
      ->check(CLI::ExistingFile);
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
  CLI::App* sweep = mr_eval::AddSweep(app, sjo);
  CLI::App* plate = mr_eval::AddPlate(app, pj);
  CLI::App* merge = mr_eval::AddMerge(app, mj);
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
