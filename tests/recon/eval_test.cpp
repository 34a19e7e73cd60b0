// Trajectory and surface error against hand-computed cases, and the RGB-D readers.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "camera/trajectory.h"
#include "core/error.h"
#include "core/image.h"
#include "eval/trajectory_error.h"
#include "geometry/primitives.h"
#include "recon/rgbd.h"
#include "test_util.h"

namespace mr {
namespace {

Trajectory Line(int n, double step) {
  Trajectory t;
  for (int i = 0; i < n; ++i) t.poses.push_back({i * 0.1, Rigid3(Eigen::Quaterniond::Identity(), {i * step, 0, 0})});
  return t;
}

TEST(Associate, MatchesTumAssociateGreedyByDifference) {
  // associate.py: all pairs within max_dt, sorted by |a - b|, taken greedily.
  // 1.00 pairs with 1.01 (0.01) before 1.02 can claim it (0.01 too, later a).
  const std::vector<double> a = {1.00, 1.02, 2.00, 5.00};
  const std::vector<double> b = {1.01, 1.03, 2.05, 4.99};
  const auto p = AssociateTimestamps(a, b, 0.02);
  ASSERT_EQ(p.size(), 3u);  // 2.00 has nothing within 0.02
  EXPECT_EQ(p[0], std::make_pair(0, 0));
  EXPECT_EQ(p[1], std::make_pair(1, 1));
  EXPECT_EQ(p[2], std::make_pair(3, 3));
}

// A list that repeats one timestamp (a recorder whose clock stopped): every
// pair is within max_dt.  Offering all of them was 10^10 candidates here, a
// hang (found by fuzz_rgbdlist, whose inputs of a few thousand lines ran at
// 1.5 ms each).  Each a is now offered its 8 nearest: here the same 8 b, so
// 8 pairs, one to one (which frame goes with which is unknowable anyway).
TEST(Associate, ARepeatedTimestampPairsInBoundedWork) {
  const std::vector<double> a(100000, 7.0), b(100000, 7.0);
  const auto p = AssociateTimestamps(a, b, 0.02);
  ASSERT_EQ(p.size(), 8u);
  std::vector<char> used_b(b.size(), 0);
  for (const auto& [i, j] : p) {
    EXPECT_FALSE(used_b[static_cast<size_t>(j)]);
    used_b[static_cast<size_t>(j)] = 1;
  }
  // Sane lists are paired as associate.py pairs them: 30 fps against 30 fps
  // shifted by 4 ms, every frame to its own.
  std::vector<double> c, d;
  for (int k = 0; k < 1000; ++k) {
    c.push_back(k / 30.0);
    d.push_back(k / 30.0 + 0.004);
  }
  const auto q = AssociateTimestamps(c, d, 0.02);
  ASSERT_EQ(q.size(), c.size());
  for (size_t k = 0; k < q.size(); ++k) EXPECT_EQ(q[k], std::make_pair(int(k), int(k)));
}

TEST(Ate, HornRemovesARigidMotionExactly) {
  Trajectory ref = Line(20, 0.05);
  // A curved reference so that the rotation is determined.
  for (size_t i = 0; i < ref.poses.size(); ++i) {
    const double x = 0.05 * static_cast<double>(i);
    ref.poses[i].world_from_cam.translation = {x, 0.3 * x * x, 0.1 * std::sin(x * 5)};
  }
  Trajectory est = ref;
  const Rigid3 T(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())), {1, -2, 0.5});
  for (size_t i = 0; i < est.poses.size(); ++i) est.poses[i].world_from_cam = T * ref.poses[i].world_from_cam;
  const AteResult r = ComputeAte(est, ref);
  EXPECT_EQ(r.pairs, 20);
  EXPECT_LT(r.rmse, 1e-9);
  EXPECT_TRUE(r.ref_from_est.IsApprox(T.Inverse(), 1e-9));
}

TEST(Ate, HandComputedOffsets) {
  // Reference: (+-a, 0, 0), (0, +-b, 0); estimate: each point pushed out
  // radially by d.  Both centroids are 0 and W = sum ref est^T =
  // diag(2a(a+d), 2b(b+d), 0) is already diagonal and positive, so Horn's
  // rotation is the identity and every residual is exactly d.
  const double a = 1.0, b = 0.5, d = 0.01;
  const std::vector<Eigen::Vector3d> ref = {{a, 0, 0}, {-a, 0, 0}, {0, b, 0}, {0, -b, 0}};
  const std::vector<Eigen::Vector3d> est = {{a + d, 0, 0}, {-a - d, 0, 0}, {0, b + d, 0}, {0, -b - d, 0}};
  Trajectory tr, te;
  for (size_t i = 0; i < ref.size(); ++i) {
    tr.poses.push_back({static_cast<double>(i), Rigid3(Eigen::Quaterniond::Identity(), ref[i])});
    te.poses.push_back({static_cast<double>(i), Rigid3(Eigen::Quaterniond::Identity(), est[i])});
  }
  const AteResult r = ComputeAte(te, tr);
  EXPECT_NEAR(r.rmse, d, 1e-12);
  EXPECT_NEAR(r.mean, d, 1e-12);
  EXPECT_NEAR(r.max, d, 1e-12);
  EXPECT_TRUE(r.ref_from_est.IsApprox(Rigid3(), 1e-12));
}

TEST(Rpe, HandComputed) {
  // The estimate steps 0.11 m where the reference steps 0.10 m: every
  // one-step relative motion is off by 1 cm, two-step motions by 2 cm.
  const Trajectory ref = Line(11, 0.10), est = Line(11, 0.11);
  const RpeResult r1 = ComputeRpe(est, ref, 0.1);
  EXPECT_EQ(r1.pairs, 10);
  EXPECT_NEAR(r1.trans_rmse, 0.01, 1e-12);
  EXPECT_NEAR(r1.rot_rmse_deg, 0, 1e-9);
  const RpeResult r2 = ComputeRpe(est, ref, 0.2);
  EXPECT_EQ(r2.pairs, 9);
  EXPECT_NEAR(r2.trans_rmse, 0.02, 1e-12);
  // A constant rotation of the estimate by 10 degrees about z at each step:
  // the relative rotation error is 10 degrees per step.
  Trajectory rot = ref;
  for (size_t i = 0; i < rot.poses.size(); ++i)
    rot.poses[i].world_from_cam.rotation =
        Eigen::AngleAxisd(0.1745329251994330 * static_cast<double>(i), Eigen::Vector3d::UnitZ());
  const RpeResult r3 = ComputeRpe(rot, ref, 0.1);
  EXPECT_NEAR(r3.rot_rmse_deg, 10.0, 1e-9);
}

TEST(MeshError, ParallelPlanesAreTheirDistanceApart) {
  const Mesh a = Quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0});
  const Mesh b = Quad({0, 0, 0.004f}, {1, 0, 0.004f}, {1, 1, 0.004f}, {0, 1, 0.004f});
  const MeshErrorResult r = CompareMeshes(a, b, 0.005, 0.1, 20000);
  // Near the rim a point's closest point can be on the rim: still 4 mm.
  EXPECT_NEAR(r.accuracy.mean, 0.004, 1e-6);
  EXPECT_NEAR(r.completeness.median, 0.004, 1e-6);
  EXPECT_DOUBLE_EQ(r.accuracy.within, 1.0);
  // Half the reference missing: completeness counts it, accuracy does not.
  const Mesh half = Quad({0, 0, 0}, {0.5f, 0, 0}, {0.5f, 1, 0}, {0, 1, 0});
  const MeshErrorResult h = CompareMeshes(half, a, 0.005, 0.1, 20000);
  EXPECT_NEAR(h.accuracy.mean, 0, 1e-9);
  EXPECT_NEAR(h.completeness.within, 0.5, 0.02);
}

TEST(Rgbd, SevenScenesFolderOpensWithItsIntrinsicsAndPoses) {
  MR_REQUIRE_SHARED_DATA("rgbd-7scenes-kitchen");
  const RgbdSequence s = OpenRgbdSequence(test::SharedData("rgbd-7scenes-kitchen"));
  EXPECT_EQ(s.layout, "7scenes");
  EXPECT_EQ(s.frames.size(), 300u);
  EXPECT_EQ(s.K.fx, 585);
  EXPECT_EQ(s.K.width, 640);
  EXPECT_EQ(s.reference.size(), 300u);
  EXPECT_TRUE(s.has_color());
  DepthReadStats st;
  const DepthMap d = ReadDepth(s.frames[0].depth, {1000, 0.1, 10}, 640, 480, &st);
  EXPECT_GT(st.valid, 200000);
  EXPECT_GT(st.median_m, 0.5);
  EXPECT_LT(st.median_m, 4);
  EXPECT_EQ(SuggestDepthScale(st.median_m, 1000), 0);
  // Read as if TUM (5000 per metre): the median is implausible and 1000 is suggested.
  DepthReadStats wrong;
  ReadDepth(s.frames[0].depth, {5000, 0.1, 10}, 640, 480, &wrong);
  EXPECT_EQ(SuggestDepthScale(wrong.median_m, 5000), 1000);
}

TEST(Rgbd, TumLayoutAssociatesAndPlainLayoutNeedsACameraModel) {
  test::TempDir dir;
  fs::create_directories(dir / "depth");
  fs::create_directories(dir / "rgb");
  Image depth = Image::Gray(8, 6, 5000.0f / 65535.0f);  // 1 m
  ImageWriteOptions wo;
  wo.pixel_type = PixelType::kUint16;
  wo.ldr_transfer = Transfer::kLinear;
  WriteImage(dir / "depth/1.0.png", depth, wo);
  WriteImage(dir / "depth/2.0.png", depth, wo);
  WriteImage(dir / "rgb/1.005.png", Image::Rgb(8, 6, 0.5f));
  WriteTextFile(dir / "depth.txt", "# depth\n1.0 depth/1.0.png\n2.0 depth/2.0.png\n");
  WriteTextFile(dir / "rgb.txt", "1.005 rgb/1.005.png\n");
  RgbdOpenOptions o;
  o.intrinsics = PinholeIntrinsics{10, 10, 3.5, 2.5, 8, 6};
  const RgbdSequence s = OpenRgbdSequence(dir.path(), o);
  EXPECT_EQ(s.layout, "tum");
  EXPECT_EQ(s.depth_scale, 5000);
  ASSERT_EQ(s.frames.size(), 1u);  // 2.0 has no colour within 0.02 s
  EXPECT_EQ(s.unpaired_depth, 1);
  const DepthMap d = ReadDepth(s.frames[0].depth, {s.depth_scale, 0.1, 10}, 8, 6);
  EXPECT_FLOAT_EQ(d.at(3, 3), 1.0f);
  // Without intrinsics: one message naming the folder.
  try {
    OpenRgbdSequence(dir.path());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("intrinsics"), std::string::npos) << std::string(e.what());
  }
  // A depth map of the wrong size is named.
  try {
    ReadDepth(s.frames[0].depth, {5000, 0.1, 10}, 640, 480);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("8x6"), std::string::npos) << std::string(e.what());
  }
}

TEST(Rgbd, GarbageDepthIsRejectedAndCounted) {
  // A float depth map with NaN, Inf, negative, the 65535 marker's float
  // twin and out-of-range values: each is dropped and counted, never fused.
  test::TempDir dir;
  Image d = Image::Gray(4, 2, 2000.0f);  // 2 m in mm
  d.at(0, 0, 0) = std::nanf("");
  d.at(1, 0, 0) = INFINITY;
  d.at(2, 0, 0) = -5;
  d.at(3, 0, 0) = 1e9f;  // 1000 km
  d.at(0, 1, 0) = 0;     // no return
  ImageWriteOptions wo;
  wo.pixel_type = PixelType::kFloat;
  WriteImage(dir / "d.exr", d, wo);
  DepthReadStats st;
  const DepthMap m = ReadDepth(dir / "d.exr", {1000, 0.1, 10}, 4, 2, &st);
  EXPECT_EQ(st.valid, 3);
  EXPECT_EQ(st.rejected, 4);
  EXPECT_EQ(st.invalid_markers, 1);
  for (int x = 0; x < 4; ++x) EXPECT_EQ(m.at(x, 0), 0.0f);
  EXPECT_FLOAT_EQ(m.at(1, 1), 2.0f);
  // 8-bit "depth" is refused with the file named.
  WriteImage(dir / "d8.png", Image::Gray(4, 2, 0.5f));
  EXPECT_THROW(ReadDepth(dir / "d8.png", {1000, 0.1, 10}, 4, 2), Error);
}

}  // namespace
}  // namespace mr
