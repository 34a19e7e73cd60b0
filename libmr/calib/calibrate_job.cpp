#include "calib/calibrate_job.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

#include <Eigen/Eigenvalues>

#include "calib/corners.h"
#include "calib/probe_file.h"
#include "core/error.h"
#include "core/image.h"
#include "core/math.h"
#include "core/parallel.h"

namespace mr {

namespace {

// Corners in every photograph (in parallel); all photographs of one camera
// must have the same size.  An empty path is an instant this camera did not
// photograph.
std::vector<CornerDetection> DetectAll(const BoardSpec& board, const std::vector<std::string>& images, int* width,
                                       int* height, Report* r) {
  Report& report = *r;
  ScopedTimer t(&report, "corners");
  *width = *height = 0;
  for (const auto& f : images) {
    if (f.empty()) continue;
    int w = 0, h = 0;
    std::vector<std::string> channels;
    ReadImageHeader(f, &w, &h, &channels);
    if (*width == 0) {
      *width = w;
      *height = h;
    } else if (w != *width || h != *height) {
      ThrowErrorAt(FileLoc{f}, "is {}x{}; the first photograph is {}x{}", w, h, *width, *height);
    }
    report.AddInput(f);
  }
  std::vector<CornerDetection> detections(images.size());
  ParallelFor(0, static_cast<int64_t>(images.size()), [&](int64_t i) {
    const auto& f = images[static_cast<size_t>(i)];
    if (f.empty()) {
      detections[static_cast<size_t>(i)].reason = "not photographed by this camera";
      return;
    }
    detections[static_cast<size_t>(i)] = DetectCorners(ReadImage(f), board, f);
  });
  return detections;
}

// One camera's figures under `prefix` ("" or "cameras.NAME."): fit, views,
// and the projection uncertainty (worst-direction 1 sigma, px, at infinity)
// at the centre, the corners and on a 9 x 7 grid; the valid region is where
// it is below 1 px.
void ReportCamera(const std::string& prefix, const std::string& name, const CalibrationResult& r, Report* rep) {
  Report& report = *rep;
  Json views = Json::array();
  for (const auto& v : r.views) {
    Json j = {{"image", v.detection.image},
              {"found", v.detection.found},
              {"used", v.used},
              {"corners", v.detection.pixels.size()},
              {"detector", v.detection.detector}};
    if (!v.used) j["rejected"] = v.reason;
    if (v.used) {
      j["rms_px"] = v.rms_px;
      j["outliers"] = v.outliers;
    }
    if (v.detection.sharpness_px > 0) j["sharpness_px"] = v.detection.sharpness_px;
    if (!v.detection.order.empty()) j["corner_order"] = v.detection.order;
    views.push_back(j);
    if (!v.used && !v.detection.image.empty())
      report.Warn(fmt::format("{}: not used: {}", v.detection.image, v.reason));
  }
  report.SetMetric(prefix + "lensmodel", r.model.lensmodel());
  report.SetMetric(prefix + "intrinsics", r.model.intrinsics());
  report.SetMetric(prefix + "rms_px", r.rms_px);
  report.SetMetric(prefix + "worst_px", r.worst_px);
  report.SetMetric(prefix + "corners", r.corners);
  report.SetMetric(prefix + "outliers", r.outliers);
  report.SetMetric(prefix + "noise_px", r.noise_px);
  ScopedTimer t(&report, "uncertainty");
  auto sigma = [&](double x, double y) { return r.uncertainty->StdevPx(Eigen::Vector2d(x, y), r.model); };
  const double W = r.model.width() - 1, H = r.model.height() - 1;
  Json grid = Json::array();
  int valid = 0, total = 0;
  for (int j = 0; j < 7; ++j)
    for (int i = 0; i < 9; ++i) {
      const double x = W * i / 8, y = H * j / 6, s = sigma(x, y);
      grid.push_back({{"x", x}, {"y", y}, {"sigma_px", std::isfinite(s) ? Json(s) : Json(nullptr)}});
      valid += std::isfinite(s) && s < 1.0;
      ++total;
    }
  report.SetMetric(prefix + "uncertainty_px", {{"centre", sigma(0.5 * W, 0.5 * H)},
                                               {"corners", {sigma(0, 0), sigma(W, 0), sigma(0, H), sigma(W, H)}},
                                               {"grid", grid},
                                               {"valid_fraction_below_1px", static_cast<double>(valid) / total}});
  report.SetMetric(prefix + "views", views);
  int used = 0;
  for (const auto& v : r.views) used += v.used;
  spdlog::info("{}: {} of {} photographs used; RMS {:.3f} px, worst {:.3f} px, {} outliers", name, used, r.views.size(),
               r.rms_px, r.worst_px, r.outliers);
  spdlog::info(
      "{}: projection uncertainty (1 sigma): {:.3f} px at the centre, {:.3f} px at the top-left corner; "
      "below 1 px over {:.0f}% of a 9x7 grid",
      name, sigma(0.5 * W, 0.5 * H), sigma(0, 0), 100.0 * valid / total);
}

// NAME=DIR/PREFIX*SUFFIX: the photographs that match, keyed by what the '*'
// matched (the instant).
std::map<std::string, std::string> Glob(const std::string& pattern, const std::string& name) {
  const fs::path p(pattern);
  const std::string file = p.filename().string();
  const size_t star = file.find('*');
  if (star == std::string::npos || file.find('*', star + 1) != std::string::npos ||
      p.parent_path().string().find('*') != std::string::npos)
    throw UsageError(
        fmt::format("--camera {}={}: the pattern needs exactly one '*', in the file name (quote it "
                    "so that the shell leaves it alone)",
                    name, pattern));
  const std::string prefix = file.substr(0, star), suffix = file.substr(star + 1);
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  if (!fs::is_directory(dir)) ThrowErrorAt(FileLoc{dir.string()}, "no such directory");
  std::map<std::string, std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string f = e.path().filename().string();
    if (f.size() < prefix.size() + suffix.size() || f.compare(0, prefix.size(), prefix) != 0 ||
        f.compare(f.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    out[f.substr(prefix.size(), f.size() - prefix.size() - suffix.size())] = e.path().string();
  }
  if (out.empty()) ThrowErrorAt(FileLoc{pattern}, "matches no file");
  return out;
}

// Instants in natural order: numbers by value, then text.
bool InstantLess(const std::string& a, const std::string& b) {
  const bool na = !a.empty() && std::all_of(a.begin(), a.end(), ::isdigit);
  const bool nb = !b.empty() && std::all_of(b.begin(), b.end(), ::isdigit);
  if (na && nb && a.size() != b.size()) return a.size() < b.size();
  return a < b;
}

// mr-calibrate sphere: probe.json (docs/formats.md).
}  // namespace

void CameraJob::Check() const {
  if (images.empty()) throw UsageError("give the photographs of the board");
  if (out.empty()) throw UsageError("--out is required");
  options.Check();
}

void RigJob::Check() const {
  if (cameras.size() < 2) throw UsageError("a rig needs --camera at least twice");
  std::vector<std::string> names;
  for (const auto& c : cameras) {
    const size_t eq = c.find('=');
    if (eq == std::string::npos || eq == 0)
      throw UsageError(fmt::format("--camera {}: expected NAME='DIR/PREFIX*SUFFIX'", c));
    names.push_back(c.substr(0, eq));
    if (std::count(names.begin(), names.end(), names.back()) > 1)
      throw UsageError(fmt::format("--camera {}: the name is given twice", names.back()));
  }
  options.Check();
}

void SphereJob::Check() const {
  if (!world_board.empty() && board.empty()) throw UsageError("--world-board needs --board");
  if (!circle.empty() && circle.size() != 3) throw UsageError("--circle: give x,y,r");
  if (images.empty()) throw UsageError("give the photographs of the sphere");
  options.Check();
}

void RunSphereCalibration(const SphereJob& job, Report* rep) {
  Report& report = *rep;
  const std::string& camera_file = job.camera;
  SphereOptions so = job.options;
  const std::vector<double>& circle = job.circle;
  const std::string& world_board = job.world_board;
  const std::string& board_file = job.board;
  const std::vector<std::string>& images = job.images;
  const std::string& out = job.out;
  job.Check();
  const CameraModel camera = CameraModel::Read(camera_file);
  report.AddInput(camera_file);
  if (circle.size() == 3) so.circle = Eigen::Vector3d(circle[0], circle[1], circle[2]);
  std::vector<SphereFit> fits;
  Json per_image = Json::array();
  {
    ScopedTimer t(&report, "fit");
    for (const auto& f : images) {
      report.AddInput(f);
      const SphereFit fit = FitMirrorSphere(ReadImage(f), camera, so, f);
      const Eigen::Vector3d s = fit.covariance.diagonal().cwiseSqrt();
      per_image.push_back({{"image", f},
                           {"centre_cam_m", {fit.centre.x(), fit.centre.y(), fit.centre.z()}},
                           {"sigma_m", {s.x(), s.y(), s.z()}},
                           {"half_angle_deg", fit.half_angle / kDegToRad},
                           {"edge_points", fit.edge_points},
                           {"inliers", fit.inliers},
                           {"rms_px", fit.rms_px},
                           {"correlation", fit.correlation},
                           {"visible_fraction", fit.visible_fraction},
                           {"first_circle_px", {fit.first_circle.x(), fit.first_circle.y(), fit.first_circle.z()}},
                           {"silhouette", fit.silhouette}});
      if (fit.mask_mismatch >= 0) per_image.back()["mask_mismatch"] = fit.mask_mismatch;
      spdlog::info(
          "{}: centre ({:.4f}, {:.4f}, {:.4f}) m, 1 sigma ({:.2g}, {:.2g}, {:.2g}) m; {} of {} edge points, "
          "RMS {:.3f} px, {:.0f}% of the outline visible; silhouette from {}",
          f, fit.centre.x(), fit.centre.y(), fit.centre.z(), s.x(), s.y(), s.z(), fit.inliers, fit.edge_points,
          fit.rms_px, 100 * fit.visible_fraction, fit.silhouette);
      if (fit.visible_fraction < 0.9)
        report.Warn(
            fmt::format("{}: only {:.0f}% of the sphere's outline is in the image; the distance to it is less "
                        "certain than its covariance says (docs/guides/calibration.md)",
                        f, 100 * fit.visible_fraction));
      fits.push_back(fit);
    }
  }
  double chi2 = 0;
  const SphereFit all = CombineSphereFits(fits, &chi2);
  // The world: the camera's rig reference (its extrinsics), or a board.
  Eigen::Matrix3d world_from_cam = camera.cam_from_ref().rotation.conjugate().toRotationMatrix();
  Eigen::Vector3d cam_in_world = camera.cam_from_ref().Inverse().translation;
  std::string world = camera.cam_from_ref().rotation.angularDistance(Eigen::Quaterniond::Identity()) == 0 &&
                              camera.cam_from_ref().translation.isZero()
                          ? "the camera's own frame (it is its rig's reference)"
                          : "the rig's reference frame (the camera's extrinsics)";
  if (!world_board.empty()) {
    const BoardSpec board = ReadBoard(board_file);
    report.AddInput(world_board);
    const Rigid3 world_from_cam_board =
        WorldFromCamByFlatBoard(BoardPose(board, camera, DetectCorners(ReadImage(world_board), board, world_board)));
    world_from_cam = world_from_cam_board.rotation.toRotationMatrix();
    cam_in_world = world_from_cam_board.translation;
    world = "the board in " + world_board;
  }
  const Eigen::Vector3d s = all.covariance.diagonal().cwiseSqrt();
  ProbeFile probe;
  probe.camera = camera_file;
  probe.radius_m = so.radius_m;
  probe.centre_cam = all.centre;
  probe.centre_covariance = all.covariance;
  probe.world_from_cam = Eigen::Quaterniond(world_from_cam);
  probe.camera_in_world = cam_in_world;
  probe.world_source = world;
  probe.photographs = per_image;
  probe.consistency_chi2 = chi2;
  probe.provenance = job.provenance;
  WriteProbeFile(out, probe);
  report.AddOutput(out);
  report.SetMetric("centre_cam_m", {all.centre.x(), all.centre.y(), all.centre.z()});
  report.SetMetric("sigma_m", {s.x(), s.y(), s.z()});
  report.SetMetric("consistency_chi2", chi2);
  report.SetMetric("photographs", per_image);
  spdlog::info(
      "{}: sphere centre ({:.4f}, {:.4f}, {:.4f}) m in the camera, 1 sigma ({:.2g}, {:.2g}, {:.2g}) m; "
      "world: {}",
      out, all.centre.x(), all.centre.y(), all.centre.z(), s.x(), s.y(), s.z(), world);
}

void RunCameraCalibration(const CameraJob& job, Report* rep) {
  job.Check();
  Report& report = *rep;
  const BoardSpec board = ReadBoard(job.board);
  report.AddInput(job.board);
  int width = 0, height = 0;
  const auto detections = DetectAll(board, job.images, &width, &height, rep);
  CalibrationResult r;
  {
    ScopedTimer t(&report, "solve");
    r = CalibrateCamera(board, detections, width, height, job.options);
  }
  report.SetMetric("stages", r.stages);
  ReportCamera("", job.out, r, rep);
  r.model.Write(job.out, fmt::format("calibrated by mr-calibrate ({}): RMS {:.3f} px over {} corners, {} outliers",
                                     job.provenance, r.rms_px, r.corners, r.outliers));
  report.AddOutput(job.out);
}

void RunRigCalibration(const RigJob& job, Report* rep) {
  job.Check();
  Report& report = *rep;
  const BoardSpec board = ReadBoard(job.board);
  report.AddInput(job.board);
  const std::vector<std::string>& cameras = job.cameras;
  const std::string& out_dir = job.out_dir;
  const std::string& provenance = job.provenance;
  const CalibrationOptions& o = job.options;
  std::vector<std::string> names;
  std::vector<std::map<std::string, std::string>> files;
  for (const auto& c : cameras) {
    const size_t eq = c.find('=');
    names.push_back(c.substr(0, eq));
    files.push_back(Glob(c.substr(eq + 1), names.back()));
  }
  std::vector<std::string> instants;
  for (const auto& f : files)
    for (const auto& [k, v] : f) instants.push_back(k);
  std::sort(instants.begin(), instants.end(), InstantLess);
  instants.erase(std::unique(instants.begin(), instants.end()), instants.end());
  std::vector<std::vector<CornerDetection>> detections;
  std::vector<Eigen::Vector2i> sizes;
  for (size_t c = 0; c < names.size(); ++c) {
    std::vector<std::string> list;
    for (const auto& k : instants) list.push_back(files[c].count(k) ? files[c].at(k) : std::string());
    int w = 0, h = 0;
    detections.push_back(DetectAll(board, list, &w, &h, rep));
    sizes.emplace_back(w, h);
  }
  RigCalibrationResult r;
  {
    ScopedTimer t(&report, "solve");
    r = CalibrateRig(board, detections, sizes, o);
  }
  report.SetMetric("stages", r.stages);
  report.SetMetric("instants", r.instants);
  report.SetMetric("shared_instants", r.shared_instants);
  report.SetMetric("rms_px", r.rms_px);
  report.SetMetric("noise_px", r.noise_px);
  spdlog::info("{} instants, {} seen by two or more cameras; joint RMS {:.3f} px", r.instants, r.shared_instants,
               r.rms_px);
  fs::create_directories(out_dir);
  std::vector<std::string> outputs;
  for (size_t c = 0; c < names.size(); ++c) {
    const CalibrationResult& cr = r.cameras[c];
    const std::string prefix = "cameras." + names[c] + ".";
    ReportCamera(prefix, names[c], cr, rep);
    double rt[6];
    cr.model.cam_from_ref().ToRt(rt);
    const Eigen::Matrix<double, 6, 6>& cov = r.extrinsics_covariance[c];
    // Worst-direction 1 sigma of the rotation (degrees) and of the position (mm).
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> er(cov.topLeftCorner<3, 3>()),
        et(cov.bottomRightCorner<3, 3>());
    const double sr = std::sqrt(std::max(0.0, er.eigenvalues().maxCoeff())) / kDegToRad;
    const double st = 1e3 * std::sqrt(std::max(0.0, et.eigenvalues().maxCoeff()));
    const Eigen::Vector3d centre = cr.model.cam_from_ref().Inverse().translation;
    Json ex = {{"rt_cam_fromref", std::vector<double>(rt, rt + 6)},
               {"centre_in_ref_m", {centre.x(), centre.y(), centre.z()}},
               {"rotation_deg", Eigen::AngleAxisd(cr.model.cam_from_ref().rotation).angle() / kDegToRad},
               {"sigma_rotation_deg", sr},
               {"sigma_translation_mm", st}};
    Json covj = Json::array();
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) covj.push_back(cov(i, j));
    ex["covariance_rt"] = covj;
    report.SetMetric(prefix + "extrinsics", ex);
    if (c > 0)
      spdlog::info("{}: {:.1f} mm from {}, turned {:.3f} deg; 1 sigma {:.3f} deg, {:.3f} mm", names[c],
                   1e3 * centre.norm(), names[0], ex["rotation_deg"].get<double>(), sr, st);
    outputs.push_back((fs::path(out_dir) / (names[c] + ".cameramodel")).string());
  }
  // Every camera's model is written only once all are solved.
  for (size_t c = 0; c < names.size(); ++c) {
    const CalibrationResult& cr = r.cameras[c];
    cr.model.Write(outputs[c], fmt::format("calibrated by mr-calibrate ({}): camera {} of a {}-camera rig, "
                                           "reference {}; RMS {:.3f} px over {} corners",
                                           provenance, names[c], names.size(), names[0], cr.rms_px, cr.corners));
    report.AddOutput(outputs[c]);
  }
}

}  // namespace mr
