// mr-hdr: merges bracketed exposures into linear radiance with its variance.
#include <spdlog/spdlog.h>

#include <fstream>
#include <sstream>

#include "cli/tool.h"
#include "core/error.h"
#include "core/image.h"
#include "core/report.h"
#include "hdr/exposure_merge.h"
#include "hdr/exposures_file.h"
#include "hdr/response.h"

int main(int argc, char** argv) {
  CLI::App app;
  std::vector<std::string> images;
  std::string exposures_file, out, response_in, response_out, method = "debevec";
  bool align = false, linear = false, half = false;
  mr::ExposureMergeOptions mo;
  mr::ResponseOptions ro;
  mr::ConfigureApp(
      app, "mr-hdr",
      "Merges bracketed exposures of a still scene (a mirror sphere, a fish-eye view of the room) into\n"
      "linear radiance. Exposure times come from EXIF (ExposureTime, with FNumber and ISO when present)\n"
      "or from --exposures FILE. 8- and 16-bit inputs go through the camera's response: recovered from\n"
      "the bracket (Debevec-Malik or Robertson; --save-response keeps it) or read with --response.\n"
      "Float inputs (EXR, float TIFF) and --linear inputs are linear already.\n"
      "Samples are weighted by their noise (read, shot and quantisation noise through the response),\n"
      "saturated and black samples are left out, things that moved are detected and taken from one\n"
      "exposure, and pixels saturated in every exposure (the sun) are censored: flagged, given a lower\n"
      "bound, and filled from a fit of the blurred source in the shortest exposure.\n"
      "Output: float32 EXR with R G B (radiance in the response's units per second), variance.R/G/B,\n"
      "saturated.Y and ghost.Y (docs/formats.md).",
      "  mr-hdr memorial*.png --exposures shutter_times.txt --save-response response.json --out memorial.exr\n"
      "  mr-hdr ball_*.JPG --align --response response.json --out probe-raw.exr --report hdr.json");
  app.add_option("images", images, "The bracket's photographs, any order")->required()->check(CLI::ExistingFile);
  app.add_option("--out", out, "Merged EXR")->required();
  app.add_option("--exposures", exposures_file,
                 "Exposure times: one per line in the images' order, or FILENAME TIME lines")
      ->check(CLI::ExistingFile);
  app.add_option("--response", response_in, "Use this response.json (from --save-response) instead of recovering one")
      ->check(CLI::ExistingFile);
  app.add_option("--save-response", response_out, "Write the recovered response here");
  app.add_option("--method", ro.method, "Response recovery: debevec or robertson")
      ->check(CLI::IsMember({"debevec", "robertson"}))
      ->default_val("debevec");
  app.add_option("--smoothness", ro.smoothness, "Debevec's lambda")->default_val(50);
  app.add_flag("--linear", linear, "8/16-bit inputs are linear (no response)");
  app.add_flag("--align", align, "Align hand-held brackets (median threshold bitmaps); crops of different sizes too");
  app.add_option("--low", mo.low, "Normalised codes at or below this are too dark to use")->default_val(0.02);
  app.add_option("--high", mo.high, "Normalised codes at or above this are saturated")->default_val(0.97);
  app.add_option("--ghost-sigma", mo.ghost_sigma, "Samples this many sigma apart mark a ghost")->default_val(5);
  bool no_ghosts = false, no_fit = false;
  app.add_flag("--no-ghosts", no_ghosts, "Do not detect ghosts");
  app.add_flag("--no-censored-fit", no_fit, "Censored pixels keep their lower bound");
  app.add_flag("--half", half, "Write half floats (refused when a value exceeds 65504)");
  return mr::RunTool("mr-hdr", app, argc, argv, [&] {
    mr::Report& report = mr::ToolReport();
    mo.ghosts = !no_ghosts;
    mo.fit_censored = !no_fit;
    mo.Check();
    if (!response_in.empty() && linear) throw mr::UsageError("--response and --linear contradict each other");
    if (!response_in.empty() && !response_out.empty())
      throw mr::UsageError("--save-response needs a recovered response, not --response");
    std::vector<double> times;
    if (!exposures_file.empty()) {
      times = mr::ReadExposures(exposures_file, images);
      report.AddInput(exposures_file);
    }
    std::vector<mr::Exposure> bracket;
    nlohmann::json inputs = nlohmann::json::array();
    {
      mr::ScopedTimer t(&report, "read");
      for (size_t i = 0; i < images.size(); ++i) {
        std::string how = "--exposures";
        mr::Exposure e = mr::ReadExposure(images[i], times.empty() ? 0.0 : times[i], times.empty() ? &how : nullptr);
        if (e.codes.channels() != 3 && e.codes.channels() != 1)
          mr::ThrowErrorAt(mr::FileLoc{images[i]}, "has {} channels; mr-hdr merges RGB or grey photographs",
                           e.codes.channels());
        if (!bracket.empty() && e.codes.channels() != bracket[0].codes.channels())
          mr::ThrowErrorAt(mr::FileLoc{images[i]}, "has {} channels, {} has {}", e.codes.channels(), bracket[0].name,
                           bracket[0].codes.channels());
        inputs.push_back({{"image", images[i]},
                          {"exposure", e.time_s},
                          {"from", how},
                          {"pixel_type", e.pixel_type},
                          {"size", {e.codes.width(), e.codes.height()}}});
        report.AddInput(images[i]);
        bracket.push_back(std::move(e));
      }
    }
    report.SetMetric("inputs", inputs);
    if (align) {
      mr::ScopedTimer t(&report, "align");
      const std::vector<Eigen::Vector2i> shifts = mr::AlignExposures(&bracket);
      nlohmann::json js = nlohmann::json::array();
      for (size_t i = 0; i < shifts.size(); ++i) js.push_back({shifts[i].x(), shifts[i].y()});
      report.SetMetric("align.shifts_px", js);
      spdlog::info("aligned to {}: shifts {}", bracket[bracket.size() / 2].name, js.dump());
    } else {
      report.Skip("alignment", "not asked for (--align): the bracket is taken as still");
    }
    const bool is_float = bracket[0].pixel_type == "float" || bracket[0].pixel_type == "half";
    for (const auto& e : bracket)
      if ((e.pixel_type == "float" || e.pixel_type == "half") != is_float)
        mr::ThrowErrorAt(mr::FileLoc{e.name}, "mixes float and integer inputs in one bracket");
    mr::CameraResponse response;
    const int nc = bracket[0].codes.channels();
    if (!response_in.empty()) {
      response = mr::ReadResponse(response_in);
      report.AddInput(response_in);
      report.Skip("response recovery", "--response " + response_in);
    } else if (linear || is_float) {
      response = mr::LinearResponse(nc);
      response.channels = bracket[0].codes.channel_names();
      report.Skip("response recovery", is_float ? "float inputs are linear" : "--linear");
    } else {
      mr::ScopedTimer t(&report, "response");
      mr::ResponseReport rr;
      response = mr::RecoverResponse(bracket, ro, &rr);
      report.SetMetric("response", {{"method", ro.method},
                                    {"samples", rr.samples},
                                    {"rms_log", rr.rms_log},
                                    {"monotonicity_fixes", rr.monotonicity_fixes}});
      spdlog::info("response ({}): {} pixels, RMS {:.3f} in ln exposure", ro.method, rr.samples, rr.rms_log);
    }
    if (static_cast<int>(response.channels.size()) != nc)
      mr::ThrowErrorAt(mr::FileLoc{response_in}, "has {} channels, the photographs {}", response.channels.size(), nc);
    mr::MergeReport mrep;
    mr::Image hdr;
    {
      mr::ScopedTimer t(&report, "merge");
      hdr = mr::MergeExposures(bracket, response, mo, &mrep);
    }
    for (const auto& w : mrep.warnings) report.Warn(w);
    nlohmann::json regions = nlohmann::json::array();
    for (const auto& r : mrep.regions)
      regions.push_back({{"pixels", r.pixels},
                         {"centre_px", {r.centre.x(), r.centre.y()}},
                         {"lower_bound_energy", {r.lower_bound.x(), r.lower_bound.y(), r.lower_bound.z()}},
                         {"estimated_energy", {r.estimate.x(), r.estimate.y(), r.estimate.z()}},
                         {"fitted", r.fitted},
                         {"blur_px", r.blur_px},
                         {"why_not_fitted", r.why_not}});
    report.SetMetric("merge", {{"order", mrep.order},
                               {"reference", mrep.order[static_cast<size_t>(mrep.reference)]},
                               {"pixels", mrep.pixels},
                               {"censored_pixels", mrep.censored_pixels},
                               {"black_pixels", mrep.black_pixels},
                               {"ghost_pixels", mrep.ghost_pixels},
                               {"censored_lower_bound_fraction", mrep.censored_lower_bound_fraction},
                               {"censored_added_fraction", mrep.censored_added_fraction},
                               {"censored_regions", regions}});
    if (mrep.censored_pixels > 0) {
      const std::string msg = fmt::format(
          "{} pixels are saturated in every exposure ({} regions): their lower bound holds {:.2g} of the image's "
          "energy and the fitted sources add {:.2g}",
          mrep.censored_pixels, mrep.regions.size(), mrep.censored_lower_bound_fraction, mrep.censored_added_fraction);
      report.Warn(msg);
    } else {
      report.Skip("censored fit", "no pixel is saturated in every exposure");
    }
    spdlog::info("merged {} exposures: {} censored, {} dark everywhere, {} ghost pixels", mrep.order.size(),
                 mrep.censored_pixels, mrep.black_pixels, mrep.ghost_pixels);
    mr::ImageWriteOptions wo;
    wo.pixel_type = half ? mr::PixelType::kHalf : mr::PixelType::kFloat;
    wo.tool = "mr-hdr";
    wo.command_line = mr::JoinCommandLine(argc, argv);
    {
      // Nothing is written before the merge has succeeded: a failed run
      // leaves no response.json behind either.
      mr::ScopedTimer t(&report, "write");
      mr::WriteImage(out, hdr, wo);
      if (!response_out.empty()) {
        mr::WriteResponse(response_out, response, "mr-hdr: " + mr::JoinCommandLine(argc, argv));
        report.AddOutput(response_out);
      }
    }
    report.AddOutput(out);
    return mr::kExitOk;
  });
}
