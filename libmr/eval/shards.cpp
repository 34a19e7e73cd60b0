#include "eval/shards.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>

#include "core/error.h"
#include "core/image.h"
#include "core/image_metrics.h"
#include "core/json.h"
#include "core/video.h"

namespace mr {

namespace {

struct Shard {
  fs::path file;
  Json json;
  int begin = 0, end = 0, scene_frames = 0;
};

Shard ReadShard(const fs::path& file) {
  Shard s;
  s.file = file;
  s.json = ReadJsonFile(file);  // every JSON error as an mr::Error naming the file
  ValidateReportJson(s.json, file.string());
  if (s.json["tool"] != "mr-render")
    ThrowErrorAt(FileLoc{file.string()}, "a report of {}, not of mr-render", s.json["tool"].get<std::string>());
  const Json& m = s.json["metrics"];
  if (!m.contains("shard") || !m.contains("frames") || !m.contains("method"))
    ThrowErrorAt(FileLoc{file.string()},
                 "has no metrics.shard, metrics.frames or metrics.method (written by an older mr-render?)");
  s.begin = m["shard"]["begin"].get<int>();
  s.end = m["shard"]["end"].get<int>();
  s.scene_frames = m["shard"]["scene_frames"].get<int>();
  return s;
}

}  // namespace

void ShardMergeOptions::Check() const {
  if (reports.empty()) throw UsageError("no shard reports to merge");
  if (!(fps >= 0)) throw UsageError("--fps must not be negative (0: the plate's rate)");
}

void MergeRenderReports(const ShardMergeOptions& o, Report* report) {
  o.Check();
  std::vector<Shard> shards;
  for (const fs::path& f : o.reports) shards.push_back(ReadShard(f));
  std::sort(shards.begin(), shards.end(), [](const Shard& a, const Shard& b) { return a.begin < b.begin; });
  const Shard& first = shards.front();
  const std::string method = first.json["metrics"]["method"];
  const Json scene_input = first.json["inputs"].empty() ? Json() : first.json["inputs"][0];
  for (const Shard& s : shards) {
    if (s.json["metrics"]["method"] != method)
      ThrowErrorAt(FileLoc{s.file.string()}, "method {} differs from {}'s {}",
                   s.json["metrics"]["method"].get<std::string>(), first.file.string(), method);
    const Json in = s.json["inputs"].empty() ? Json() : s.json["inputs"][0];
    if (in != scene_input)
      ThrowErrorAt(FileLoc{s.file.string()}, "renders scene {} but {} renders {}", in.dump(), first.file.string(),
                   scene_input.dump());
    if (s.scene_frames != first.scene_frames)
      ThrowErrorAt(FileLoc{s.file.string()}, "the scene has {} frames here but {} in {}", s.scene_frames,
                   first.scene_frames, first.file.string());
  }
  // Coverage: no frame twice, no gap unless allowed.
  int next = 0;
  std::vector<std::string> gaps;
  for (size_t i = 0; i < shards.size(); ++i) {
    const Shard& s = shards[i];
    if (i > 0 && s.begin < shards[i - 1].end)
      ThrowErrorAt(FileLoc{s.file.string()}, "frames {}:{} overlap {}'s {}:{}", s.begin, s.end,
                   shards[i - 1].file.string(), shards[i - 1].begin, shards[i - 1].end);
    if (s.begin > next) gaps.push_back(fmt::format("{}:{}", next, s.begin));
    next = s.end;
  }
  if (next < first.scene_frames) gaps.push_back(fmt::format("{}:{}", next, first.scene_frames));
  if (!gaps.empty()) {
    const std::string list = fmt::format("{}", fmt::join(gaps, ", "));
    if (!o.allow_gaps)
      throw Error(FileLoc{}, fmt::format("no shard rendered frames {} (--allow-gaps merges what there is)", list));
    report->Warn("no shard rendered frames " + list);
  }

  Json frames = Json::array();
  Json timings = Json::object();
  double sum_rmse = 0, sum_relmse = 0, sum_region = 0;
  int n_ref = 0;
  int64_t clamped = 0, nonfinite = 0;
  std::map<int, Json> curve;  // by spp: sums over frames
  std::vector<fs::path> composites;
  for (const Shard& s : shards) {
    report->AddInput(s.file.string());
    const Json& m = s.json["metrics"];
    for (const Json& w : s.json["warnings"]) report->Warn(w.get<std::string>());
    for (const Json& k : s.json["skipped"]) report->Skip(k["what"], k["why"]);
    for (auto& [part, sec] : s.json["timings"].items()) report->AddTiming(part, sec.get<double>());
    for (const Json& p : s.json["outputs"]) {
      report->AddOutput(p.get<std::string>());
      if (LowerExtension(p.get<std::string>()) == ".exr") composites.push_back(p.get<std::string>());
    }
    for (const Json& f : m["frames"]) {
      frames.push_back(f);
      if (f.contains("relmse")) {
        sum_rmse += f["rmse"].get<double>();
        sum_relmse += f["relmse"].get<double>();
        sum_region += f["region_relmse"].get<double>();
        ++n_ref;
      }
    }
    clamped += m.value("clamped_negative", int64_t{0});
    nonfinite += m.value("nonfinite_samples", int64_t{0});
    // The shard's curve is already a mean over its frames: weight it back.
    const int nf_ref = static_cast<int>(
        std::count_if(m["frames"].begin(), m["frames"].end(), [](const Json& f) { return f.contains("relmse"); }));
    if (m.contains("curve"))
      for (const Json& c : m["curve"]) {
        Json& acc = curve[c["spp"].get<int>()];
        if (acc.is_null()) acc = {{"seconds", 0.0}, {"relmse", 0.0}, {"region_relmse", 0.0}, {"frames", 0}};
        for (const char* key : {"seconds", "relmse", "region_relmse"})
          acc[key] = acc[key].get<double>() + c[key].get<double>() * nf_ref;
        acc["frames"] = acc["frames"].get<int>() + nf_ref;
      }
  }
  report->SetMetric("method", method);
  report->SetMetric("shards", static_cast<int>(shards.size()));
  report->SetMetric("shard",
                    Json{{"begin", first.begin}, {"end", shards.back().end}, {"scene_frames", first.scene_frames}});
  report->SetMetric("frames", frames);
  report->SetMetric("clamped_negative", clamped);
  report->SetMetric("nonfinite_samples", nonfinite);
  if (n_ref > 0) {
    report->SetMetric("rmse", sum_rmse / n_ref);
    report->SetMetric("relmse", sum_relmse / n_ref);
    report->SetMetric("region_relmse", sum_region / n_ref);
    Json c = Json::array();
    for (auto& [spp, acc] : curve) {
      const int nf = acc["frames"].get<int>();
      if (nf == 0) continue;
      c.push_back({{"seconds", acc["seconds"].get<double>() / nf},
                   {"spp", spp},
                   {"relmse", acc["relmse"].get<double>() / nf},
                   {"region_relmse", acc["region_relmse"].get<double>() / nf}});
    }
    report->SetMetric("curve", c);
  }
  if (o.video) {
    if (composites.empty()) throw Error(FileLoc{}, "the shards list no EXR frames to make a video of");
    // NNNNN.exr: frame order, whichever folder each shard wrote to.
    std::sort(composites.begin(), composites.end(),
              [](const fs::path& a, const fs::path& b) { return a.filename() < b.filename(); });
    // The plate's frame rate, as the shards report it, unless given.
    const Json& m = first.json["metrics"];
    const double fps = o.fps > 0 ? o.fps : m.contains("plate_fps") ? m["plate_fps"].get<double>() : 30.0;
    std::unique_ptr<VideoWriter> writer;
    for (const fs::path& p : composites) {
      RequireFile(p, "a shard's frame");
      // The frame's PNG holds the composite as the plate's code values (the
      // codes a single run writes to its video); without one, sRGB.
      const fs::path png = fs::path(p).replace_extension(".png");
      std::error_code ec;
      const bool codes = fs::is_regular_file(png, ec);
      const Image frame = codes ? ReadRgbForComparison(png, Transfer::kLinear, true) : ReadImage(p).Layer("composite");
      if (!writer) writer = std::make_unique<VideoWriter>(*o.video, frame.width(), frame.height(), fps);
      if (codes)
        writer->WriteCodes(frame);
      else
        writer->Write(frame);
    }
    writer->Close();
    report->AddOutput(o.video->string());
  }
}

}  // namespace mr
