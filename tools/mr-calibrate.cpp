// mr-calibrate: camera, rig and mirror-sphere calibration with mrcal.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <map>

#include <Eigen/Eigenvalues>

#include "calib/calibrate.h"
#include "calib/corners.h"
#include "calib/sphere.h"
#include "core/file.h"
#include "core/json.h"
#include "core/error.h"
#include "core/image.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/report.h"
#include "tool/cli.h"

namespace {

// Corners in every photograph (in parallel); all photographs of one camera
// must have the same size.  An empty path is an instant this camera did not
// photograph.
std::vector<mr::CornerDetection> DetectAll(const mr::BoardSpec& board, const std::vector<std::string>& images,
                                           int* width, int* height) {
  mr::Report& report = mr::ToolReport();
  mr::ScopedTimer t(&report, "corners");
  *width = *height = 0;
  for (const auto& f : images) {
    if (f.empty()) continue;
    int w = 0, h = 0;
    std::vector<std::string> channels;
    mr::ReadImageHeader(f, &w, &h, &channels);
    if (*width == 0) {
      *width = w;
      *height = h;
    } else if (w != *width || h != *height) {
      mr::ThrowErrorAt(mr::FileLoc{f}, "is {}x{}; the first photograph is {}x{}", w, h, *width, *height);
    }
    report.AddInput(f);
  }
  std::vector<mr::CornerDetection> detections(images.size());
  mr::ParallelFor(0, static_cast<int64_t>(images.size()), [&](int64_t i) {
    const auto& f = images[static_cast<size_t>(i)];
    if (f.empty()) {
      detections[static_cast<size_t>(i)].reason = "not photographed by this camera";
      return;
    }
    detections[static_cast<size_t>(i)] = mr::DetectCorners(mr::ReadImage(f), board, f);
  });
  return detections;
}

// One camera's figures under `prefix` ("" or "cameras.NAME."): fit, views,
// and the projection uncertainty (worst-direction 1 sigma, px, at infinity)
// at the centre, the corners and on a 9 x 7 grid; the valid region is where
// it is below 1 px.
void ReportCamera(const std::string& prefix, const std::string& name, const mr::CalibrationResult& r) {
  mr::Report& report = mr::ToolReport();
  nlohmann::json views = nlohmann::json::array();
  for (const auto& v : r.views) {
    nlohmann::json j = {{"image", v.detection.image}, {"found", v.detection.found}, {"used", v.used},
                        {"corners", v.detection.pixels.size()}, {"detector", v.detection.detector}};
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
  mr::ScopedTimer t(&report, "uncertainty");
  auto sigma = [&](double x, double y) { return r.uncertainty->StdevPx(Eigen::Vector2d(x, y), r.model); };
  const double W = r.model.width() - 1, H = r.model.height() - 1;
  nlohmann::json grid = nlohmann::json::array();
  int valid = 0, total = 0;
  for (int j = 0; j < 7; ++j)
    for (int i = 0; i < 9; ++i) {
      const double x = W * i / 8, y = H * j / 6, s = sigma(x, y);
      grid.push_back({{"x", x}, {"y", y}, {"sigma_px", std::isfinite(s) ? nlohmann::json(s) : nlohmann::json(nullptr)}});
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
  spdlog::info("{}: {} of {} photographs used; RMS {:.3f} px, worst {:.3f} px, {} outliers", name, used,
               r.views.size(), r.rms_px, r.worst_px, r.outliers);
  spdlog::info("{}: projection uncertainty (1 sigma): {:.3f} px at the centre, {:.3f} px at the top-left corner; "
               "below 1 px over {:.0f}% of a 9x7 grid",
               name, sigma(0.5 * W, 0.5 * H), sigma(0, 0), 100.0 * valid / total);
}

// NAME=DIR/PREFIX*SUFFIX: the photographs that match, keyed by what the '*'
// matched (the instant).
std::map<std::string, std::string> Glob(const std::string& pattern, const std::string& name) {
  const mr::fs::path p(pattern);
  const std::string file = p.filename().string();
  const size_t star = file.find('*');
  if (star == std::string::npos || file.find('*', star + 1) != std::string::npos ||
      p.parent_path().string().find('*') != std::string::npos)
    throw mr::UsageError(fmt::format("--camera {}={}: the pattern needs exactly one '*', in the file name (quote it "
                                     "so that the shell leaves it alone)",
                                     name, pattern));
  const std::string prefix = file.substr(0, star), suffix = file.substr(star + 1);
  const mr::fs::path dir = p.parent_path().empty() ? mr::fs::path(".") : p.parent_path();
  if (!mr::fs::is_directory(dir)) mr::ThrowErrorAt(mr::FileLoc{dir.string()}, "no such directory");
  std::map<std::string, std::string> out;
  for (const auto& e : mr::fs::directory_iterator(dir)) {
    const std::string f = e.path().filename().string();
    if (f.size() < prefix.size() + suffix.size() || f.compare(0, prefix.size(), prefix) != 0 ||
        f.compare(f.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    out[f.substr(prefix.size(), f.size() - prefix.size() - suffix.size())] = e.path().string();
  }
  if (out.empty()) mr::ThrowErrorAt(mr::FileLoc{pattern}, "matches no file");
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
int CalibrateSphere(const std::string& camera_file, mr::SphereOptions so, const std::vector<double>& circle,
                    const std::string& world_board, const std::string& board_file, const std::vector<std::string>& images,
                    const std::string& out, int argc, char** argv) {
  mr::Report& report = mr::ToolReport();
  const mr::CameraModel camera = mr::CameraModel::Read(camera_file);
  report.AddInput(camera_file);
  if (circle.size() == 3) so.circle = Eigen::Vector3d(circle[0], circle[1], circle[2]);
  if (!world_board.empty() && board_file.empty()) throw mr::UsageError("--world-board needs --board");
  std::vector<mr::SphereFit> fits;
  nlohmann::json per_image = nlohmann::json::array();
  {
    mr::ScopedTimer t(&report, "fit");
    for (const auto& f : images) {
      report.AddInput(f);
      const mr::SphereFit fit = mr::FitMirrorSphere(mr::ReadImage(f), camera, so, f);
      const Eigen::Vector3d s = fit.covariance.diagonal().cwiseSqrt();
      per_image.push_back({{"image", f},
                           {"centre_cam_m", {fit.centre.x(), fit.centre.y(), fit.centre.z()}},
                           {"sigma_m", {s.x(), s.y(), s.z()}},
                           {"half_angle_deg", fit.half_angle / mr::kDegToRad},
                           {"edge_points", fit.edge_points},
                           {"inliers", fit.inliers},
                           {"rms_px", fit.rms_px},
                           {"correlation", fit.correlation},
                           {"visible_fraction", fit.visible_fraction},
                           {"first_circle_px", {fit.first_circle.x(), fit.first_circle.y(), fit.first_circle.z()}}});
      spdlog::info("{}: centre ({:.4f}, {:.4f}, {:.4f}) m, 1 sigma ({:.2g}, {:.2g}, {:.2g}) m; {} of {} edge points, "
                   "RMS {:.3f} px, {:.0f}% of the outline visible",
                   f, fit.centre.x(), fit.centre.y(), fit.centre.z(), s.x(), s.y(), s.z(), fit.inliers, fit.edge_points,
                   fit.rms_px, 100 * fit.visible_fraction);
      if (fit.visible_fraction < 0.9)
        report.Warn(fmt::format("{}: only {:.0f}% of the sphere's outline is in the image; the distance to it is less "
                                "certain than its covariance says (docs/guides/calibration.md)",
                                f, 100 * fit.visible_fraction));
      fits.push_back(fit);
    }
  }
  double chi2 = 0;
  const mr::SphereFit all = mr::CombineSphereFits(fits, &chi2);
  // The world: the camera's rig reference (its extrinsics), or a board.
  Eigen::Matrix3d world_from_cam = camera.cam_from_ref().rotation.conjugate().toRotationMatrix();
  Eigen::Vector3d cam_in_world = camera.cam_from_ref().Inverse().translation;
  std::string world = camera.cam_from_ref().rotation.angularDistance(Eigen::Quaterniond::Identity()) == 0 &&
                              camera.cam_from_ref().translation.isZero()
                          ? "the camera's own frame (it is its rig's reference)"
                          : "the rig's reference frame (the camera's extrinsics)";
  if (!world_board.empty()) {
    const mr::BoardSpec board = mr::ReadBoard(board_file);
    report.AddInput(world_board);
    const mr::Rigid3 world_from_cam_board = mr::WorldFromCamByFlatBoard(
        mr::BoardPose(board, camera, mr::DetectCorners(mr::ReadImage(world_board), board, world_board)));
    world_from_cam = world_from_cam_board.rotation.toRotationMatrix();
    cam_in_world = world_from_cam_board.translation;
    world = "the board in " + world_board;
  }
  const Eigen::Quaterniond q(world_from_cam);
  nlohmann::json cov = nlohmann::json::array();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) cov.push_back(all.covariance(i, j));
  const Eigen::Vector3d s = all.covariance.diagonal().cwiseSqrt();
  nlohmann::json probe = {
      {"format", "mr-probe"},
      {"version", 1},
      {"camera", mr::fs::relative(mr::fs::absolute(camera_file), mr::fs::absolute(out).parent_path()).generic_string()},
      {"radius_m", so.radius_m},
      {"centre_cam_m", {all.centre.x(), all.centre.y(), all.centre.z()}},
      {"centre_covariance_m2", cov},
      {"world_from_cam", {{"quaternion_wxyz", {q.w(), q.x(), q.y(), q.z()}},
                          {"camera_in_world_m", {cam_in_world.x(), cam_in_world.y(), cam_in_world.z()}},
                          {"source", world}}},
      {"photographs", per_image},
      {"consistency_chi2", chi2},
      {"provenance", mr::JoinCommandLine(argc, argv)}};
  mr::WriteTextFile(out, probe.dump(2) + "\n");
  report.AddOutput(out);
  report.SetMetric("centre_cam_m", {all.centre.x(), all.centre.y(), all.centre.z()});
  report.SetMetric("sigma_m", {s.x(), s.y(), s.z()});
  report.SetMetric("consistency_chi2", chi2);
  report.SetMetric("photographs", per_image);
  spdlog::info("{}: sphere centre ({:.4f}, {:.4f}, {:.4f}) m in the camera, 1 sigma ({:.2g}, {:.2g}, {:.2g}) m; "
               "world: {}",
               out, all.centre.x(), all.centre.y(), all.centre.z(), s.x(), s.y(), s.z(), world);
  return mr::kExitOk;
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app;
  std::string board_file, out, out_dir;
  std::vector<std::string> images, cameras;
  mr::CalibrationOptions o;
  mr::ConfigureApp(
      app, "mr-calibrate",
      "Calibrates cameras from photographs of a calibration board (calib/boards/*.json), with\n"
      "libmrcal's optimiser; the written .cameramodel files carry mrcal's optimisation inputs, so\n"
      "mrcal's own tools (mrcal-show-projection-uncertainty ...) accept them.\n"
      "Subcommands: camera (intrinsics of one camera), rig (two or more cameras photographing the\n"
      "board at the same instants: intrinsics and extrinsics jointly), sphere (a mirror sphere's\n"
      "centre from its silhouette under a calibrated camera, with its covariance: probe.json).",
      "  mr-calibrate camera --board calib/boards/chessboard-8x6.json --lensmodel LENSMODEL_OPENCV8 \\\n"
      "      --out light.cameramodel photos/*.png\n"
      "  mr-calibrate rig --board calib/boards/chessboard-9x6.json --lensmodel LENSMODEL_OPENCV8 \\\n"
      "      --camera light='rig/light-*.png' --camera scene='rig/scene-*.png' --out-dir rig/\n"
      "  mr-calibrate sphere --camera rig/light.cameramodel --radius 0.0254 --out probe.json probe-*.exr");
  app.require_subcommand(1);
  CLI::App* cam = app.add_subcommand("camera", "Intrinsics of one camera from photographs of a board");
  cam->fallthrough();  // --report, --threads ... after the subcommand
  cam->add_option("--board", board_file, "Board definition (calib/boards/*.json)")->required()->check(CLI::ExistingFile);
  cam->add_option("--lensmodel", o.lensmodel, "Any mrcal lens model with an intrinsics core")->default_val("LENSMODEL_OPENCV8");
  cam->add_option("--focal", o.focal_px, "Seed focal length in pixels (default: half the image width)");
  cam->add_option("--out", out, "The .cameramodel to write")->required();
  cam->add_option("images", images, "Photographs of the board")->required()->check(CLI::ExistingFile);
  CLI::App* rig = app.add_subcommand(
      "rig", "Two or more cameras photographing the board at the same instants: intrinsics and extrinsics, jointly");
  rig->fallthrough();
  rig->add_option("--board", board_file, "Board definition (calib/boards/*.json)")->required()->check(CLI::ExistingFile);
  rig->add_option("--lensmodel", o.lensmodel, "One mrcal lens model for every camera (mrcal's restriction)")
      ->default_val("LENSMODEL_OPENCV8");
  rig->add_option("--focal", o.focal_px, "Seed focal length in pixels (default: half the image width)");
  rig->add_option("--camera", cameras,
                  "NAME='DIR/PREFIX*SUFFIX', once per camera, the first being the reference; photographs are "
                  "paired across cameras by what the '*' matches")
      ->required();
  rig->add_option("--out-dir", out_dir, "Where NAME.cameramodel is written for each camera")->required();
  CLI::App* sph = app.add_subcommand(
      "sphere", "A mirror sphere's centre, from its silhouette in photographs by a calibrated camera");
  sph->fallthrough();
  std::string camera_file, world_board;
  std::vector<double> circle;
  mr::SphereOptions so;
  sph->add_option("--camera", camera_file, "The camera's .cameramodel (its extrinsics place it in the rig)")
      ->required()
      ->check(CLI::ExistingFile);
  sph->add_option("--radius", so.radius_m, "The sphere's radius, metres (measured with calipers)")
      ->required()
      ->check(CLI::PositiveNumber);
  sph->add_option("--circle", circle, "A first circle x,y,r px instead of the Hough transform")->delimiter(',')->expected(3);
  sph->add_option("--min-visible", so.min_visible, "Refuse when less of the silhouette is in the image")->default_val(0.5);
  sph->add_option("--world-board", world_board,
                  "A photograph by this camera of the board lying flat, printed side up: it defines the world "
                  "(origin at its first inner corner, +x along its rows, +y up, +z along its columns); needs --board")
      ->check(CLI::ExistingFile);
  sph->add_option("--board", board_file, "Board definition, for --world-board")->check(CLI::ExistingFile);
  sph->add_option("--out", out, "probe.json to write")->required();
  sph->add_option("images", images, "Photographs of the sphere (camera and sphere fixed)")->required()->check(CLI::ExistingFile);
  return mr::RunTool("mr-calibrate", app, argc, argv, [&] {
    mr::Report& report = mr::ToolReport();
    if (sph->parsed()) return CalibrateSphere(camera_file, so, circle, world_board, board_file, images, out, argc, argv);
    const mr::BoardSpec board = mr::ReadBoard(board_file);
    report.AddInput(board_file);
    const std::string provenance = mr::JoinCommandLine(argc, argv);
    if (cam->parsed()) {
      int width = 0, height = 0;
      const auto detections = DetectAll(board, images, &width, &height);
      mr::CalibrationResult r;
      {
        mr::ScopedTimer t(&report, "solve");
        r = mr::CalibrateCamera(board, detections, width, height, o);
      }
      report.SetMetric("stages", r.stages);
      ReportCamera("", out, r);
      r.model.Write(out, fmt::format("calibrated by mr-calibrate ({}): RMS {:.3f} px over {} corners, {} outliers",
                                     provenance, r.rms_px, r.corners, r.outliers));
      report.AddOutput(out);
      return mr::kExitOk;
    }
    // rig
    if (cameras.size() < 2) throw mr::UsageError("a rig needs --camera at least twice");
    std::vector<std::string> names;
    std::vector<std::map<std::string, std::string>> files;
    for (const auto& c : cameras) {
      const size_t eq = c.find('=');
      if (eq == std::string::npos || eq == 0)
        throw mr::UsageError(fmt::format("--camera {}: expected NAME='DIR/PREFIX*SUFFIX'", c));
      names.push_back(c.substr(0, eq));
      if (std::count(names.begin(), names.end(), names.back()) > 1)
        throw mr::UsageError(fmt::format("--camera {}: the name is given twice", names.back()));
      files.push_back(Glob(c.substr(eq + 1), names.back()));
    }
    std::vector<std::string> instants;
    for (const auto& f : files)
      for (const auto& [k, v] : f) instants.push_back(k);
    std::sort(instants.begin(), instants.end(), InstantLess);
    instants.erase(std::unique(instants.begin(), instants.end()), instants.end());
    std::vector<std::vector<mr::CornerDetection>> detections;
    std::vector<Eigen::Vector2i> sizes;
    for (size_t c = 0; c < names.size(); ++c) {
      std::vector<std::string> list;
      for (const auto& k : instants) list.push_back(files[c].count(k) ? files[c].at(k) : std::string());
      int w = 0, h = 0;
      detections.push_back(DetectAll(board, list, &w, &h));
      sizes.emplace_back(w, h);
    }
    mr::RigCalibrationResult r;
    {
      mr::ScopedTimer t(&report, "solve");
      r = mr::CalibrateRig(board, detections, sizes, o);
    }
    report.SetMetric("stages", r.stages);
    report.SetMetric("instants", r.instants);
    report.SetMetric("shared_instants", r.shared_instants);
    report.SetMetric("rms_px", r.rms_px);
    report.SetMetric("noise_px", r.noise_px);
    spdlog::info("{} instants, {} seen by two or more cameras; joint RMS {:.3f} px", r.instants, r.shared_instants,
                 r.rms_px);
    mr::fs::create_directories(out_dir);
    std::vector<std::string> outputs;
    for (size_t c = 0; c < names.size(); ++c) {
      const mr::CalibrationResult& cr = r.cameras[c];
      const std::string prefix = "cameras." + names[c] + ".";
      ReportCamera(prefix, names[c], cr);
      double rt[6];
      cr.model.cam_from_ref().ToRt(rt);
      const Eigen::Matrix<double, 6, 6>& cov = r.extrinsics_covariance[c];
      // Worst-direction 1 sigma of the rotation (degrees) and of the position (mm).
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> er(cov.topLeftCorner<3, 3>()), et(cov.bottomRightCorner<3, 3>());
      const double sr = std::sqrt(std::max(0.0, er.eigenvalues().maxCoeff())) / mr::kDegToRad;
      const double st = 1e3 * std::sqrt(std::max(0.0, et.eigenvalues().maxCoeff()));
      const Eigen::Vector3d centre = cr.model.cam_from_ref().Inverse().translation;
      nlohmann::json ex = {{"rt_cam_fromref", std::vector<double>(rt, rt + 6)},
                           {"centre_in_ref_m", {centre.x(), centre.y(), centre.z()}},
                           {"rotation_deg", Eigen::AngleAxisd(cr.model.cam_from_ref().rotation).angle() / mr::kDegToRad},
                           {"sigma_rotation_deg", sr},
                           {"sigma_translation_mm", st}};
      nlohmann::json covj = nlohmann::json::array();
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) covj.push_back(cov(i, j));
      ex["covariance_rt"] = covj;
      report.SetMetric(prefix + "extrinsics", ex);
      if (c > 0)
        spdlog::info("{}: {:.1f} mm from {}, turned {:.3f} deg; 1 sigma {:.3f} deg, {:.3f} mm", names[c],
                     1e3 * centre.norm(), names[0], ex["rotation_deg"].get<double>(), sr, st);
      outputs.push_back((mr::fs::path(out_dir) / (names[c] + ".cameramodel")).string());
    }
    // Every camera's model is written only once all are solved.
    for (size_t c = 0; c < names.size(); ++c) {
      const mr::CalibrationResult& cr = r.cameras[c];
      cr.model.Write(outputs[c], fmt::format("calibrated by mr-calibrate ({}): camera {} of a {}-camera rig, "
                                             "reference {}; RMS {:.3f} px over {} corners",
                                             provenance, names[c], names.size(), names[0], cr.rms_px, cr.corners));
      report.AddOutput(outputs[c]);
    }
    return mr::kExitOk;
  });
}
