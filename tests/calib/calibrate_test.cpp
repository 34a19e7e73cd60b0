#include "calib/calibrate.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <sstream>

#include <Eigen/SVD>

#include "calib/corners.h"
#include "core/error.h"
#include "core/file.h"
#include "core/image.h"
#include "core/math.h"
#include "synth/board_view.h"
#include "synthetic_board.h"
#include "test_util.h"

namespace mr {
namespace {

// python3-mrcal, the oracle: reads the .cameramodel mr writes, as mrcal's
// tools do, and recomputes from its optimisation inputs the residuals at
// mr's solution, the unprojection and the projection uncertainty (mrcal's
// own implementation) at the given pixels.  mr's figures must agree.
::testing::AssertionResult OracleAgrees(const CalibrationResult& r, const std::vector<Eigen::Vector2d>& pixels) {
  test::TempDir dir;
  const fs::path model = dir.path() / "camera.cameramodel", out_file = dir.path() / "out.txt";
  r.model.Write(model);
  std::string cmd = fmt::format("/usr/bin/python3 {}/tests/calib/mrcal_oracle.py {} {:.9g}", MR_SOURCE_DIR,
                                model.string(), r.noise_px);
  for (const auto& q : pixels) cmd += fmt::format(" {} {}", q.x(), q.y());
  cmd += " > " + out_file.string();
  if (std::system(cmd.c_str()) != 0) return ::testing::AssertionFailure() << "failed: " << cmd;
  std::istringstream out(ReadTextFile(out_file));
  std::string word;
  double mrcal_rms = 0, mrcal_noise = 0;
  out >> word >> mrcal_rms >> word >> mrcal_noise;
  std::printf("residuals per coordinate: mr %.5f px, mrcal %.5f px; mrcal's default noise %.5f px\n", r.noise_px,
              mrcal_rms, mrcal_noise);
  if (std::abs(mrcal_rms - r.noise_px) > 1e-3 * r.noise_px)
    return ::testing::AssertionFailure() << "residual RMS: mr " << r.noise_px << ", mrcal " << mrcal_rms;
  for (const auto& q : pixels) {
    double x = 0, y = 0, s = 0, s_def = 0;
    Eigen::Vector3d v_mrcal, v_mr;
    out >> x >> y >> v_mrcal.x() >> v_mrcal.y() >> v_mrcal.z() >> s >> s_def;
    if (!out) return ::testing::AssertionFailure() << "short oracle output";
    if (!r.model.Unproject(q, &v_mr)) return ::testing::AssertionFailure() << "mr cannot unproject " << q.transpose();
    const double mine = r.uncertainty->StdevPx(q, r.model);
    const double angle = std::atan2(v_mr.normalized().cross(v_mrcal).norm(), v_mr.normalized().dot(v_mrcal));
    std::printf(
        "pixel (%.0f, %.0f): sigma mr %.4f px, mrcal %.4f px (%.4f with its default noise); rays %.2g rad apart\n",
        q.x(), q.y(), mine, s, s_def, angle);
    // Measured: equal to 4 digits; the rays to 1e-9 rad (both are libmrcal's).
    if (std::abs(mine - s) > 0.01 * s)
      return ::testing::AssertionFailure() << "sigma at " << q.transpose() << ": mr " << mine << ", mrcal " << s;
    if (angle > 1e-6) return ::testing::AssertionFailure() << "rays differ by " << angle << " rad";
  }
  return ::testing::AssertionSuccess();
}

// The recovered lens against the truth where the boards were seen (a lens
// is known only where it was observed): every detected corner's true
// direction, projected through the recovered lens.  A rotation of the
// camera frame trades against the principal point, so, as mrcal's
// projection diff does, the best rotation between the two frames is fitted
// first (Kabsch).  The reported uncertainty must cover the difference:
// within 3 sigma at every (7th) observed corner, mrcal's criterion.
struct TruthAgreement {
  double rms_px = 0, worst_px = 0, max_ratio = 0;
  int beyond_3_sigma = 0, checked = 0;
  Eigen::Matrix3d recovered_from_true = Eigen::Matrix3d::Identity();  // the fitted rotation
};

TruthAgreement CompareWithTruth(const CameraModel& truth, const CalibrationResult& r) {
  std::vector<Eigen::Vector3d> dt, de;
  std::vector<Eigen::Vector2d> pxs;
  for (const auto& v : r.views)
    for (const auto& px : v.detection.pixels) {
      Eigen::Vector3d a, e;
      if (!truth.Unproject(px, &a) || !r.model.Unproject(px, &e)) continue;
      dt.push_back(a.normalized());
      de.push_back(e.normalized());
      pxs.push_back(px);
    }
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < dt.size(); ++i) H += dt[i] * de[i].transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d Rfit = svd.matrixV() * svd.matrixU().transpose();
  if (Rfit.determinant() < 0) {
    Eigen::Matrix3d V = svd.matrixV();
    V.col(2) *= -1;
    Rfit = V * svd.matrixU().transpose();
  }
  TruthAgreement out;
  out.recovered_from_true = Rfit;
  double sum2 = 0;
  for (size_t i = 0; i < dt.size(); ++i) {
    Eigen::Vector2d q;
    if (!r.model.Project(Rfit * dt[i], &q)) {
      out.worst_px = INFINITY;
      continue;
    }
    const double d = (q - pxs[i]).norm();
    out.worst_px = std::max(out.worst_px, d);
    sum2 += d * d;
    if (i % 7 == 0) {
      const double sigma = r.uncertainty->StdevPx(pxs[i], r.model);
      out.max_ratio = std::max(out.max_ratio, d / sigma);
      out.beyond_3_sigma += !(d <= 3 * sigma);
      ++out.checked;
    }
  }
  out.rms_px = dt.empty() ? INFINITY : std::sqrt(sum2 / static_cast<double>(dt.size()));
  std::printf(
      "fitted rotation between the frames %.4f deg; projection difference over the observed region: RMS %.3f "
      "px, worst %.3f px; largest difference / sigma %.2f (%d of %d beyond 3 sigma)\n",
      Eigen::AngleAxisd(Rfit).angle() / kDegToRad, out.rms_px, out.worst_px, out.max_ratio, out.beyond_3_sigma,
      out.checked);
  return out;
}

// Photographs rendered through a known OPENCV8 lens with noise: the
// recovered lens projects like the true one to a fraction of a pixel over
// the region the boards covered, and the fit's RMS is at the noise level.
// Measured: 16 views give a projection difference of 0.013 px RMS, 0.09 px
// at worst; 10 views leave OPENCV8's 12 parameters loosely held (0.2 px RMS,
// 0.6 worst, with the same 0.045 px fit): the projection uncertainty that
// mr-calibrate is to report is what tells those apart.
TEST(Calibrate, RecoversAKnownLensFromSyntheticPhotographs) {
  const BoardSpec b = test::SyntheticBoard86();
  const CameraModel truth("LENSMODEL_OPENCV8", {330, 332, 241, 178, 0.08, -0.05, 0.001, -0.0015, 0, 0, 0, 0}, 480, 360);
  std::vector<CornerDetection> detections;
  BoardViewOptions vo;
  vo.supersample = 2;
  vo.noise_sigma = 0.01;
  int k = 0;
  const BoardViewRenderer renderer(truth, vo.supersample);
  for (const Rigid3& pose : CalibrationBoardPoses(b, 16)) {
    vo.seed = static_cast<uint64_t>(++k);
    detections.push_back(DetectCorners(renderer.Render(b, pose, vo), b, fmt::format("view{}", k)));
  }
  CalibrationOptions o;
  o.lensmodel = "LENSMODEL_OPENCV8";
  const CalibrationResult r = CalibrateCamera(b, detections, 480, 360, o);
  for (const auto& s : r.stages) std::printf("%s\n", s.c_str());
  int used = 0;
  for (const auto& v : r.views) used += v.used;
  EXPECT_GE(used, 15);
  EXPECT_LT(r.rms_px, 0.15);
  const TruthAgreement a = CompareWithTruth(truth, r);
  EXPECT_EQ(a.beyond_3_sigma, 0);
  EXPECT_GT(a.max_ratio, 0.1);  // and is not so large that it says nothing (measured 0.43;
                                // with 10 views the ratio reaches 3.6: the noise model leaves
                                // out the regularisation's bias, as mrcal's does)
  EXPECT_LT(a.rms_px, 0.1);
  EXPECT_LT(a.worst_px, 0.3);
  const double centre = r.uncertainty->StdevPx(Eigen::Vector2d(240, 180), r.model);
  const double corner = r.uncertainty->StdevPx(Eigen::Vector2d(5, 5), r.model);
  std::printf("sigma at the centre %.4f px, at the corner %.4f px\n", centre, corner);
  EXPECT_GT(corner, centre);  // the boards were seen near the centre

  // python3-mrcal, the oracle: the same residuals at mr's solution, and the
  // same projection uncertainty (mrcal's own implementation) at the centre,
  // the corner and two more pixels, with the same observation noise.
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "python3-mrcal is not installed";
  EXPECT_TRUE(OracleAgrees(r, {{240, 180}, {5, 5}, {120, 90}, {400, 300}}));
}

// Boards seen only near the image's centre: the lens is known there and
// guessed elsewhere, and the report says so: the uncertainty at the image's
// corners is many times that at the centre and above a pixel (measured
// 14-22 px, where the recovered lens is indeed 16-20 px off), and the share
// of the 9 x 7 grid below 1 px (the report's valid region) is at most two
// thirds (measured 37 of 63).  Measured and not asserted: inside the
// observed middle third the recovered lens differs from the truth by 0.36
// px RMS, up to 4.5 sigma: with so little of the field seen, OPENCV8's
// higher terms are held by mrcal's regularisation, whose bias the
// uncertainty (mrcal's definition) leaves out.
TEST(Calibrate, BoardsOnlyNearTheCentreLeaveTheEdgesUncertainAndSaySo) {
  const BoardSpec b = test::SyntheticBoard86();
  const CameraModel truth("LENSMODEL_OPENCV8", {330, 332, 241, 178, 0.08, -0.05, 0.001, -0.0015, 0, 0, 0, 0}, 480, 360);
  std::vector<CornerDetection> detections;
  BoardViewOptions vo;
  vo.supersample = 2;
  vo.noise_sigma = 0.01;
  int k = 0;
  const BoardViewRenderer renderer(truth, vo.supersample);
  for (Rigid3 pose : CalibrationBoardPoses(b, 12)) {
    // Twice as far and drawn towards the axis: the boards cover the middle third.
    pose.translation = 0.3 * pose.translation + Eigen::Vector3d(0, 0, 0.45);
    pose.translation.x() -= 0.5 * (pose.rotation * Eigen::Vector3d(0.105, 0, 0)).x();
    pose.translation.y() -= 0.5 * (pose.rotation * Eigen::Vector3d(0, 0.075, 0)).y();
    vo.seed = static_cast<uint64_t>(++k);
    detections.push_back(DetectCorners(renderer.Render(b, pose, vo), b, fmt::format("view{}", k)));
  }
  double lo_x = 1e9, hi_x = -1e9;
  for (const auto& d : detections)
    for (const auto& p : d.pixels) {
      lo_x = std::min(lo_x, p.x());
      hi_x = std::max(hi_x, p.x());
    }
  std::printf("corners seen between x = %.0f and %.0f of 480\n", lo_x, hi_x);
  const CalibrationResult r = CalibrateCamera(b, detections, 480, 360, CalibrationOptions());
  const TruthAgreement a = CompareWithTruth(truth, r);
  const double centre = r.uncertainty->StdevPx(Eigen::Vector2d(240, 180), r.model);
  int valid = 0;
  for (int j = 0; j < 7; ++j)
    for (int i = 0; i < 9; ++i) {
      const double sg = r.uncertainty->StdevPx(Eigen::Vector2d(479.0 * i / 8, 359.0 * j / 6), r.model);
      valid += std::isfinite(sg) && sg < 1;
    }
  for (const Eigen::Vector2d& q :
       {Eigen::Vector2d(0, 0), Eigen::Vector2d(479, 0), Eigen::Vector2d(0, 359), Eigen::Vector2d(479, 359)}) {
    const double sg = r.uncertainty->StdevPx(q, r.model);
    Eigen::Vector3d d;
    Eigen::Vector2d p;
    ASSERT_TRUE(truth.Unproject(q, &d));
    const bool ok = r.model.Project(a.recovered_from_true * d.normalized(), &p);
    std::printf("corner (%.0f, %.0f): sigma %.2f px (centre %.3f px); the recovered lens is %.2f px off there\n", q.x(),
                q.y(), sg, centre, ok ? (p - q).norm() : NAN);
    EXPECT_FALSE(sg < 1.0) << "the corner is reported known to " << sg << " px";
    EXPECT_FALSE(sg < 5 * centre);
  }
  std::printf("grid below 1 px: %d of 63\n", valid);
  EXPECT_LT(centre, 0.2);
  EXPECT_LE(valid, 42);
}

// A 190-degree fish-eye (a splined stereographic lens, as mrcal models
// such lenses) calibrated from boards spread over its whole field, past 90
// degrees from the axis (corners to 103 degrees; the board is found in 15
// of the 17 photographs): the recovered lens projects
// like the truth where the boards were, within 3 sigma of its reported
// uncertainty.
TEST(Calibrate, RecoversA190DegreeFisheye) {
  const BoardSpec b = test::SyntheticBoard86();
  const std::string model = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=8_fov_x_deg=200";
  // 2 f tan(95 deg / 2) = 320 px: 190 degrees across the 640 px width; a
  // smooth distortion on the spline's knots.
  std::vector<double> k = {146.6, 146.6, 319.5, 319.5};
  for (int i = 0; i < 2 * 8 * 8; ++i) k.push_back(0.01 * std::sin(0.7 * i));
  const CameraModel truth(model, k, 640, 640);
  std::printf("truth: %s\n", truth.Describe().c_str());
  std::vector<CornerDetection> detections;
  BoardViewOptions vo;
  vo.supersample = 2;
  vo.noise_sigma = 0.01;
  int n = 0;
  const BoardViewRenderer renderer(truth, vo.supersample);
  for (const Rigid3& pose : FisheyeBoardPoses(b, 0.3)) {
    vo.seed = static_cast<uint64_t>(++n);
    detections.push_back(DetectCorners(renderer.Render(b, pose, vo), b, fmt::format("view{}", n)));
  }
  int found = 0;
  double widest = 0;
  for (const auto& d : detections) {
    found += d.found;
    for (const auto& p : d.pixels) {
      Eigen::Vector3d ray;
      if (truth.Unproject(p, &ray)) widest = std::max(widest, std::acos(ray.normalized().z()) / kDegToRad);
    }
  }
  std::printf("board found in %d of %zu photographs; corners up to %.1f degrees from the axis\n", found,
              detections.size(), widest);
  EXPECT_GT(widest, 90.0);  // behind the camera's plane
  CalibrationOptions o;
  o.lensmodel = model;
  o.focal_px = 146;
  const CalibrationResult r = CalibrateCamera(b, detections, 640, 640, o);
  for (const auto& s : r.stages) std::printf("%s\n", s.c_str());
  EXPECT_LT(r.rms_px, 0.2);
  const TruthAgreement a = CompareWithTruth(truth, r);
  EXPECT_EQ(a.beyond_3_sigma, 0);
  EXPECT_LT(a.rms_px, 0.4);    // measured 0.18 px
  EXPECT_LT(a.worst_px, 1.5);  // measured 0.65 px, at the field's rim
}

// A rig of two cameras 11 cm apart, turned 4 degrees against each other,
// photographing the same boards: the joint solve recovers the second
// camera's pose within 3 sigma of its reported uncertainty (each of the six
// extrinsics), and mrcal, reading the written model of the second camera,
// agrees with mr's projection uncertainty (which now runs through the
// extrinsics too).
TEST(Calibrate, RigExtrinsicsWithinThreeSigmaOfTheTruth) {
  const BoardSpec b = test::SyntheticBoard86();
  const CameraModel cam0("LENSMODEL_OPENCV8", {330, 332, 241, 178, 0.08, -0.05, 0.001, -0.0015, 0, 0, 0, 0}, 480, 360);
  const CameraModel cam1("LENSMODEL_OPENCV8", {300, 301, 236, 182, 0.05, -0.02, -0.001, 0.001, 0, 0, 0, 0}, 480, 360);
  const Rigid3 cam1_from_cam0(
      Eigen::Quaterniond(Eigen::AngleAxisd(4 * kDegToRad, Eigen::Vector3d(0.2, 1, 0.1).normalized())),
      Eigen::Vector3d(-0.11, 0.004, 0.002));
  std::vector<std::vector<CornerDetection>> detections(2);
  BoardViewOptions vo;
  vo.supersample = 2;
  vo.noise_sigma = 0.01;
  int k = 0;
  const BoardViewRenderer render0(cam0, vo.supersample), render1(cam1, vo.supersample);
  for (const Rigid3& pose : CalibrationBoardPoses(b, 14)) {
    // The boards shifted half the baseline, so that both cameras see most of them.
    const Rigid3 shifted(pose.rotation, pose.translation + Eigen::Vector3d(0.055, 0, 0.05));
    vo.seed = static_cast<uint64_t>(++k);
    detections[0].push_back(DetectCorners(render0.Render(b, shifted, vo), b, fmt::format("cam0-{}", k)));
    vo.seed += 1000;
    detections[1].push_back(
        DetectCorners(render1.Render(b, cam1_from_cam0 * shifted, vo), b, fmt::format("cam1-{}", k)));
  }
  CalibrationOptions o;
  const RigCalibrationResult rig = CalibrateRig(b, detections, {{480, 360}, {480, 360}}, o);
  for (const auto& s : rig.stages) std::printf("%s\n", s.c_str());
  std::printf("%d instants, %d seen by both\n", rig.instants, rig.shared_instants);
  EXPECT_GE(rig.shared_instants, 8);
  EXPECT_LT(rig.rms_px, 0.15);
  double rt_true[6], rt[6];
  cam1_from_cam0.ToRt(rt_true);
  rig.cameras[1].model.cam_from_ref().ToRt(rt);
  for (int i = 0; i < 6; ++i) {
    const double sigma = std::sqrt(rig.extrinsics_covariance[1](i, i));
    std::printf("extrinsic %d: true %.6f, solved %.6f, sigma %.2g, error/sigma %.2f\n", i, rt_true[i], rt[i], sigma,
                (rt[i] - rt_true[i]) / sigma);
    EXPECT_LT(std::abs(rt[i] - rt_true[i]), 3 * sigma) << "extrinsic " << i;
    EXPECT_LT(sigma, i < 3 ? 2e-3 : 2e-3);  // and is informative: below 0.1 degree and 2 mm
  }
  EXPECT_TRUE(rig.extrinsics_covariance[0].isZero());
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "python3-mrcal is not installed";
  EXPECT_TRUE(OracleAgrees(rig.cameras[1], {{240, 180}, {5, 5}, {400, 300}}));
}

// A view with too few corners to place the board (e.g. a ChArUco board
// mostly hidden) is left out with the reason; with too few views left the
// solve is refused, saying what is missing.
TEST(Calibrate, ViewsWithTooFewCornersAreLeftOutWithAReason) {
  const BoardSpec b = test::SyntheticBoard86();
  CornerDetection few;
  few.image = "few.png";
  few.found = true;
  few.pixels = {{100, 100}, {120, 100}, {100, 120}};
  few.ids = {0, 1, 8};
  try {
    CalibrateCamera(b, {few, few, few}, 640, 480, CalibrationOptions());
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {  // bad data (exit 1), not a usage error
    EXPECT_NE(std::string(e.what()).find("0 usable views of the board (3 photographs, the board found in 3)"),
              std::string::npos)
        << e.what();
  }
}

TEST(Calibrate, TooFewViewsIsAClearRefusal) {
  const BoardSpec b = test::SyntheticBoard86();
  CornerDetection missing;
  missing.image = "a.png";
  missing.reason = "no 8x6 board found";
  try {
    CalibrateCamera(b, {missing, missing}, 640, 480, CalibrationOptions());
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {  // bad data (exit 1), not a usage error
    EXPECT_NE(std::string(e.what()).find("0 usable views of the board (2 photographs, the board found in 0)"),
              std::string::npos)
        << e.what();
  }
}

// The real fish-eye photographs (every second one of 24): mrcal's OPENCV8
// fit lands near the reference cv::fisheye result shipped with the data
// (fx 290.05, fy 289.39, cx 399.94, cy 273.89; a different lens model, so
// within 1% and 5 px, not exactly), with a sub-pixel fit.
TEST(Calibrate, RealFisheyePhotographs) {
  MR_REQUIRE_SHARED_DATA("fisheye-mono-ros");
  const BoardSpec b = ReadBoard(fs::path(MR_SOURCE_DIR) / "calib" / "boards" / "chessboard-8x6.json");
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(test::SharedData("fisheye-mono-ros") / "calibrationdata"))
    if (e.path().extension() == ".png") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::vector<CornerDetection> detections;
  for (size_t i = 0; i < files.size(); i += 2)
    detections.push_back(DetectCorners(ReadImage(files[i]), b, files[i].filename().string()));
  const CalibrationResult r = CalibrateCamera(b, detections, 800, 503, CalibrationOptions());
  for (const auto& s : r.stages) std::printf("%s\n", s.c_str());
  const auto& k = r.model.intrinsics();
  EXPECT_NEAR(k[0], 290.05, 2.9);
  EXPECT_NEAR(k[1], 289.39, 2.9);
  EXPECT_NEAR(k[2], 399.94, 5);
  EXPECT_NEAR(k[3], 273.89, 5);
  EXPECT_LT(r.rms_px, 0.6);
}

}  // namespace
}  // namespace mr
