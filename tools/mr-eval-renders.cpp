// mr-eval's subcommands over renders: sweep, plate and merge (their flags).
#include "mr-eval-renders.h"

#include <fmt/ranges.h>

#include "eval/sweep.h"
#include "render/method.h"

namespace mr_eval {

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
  static std::string refine_mode;
  CLI::App* plate = app.add_subcommand(
      "plate",
      "The plate's radiometric fit and the capture chain's error on real frames: renders the real room\n"
      "alone (geometry, albedo, captured light, camera and poses) for each frame of SCENE's plate, fits\n"
      "the per-channel gain that takes the render to the plate over the pixels showing the room (clipped\n"
      "and outlying pixels left out; standard error by a delete-one-tile jackknife), smooths the gains\n"
      "over time without crossing exposure jumps, and reports the re-rendering error after the fit\n"
      "(relMSE, SSIM, and relMSE around the virtual objects). Writes OUT/gains.json, which scene.json's\n"
      "camera.gains names so that mr-render lights the objects in the plate's units (docs/radiometry.md).\n"
      "Each fitted frame's registration is measured in pixels (dense flow between the rendered room and\n"
      "the plate); with --refine-poses each fitted frame's pose is refined until the room falls on the\n"
      "plate, and the registration measured again (docs/methods.md, \"Registration in pixels\").");
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
  plate->add_option("--refine-poses", po_plate.refine_poses,
                    "Refine each fitted frame's pose against the room and write every pose here (TUM, one line\n"
                    "per frame in frame order: scene.json's camera.poses)");
  plate
      ->add_option("--refine-mode", refine_mode,
                   "--refine-poses: shared (one correction for every frame: the camera's offset from the room,\n"
                   "the registered motion kept), frame (each fitted frame its own: the objects may swim) or\n"
                   "smooth (each frame's own, averaged over the fitted frames around it: --refine-smooth)")
      ->check(CLI::IsMember({"shared", "frame", "smooth"}))
      ->default_val("smooth")
      ->each([&po_plate](const std::string& v) {
        po_plate.refine_shared = v == "shared";
        if (v == "smooth" && po_plate.refine_smooth_frames <= 0) po_plate.refine_smooth_frames = 2;
        if (v != "smooth") po_plate.refine_smooth_frames = 0;
      });
  plate
      ->add_option("--refine-smooth", po_plate.refine_smooth_frames,
                   "--refine-mode smooth: the Gaussian's sigma, in fitted frames (default 2)")
      ->check(CLI::Range(0.1, 1e6));
  plate->add_option("--refine-camera", po_plate.refine_camera,
                    "--refine-mode shared: also solve the focal length where the frames determine it, and\n"
                    "write the camera model here (the given one where they do not)");
  plate
      ->add_option("--prior-points", po_plate.prior_points,
                   "--refine-poses: COLMAP's points as a prior (mr-register --observations-out), solved with\n"
                   "the room's matches of each frame")
      ->check(CLI::ExistingFile);
  plate
      ->add_option("--prior-weight", po_plate.prior_weight,
                   "--prior-points: one observation's weight against one match")
      ->default_val(1)
      ->check(mr::kPositive);
  plate->add_option("--refine-rounds", po_plate.refine.rounds, "Render, match and solve rounds of --refine-poses")
      ->default_val(2)
      ->check(CLI::Range(1, 10));
  plate
      ->add_option("--register-on", po_plate.register_on,
                   "Registration and --refine-poses over: texture (every pixel of the room) or edges (only near the\n"
                   "room's creases and depth steps: where the plate's shading and shadows differ from the render's)")
      ->default_val("texture")
      ->check(CLI::IsMember({"texture", "edges"}));
  plate->add_option("--edge-band", po_plate.edge_band_px, "--register-on edges: pixels within this of an edge")
      ->default_val(4)
      ->check(CLI::Range(1, 64));
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

}  // namespace mr_eval
