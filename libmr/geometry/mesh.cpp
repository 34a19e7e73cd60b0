#include "geometry/mesh.h"

#include <cmath>

#include "core/error.h"
#include "core/math.h"

namespace mr {

Eigen::AlignedBox3f Mesh::Bounds() const {
  Eigen::AlignedBox3f b;
  for (const auto& p : positions) b.extend(p);
  return b;
}

double Mesh::SurfaceArea() const {
  CompensatedSum<double> a;
  for (const auto& t : triangles) {
    Eigen::Vector3d p0 = positions[static_cast<size_t>(t[0])].cast<double>();
    Eigen::Vector3d p1 = positions[static_cast<size_t>(t[1])].cast<double>();
    Eigen::Vector3d p2 = positions[static_cast<size_t>(t[2])].cast<double>();
    a += 0.5 * (p1 - p0).cross(p2 - p0).norm();
  }
  return a.Value();
}

void Mesh::ComputeNormals() {
  std::vector<Eigen::Vector3d> n(positions.size(), Eigen::Vector3d::Zero());
  for (const auto& t : triangles) {
    Eigen::Vector3d p0 = positions[static_cast<size_t>(t[0])].cast<double>();
    Eigen::Vector3d p1 = positions[static_cast<size_t>(t[1])].cast<double>();
    Eigen::Vector3d p2 = positions[static_cast<size_t>(t[2])].cast<double>();
    Eigen::Vector3d fn = (p1 - p0).cross(p2 - p0);  // length = 2 * area
    for (int k = 0; k < 3; ++k) n[static_cast<size_t>(t[k])] += fn;
  }
  normals.resize(positions.size());
  for (size_t i = 0; i < n.size(); ++i) {
    double len = n[i].norm();
    normals[i] = len > 0 ? (n[i] / len).cast<float>() : Eigen::Vector3f(0, 0, 1);
  }
}

void Mesh::Validate(const std::string& name) const {
  const FileLoc loc{name};
  const size_t nv = positions.size();
  if (!normals.empty() && normals.size() != nv) ThrowErrorAt(loc, "{} normals for {} vertices", normals.size(), nv);
  if (!colors.empty() && colors.size() != nv) ThrowErrorAt(loc, "{} colours for {} vertices", colors.size(), nv);
  if (!uvs.empty() && uvs.size() != nv) ThrowErrorAt(loc, "{} uvs for {} vertices", uvs.size(), nv);
  for (const Scalar& s : scalars)
    if (s.values.size() != nv) ThrowErrorAt(loc, "{} values of \"{}\" for {} vertices", s.values.size(), s.name, nv);
  for (size_t i = 0; i < nv; ++i)
    if (!positions[i].allFinite()) ThrowErrorAt(loc, "vertex {} has a non-finite coordinate", i);
  for (size_t f = 0; f < triangles.size(); ++f)
    for (int k = 0; k < 3; ++k)
      if (triangles[f][k] < 0 || static_cast<size_t>(triangles[f][k]) >= nv)
        ThrowErrorAt(loc, "face {} uses vertex {}, but there are {} vertices", f, triangles[f][k], nv);
}

bool IsDegenerate(const Mesh& m, const Eigen::Vector3i& t) {
  if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return true;
  Eigen::Vector3d p0 = m.positions[static_cast<size_t>(t[0])].cast<double>();
  Eigen::Vector3d p1 = m.positions[static_cast<size_t>(t[1])].cast<double>();
  Eigen::Vector3d p2 = m.positions[static_cast<size_t>(t[2])].cast<double>();
  const double e = std::max({(p1 - p0).squaredNorm(), (p2 - p1).squaredNorm(), (p0 - p2).squaredNorm()});
  const double area = 0.5 * (p1 - p0).cross(p2 - p0).norm();
  return !(area > kDegenerateAreaFraction * e);
}

}  // namespace mr
