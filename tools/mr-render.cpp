// mr-render: renders virtual objects into every frame of a scene and
// composites them differentially.
#include "cli/tool.h"
#include "core/error.h"
#include "render/method.h"
#include "render/render_job.h"
#include "scene/frames.h"
#include "scene/scene.h"

int main(int argc, char** argv) {
  CLI::App app;
  std::string scene_file, out, method, frames, reference;
  int spp = 0;
  double budget = -1;
  mr::ConfigureApp(
      app, "mr-render",
      "Renders the virtual objects of SCENE.json into every frame with global illumination and\n"
      "composites them differentially: I_f = M*I_m + (1-M)*(I_c + I_m - I_r).\n"
      "Writes per frame OUT/NNNNN.exr (layers composite, mixed, real, mask, difference, variance,\n"
      "samples, photo) and OUT/NNNNN.png: the composite as the plate's own code values (encoded\n"
      "through the inverse of the frames' decoding: an untouched pixel keeps the plate's value);\n"
      "a video plate also gives OUT/composite.mp4 or .mkv (output.video). With a reference (--reference or\n"
      "the scene's \"reference\"), the report holds rmse, relmse, region_relmse and the error-vs-time\n"
      "curve at 1, 2, 4, ... samples per pixel.",
      "  mr-render capture/scene.json --out render --spp 64 --report render/report.json");
  app.add_option("scene", scene_file, "Scene description (docs/formats.md)")->required()->check(CLI::ExistingFile);
  app.add_option("--out", out, "Output folder (default: the scene's output.dir)");
  std::string methods_help;
  for (const auto& m : mr::RenderMethodRegistry()) methods_help += "\n  " + m.name + ": " + m.summary;
  app.add_option("--method", method, "Rendering method (default: the scene's render.method):" + methods_help);
  auto* spp_opt =
      app.add_option("--spp", spp, "Samples per pixel (default: the scene's render.spp)")->check(mr::kPositive);
  app.add_option("--time-budget", budget, "Seconds per frame; stops sampling when reached (0 = none)")
      ->check(mr::kNonNegative)
      ->excludes(spp_opt);
  app.add_option("--frames", frames, "Frame range A:B (B exclusive; default: the scene's render.frames)");
  app.add_option("--reference", reference, "Ground truth image or pattern (e.g. truth/%05d.exr)");
  bool resume = false;
  app.add_flag("--resume", resume,
               "Keep the frames an earlier (killed) run with the same settings completed in the output folder, and "
               "render from the first missing one; the outputs equal one uninterrupted run's");
  return mr::RunTool("mr-render", app, argc, argv, [&] {
    mr::Scene scene = mr::ReadScene(scene_file);
    mr::RenderOptions o;
    o.method = method;
    o.spp = spp;
    if (budget >= 0) {
      o.time_budget_s = budget;
      if (spp == 0) o.spp = 1 << 20;  // a budget alone: sample until it is spent
    }
    if (!frames.empty()) {
      if (!mr::ParseFrameRange(frames, &o.frame_begin, &o.frame_end))
        throw mr::UsageError("--frames must be A:B with 0 <= A < B");
    }
    if (!reference.empty()) o.reference = reference;
    o.out_dir = out;
    o.resume = resume;
    o.command_line = mr::JoinCommandLine(argc, argv);
    mr::RunRenderJob(scene, o, &mr::ToolReport());
    return mr::kExitOk;
  });
}
