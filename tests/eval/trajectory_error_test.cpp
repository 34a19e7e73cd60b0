// Trajectory and surface error (eval/trajectory_error.h) against hand-computed cases.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "camera/trajectory.h"
#include "core/error.h"
#include "core/image.h"
#include "eval/trajectory_error.h"
#include "geometry/primitives.h"
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

}  // namespace
}  // namespace mr
