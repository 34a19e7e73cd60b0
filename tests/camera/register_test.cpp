// Video registration: the similarity fit of COLMAP poses to the room's
// trajectory, recovered from synthetic poses with a known transform, with
// noise, outliers and a camera moving on a straight line; the whole
// alignment through COLMAP's text format; and (with ../shared/data and the
// colmap command) COLMAP run on real 7-Scenes frames.
#include "camera/register.h"

#include <gtest/gtest.h>

#include <random>

#include "core/error.h"
#include "core/json.h"
#include "core/math.h"
#include "synth/synth.h"
#include "test_util.h"

namespace mr {
namespace {

// Cameras on an arc around the room's centre, looking inwards, with jitter.
std::vector<Rigid3> RoomPoses(int n, bool line, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Rigid3> out;
  for (int i = 0; i < n; ++i) {
    const double a = 0.1 * i;
    const Eigen::Vector3d c = line ? Eigen::Vector3d(0.05 * i, 1.5, -2)
                                   : Eigen::Vector3d(2 * std::cos(a), 1.5 + 0.1 * u(rng), 2 * std::sin(a));
    const Eigen::Quaterniond q = Eigen::AngleAxisd(a + 0.2 * u(rng), Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(0.1 * u(rng), Eigen::Vector3d::UnitX());
    out.emplace_back(q, c);
  }
  return out;
}

Similarity3 Known() {
  Similarity3 s;
  s.scale = 0.27;
  s.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(2.1, Eigen::Vector3d(0.3, -1, 0.5).normalized()));
  s.translation = Eigen::Vector3d(4, -2, 7);
  return s;
}

// Poses in COLMAP's frame a, given the room's b = known(a).
std::vector<PosePair> Pairs(const std::vector<Rigid3>& room, const Similarity3& b_from_a) {
  std::vector<PosePair> pairs;
  const Eigen::Quaterniond ri = b_from_a.rotation.conjugate();
  for (const Rigid3& b : room) {
    Rigid3 a(ri * b.rotation, ri * (b.translation - b_from_a.translation) / b_from_a.scale);
    pairs.push_back({a, b});
  }
  return pairs;
}

TEST(FitSimilarity, RecoversAKnownTransformExactly) {
  const Similarity3 k = Known();
  const SimilarityFit fit = FitSimilarity(Pairs(RoomPoses(20, false, 1), k));
  // Exact data: only round-off remains.
  EXPECT_NEAR(fit.b_from_a.scale, k.scale, 1e-9);
  EXPECT_LT(fit.b_from_a.rotation.angularDistance(k.rotation), 1e-9);
  EXPECT_LT((fit.b_from_a.translation - k.translation).norm(), 1e-8);
  EXPECT_LT(fit.centre_rmse_m, 1e-8);
}

TEST(FitSimilarity, StraightLineMotionStillFixesTheRotation) {
  // Centres on a line leave the rotation about it free; the orientations fix it.
  const Similarity3 k = Known();
  const SimilarityFit fit = FitSimilarity(Pairs(RoomPoses(15, true, 2), k));
  EXPECT_LT(fit.b_from_a.rotation.angularDistance(k.rotation), 1e-8);
  EXPECT_NEAR(fit.b_from_a.scale, k.scale, 1e-9);
}

TEST(FitSimilarity, NoiseAndOutliers) {
  const Similarity3 k = Known();
  auto pairs = Pairs(RoomPoses(40, false, 3), k);
  std::mt19937_64 rng(4);
  std::normal_distribution<double> g(0, 0.005);  // 5 mm of tracking noise in the room
  for (auto& p : pairs) p.b.translation += Eigen::Vector3d(g(rng), g(rng), g(rng));
  pairs[5].b.translation += Eigen::Vector3d(0.8, 0, 0);  // two frames COLMAP got badly wrong
  pairs[17].b.translation += Eigen::Vector3d(0, -0.5, 0.4);
  const SimilarityFit fit = FitSimilarity(pairs);
  // 38 inliers with 5 mm noise over a 4 m arc: scale to ~0.1%, rotation to
  // ~0.1 degrees; tolerances 5x that.  The outliers keep their residuals.
  EXPECT_NEAR(fit.b_from_a.scale / k.scale, 1.0, 5e-3);
  EXPECT_LT(fit.b_from_a.rotation.angularDistance(k.rotation) / kDegToRad, 0.5);
  EXPECT_LT(fit.centre_median_m, 0.012);
  EXPECT_GT(fit.centre_residual_m[5], 0.7);
  EXPECT_GT(fit.centre_residual_m[17], 0.5);
}

TEST(FitSimilarity, DegenerateInputIsAnError) {
  const auto pairs = Pairs(RoomPoses(2, false, 5), Known());
  EXPECT_THROW(FitSimilarity(pairs), Error);
  std::vector<PosePair> same(5, pairs[0]);
  EXPECT_THROW(FitSimilarity(same), Error);
}

// Points on the synthetic room's surfaces (floor, two walls, table, boxes),
// in COLMAP's frame a of Known(), with noise.
std::vector<Eigen::Vector3d> RoomPoints(const Mesh& room, const Similarity3& b_from_a, int n, double noise,
                                        uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, noise);
  std::vector<Eigen::Vector3d> out;
  const Eigen::Quaterniond ri = b_from_a.rotation.conjugate();
  while (static_cast<int>(out.size()) < n) {
    const auto& t = room.triangles[static_cast<size_t>(rng() % room.triangles.size())];
    double r1 = std::sqrt(u(rng)), r2 = u(rng);
    const Eigen::Vector3d p = (1 - r1) * room.positions[static_cast<size_t>(t[0])].cast<double>() +
                              r1 * (1 - r2) * room.positions[static_cast<size_t>(t[1])].cast<double>() +
                              r1 * r2 * room.positions[static_cast<size_t>(t[2])].cast<double>() +
                              Eigen::Vector3d(g(rng), g(rng), g(rng));
    out.push_back(ri * (p - b_from_a.translation) / b_from_a.scale);
  }
  return out;
}

TEST(RefineSimilarityToMesh, RecoversTheRoomFromARoughStart) {
  const Mesh room = MergeParts(SynthRoom());
  const Similarity3 k = Known();
  auto pts = RoomPoints(room, k, 3000, 0.005, 7);                    // COLMAP-like: 5 mm noise
  for (int i = 0; i < 150; ++i) pts[static_cast<size_t>(i)] *= 1.3;  // 5% of the points far off the surfaces
  Similarity3 start = k;                                             // a rough start: 4 degrees, 5% scale, 5 cm off
  start.rotation =
      k.rotation * Eigen::Quaterniond(Eigen::AngleAxisd(4 * kDegToRad, Eigen::Vector3d(1, 2, 0.5).normalized()));
  start.scale *= 1.05;
  start.translation += Eigen::Vector3d(0.03, -0.04, 0.02);
  const MeshFit fit = RefineSimilarityToMesh(pts, room, start);
  // 2850 inliers with 5 mm noise on planes in three directions: every room
  // point lands within 3 mm of where it belongs (measured 1.5 mm; the tolerances:
  // 0.1 degree, 0.1% of scale).
  EXPECT_NEAR(fit.b_from_a.scale / k.scale, 1.0, 1e-3);
  EXPECT_LT(fit.b_from_a.rotation.angularDistance(k.rotation) / kDegToRad, 0.1);
  double worst = 0;  // over the room's vertices, mapped back to frame a
  for (const auto& v : room.positions) {
    const Eigen::Vector3d a = k.rotation.conjugate() * (v.cast<double>() - k.translation) / k.scale;
    worst = std::max(worst, (fit.b_from_a.Apply(a) - v.cast<double>()).norm());
  }
  EXPECT_LT(worst, 3e-3);
  EXPECT_NEAR(fit.median_m, 0.005 * 0.6745 * std::sqrt(1.0), 0.003);  // |N(0, 5 mm)| along the normal: median 3.4 mm
  EXPECT_GT(fit.within_5cm, 0.9);
}

TEST(RefineSimilarityToMesh, AStartTooFarOffIsAnError) {
  const Mesh room = MergeParts(SynthRoom());
  const Similarity3 k = Known();
  const auto pts = RoomPoints(room, k, 500, 0.0, 8);
  Similarity3 start = k;
  start.translation += Eigen::Vector3d(0, 50, 0);  // 50 m away: nothing within the gate
  EXPECT_THROW(RefineSimilarityToMesh(pts, room, start), Error);
  // 6 degrees and 5% off: the fit would run away (the scale towards 0, where
  // point-to-plane distances vanish); it stops at its bound and says so.
  start = k;
  start.rotation =
      k.rotation * Eigen::Quaterniond(Eigen::AngleAxisd(6 * kDegToRad, Eigen::Vector3d(1, 2, 0.5).normalized()));
  start.scale *= 1.05;
  EXPECT_THROW(RefineSimilarityToMesh(RoomPoints(room, k, 3000, 0.005, 7), room, start), Error);
}

TEST(FrameNumberOf, LastDigits) {
  EXPECT_EQ(FrameNumberOf("frame-000010.color.jpg"), 10);
  EXPECT_EQ(FrameNumberOf("00042.png"), 42);
  EXPECT_EQ(FrameNumberOf("video_3_frame7.jpg"), 7);
  EXPECT_EQ(FrameNumberOf("still.png"), -1);
}

TEST(AlignColmapModel, WritesEveryFramesPoseInTheRoom) {
  test::TempDir dir;
  const Similarity3 k = Known();
  const auto room = RoomPoses(12, false, 6);
  const auto pairs = Pairs(room, k);
  ColmapModel model;
  model.cameras[1] = ColmapCamera{1, "PINHOLE", 160, 120, {150, 151, 79.5, 59.5}};
  Trajectory truth;
  for (int f = 0; f < 12; ++f) {
    truth.poses.push_back({static_cast<double>(f), room[static_cast<size_t>(f)]});
    if (f == 4 || f == 7) continue;  // not registered by COLMAP
    ColmapImage im;
    im.id = f + 1;
    im.camera_id = 1;
    im.name = fmt::format("{:05d}.png", f);
    im.cam_from_world = pairs[static_cast<size_t>(f)].a.Inverse();
    model.images[im.id] = im;
  }
  WriteTum(dir / "room.txt", truth);
  fs::create_directories(dir / "model");
  WriteColmapText(dir / "model", model);
  RegisterOptions o;
  o.trajectory = dir / "room.txt";
  o.truth = dir / "room.txt";
  o.frames = 12;
  o.out_poses = dir / "poses.txt";
  o.out_camera = dir / "video.cameramodel";
  Report report;
  AlignColmapModel(ReadColmapText(dir / "model"), o, &report);
  const Trajectory out = ReadTum(dir / "poses.txt");
  ASSERT_EQ(out.poses.size(), 12u);
  for (int f = 0; f < 12; ++f) {
    const auto& p = out.poses[static_cast<size_t>(f)];
    EXPECT_EQ(p.timestamp, f);
    // Registered frames: exact up to the text format's 17 digits.  The
    // interpolated ones lie between their neighbours: within the step
    // between frames (0.1 rad of arc on 2 m: 0.2 m).
    const double tol = (f == 4 || f == 7) ? 0.2 : 1e-7;
    EXPECT_LT((p.world_from_cam.translation - room[static_cast<size_t>(f)].translation).norm(), tol) << f;
  }
  EXPECT_EQ(report.metrics()["alignment"]["pairs"], 10);
  EXPECT_EQ(report.metrics()["alignment"]["match"], "timestamp");
  EXPECT_EQ(report.metrics()["interpolated_frames"], Json({4, 7}));
  EXPECT_LT(report.metrics()["alignment"]["centre_rmse_m"].get<double>(), 1e-7);
  const CameraModel cam = CameraModel::Read(dir / "video.cameramodel");
  EXPECT_EQ(cam.lensmodel(), "LENSMODEL_PINHOLE");
  EXPECT_NEAR(cam.intrinsics()[2], 79.5, 1e-12);  // in memory, COLMAP cameras are in mr's pixel convention
}

TEST(AlignColmapModel, RefusesAModelThatDoesNotFit) {
  // A broken reconstruction: poses that belong to other frames.
  test::TempDir dir;
  const auto room = RoomPoses(12, false, 9);
  const auto pairs = Pairs(room, Known());
  ColmapModel model;
  model.cameras[1] = ColmapCamera{1, "PINHOLE", 160, 120, {150, 151, 79.5, 59.5}};
  Trajectory truth;
  for (int f = 0; f < 12; ++f) {
    truth.poses.push_back({static_cast<double>(f), room[static_cast<size_t>(f)]});
    ColmapImage im;
    im.id = f + 1;
    im.camera_id = 1;
    im.name = fmt::format("{:05d}.png", f);
    im.cam_from_world = pairs[static_cast<size_t>((f * 5) % 12)].a.Inverse();
    model.images[im.id] = im;
  }
  WriteTum(dir / "room.txt", truth);
  RegisterOptions o;
  o.trajectory = dir / "room.txt";
  o.out_poses = dir / "poses.txt";
  Report report;
  EXPECT_THROW(AlignColmapModel(model, o, &report), AlignmentError);
  EXPECT_FALSE(fs::exists(dir / "poses.txt"));  // nothing written
}

// Without a trajectory a model is unchecked, but a video's camera moves
// smoothly: a model whose steps jump to 3x the median between two frames
// (its scale folds there: frames 4 to 5) is warned of; a smooth one is
// not.  And the points
// are written moved by the alignment (here: none, COLMAP's frame).
TEST(AlignColmapModel, WarnsOfAModelWhoseScaleFoldsWithoutATrajectory) {
  test::TempDir dir;
  auto make = [&](double jump) {
    ColmapModel model;
    model.cameras[1] = ColmapCamera{1, "PINHOLE", 160, 120, {150, 151, 79.5, 59.5}};
    double x = 0;
    for (int f = 0; f < 10; ++f) {
      x += (f == 5 ? jump : 1.0) * 0.1;
      ColmapImage im;
      im.id = f + 1;
      im.camera_id = 1;
      im.name = fmt::format("{:05d}.png", f);
      im.cam_from_world = Rigid3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, 0, 0)).Inverse();
      model.images[im.id] = im;
    }
    ColmapPoint3D p;
    p.id = 1;
    p.xyz = Eigen::Vector3d(1, 2, 3);
    p.rgb[0] = 255;
    p.error = 0.5;
    p.track = {{1, 0}, {2, 0}, {3, 0}};
    model.points3d[1] = p;
    return model;
  };
  RegisterOptions o;
  o.out_poses = dir / "poses.txt";
  o.out_points = dir / "points.ply";
  Report smooth;
  AlignColmapModel(make(1.0), o, &smooth);
  EXPECT_TRUE(smooth.warnings().empty());
  EXPECT_NEAR(smooth.metrics()["model"]["step_ratio_max"].get<double>(), 1.0, 1e-6);
  MeshReadOptions read;
  read.points = true;
  const Mesh cloud = ReadMesh(dir / "points.ply", read);
  ASSERT_EQ(cloud.vertex_count(), 1u);
  EXPECT_TRUE(cloud.positions[0].isApprox(Eigen::Vector3f(1, 2, 3)));
  EXPECT_NEAR(cloud.colors[0].x(), 1.0, 1e-6);
  Report folded;
  AlignColmapModel(make(3.0), o, &folded);
  ASSERT_EQ(folded.warnings().size(), 1u);
  EXPECT_NE(folded.warnings()[0].find("after frame 4 is 3.0x the median"), std::string::npos) << folded.warnings()[0];
}

TEST(RunColmap, RealKitchenFramesAlignToTheirPoses) {
  const auto data = test::SharedData("rgbd-7scenes-kitchen");
  if (data.empty()) return;
  if (std::system("colmap -h > /dev/null 2>&1") != 0) GTEST_SKIP() << "the colmap command is not installed";
  test::TempDir dir;
  // 20 frames, every 15th of 300 (a few cm apart): COLMAP on the CPU in ~20 s.
  fs::create_directories(dir / "frames");
  std::vector<fs::path> frames;
  for (int f = 0; f < 300; f += 15) {
    const fs::path src = data / fmt::format("frame-{:06d}.color.jpg", f);
    fs::copy_file(src, dir / "frames" / src.filename());
    frames.push_back(dir / "frames" / src.filename());
  }
  WriteTextFile(dir / "kitchen.cameramodel",
                CameraModel("LENSMODEL_PINHOLE", {585, 585, 320, 240}, 640, 480).ToString());
  ColmapRunOptions co;
  co.workspace = dir / "colmap";
  co.camera = dir / "kitchen.cameramodel";
  Report report;
  RegisterOptions o;
  o.trajectory = data;
  o.out_poses = dir / "poses.txt";
  RegisterFrames(frames, co, o, 3, &report);
  EXPECT_GE(report.metrics()["colmap"]["registered"].get<int>(), 18) << "COLMAP registered too few of 20 frames";
  // The 7-Scenes poses are the depth camera's (KinectFusion) and the colour
  // camera is not registered to it: a constant offset of a few cm and
  // degrees remains (measured: 2.8 cm and 4.3 degrees RMS with 30 frames).
  const Json& a = report.metrics()["alignment"];
  EXPECT_LT(a["centre_rmse_m"].get<double>(), 0.06);
  EXPECT_LT(a["rotation_rmse_deg"].get<double>(), 8.0);
}

}  // namespace
}  // namespace mr
