#include "jobs/eval_jobs.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "camera/trajectory.h"
#include "core/error.h"
#include "core/image.h"
#include "core/image_metrics.h"
#include "eval/plot.h"
#include "eval/trajectory_error.h"
#include "geometry/mesh.h"
#include "probe/light_sequence.h"
#include "render/method.h"
#include "scene/frames.h"
#include "scene/scene.h"

namespace mr {

void CompareJobOptions::Check() const {
  if (estimate.empty() || reference.empty()) throw UsageError("compare: give A and B");
  if (!(scale > 0)) throw UsageError("--scale must be positive");
}

void RunCompare(const CompareJobOptions& o, Report* rep) {
  o.Check();
  const Image ia = ReadRgbForComparison(o.estimate), ib = ReadRgbForComparison(o.reference);
  if (ia.width() != ib.width() || ia.height() != ib.height())
    ThrowErrorAt(FileLoc{o.estimate}, "image is {}x{}, the reference {} is {}x{}", ia.width(), ia.height(), o.reference,
                 ib.width(), ib.height());
  std::optional<Image> reg;
  if (!o.region.empty()) {
    Image r = ReadImage(o.region);
    if (r.width() != ia.width() || r.height() != ia.height())
      ThrowErrorAt(FileLoc{o.region}, "region is {}x{}, the images {}x{}", r.width(), r.height(), ia.width(),
                   ia.height());
    // An mr-render EXR: its mask layer; a one-layer image (a mask as grey,
    // RGB or RGBA): its first channel; any other layered image is refused
    // rather than compared by its first layer (a composite, nonzero almost
    // everywhere).
    const std::vector<std::string> layers = r.LayerNames();
    if (std::find(layers.begin(), layers.end(), "mask") != layers.end())
      reg = r.Layer("mask");
    else if (layers.size() == 1)
      reg = r.channels() == 1 ? r : r.Layer(layers.front());
    else
      ThrowErrorAt(FileLoc{o.region},
                   "region has {} layers and none is \"mask\": give a one-layer mask image or an "
                   "mr-render EXR",
                   layers.size());
  }
  const ImageMetrics m = CompareImages(ia, ib, reg ? &*reg : nullptr);
  rep->AddInput(o.estimate);
  rep->AddInput(o.reference);
  rep->SetMetric("rmse", m.rmse);
  rep->SetMetric("relmse", m.relmse);
  rep->SetMetric("psnr", m.psnr);
  rep->SetMetric("ssim", m.ssim);
  rep->SetMetric("pixels", m.pixels);
  std::printf("rmse %.6g relmse %.6g psnr %.4g dB ssim %.6g (%lld pixels)\n", m.rmse, m.relmse, m.psnr, m.ssim,
              static_cast<long long>(m.pixels));
  if (!o.diff.empty()) {
    WriteImage(o.diff, ScaledDifference(ia, ib, o.scale));
    rep->AddOutput(o.diff);
  }
}

void TrajectoryJobOptions::Check() const {
  if (estimate.empty() || reference.empty()) throw UsageError("traj: give ESTIMATE and REFERENCE");
  if (!(max_dt >= 0)) throw UsageError("--max-dt must be 0 or more");
  if (!(delta > 0)) throw UsageError("--delta must be positive");
}

void RunTrajectoryError(const TrajectoryJobOptions& o, Report* rep) {
  o.Check();
  auto load = [](const std::string& p) { return fs::is_directory(p) ? Read7ScenesFolder(p) : ReadTum(fs::path(p)); };
  const Trajectory e = load(o.estimate), r = load(o.reference);
  AteResult ate;
  RpeResult rpe;
  try {
    ate = ComputeAte(e, r, o.max_dt);
    rpe = ComputeRpe(e, r, o.delta, o.max_dt);
  } catch (const Error& err) {  // name both files
    ThrowErrorAt(FileLoc{o.estimate}, "against {}: {}", o.reference, err.message());
  }
  rep->AddInput(o.estimate);
  rep->AddInput(o.reference);
  rep->SetMetric(
      "ate",
      {{"pairs", ate.pairs}, {"rmse_m", ate.rmse}, {"mean_m", ate.mean}, {"median_m", ate.median}, {"max_m", ate.max}});
  rep->SetMetric("rpe", {{"delta", o.delta},
                         {"pairs", rpe.pairs},
                         {"trans_rmse_m", rpe.trans_rmse},
                         {"trans_mean_m", rpe.trans_mean},
                         {"rot_rmse_deg", rpe.rot_rmse_deg}});
  std::printf("ATE rmse %.4f m mean %.4f median %.4f max %.4f (%d pairs)\n", ate.rmse, ate.mean, ate.median, ate.max,
              ate.pairs);
  std::printf("RPE (delta %g) trans rmse %.4f m, rot rmse %.3f deg (%d pairs)\n", o.delta, rpe.trans_rmse,
              rpe.rot_rmse_deg, rpe.pairs);
}

void MeshJobOptions::Check() const {
  if (estimate.empty() || reference.empty()) throw UsageError("mesh: give MESH and REFERENCE");
  if (!region.empty() && region.size() != 6) throw UsageError("--region: give xmin,ymin,zmin,xmax,ymax,zmax");
}

void RunMeshError(const MeshJobOptions& o, Report* rep) {
  o.Check();
  const Mesh m = ReadMesh(o.estimate), r = ReadMesh(o.reference);
  std::optional<Eigen::AlignedBox3f> reg;
  if (o.region.size() == 6)
    reg = Eigen::AlignedBox3f(Eigen::Vector3d(o.region[0], o.region[1], o.region[2]).cast<float>(),
                              Eigen::Vector3d(o.region[3], o.region[4], o.region[5]).cast<float>());
  const MeshErrorResult e = CompareMeshes(m, r, o.threshold, o.cutoff, o.samples, 1, reg ? &*reg : nullptr);
  rep->AddInput(o.estimate);
  rep->AddInput(o.reference);
  for (const auto& [name, d] : {std::pair{"accuracy", e.accuracy}, std::pair{"completeness", e.completeness}}) {
    rep->SetMetric(name, {{"mean_m", d.mean},
                          {"median_m", d.median},
                          {"rmse_m", d.rmse},
                          {"p90_m", d.p90},
                          {"within_threshold", d.within},
                          {"samples", d.samples}});
    std::printf("%-12s mean %.4f m median %.4f p90 %.4f, %.1f%% within %.3f m\n", name, d.mean, d.median, d.p90,
                100 * d.within, o.threshold);
  }
  rep->SetMetric("threshold_m", o.threshold);
  rep->SetMetric("cutoff_m", o.cutoff);
  rep->SetMetric("fscore", e.fscore);
  std::printf("F-score %.4f\n", e.fscore);
}

void LightErrorJobOptions::Check() const {
  if (estimate.empty() || reference.empty()) throw UsageError("light: give ESTIMATE and REFERENCE");
  if (frames < 0) throw UsageError("--frames must be 0 or more");
}

void RunLightError(const LightErrorJobOptions& o, Report* rep) {
  o.Check();
  Json per_frame = Json::array();
  std::optional<LightMapError> prev;
  double sum_err = 0, sum_flicker = 0;
  int n = 0;
  std::printf("frame  irradiance_relrms  energy_ratio  unseen_energy  flicker\n");
  for (int f = 0; o.frames == 0 || f < o.frames; ++f) {
    const fs::path pe = FramePath(o.estimate, f), pr = FramePath(o.reference, f);
    if (o.frames == 0 && !fs::exists(pe)) break;
    const LightMapError e = CompareLightMaps(ReadImage(pe), ReadImage(pr));
    rep->AddInput(pe.string());
    rep->AddInput(pr.string());
    const double flicker = prev ? LightFlicker(*prev, e) : 0;
    per_frame.push_back({{"frame", f},
                         {"irradiance_relrms", e.irradiance_rel_rms},
                         {"energy_ratio", e.energy_ratio},
                         {"unseen_energy_fraction", e.unseen_energy_fraction},
                         {"flicker", flicker}});
    std::printf("%5d  %17.4g  %12.4f  %13.4f  %7.4g\n", f, e.irradiance_rel_rms, e.energy_ratio,
                e.unseen_energy_fraction, flicker);
    sum_err += e.irradiance_rel_rms;
    sum_flicker += flicker;
    ++n;
    prev = e;
  }
  if (n == 0) ThrowErrorAt(FileLoc{FramePath(o.estimate, 0).string()}, "no such file");
  rep->SetMetric("frames", per_frame);
  rep->SetMetric("mean_irradiance_relrms", sum_err / n);
  rep->SetMetric("mean_flicker", n > 1 ? sum_flicker / (n - 1) : 0.0);
  std::printf("mean   %17.4g  flicker %.4g over %d frames\n", sum_err / n, n > 1 ? sum_flicker / (n - 1) : 0.0, n);
}

void PlotJobOptions::Check() const {
  if (table.empty() || x.empty() || y.empty() || out.empty()) throw UsageError("plot: give TABLE, --x, --y and --out");
}

void RunPlot(const PlotJobOptions& o, Report* rep) {
  o.Check();
  const std::vector<PlotSeries> series = ReadPlotSeries(o.table, o.x, o.y, o.group);
  PlotOptions po;
  po.title = o.title.empty() ? o.y + " against " + o.x : o.title;
  po.x_label = o.x;
  po.y_label = o.y;
  po.log_x = !o.linear_x;
  po.log_y = !o.linear_y;
  WriteSvgPlot(o.out, series, po);
  rep->AddInput(o.table);
  rep->AddOutput(o.out);
}

namespace {

// BEGIN:END into [*begin, *end); a UsageError naming `flag` otherwise.
void FrameRange(const std::string& range, const char* flag, int* begin, int* end) {
  if (!range.empty() && !ParseFrameRange(range, begin, end))
    throw UsageError(fmt::format("{} {}: expected BEGIN:END", flag, range));
}

SweepOptions SweepOf(const SweepJobOptions& o) {
  SweepOptions so = o.sweep;
  so.methods.clear();
  std::stringstream ss(o.methods);
  for (std::string m; std::getline(ss, m, ',');)
    if (!m.empty()) so.methods.push_back(m);
  FrameRange(o.frames, "--frames", &so.frame_begin, &so.frame_end);
  for (const auto& [key, values] : o.old_flags)
    if (!values.empty()) AddSweepAxis(key + "=" + values, &so);
  for (const auto& spec : o.set) AddSweepAxis(spec, &so);
  so.command_line = o.command_line;
  return so;
}

}  // namespace

void SweepJobOptions::Check() const { SweepOf(*this).Check(); }

void RunSweepJob(const SweepJobOptions& o, Report* rep) {
  const SweepOptions so = SweepOf(o);
  so.Check();
  const Scene scene = ReadScene(o.scene);
  rep->AddInput(o.scene);
  const auto rows = RunSweep(scene, so, rep);
  std::printf("%-5s %-36s %10s %12s %14s\n", "method", "setting", "s/frame", "relMSE", "region relMSE");
  for (const auto& r : rows)
    std::printf("%-5s %-36s %10.3f %12.4g %14.4g\n", r.method.c_str(), r.setting.c_str(), r.seconds, r.relmse,
                r.region_relmse);
}

namespace {

PlateCheckOptions PlateOf(const PlateJobOptions& o) {
  PlateCheckOptions po = o.plate;
  FrameRange(o.frames, "--frames", &po.frame_begin, &po.frame_end);
  po.command_line = o.command_line;
  return po;
}

}  // namespace

void PlateJobOptions::Check() const { PlateOf(*this).Check(); }

void RunPlate(const PlateJobOptions& o, Report* rep) {
  const PlateCheckOptions po = PlateOf(o);
  po.Check();  // before the scene is read; RunPlateCheck checks the scene's plate
  const Scene scene = ReadScene(o.scene);
  RunPlateCheck(scene, po, rep);
  const auto& m = rep->metrics();
  std::printf("gains: %s\n", m["gains_file"].get<std::string>().c_str());
  if (m.contains("relmse"))
    std::printf("re-rendering error after the fit: relMSE %.4g, SSIM %.4f%s\n", m["relmse"].get<double>(),
                m["ssim"].get<double>(),
                m.contains("region_relmse")
                    ? fmt::format(", around the objects relMSE {:.4g}", m["region_relmse"].get<double>()).c_str()
                    : "");
}

void MergeJobOptions::Check() const {
  ShardMergeOptions mo = merge;
  mo.reports.assign(reports.begin(), reports.end());
  mo.Check();
}

void RunMerge(const MergeJobOptions& o, Report* rep) {
  ShardMergeOptions mo = o.merge;
  mo.reports.assign(o.reports.begin(), o.reports.end());
  if (!o.video.empty()) mo.video = o.video;
  MergeRenderReports(mo, rep);
  const auto& m = rep->metrics();
  std::printf("merged %d shards: %zu frames%s\n", m["shards"].get<int>(), m["frames"].size(),
              m.contains("relmse") ? fmt::format(", relMSE {:.4g}", m["relmse"].get<double>()).c_str() : "");
}

}  // namespace mr
