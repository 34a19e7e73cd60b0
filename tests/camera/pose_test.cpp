#include "camera/pose.h"

#include <gtest/gtest.h>

#include "core/math.h"

namespace mr {
namespace {

TEST(Rigid3, ComposeAndInvert) {
  Rigid3 b_from_a(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())), {1, 2, 3});
  Rigid3 c_from_b(Eigen::Quaterniond(Eigen::AngleAxisd(-1.1, Eigen::Vector3d::UnitY())), {-4, 0, 1});
  Eigen::Vector3d p_in_a(0.5, -0.25, 2);
  Rigid3 c_from_a = c_from_b * b_from_a;
  EXPECT_NEAR((c_from_a * p_in_a - c_from_b * (b_from_a * p_in_a)).norm(), 0, 1e-14);
  EXPECT_NEAR((b_from_a.Inverse() * (b_from_a * p_in_a) - p_in_a).norm(), 0, 1e-14);
  EXPECT_NEAR((c_from_a.ToMatrix() * p_in_a.homogeneous()).head<3>().isApprox(c_from_a * p_in_a), true, 0);
}

// mrcal's rt through libmrcal's Rodrigues code: exact at 0 and stable
// around the singularities (cf. mrcal test-poseutils-near-singularity).
TEST(Rigid3, RtRoundTripNearSingularities) {
  for (double angle : {0.0, 1e-10, -1e-10, 1e-4, -1e-4, 1.0, kPi - 1e-4, kPi - 1e-10}) {
    Eigen::Vector3d axis = Eigen::Vector3d(0.2, -0.5, 0.8).normalized();
    double rt[6] = {axis.x() * angle, axis.y() * angle, axis.z() * angle, 1, 2, 3};
    Rigid3 r = Rigid3::FromRt(rt);
    ASSERT_TRUE(r.rotation.coeffs().allFinite()) << angle;
    Eigen::Quaterniond expected(Eigen::AngleAxisd(angle, axis));
    EXPECT_LT(RotationAngle(r.rotation, expected), 1e-12) << angle;
    double back[6];
    r.ToRt(back);
    // Near pi, r and -r describe nearly the same rotation; compare rotations.
    Rigid3 again = Rigid3::FromRt(back);
    EXPECT_LT(RotationAngle(again.rotation, r.rotation), 1e-9) << angle;
    if (std::abs(angle) < 1) {
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(back[k], rt[k], 1e-15 + 1e-12 * std::abs(angle)) << angle;
    }
    EXPECT_EQ(back[3], 1);
  }
}

TEST(Rigid3, FromMatrixProjectsToTheNearestRotation) {
  Eigen::Matrix<double, 3, 4> m;
  m.leftCols<3>() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  m.col(3) = Eigen::Vector3d(1, 2, 3);
  m(0, 0) += 1e-4;  // like 7-Scenes' slightly non-orthonormal poses
  double err = 0;
  Rigid3 r = Rigid3::FromMatrix(m, &err);
  EXPECT_GT(err, 0.5e-4);
  EXPECT_LT(err, 1e-4);
  Eigen::Matrix3d R = r.rotation.toRotationMatrix();
  EXPECT_NEAR((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-14);
  EXPECT_NEAR(R.determinant(), 1, 1e-14);
}

TEST(Rigid3, RotationAngleIsAccurateForTinyAngles) {
  Eigen::Quaterniond a = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond b(Eigen::AngleAxisd(1e-9, Eigen::Vector3d::UnitX()));
  EXPECT_NEAR(RotationAngle(a, b), 1e-9, 1e-20);
  Eigen::Quaterniond neg(-b.w(), -b.x(), -b.y(), -b.z());  // same rotation
  EXPECT_NEAR(RotationAngle(a, neg), 1e-9, 1e-20);
}

}  // namespace
}  // namespace mr
