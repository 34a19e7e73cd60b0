#include "eval/sweep.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <map>
#include <sstream>

#include <fmt/ranges.h>

#include "core/error.h"
#include "core/image.h"
#include "core/image_metrics.h"
#include "eval/plot.h"
#include "render/method.h"
#include "render/render_job.h"
#include "scene/frames.h"

namespace mr {

namespace {

struct Setting {
  std::string method, name, dir;
  Scene scene;
  int spp = 0;
};

std::string ValueText(const Json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); }

std::vector<Setting> Settings(const Scene& base, const SweepOptions& options) {
  SweepOptions o = options;
  if (o.methods.empty()) o.methods = DefaultSweepMethods();
  for (const auto& [key, values] : o.set) {
    const std::string m = key.substr(0, key.find('.'));
    if (std::find(o.methods.begin(), o.methods.end(), m) == o.methods.end())
      throw UsageError(
          fmt::format("--set {}: {} is not among the methods swept ({})", key, m, fmt::join(o.methods, ",")));
  }
  std::vector<Setting> out;
  for (const std::string& m : o.methods) {
    const MethodInfo& info = FindRenderMethod(m);
    // The method's axes: its defaults, then what --set replaces or adds.
    std::vector<std::pair<std::string, std::vector<Json>>> axes;
    for (const auto& [key, values] : info.sweep) {
      std::vector<Json> v;
      for (const Json& x : values) v.push_back(x);
      axes.emplace_back(key, v);
    }
    for (const auto& [name, values] : o.set) {
      if (name.rfind(m + ".", 0) != 0) continue;
      const std::string key = name.substr(m.size() + 1);
      auto it = std::find_if(axes.begin(), axes.end(), [&](const auto& a) { return a.first == key; });
      if (it == axes.end())
        axes.emplace_back(key, values);
      else
        it->second = values;
    }
    size_t n = 1;
    for (const auto& [key, values] : axes) n = std::max(n, values.size());
    for (const auto& [key, values] : axes)
      if (values.size() != 1 && values.size() != n)
        throw UsageError(fmt::format("{}.{} has {} values for {} settings (give one, or one per setting)", m, key,
                                     values.size(), n));
    for (size_t i = 0; i < n; ++i) {
      Setting s{m, "", m, base, base.render.spp};
      s.scene.render.method = m;
      s.scene.render.time_budget_s = 0;
      s.scene.output.review = false;  // the sweep compares files; review sheets are for the scene's own render
      std::string name, dir;
      // Keys other than spp first, in axis order: "rays=256 spp=4", "ic-rays256-spp4".
      for (int pass = 0; pass < 2; ++pass)
        for (const auto& [key, values] : axes) {
          if ((key == "spp") != (pass == 1)) continue;
          const Json& v = values.size() == 1 ? values[0] : values[i];
          if (key == "spp") {
            if (!v.is_number_integer() || v.get<int64_t>() < 1)
              throw UsageError(fmt::format("{}.spp: {} is not a positive whole number", m, v.dump()));
            s.spp = v.get<int>();
          } else {
            Json& block = s.scene.render.method_settings[m];
            if (!block.is_object()) block = Json::object();
            block[key] = v;
          }
          name += (name.empty() ? "" : " ") + key + "=" + ValueText(v);
          dir += "-" + key + ValueText(v);
        }
      s.scene.render.spp = s.spp;
      s.name = name;
      s.dir = m + dir;
      out.push_back(std::move(s));
    }
  }
  return out;
}

double Timing(const Json& timings, const char* part) {
  return timings.contains(part) ? timings[part].get<double>() : 0.0;
}

}  // namespace

std::string SweepDefaultsText() {
  std::vector<std::string> methods;
  for (const MethodInfo& m : RenderMethodRegistry()) {
    std::vector<std::string> axes;
    for (const auto& [key, values] : m.sweep) {
      std::vector<std::string> v;
      for (const Json& x : values) v.push_back(ValueText(x));
      axes.push_back(fmt::format("{}.{}={}", m.name, key, fmt::join(v, ",")));
    }
    methods.push_back(fmt::format("{}", fmt::join(axes, " ")));
  }
  return fmt::format("{}", fmt::join(methods, "\n"));
}

void AddSweepAxis(const std::string& spec, SweepOptions* o) {
  const auto eq = spec.find('='), dot = spec.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot > eq || dot == 0 || eq == dot + 1 ||
      eq + 1 == spec.size())
    throw UsageError(fmt::format("--set {}: expected METHOD.KEY=V1,V2,... (e.g. vpl.paths=64,256)", spec));
  FindRenderMethod(spec.substr(0, dot));
  std::vector<Json> values;
  std::stringstream ss(spec.substr(eq + 1));
  for (std::string t; std::getline(ss, t, ',');) {
    if (t.empty()) throw UsageError(fmt::format("--set {}: an empty value", spec));
    const Json v = Json::parse(t, nullptr, false);
    values.push_back(v.is_discarded() || v.is_object() || v.is_array() ? Json(t) : v);
  }
  o->set[spec.substr(0, eq)] = values;
}

void SweepOptions::Check() const {
  if (out.empty()) throw UsageError("--out is required");
  for (const std::string& m : methods) FindRenderMethod(m);
  if (!(diff_scale > 0)) throw UsageError("--diff-scale must be positive");
}

std::vector<FastestAtError> FastestAtPtErrors(const std::vector<SweepRow>& rows) {
  bool region = !rows.empty();
  for (const SweepRow& r : rows) region = region && r.region_relmse > 0;
  auto error = [&](const SweepRow& r) { return region ? r.region_relmse : r.relmse; };
  std::vector<FastestAtError> out;
  for (const SweepRow& p : rows) {
    if (p.method != "pt") continue;
    FastestAtError f{p.setting, p.seconds, error(p), p.method, p.setting, p.seconds, 1};
    for (const SweepRow& r : rows)
      if (error(r) <= error(p) && r.seconds < f.seconds) {
        f.method = r.method;
        f.setting = r.setting;
        f.seconds = r.seconds;
      }
    f.speedup = f.seconds > 0 ? p.seconds / f.seconds : 1;
    if (f.method == "pt")
      for (const SweepRow& r : rows)
        if (r.method != "pt" && r.seconds < p.seconds && error(p) > 0 &&
            (f.nearest_method.empty() || error(r) / error(p) < f.nearest_error_ratio)) {
          f.nearest_method = r.method;
          f.nearest_setting = r.setting;
          f.nearest_error_ratio = error(r) / error(p);
          f.nearest_time_ratio = r.seconds / p.seconds;
        }
    out.push_back(f);
  }
  return out;
}

namespace {

// fastest.csv, the report's `fastest` and a line per pt setting in the log.
void ReportFastest(const std::vector<FastestAtError>& fastest, const fs::path& csv_path, Report* report) {
  std::string csv = "pt_setting,pt_seconds,error,method,setting,seconds,speedup\n";
  Json table = Json::array();
  for (const FastestAtError& f : fastest) {
    csv += fmt::format("\"{}\",{:.6g},{:.6g},{},\"{}\",{:.6g},{:.4g}\n", f.pt_setting, f.pt_seconds, f.error, f.method,
                       f.setting, f.seconds, f.speedup);
    table.push_back({{"pt_setting", f.pt_setting},
                     {"pt_seconds", f.pt_seconds},
                     {"error", f.error},
                     {"method", f.method},
                     {"setting", f.setting},
                     {"seconds", f.seconds},
                     {"speedup", f.speedup}});
    if (!f.nearest_method.empty())
      table.back()["nearest"] = {{"method", f.nearest_method},
                                 {"setting", f.nearest_setting},
                                 {"error_ratio", f.nearest_error_ratio},
                                 {"time_ratio", f.nearest_time_ratio}};
    if (f.method == "pt" && !f.nearest_method.empty())
      spdlog::info(
          "pt's error at {} ({:.3g} in {:.2f} s): pt is the fastest to it; the nearest quicker run, {} {}, "
          "gives {:.2f} x its error in {:.2f} x its time",
          f.pt_setting, f.error, f.pt_seconds, f.nearest_method, f.nearest_setting, f.nearest_error_ratio,
          f.nearest_time_ratio);
    else if (f.method == "pt")
      spdlog::info("pt's error at {} ({:.3g} in {:.2f} s): pt is the fastest to it", f.pt_setting, f.error,
                   f.pt_seconds);
    else
      spdlog::info("pt's error at {} ({:.3g} in {:.2f} s): {} {} in {:.2f} s, {:.1f}x faster", f.pt_setting, f.error,
                   f.pt_seconds, f.method, f.setting, f.seconds, f.speedup);
  }
  WriteTextFile(csv_path, csv);
  report->AddOutput(csv_path.string());
  report->SetMetric("fastest", table);
}

}  // namespace

std::vector<SweepRow> RunSweep(const Scene& scene, const SweepOptions& o, Report* report) {
  if (!scene.reference)
    throw UsageError(fmt::format("{} names no reference: a sweep needs ground truth", scene.file.string()));
  o.Check();
  std::error_code ec;
  fs::create_directories(o.out / "diff", ec);
  if (!fs::is_directory(o.out / "diff")) ThrowErrorAt(FileLoc{o.out.string()}, "cannot create the output folder");
  std::vector<SweepRow> rows;
  Json runs = Json::array();
  for (const Setting& s : Settings(scene, o)) {
    RenderOptions ro;
    ro.out_dir = o.out / "renders" / s.dir;
    ro.frame_begin = o.frame_begin;
    ro.frame_end = o.frame_end;
    ro.tool = "mr-eval sweep";
    ro.command_line = o.command_line;
    Report r("mr-render", o.command_line);
    RunRenderJob(s.scene, ro, &r);
    const Json j = r.ToJson();
    const Json& m = j["metrics"];
    SweepRow row;
    row.method = s.method;
    row.setting = s.name;
    row.frames = static_cast<int>(m["frames"].size());
    // Rendering and the per-render preparation (VPLs, prt shading); not
    // loading, compositing or writing, which every method shares.
    const Json& t = j["timings"];
    const std::string& prepare = FindRenderMethod(s.method).prepare_timing;
    row.seconds =
        (Timing(t, "render") + (prepare.empty() ? 0.0 : Timing(t, prepare.c_str()))) / std::max(1, row.frames);
    row.relmse = m.value("relmse", NAN);
    row.region_relmse = m.value("region_relmse", NAN);
    row.rmse = m.value("rmse", NAN);
    spdlog::info("{} {}: {:.2f} s/frame, relMSE {:.3g}, in the object's region {:.3g}", s.method, s.name, row.seconds,
                 row.relmse, row.region_relmse);
    rows.push_back(row);
    runs.push_back({{"method", row.method},
                    {"setting", row.setting},
                    {"seconds", row.seconds},
                    {"relmse", row.relmse},
                    {"region_relmse", row.region_relmse},
                    {"rmse", row.rmse},
                    {"frames", row.frames},
                    {"report", m},
                    {"skipped", j["skipped"]}});
    // |composite - reference| x scale of the first frame.
    const int f0 = m["frames"][0]["frame"].get<int>();
    const Image composite = ReadRgbForComparison(ro.out_dir / fmt::format("{:05d}.exr", f0));
    const Image ref = ReadRgbForComparison(FramePath(*scene.reference, f0));
    ImageWriteOptions wo;
    wo.pixel_type = PixelType::kUint8;
    wo.ldr_transfer = Transfer::kLinear;  // the difference as is, not sRGB-encoded
    const fs::path diff = o.out / "diff" / (s.dir + ".png");
    WriteImage(diff, ScaledDifference(composite, ref, o.diff_scale), wo);
    report->AddOutput(diff.string());
  }
  std::string csv = "method,setting,seconds,relmse,region_relmse,rmse,frames\n";
  for (const SweepRow& r : rows)
    csv += fmt::format("{},\"{}\",{:.6g},{:.6g},{:.6g},{:.6g},{}\n", r.method, r.setting, r.seconds, r.relmse,
                       r.region_relmse, r.rmse, r.frames);
  WriteTextFile(o.out / "sweep.csv", csv);
  WriteTextFile(o.out / "sweep.json", Json({{"scene", scene.file.string()}, {"runs", runs}}).dump(2) + "\n");
  for (const char* which : {"relmse", "region_relmse"}) {
    std::vector<PlotSeries> series;
    std::map<std::string, size_t> index;
    for (const SweepRow& r : rows) {
      if (!index.count(r.method)) {
        index[r.method] = series.size();
        series.push_back({r.method, {}});
      }
      series[index[r.method]].points.emplace_back(r.seconds,
                                                  std::string(which) == "relmse" ? r.relmse : r.region_relmse);
    }
    PlotOptions po;
    po.title =
        fmt::format("{}: {} against time", (scene.file.parent_path().filename() / scene.file.filename()).string(),
                    std::string(which) == "relmse" ? "relMSE" : "relMSE in the object's region");
    po.x_label = "seconds per frame";
    po.y_label = std::string(which) == "relmse" ? "relMSE" : "region relMSE";
    const std::string stem = std::string("error-vs-time") + (std::string(which) == "relmse" ? "" : "-region");
    WriteSvgPlot(o.out / (stem + ".svg"), series, po);
    WritePngPlot(o.out / (stem + ".png"), series, po);
    report->AddOutput((o.out / (stem + ".svg")).string());
    report->AddOutput((o.out / (stem + ".png")).string());
  }
  report->AddOutput((o.out / "sweep.csv").string());
  report->AddOutput((o.out / "sweep.json").string());
  ReportFastest(FastestAtPtErrors(rows), o.out / "fastest.csv", report);
  Json table = Json::array();
  for (const SweepRow& r : rows)
    table.push_back({{"method", r.method},
                     {"setting", r.setting},
                     {"seconds", r.seconds},
                     {"relmse", r.relmse},
                     {"region_relmse", r.region_relmse}});
  report->SetMetric("sweep", table);
  return rows;
}

}  // namespace mr
