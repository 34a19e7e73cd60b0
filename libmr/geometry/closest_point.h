// Closest points on a triangle mesh: triangles bucketed in a uniform grid,
// exact point-to-triangle distances (Ericson, Real-Time Collision Detection
// 5.1.5).  Queries look in the 27 cells around the point, so a query finds
// every triangle within one cell size.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"

namespace mr {

// The closest point of triangle abc to p.
Eigen::Vector3d ClosestOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                  const Eigen::Vector3d& c);

struct ClosestPoint {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // the triangle's unit normal
  double distance = 0;
  int32_t triangle = -1;  // -1: nothing within the cutoff
};

class TriangleGrid {
 public:
  // `mesh` must outlive the grid; `cell` is the largest cutoff queries use.
  TriangleGrid(const Mesh& mesh, double cell);
  // The closest point within `cutoff` (<= the cell size).
  ClosestPoint Closest(const Eigen::Vector3d& p, double cutoff) const;
  double Distance(const Eigen::Vector3d& p, double cutoff) const { return Closest(p, cutoff).distance; }

 private:
  Eigen::Vector3i Cell(const Eigen::Vector3d& p) const { return (p / cell_).array().floor().cast<int>(); }
  static uint64_t Key(const Eigen::Vector3i& c) {
    return (static_cast<uint64_t>(static_cast<uint32_t>(c.x()) & 0x1fffff) << 42) |
           (static_cast<uint64_t>(static_cast<uint32_t>(c.y()) & 0x1fffff) << 21) |
           (static_cast<uint64_t>(static_cast<uint32_t>(c.z()) & 0x1fffff));
  }
  const Mesh& mesh_;
  double cell_;
  std::unordered_map<uint64_t, std::vector<int32_t>> cells_;
};

}  // namespace mr
