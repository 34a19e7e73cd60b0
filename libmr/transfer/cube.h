// The cube-map basis of form-factor transfer: 6 faces of N x N cells.
//
// Face f is +X, -X, +Y, -Y, +Z, -Z (f = 2 axis + (negative ? 1 : 0)); on a
// face, (u, v) in [-1, 1]^2 index cells i = column along u, j = row along v,
// cell index (f N + j) N + i.  The solid angle of any rectangle on a face is
// exact (the arctangent formula), so the cells' solid angles sum to 4 pi.
#pragma once

#include <Eigen/Core>

namespace mr {

struct CubeFace {
  Eigen::Vector3d axis, u, v;  // direction = normalize(axis + u_coord u + v_coord v)
};
const CubeFace& GetCubeFace(int f);

inline int CubeCellCount(int n) { return 6 * n * n; }

// Direction through face coordinates (a, b) in [-1, 1]^2.
Eigen::Vector3d CubeDirection(int face, double a, double b);
// Solid angle of the rectangle [a0, a1] x [b0, b1] on a face.
double CubeRectSolidAngle(double a0, double b0, double a1, double b1);
// The cell a (non-zero) direction falls in.
int CubeCell(const Eigen::Vector3d& d, int n);

}  // namespace mr
