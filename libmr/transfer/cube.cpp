#include "transfer/cube.h"

#include <cmath>

#include "core/math.h"

namespace mr {

const CubeFace& GetCubeFace(int f) {
  static const CubeFace kFaces[6] = {{Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0, -1, 0)},
                                     {Eigen::Vector3d(-1, 0, 0), Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, -1, 0)},
                                     {Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 0, 1)},
                                     {Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 0, -1)},
                                     {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, -1, 0)},
                                     {Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(-1, 0, 0), Eigen::Vector3d(0, -1, 0)}};
  return kFaces[f];
}

Eigen::Vector3d CubeDirection(int face, double a, double b) {
  const CubeFace& f = GetCubeFace(face);
  return (f.axis + a * f.u + b * f.v).normalized();
}

double CubeRectSolidAngle(double a0, double b0, double a1, double b1) {
  auto A = [](double x, double y) { return std::atan2(x * y, std::sqrt(x * x + y * y + 1)); };
  return A(a1, b1) - A(a0, b1) - A(a1, b0) + A(a0, b0);
}

int CubeCell(const Eigen::Vector3d& d, int n) {
  const Eigen::Vector3d a = d.cwiseAbs();
  int axis = 0;
  if (a.y() > a[axis]) axis = 1;
  if (a.z() > a[axis]) axis = 2;
  const int face = 2 * axis + (d[axis] < 0 ? 1 : 0);
  const CubeFace& f = GetCubeFace(face);
  const double inv = 1.0 / a[axis];
  const double u = d.dot(f.u) * inv, v = d.dot(f.v) * inv;
  const int i = Clamp(static_cast<int>(std::floor((u + 1) * 0.5 * n)), 0, n - 1);
  const int j = Clamp(static_cast<int>(std::floor((v + 1) * 0.5 * n)), 0, n - 1);
  return (face * n + j) * n + i;
}

}  // namespace mr
