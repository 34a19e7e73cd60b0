#include "geometry/closest_point.h"

#include <Eigen/Geometry>
#include <cmath>

namespace mr {

Eigen::Vector3d ClosestOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                  const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

TriangleGrid::TriangleGrid(const Mesh& m, double cell) : mesh_(m), cell_(cell) {
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    Eigen::AlignedBox3d box;
    for (int k = 0; k < 3; ++k) box.extend(m.positions[static_cast<size_t>(m.triangles[t][k])].cast<double>());
    const Eigen::Vector3i lo = Cell(box.min()), hi = Cell(box.max());
    for (int z = lo.z(); z <= hi.z(); ++z)
      for (int y = lo.y(); y <= hi.y(); ++y)
        for (int x = lo.x(); x <= hi.x(); ++x) cells_[Key({x, y, z})].push_back(static_cast<int32_t>(t));
  }
}

ClosestPoint TriangleGrid::Closest(const Eigen::Vector3d& p, double cutoff) const {
  const Eigen::Vector3i c = Cell(p);
  ClosestPoint best;
  double best_d2 = cutoff * cutoff;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        auto it = cells_.find(Key(c + Eigen::Vector3i(dx, dy, dz)));
        if (it == cells_.end()) continue;
        for (int32_t t : it->second) {
          const Eigen::Vector3i& tri = mesh_.triangles[static_cast<size_t>(t)];
          const Eigen::Vector3d a = mesh_.positions[static_cast<size_t>(tri[0])].cast<double>();
          const Eigen::Vector3d b = mesh_.positions[static_cast<size_t>(tri[1])].cast<double>();
          const Eigen::Vector3d cc = mesh_.positions[static_cast<size_t>(tri[2])].cast<double>();
          const Eigen::Vector3d q = ClosestOnTriangle(p, a, b, cc);
          const double d2 = (p - q).squaredNorm();
          if (d2 < best_d2) {
            best_d2 = d2;
            best.point = q;
            best.triangle = t;
            best.normal = (b - a).cross(cc - a).normalized();
          }
        }
      }
  best.distance = std::sqrt(best_d2);
  return best;
}

}  // namespace mr
