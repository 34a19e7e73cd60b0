// Closed surfaces in the real geometry, and proofs that they keep the
// camera and a virtual object apart.
//
// Every material of mr is opaque, so a closed surface (a room with no
// opening, a cupboard, a box) is a wall no path crosses: when the camera is
// on one side of it and a virtual object or light wholly on the other, no
// path from the camera meets the object and I_m - I_r is exactly zero in the
// whole frame.  mr-render copies such frames through.
//
// A connected component of the real triangles (vertices welded by exact
// position, across meshes) is closed when every edge has an even number of
// faces, none has one.  "Inside" is the parity of crossings along a ray; a
// ray that passes within 1e-9 (relative) of an edge or a vertex is retried
// in another direction, and after three tries the answer is "not proven":
// the test errs only towards rendering.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "geometry/mesh.h"

namespace mr {

class ClosedSurfaces {
 public:
  // Adds real triangles in world coordinates.  Call Build() after the last.
  void Add(const Mesh& mesh);
  void Build();
  int count() const { return static_cast<int>(closed_.size()); }

  // Whether some closed surface provably has `point` on one side and all of
  // `box` strictly on the other (the box touches none of its triangles'
  // bounds).  An empty box stands for a point at infinity (a distant light).
  // `which` gets the index of the separating surface.
  bool Separates(const Eigen::Vector3d& point, const Eigen::AlignedBox3d& box, int* which = nullptr) const;

 private:
  struct Component {
    std::vector<int> triangles;
    Eigen::AlignedBox3d bounds;
  };
  // 1 inside, 0 outside, -1 not decided.
  int Inside(const Component& c, const Eigen::Vector3d& p) const;
  std::vector<Eigen::Vector3d> positions_;
  std::vector<Eigen::Vector3i> triangles_;
  std::vector<Component> closed_;
};

}  // namespace mr
