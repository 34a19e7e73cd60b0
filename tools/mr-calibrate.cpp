// mr-calibrate: camera calibration with mrcal.
#include <spdlog/spdlog.h>

#include <chrono>

#include "calib/calibrate.h"
#include "calib/corners.h"
#include "core/error.h"
#include "core/image.h"
#include "core/parallel.h"
#include "core/report.h"
#include "tool/cli.h"

int main(int argc, char** argv) {
  CLI::App app;
  std::string board_file, out;
  std::vector<std::string> images;
  mr::CalibrationOptions o;
  mr::ConfigureApp(
      app, "mr-calibrate",
      "Calibrates cameras from photographs of a calibration board (calib/boards/*.json), with\n"
      "libmrcal's optimiser. Subcommands: camera (intrinsics of one camera). The rig and the\n"
      "mirror sphere are to come (docs/tools.md).",
      "  mr-calibrate camera --board calib/boards/chessboard-8x6.json --lensmodel LENSMODEL_OPENCV8 \\\n"
      "      --out light.cameramodel photos/*.png");
  app.require_subcommand(1);
  CLI::App* cam = app.add_subcommand("camera", "Intrinsics of one camera from photographs of a board");
  cam->fallthrough();  // --report, --threads ... after the subcommand
  cam->add_option("--board", board_file, "Board definition (calib/boards/*.json)")->required()->check(CLI::ExistingFile);
  cam->add_option("--lensmodel", o.lensmodel, "Any mrcal lens model with an intrinsics core")->default_val("LENSMODEL_OPENCV8");
  cam->add_option("--focal", o.focal_px, "Seed focal length in pixels (default: half the image width)");
  cam->add_option("--out", out, "The .cameramodel to write")->required();
  cam->add_option("images", images, "Photographs of the board")->required()->check(CLI::ExistingFile);
  return mr::RunTool("mr-calibrate", app, argc, argv, [&] {
    mr::Report& report = mr::ToolReport();
    const mr::BoardSpec board = mr::ReadBoard(board_file);
    report.AddInput(board_file);
    std::vector<mr::CornerDetection> detections(images.size());
    int width = 0, height = 0;
    {
      mr::ScopedTimer t(&report, "corners");
      // Sizes first: every photograph must have the same.
      for (const auto& f : images) {
        int w = 0, h = 0;
        std::vector<std::string> channels;
        mr::ReadImageHeader(f, &w, &h, &channels);
        if (width == 0) {
          width = w;
          height = h;
        } else if (w != width || h != height) {
          mr::ThrowErrorAt(mr::FileLoc{f}, "is {}x{}; the first photograph is {}x{}", w, h, width, height);
        }
        report.AddInput(f);
      }
      mr::ParallelFor(0, static_cast<int64_t>(images.size()), [&](int64_t i) {
        const auto& f = images[static_cast<size_t>(i)];
        detections[static_cast<size_t>(i)] = mr::DetectCorners(mr::ReadImage(f), board, f);
      });
    }
    mr::CalibrationResult r;
    {
      mr::ScopedTimer t(&report, "solve");
      r = mr::CalibrateCamera(board, detections, width, height, o);
    }
    r.model.Write(out, fmt::format("calibrated by mr-calibrate ({}): RMS {:.3f} px over {} corners, {} outliers",
                                   mr::JoinCommandLine(argc, argv), r.rms_px, r.corners, r.outliers));
    report.AddOutput(out);
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
      if (!v.used) report.Warn(fmt::format("{}: not used: {}", v.detection.image, v.reason));
    }
    report.SetMetric("lensmodel", o.lensmodel);
    report.SetMetric("intrinsics", r.model.intrinsics());
    report.SetMetric("rms_px", r.rms_px);
    report.SetMetric("worst_px", r.worst_px);
    report.SetMetric("corners", r.corners);
    report.SetMetric("outliers", r.outliers);
    report.SetMetric("stages", r.stages);
    report.SetMetric("noise_px", r.noise_px);
    // Projection uncertainty (worst-direction 1-sigma, px, at infinity) at
    // the centre, the corners and on a 9 x 7 grid; the valid region is where
    // it is below 1 px.
    {
      mr::ScopedTimer t(&report, "uncertainty");
      auto sigma = [&](double x, double y) { return r.uncertainty->StdevPx(Eigen::Vector2d(x, y), r.model); };
      const double W = width - 1, H = height - 1;
      nlohmann::json grid = nlohmann::json::array();
      int valid = 0, total = 0;
      for (int j = 0; j < 7; ++j)
        for (int i = 0; i < 9; ++i) {
          const double x = W * i / 8, y = H * j / 6, s = sigma(x, y);
          grid.push_back({{"x", x}, {"y", y}, {"sigma_px", std::isfinite(s) ? nlohmann::json(s) : nlohmann::json(nullptr)}});
          valid += std::isfinite(s) && s < 1.0;
          ++total;
        }
      report.SetMetric("uncertainty_px", {{"centre", sigma(0.5 * W, 0.5 * H)},
                                          {"corners", {sigma(0, 0), sigma(W, 0), sigma(0, H), sigma(W, H)}},
                                          {"grid", grid},
                                          {"valid_fraction_below_1px", static_cast<double>(valid) / total}});
      spdlog::info("projection uncertainty (1 sigma): {:.3f} px at the centre, {:.3f} px at the top-left corner; "
                   "below 1 px over {:.0f}% of a 9x7 grid",
                   sigma(0.5 * W, 0.5 * H), sigma(0, 0), 100.0 * valid / total);
    }
    report.SetMetric("views", views);
    int used = 0;
    for (const auto& v : r.views) used += v.used;
    spdlog::info("{}: {} of {} photographs used; RMS {:.3f} px, worst {:.3f} px, {} outliers", out, used, r.views.size(),
                 r.rms_px, r.worst_px, r.outliers);
    return mr::kExitOk;
  });
}
