#include "camera/pose.h"

#include <Eigen/SVD>

extern "C" {
#include <mrcal/poseutils.h>
}

#include "core/math.h"

namespace mr {

Eigen::Matrix4d Rigid3::ToMatrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = rotation.toRotationMatrix();
  m.topRightCorner<3, 1>() = translation;
  return m;
}

Eigen::Matrix<double, 3, 4> Rigid3::ToMatrix3x4() const { return ToMatrix().topRows<3>(); }

Rigid3 Rigid3::FromMatrix(const Eigen::Matrix<double, 3, 4>& m, double* orthonormality_error) {
  Eigen::Matrix3d r = m.leftCols<3>();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  Eigen::Matrix3d nearest = svd.matrixU() * d * svd.matrixV().transpose();
  if (orthonormality_error) *orthonormality_error = (r - nearest).norm();
  return Rigid3(Eigen::Quaterniond(nearest), m.col(3));
}

Rigid3 Rigid3::FromRt(const double rt[6]) {
  double R[9];
  mrcal_R_from_r(R, nullptr, rt);
  Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> Rm(R);
  return Rigid3(Eigen::Quaterniond(Eigen::Matrix3d(Rm)), Eigen::Vector3d(rt[3], rt[4], rt[5]));
}

void Rigid3::ToRt(double rt[6]) const {
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R = rotation.toRotationMatrix();
  mrcal_r_from_R(rt, nullptr, R.data());
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
