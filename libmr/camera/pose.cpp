#include "camera/pose.h"

#include <Eigen/SVD>

#include "core/math.h"

namespace mr {

Eigen::Matrix4d Rigid3::ToMatrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = rotation.toRotationMatrix();
  m.topRightCorner<3, 1>() = translation;
  return m;
}

Rigid3 Rigid3::FromMatrix(const Eigen::Matrix<double, 3, 4>& m, double* orthonormality_error) {
  Eigen::Matrix3d r = m.leftCols<3>();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  Eigen::Matrix3d nearest = svd.matrixU() * d * svd.matrixV().transpose();
  if (orthonormality_error) *orthonormality_error = (r - nearest).norm();
  return Rigid3(Eigen::Quaterniond(nearest), m.col(3));
}

// Rodrigues vector <-> quaternion directly, with Taylor limits at 0 and
// atan2 for the angle, so both are exact at 0 and well conditioned up to pi
// (cf. mrcal poseutils.c, which goes through the matrix).
Rigid3 Rigid3::FromRt(const double rt[6]) {
  const Eigen::Vector3d r(rt[0], rt[1], rt[2]);
  const double theta2 = r.squaredNorm();
  const double theta = std::sqrt(theta2);
  double w, s;  // q = (cos(theta/2), s * r) with s = sin(theta/2) / theta
  if (theta < 1e-4) {
    w = 1.0 - theta2 / 8.0;  // error O(theta^4) < 1e-17
    s = 0.5 - theta2 / 48.0;
  } else {
    w = std::cos(theta / 2);
    s = std::sin(theta / 2) / theta;
  }
  return Rigid3(Eigen::Quaterniond(w, s * r.x(), s * r.y(), s * r.z()), Eigen::Vector3d(rt[3], rt[4], rt[5]));
}

void Rigid3::ToRt(double rt[6]) const {
  Eigen::Quaterniond q = rotation.normalized();
  if (q.w() < 0) q.coeffs() = -q.coeffs();  // angle in [0, pi]
  const Eigen::Vector3d v = q.vec();
  const double sin_half = v.norm();
  // theta = 2 atan2(|v|, w); r = theta * v / |v|, with the limit 2 v / w at 0.
  const double scale = sin_half < 1e-12 ? 2.0 / q.w() : 2.0 * std::atan2(sin_half, q.w()) / sin_half;
  for (int k = 0; k < 3; ++k) rt[k] = scale * v[k];
  rt[3] = translation.x();
  rt[4] = translation.y();
  rt[5] = translation.z();
}

bool Rigid3::IsApprox(const Rigid3& o, double tol) const {
  return RotationAngle(rotation, o.rotation) <= tol && (translation - o.translation).norm() <= tol;
}

double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  // 2 * asin(|q_a - q_b| / 2) with the sign ambiguity of quaternions removed:
  // well conditioned at 0, unlike acos of the dot product.
  Eigen::Vector4d qa = a.normalized().coeffs(), qb = b.normalized().coeffs();
  if (qa.dot(qb) < 0) qb = -qb;
  return 4.0 * SafeASin(std::min(1.0, (qa - qb).norm() / 2.0));
}

}  // namespace mr
