// Procedural meshes: the parts of mr-synth's room, and test and benchmark
// objects.
#pragma once

#include <Eigen/Core>

#include "geometry/mesh.h"

namespace mr {

// An axis-aligned box, faces counter-clockwise seen from outside.
Mesh Box(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi);
// The quad a-b-c-d as two triangles.
Mesh Quad(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c, const Eigen::Vector3f& d);
// A closed latitude-longitude sphere of (n+1) x 2n vertices (the seam welded),
// radius r about the origin, poles on the y axis.
Mesh UvSphere(float r, int n);
// The same grid with the radius 1 + 0.15 sin(6 theta) cos(5 phi): folds
// that shadow each other.
Mesh BumpySphere(int n);

}  // namespace mr
