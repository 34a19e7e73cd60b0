#include "camera/trajectory.h"

#include <gtest/gtest.h>

#include <sstream>

#include "core/error.h"
#include "test_util.h"

namespace mr {
namespace {

std::string ErrorOf(const std::string& text) {
  std::istringstream in(text);
  try {
    ReadTum(in, "traj.txt");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Tum, RoundTripIsExact) {
  Trajectory t;
  for (int i = 0; i < 5; ++i) {
    Rigid3 p(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * i + 0.123456789, Eigen::Vector3d(1, 1, 0).normalized())),
             {0.1 * i, -0.2, 1.0 / 3});
    t.poses.push_back({1305031102.175304 + 0.033 * i, p});
  }
  std::stringstream ss;
  WriteTum(ss, t);
  Trajectory back = ReadTum(ss, "mem");
  ASSERT_EQ(back.size(), t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    EXPECT_EQ(back.poses[i].timestamp, t.poses[i].timestamp);  // precision 17: exact
    EXPECT_EQ(back.poses[i].world_from_cam.translation, t.poses[i].world_from_cam.translation);
    EXPECT_LT(RotationAngle(back.poses[i].world_from_cam.rotation, t.poses[i].world_from_cam.rotation), 1e-15);
  }
  EXPECT_NEAR(t.PathLength(), 0.4, 1e-12);
}

TEST(Tum, ConventionIsCameraToWorldWithQwLast) {
  // A camera at (1,2,3) rotated 90 deg about z: its x axis points along world y.
  std::istringstream in("# comment\n0.0 1 2 3 0 0 0.7071067811865476 0.7071067811865476\n");
  Trajectory t = ReadTum(in, "mem");
  Eigen::Vector3d x_axis_in_world = t.poses[0].world_from_cam.rotation * Eigen::Vector3d::UnitX();
  EXPECT_NEAR((x_axis_in_world - Eigen::Vector3d::UnitY()).norm(), 0, 1e-12);
  EXPECT_EQ(t.poses[0].world_from_cam * Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 2, 3));
}

TEST(Tum, BadInputNamesTheLine) {
  EXPECT_EQ(ErrorOf("0 1 2 3 0 0 0 1\n1 1 2 3 0 0 1\n"),
            "traj.txt:2: expected 8 numbers (timestamp tx ty tz qx qy qz qw), got 7");
  EXPECT_EQ(ErrorOf("0 1 2 x 0 0 0 1\n"), "traj.txt:1: \"x\" is not a number");
  EXPECT_EQ(ErrorOf("0 1 2 3 0 0 0 nan\n"), "traj.txt:1: NaN or Inf in pose");
  EXPECT_EQ(ErrorOf("0 1 2 3 0 0 0 2\n"), "traj.txt:1: quaternion norm is 2, not 1 (wrong column order?)");
  EXPECT_EQ(ErrorOf("1 0 0 0 0 0 0 1\n0 0 0 0 0 0 0 1\n"), "traj.txt:2: timestamp 0 goes back in time (previous 1)");
  EXPECT_EQ(ErrorOf("# only comments\n\n"), "traj.txt: no poses in TUM trajectory");
}

TEST(SevenScenes, PoseRoundTripAndErrors) {
  test::TempDir dir;
  Rigid3 p(Eigen::Quaterniond(Eigen::AngleAxisd(2.0, Eigen::Vector3d(0, 1, 1).normalized())), {0.5, -1, 2});
  Write7ScenesPose(dir / "frame-000007.pose.txt", p);
  Write7ScenesPose(dir / "frame-000003.pose.txt", p.Inverse());
  EXPECT_TRUE(Read7ScenesPose(dir / "frame-000007.pose.txt").IsApprox(p, 1e-14));
  Trajectory t = Read7ScenesFolder(dir.path());
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t.poses[0].timestamp, 3);  // frame order
  std::istringstream bad("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n");
  EXPECT_THROW(Read7ScenesPose(bad, "bad.txt"), Error);
  std::istringstream short_("1 0 0 0\n0 1 0 0\n");
  EXPECT_THROW(Read7ScenesPose(short_, "short.txt"), Error);
  EXPECT_EQ(DetectPoseFormat(dir / "frame-000007.pose.txt"), "7scenes");
}

TEST(SevenScenes, RealKitchenPosesLoad) {
  MR_REQUIRE_SHARED_DATA("rgbd-7scenes-kitchen");
  Trajectory t = Read7ScenesFolder(test::SharedData("rgbd-7scenes-kitchen"));
  EXPECT_EQ(t.size(), 300u);
  // The data README: rotations are slightly non-orthonormal, ~1e-4.
  EXPECT_GT(t.max_orthonormality_error, 0.0);
  EXPECT_LT(t.max_orthonormality_error, 1e-2);
  // ~30 Hz and a few millimetres per frame: 300 frames move well under 5 m.
  EXPECT_GT(t.PathLength(), 0.05);
  EXPECT_LT(t.PathLength(), 5.0);
}

}  // namespace
}  // namespace mr
