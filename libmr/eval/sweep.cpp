#include "eval/sweep.h"

#include <spdlog/spdlog.h>

#include <map>

#include "core/error.h"
#include "core/image.h"
#include "eval/metrics.h"
#include "eval/plot.h"
#include "render/render_job.h"

namespace mr {

namespace {

struct Setting {
  std::string method, name, dir;
  Scene scene;
  int spp = 0;
};

int Paired(const std::vector<int>& spp, size_t i, const char* name, size_t n) {
  if (spp.size() == 1) return spp[0];
  if (spp.size() != n) throw UsageError(fmt::format("{} has {} values for {} settings (give one, or one per setting)", name, spp.size(), n));
  return spp[i];
}

std::vector<Setting> Settings(const Scene& base, const SweepOptions& o) {
  std::vector<Setting> out;
  for (const std::string& m : o.methods) {
    auto add = [&](const std::string& name, const std::string& dir, int spp, const std::function<void(Scene*)>& edit) {
      Setting s{m, name, m + "-" + dir, base, spp};
      s.scene.render.method = m;
      s.scene.render.spp = spp;
      s.scene.render.time_budget_s = 0;
      edit(&s.scene);
      out.push_back(std::move(s));
    };
    if (m == "pt") {
      for (int spp : o.pt_spp) add(fmt::format("spp={}", spp), fmt::format("spp{}", spp), spp, [](Scene*) {});
    } else if (m == "prt") {
      for (int spp : o.prt_spp) add(fmt::format("spp={}", spp), fmt::format("spp{}", spp), spp, [](Scene*) {});
    } else if (m == "ic") {
      for (size_t i = 0; i < o.ic_rays.size(); ++i) {
        const int rays = o.ic_rays[i], spp = Paired(o.ic_spp, i, "--ic-spp", o.ic_rays.size());
        add(fmt::format("rays={} spp={}", rays, spp), fmt::format("rays{}-spp{}", rays, spp), spp,
            [&](Scene* s) { s->render.ic.rays = rays; });
      }
    } else if (m == "vpl") {
      for (size_t i = 0; i < o.vpl_paths.size(); ++i) {
        const int paths = o.vpl_paths[i], spp = Paired(o.vpl_spp, i, "--vpl-spp", o.vpl_paths.size());
        add(fmt::format("paths={} directions={} spp={}", paths, std::max(16, paths / 4), spp),
            fmt::format("paths{}-spp{}", paths, spp), spp, [&](Scene* s) {
              s->render.vpl.paths = paths;
              s->render.vpl.directions = std::max(16, paths / 4);
            });
      }
    } else if (m == "vct") {
      for (size_t i = 0; i < o.vct_resolution.size(); ++i) {
        const int res = o.vct_resolution[i], spp = Paired(o.vct_spp, i, "--vct-spp", o.vct_resolution.size());
        add(fmt::format("resolution={} spp={}", res, spp), fmt::format("res{}-spp{}", res, spp), spp,
            [&](Scene* s) { s->render.vct.resolution = res; });
      }
    } else {
      throw UsageError(fmt::format("unknown method \"{}\" (pt, ic, vpl, vct, prt)", m));
    }
  }
  return out;
}

double Timing(const Json& timings, const char* part) {
  return timings.contains(part) ? timings[part].get<double>() : 0.0;
}

}  // namespace

std::vector<SweepRow> RunSweep(const Scene& scene, const SweepOptions& o, Report* report) {
  if (!scene.reference) throw UsageError(fmt::format("{} names no reference: a sweep needs ground truth", scene.file.string()));
  if (o.out.empty()) throw UsageError("--out is required");
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
    row.seconds = (Timing(t, "render") + Timing(t, "build vpls") + Timing(t, "build volumes") + Timing(t, "prepare prt")) / std::max(1, row.frames);
    row.relmse = m.value("relmse", NAN);
    row.region_relmse = m.value("region_relmse", NAN);
    row.rmse = m.value("rmse", NAN);
    spdlog::info("{} {}: {:.2f} s/frame, relMSE {:.3g}, in the object's region {:.3g}", s.method, s.name, row.seconds,
                 row.relmse, row.region_relmse);
    rows.push_back(row);
    runs.push_back({{"method", row.method}, {"setting", row.setting}, {"seconds", row.seconds}, {"relmse", row.relmse},
                    {"region_relmse", row.region_relmse}, {"rmse", row.rmse}, {"frames", row.frames},
                    {"report", m}, {"skipped", j["skipped"]}});
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
      series[index[r.method]].points.emplace_back(r.seconds, std::string(which) == "relmse" ? r.relmse : r.region_relmse);
    }
    PlotOptions po;
    po.title = fmt::format("{}: {} against time", (scene.file.parent_path().filename() / scene.file.filename()).string(),
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
  Json table = Json::array();
  for (const SweepRow& r : rows)
    table.push_back({{"method", r.method}, {"setting", r.setting}, {"seconds", r.seconds}, {"relmse", r.relmse},
                     {"region_relmse", r.region_relmse}});
  report->SetMetric("sweep", table);
  return rows;
}

}  // namespace mr
