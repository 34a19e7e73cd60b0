#include "hdr/hdr_job.h"

#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/image.h"
#include "hdr/exposures_file.h"

namespace mr {

namespace {

// The bracket's photographs with their exposure times, all RGB or all grey.
std::vector<Exposure> ReadBracket(const HdrJobOptions& o, Report* report) {
  std::vector<double> times;
  if (!o.exposures.empty()) {
    times = ReadExposures(o.exposures, o.images);
    report->AddInput(o.exposures);
  }
  std::vector<Exposure> bracket;
  Json inputs = Json::array();
  {
    ScopedTimer t(report, "read");
    for (size_t i = 0; i < o.images.size(); ++i) {
      std::string how = "--exposures";
      Exposure e = ReadExposure(o.images[i], times.empty() ? 0.0 : times[i], times.empty() ? &how : nullptr);
      if (e.codes.channels() != 3 && e.codes.channels() != 1)
        ThrowErrorAt(FileLoc{o.images[i]}, "has {} channels; mr-hdr merges RGB or grey photographs",
                     e.codes.channels());
      if (!bracket.empty() && e.codes.channels() != bracket[0].codes.channels())
        ThrowErrorAt(FileLoc{o.images[i]}, "has {} channels, {} has {}", e.codes.channels(), bracket[0].name,
                     bracket[0].codes.channels());
      inputs.push_back({{"image", o.images[i]},
                        {"exposure", e.time_s},
                        {"from", how},
                        {"pixel_type", e.pixel_type},
                        {"size", {e.codes.width(), e.codes.height()}}});
      report->AddInput(o.images[i]);
      bracket.push_back(std::move(e));
    }
  }
  report->SetMetric("inputs", inputs);
  if (o.align) {
    ScopedTimer t(report, "align");
    const std::vector<Eigen::Vector2i> shifts = AlignExposures(&bracket);
    Json js = Json::array();
    for (size_t i = 0; i < shifts.size(); ++i) js.push_back({shifts[i].x(), shifts[i].y()});
    report->SetMetric("align.shifts_px", js);
    spdlog::info("aligned to {}: shifts {}", bracket[bracket.size() / 2].name, js.dump());
  } else {
    report->Skip("alignment", "not asked for (--align): the bracket is taken as still");
  }
  const bool is_float = bracket[0].pixel_type == "float" || bracket[0].pixel_type == "half";
  for (const auto& e : bracket)
    if ((e.pixel_type == "float" || e.pixel_type == "half") != is_float)
      ThrowErrorAt(FileLoc{e.name}, "mixes float and integer inputs in one bracket");
  return bracket;
}

// The response: read (--response), linear (float inputs, --linear) or
// recovered from the bracket.
CameraResponse ResponseFor(const HdrJobOptions& o, const std::vector<Exposure>& bracket, Report* report) {
  CameraResponse response;
  const bool is_float = bracket[0].pixel_type == "float" || bracket[0].pixel_type == "half";
  const int nc = bracket[0].codes.channels();
  if (!o.response_in.empty()) {
    response = ReadResponse(o.response_in);
    report->AddInput(o.response_in);
    report->Skip("response recovery", "--response " + o.response_in);
  } else if (o.linear || is_float) {
    response = LinearResponse(nc);
    response.channels = bracket[0].codes.channel_names();
    report->Skip("response recovery", is_float ? "float inputs are linear" : "--linear");
  } else {
    ScopedTimer t(report, "response");
    ResponseReport rr;
    response = RecoverResponse(bracket, o.response, &rr);
    report->SetMetric("response", {{"method", o.response.method},
                                   {"samples", rr.samples},
                                   {"rms_log", rr.rms_log},
                                   {"monotonicity_fixes", rr.monotonicity_fixes}});
    spdlog::info("response ({}): {} pixels, RMS {:.3f} in ln exposure", o.response.method, rr.samples, rr.rms_log);
  }
  if (static_cast<int>(response.channels.size()) != nc)
    ThrowErrorAt(FileLoc{o.response_in}, "has {} channels, the photographs {}", response.channels.size(), nc);
  return response;
}

// What the merge did: its order and reference, and what it censored, found
// dark or ghosted.
void ReportMerge(const MergeReport& mrep, Report* report) {
  for (const auto& w : mrep.warnings) report->Warn(w);
  Json regions = Json::array();
  for (const auto& r : mrep.regions)
    regions.push_back({{"pixels", r.pixels},
                       {"centre_px", {r.centre.x(), r.centre.y()}},
                       {"lower_bound_energy", {r.lower_bound.x(), r.lower_bound.y(), r.lower_bound.z()}},
                       {"estimated_energy", {r.estimate.x(), r.estimate.y(), r.estimate.z()}},
                       {"fitted", r.fitted},
                       {"blur_px", r.blur_px},
                       {"why_not_fitted", r.why_not}});
  report->SetMetric("merge", {{"order", mrep.order},
                              {"reference", mrep.order[static_cast<size_t>(mrep.reference)]},
                              {"pixels", mrep.pixels},
                              {"censored_pixels", mrep.censored_pixels},
                              {"black_pixels", mrep.black_pixels},
                              {"ghost_pixels", mrep.ghost_pixels},
                              {"censored_lower_bound_fraction", mrep.censored_lower_bound_fraction},
                              {"censored_added_fraction", mrep.censored_added_fraction},
                              {"censored_regions", regions}});
  if (mrep.censored_pixels > 0) {
    report->Warn(fmt::format(
        "{} pixels are saturated in every exposure ({} regions): their lower bound holds {:.2g} of the image's "
        "energy and the fitted sources add {:.2g}",
        mrep.censored_pixels, mrep.regions.size(), mrep.censored_lower_bound_fraction, mrep.censored_added_fraction));
  } else {
    report->Skip("censored fit", "no pixel is saturated in every exposure");
  }
  spdlog::info("merged {} exposures: {} censored, {} dark everywhere, {} ghost pixels", mrep.order.size(),
               mrep.censored_pixels, mrep.black_pixels, mrep.ghost_pixels);
}

}  // namespace

void HdrJobOptions::Check() const {
  merge.Check();
  if (!response_in.empty() && linear) throw UsageError("--response and --linear contradict each other");
  if (!response_in.empty() && !response_out.empty())
    throw UsageError("--save-response needs a recovered response, not --response");
  if (images.empty()) throw UsageError("give the bracket's photographs");
  if (out.empty()) throw UsageError("give --out");
}

void RunHdrMerge(const HdrJobOptions& o, Report* report) {
  o.Check();
  const std::vector<Exposure> bracket = ReadBracket(o, report);
  const CameraResponse response = ResponseFor(o, bracket, report);
  MergeReport mrep;
  Image hdr;
  {
    ScopedTimer t(report, "merge");
    hdr = MergeExposures(bracket, response, o.merge, &mrep);
  }
  ReportMerge(mrep, report);
  ImageWriteOptions wo;
  wo.pixel_type = o.half ? PixelType::kHalf : PixelType::kFloat;
  wo.tool = "mr-hdr";
  wo.command_line = o.command_line;
  {
    // Nothing is written before the merge has succeeded: a failed run
    // leaves no response.json behind either.
    ScopedTimer t(report, "write");
    WriteImage(o.out, hdr, wo);
    if (!o.response_out.empty()) {
      WriteResponse(o.response_out, response, "mr-hdr: " + o.command_line);
      report->AddOutput(o.response_out);
    }
  }
  report->AddOutput(o.out);
}

}  // namespace mr
