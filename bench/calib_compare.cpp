// mr-calibrate against OpenCV's fisheye calibration on the same detected
// corners, on the real photographs of ../shared/data (docs/benchmarks.md).
//   bench_calib_compare
#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "calib/calibrate.h"
#include "calib/corners.h"
#include "core/image.h"
#include "core/parallel.h"

namespace {

void Run(const std::string& name, const std::string& dir, const std::string& prefix, const std::string& board_file,
         const std::vector<std::string>& models) {
  const mr::BoardSpec b = mr::ReadBoard(board_file);
  std::vector<mr::fs::path> files;
  for (const auto& e : mr::fs::directory_iterator(dir))
    if (e.path().filename().string().rfind(prefix, 0) == 0) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::vector<mr::CornerDetection> det(files.size());
  int w = 0, h = 0;
  {
    std::vector<std::string> ch;
    mr::ReadImageHeader(files[0], &w, &h, &ch);
  }
  mr::ParallelFor(0, static_cast<int64_t>(files.size()), [&](int64_t i) {
    det[static_cast<size_t>(i)] = mr::DetectCorners(mr::ReadImage(files[static_cast<size_t>(i)]), b,
                                                    files[static_cast<size_t>(i)].filename().string());
  });
  int found = 0;
  for (const auto& d : det) found += d.found;
  std::printf(
      "\n%s: %zu photographs, board found in %d\n\n| solver | model | fx | fy | cx | cy | RMS px | worst px | outliers "
      "| time s | sigma centre px | sigma corner px | grid < 1 px "
      "|\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
      name.c_str(), files.size(), found);
  for (const auto& m : models) {
    mr::CalibrationOptions o;
    o.lensmodel = m;
    const auto t0 = std::chrono::steady_clock::now();
    const mr::CalibrationResult r = mr::CalibrateCamera(b, det, w, h, o);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto& k = r.model.intrinsics();
    int valid = 0;
    for (int j = 0; j < 7; ++j)
      for (int i = 0; i < 9; ++i) {
        const double sg = r.uncertainty->StdevPx(Eigen::Vector2d((w - 1) * i / 8.0, (h - 1) * j / 6.0), r.model);
        valid += std::isfinite(sg) && sg < 1.0;
      }
    std::printf("| mr (mrcal) | %s | %.2f | %.2f | %.2f | %.2f | %.3f | %.3f | %d | %.2f | %.3f | %.2f | %d%% |\n",
                m.c_str(), k[0], k[1], k[2], k[3], r.rms_px, r.worst_px, r.outliers, s,
                r.uncertainty->StdevPx(Eigen::Vector2d(0.5 * (w - 1), 0.5 * (h - 1)), r.model),
                r.uncertainty->StdevPx(Eigen::Vector2d(0, 0), r.model), 100 * valid / 63);
  }
  // OpenCV's fisheye model (Kannala-Brandt k1..k4) on the same corners.
  std::vector<std::vector<cv::Point3d>> obj;
  std::vector<std::vector<cv::Point2d>> img;
  const auto op = b.ObjectPoints();
  for (const auto& d : det) {
    if (!d.found) continue;
    std::vector<cv::Point3d> o3;
    std::vector<cv::Point2d> i2;
    for (size_t i = 0; i < d.pixels.size(); ++i) {
      const auto& P = op[static_cast<size_t>(d.ids[i])];
      o3.emplace_back(P.x(), P.y(), P.z());
      i2.emplace_back(d.pixels[i].x(), d.pixels[i].y());
    }
    obj.push_back(o3);
    img.push_back(i2);
  }
  cv::Matx33d K;
  cv::Vec4d D;
  std::vector<cv::Vec3d> rv, tv;
  const auto t0 = std::chrono::steady_clock::now();
  const double rms = cv::fisheye::calibrate(
      obj, img, cv::Size(w, h), K, D, rv, tv, cv::fisheye::CALIB_RECOMPUTE_EXTRINSIC | cv::fisheye::CALIB_FIX_SKEW,
      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-9));
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // OpenCV's figure is per coordinate; report the residual length as mr does.
  double sum2 = 0, worst = 0;
  size_t n = 0;
  for (size_t v = 0; v < obj.size(); ++v) {
    std::vector<cv::Point2d> proj;
    cv::fisheye::projectPoints(obj[v], proj, rv[v], tv[v], K, D);
    for (size_t i = 0; i < proj.size(); ++i) {
      const double e2 =
          (proj[i].x - img[v][i].x) * (proj[i].x - img[v][i].x) + (proj[i].y - img[v][i].y) * (proj[i].y - img[v][i].y);
      sum2 += e2;
      worst = std::max(worst, std::sqrt(e2));
      ++n;
    }
  }
  std::printf(
      "| OpenCV cv::fisheye | Kannala-Brandt k1..k4 | %.2f | %.2f | %.2f | %.2f | %.3f | %.3f | (none) | %.2f | | | "
      "|\n",
      K(0, 0), K(1, 1), K(0, 2), K(1, 2), std::sqrt(sum2 / static_cast<double>(n)), worst, s);
  (void)rms;
}

}  // namespace

int main() {
  const std::string data = MR_SHARED_DATA, boards = std::string(MR_SOURCE_DIR) + "/calib/boards/";
  // The lens-model complexity table: the same corners, models from 4 to hundreds of parameters.
  Run("fisheye-mono-ros", data + "/fisheye-mono-ros/calibrationdata", "left-", boards + "chessboard-8x6.json",
      {"LENSMODEL_OPENCV4", "LENSMODEL_OPENCV5", "LENSMODEL_OPENCV8", "LENSMODEL_OPENCV12",
       "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=5_fov_x_deg=200",
       "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=12_Ny=8_fov_x_deg=200",
       "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=10_fov_x_deg=200",
       "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=24_Ny=16_fov_x_deg=200"});
  Run("fisheye-stereo, left camera", data + "/fisheye-stereo/imgs", "left", boards + "chessboard-9x6-24.23mm.json",
      {"LENSMODEL_OPENCV8", "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=10_fov_x_deg=200"});
  return 0;
}
