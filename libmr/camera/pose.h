// Rigid transforms, named b_from_a: p_in_b = b_from_a * p_in_a
// (docs/conventions.md).  Double precision throughout.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace mr {

struct Rigid3 {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3() = default;
  Rigid3(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) : rotation(q.normalized()), translation(t) {}

  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return rotation * p + translation; }
  // c_from_a = c_from_b * b_from_a
  Rigid3 operator*(const Rigid3& b_from_a) const {
    return Rigid3(rotation * b_from_a.rotation, rotation * b_from_a.translation + translation);
  }
  Rigid3 Inverse() const {
    Eigen::Quaterniond qi = rotation.conjugate();
    return Rigid3(qi, -(qi * translation));
  }
  Eigen::Matrix4d ToMatrix() const;

  // From a 3x4 or 4x4 matrix whose rotation block may be slightly
  // non-orthonormal (7-Scenes poses): projects it to the nearest rotation
  // (SVD) and returns how far it was (Frobenius norm of R - nearest).
  static Rigid3 FromMatrix(const Eigen::Matrix<double, 3, 4>& m, double* orthonormality_error = nullptr);

  // mrcal's rt: Rodrigues rotation vector r (3) then translation t (3);
  // exact at r = 0 and well conditioned up to pi.
  static Rigid3 FromRt(const double rt[6]);
  void ToRt(double rt[6]) const;

  bool IsApprox(const Rigid3& o, double tol) const;
};

// Rotation angle (radians) between two rotations, accurate near 0.
double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

}  // namespace mr
