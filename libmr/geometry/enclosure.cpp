#include "geometry/enclosure.h"

#include <algorithm>
#include <array>
#include <map>
#include <numeric>

namespace mr {

void ClosedSurfaces::Add(const Mesh& mesh) {
  const int base = static_cast<int>(positions_.size());
  for (const auto& p : mesh.positions) positions_.push_back(p.cast<double>());
  for (const auto& t : mesh.triangles) triangles_.push_back(t + Eigen::Vector3i::Constant(base));
}

void ClosedSurfaces::Build() {
  closed_.clear();
  // Weld vertices by exact position.
  std::map<std::array<double, 3>, int> index;
  std::vector<int> weld(positions_.size());
  for (size_t i = 0; i < positions_.size(); ++i) {
    const auto& p = positions_[i];
    weld[i] = index.emplace(std::array<double, 3>{p.x(), p.y(), p.z()}, static_cast<int>(i)).first->second;
  }
  // Edges -> faces; union-find over faces sharing an edge.
  const int n = static_cast<int>(triangles_.size());
  std::vector<int> parent(static_cast<size_t>(n));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[static_cast<size_t>(x)] != x)
      x = parent[static_cast<size_t>(x)] = parent[static_cast<size_t>(parent[static_cast<size_t>(x)])];
    return x;
  };
  std::map<std::pair<int, int>, std::vector<int>> edges;
  std::vector<char> degenerate(static_cast<size_t>(n), 0);
  for (int f = 0; f < n; ++f) {
    const auto& t = triangles_[static_cast<size_t>(f)];
    const int v[3] = {weld[static_cast<size_t>(t[0])], weld[static_cast<size_t>(t[1])],
                      weld[static_cast<size_t>(t[2])]};
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) {
      degenerate[static_cast<size_t>(f)] = 1;  // no area: neither closes nor opens a surface
      continue;
    }
    for (int k = 0; k < 3; ++k) edges[{std::min(v[k], v[(k + 1) % 3]), std::max(v[k], v[(k + 1) % 3])}].push_back(f);
  }
  for (const auto& [e, faces] : edges)
    for (size_t k = 1; k < faces.size(); ++k) parent[static_cast<size_t>(find(faces[k]))] = find(faces[0]);
  std::map<int, Component> comps;
  std::map<int, bool> open;
  for (const auto& [e, faces] : edges) {
    const int root = find(faces[0]);
    if (faces.size() % 2 == 1) open[root] = true;
  }
  for (int f = 0; f < n; ++f) {
    if (degenerate[static_cast<size_t>(f)]) continue;
    const int root = find(f);
    if (open.count(root)) continue;
    Component& c = comps[root];
    c.triangles.push_back(f);
    for (int k = 0; k < 3; ++k) c.bounds.extend(positions_[static_cast<size_t>(triangles_[static_cast<size_t>(f)][k])]);
  }
  for (auto& [root, c] : comps) closed_.push_back(std::move(c));
}

int ClosedSurfaces::Inside(const Component& c, const Eigen::Vector3d& p) const {
  if (!c.bounds.contains(p)) return 0;
  const double scale = std::max(1.0, c.bounds.diagonal().norm());
  // Fixed directions with no special relation to axis-aligned geometry.
  static const Eigen::Vector3d kDirs[3] = {Eigen::Vector3d(0.5377, 0.8339, -0.1245).normalized(),
                                           Eigen::Vector3d(-0.3771, 0.2193, 0.8999).normalized(),
                                           Eigen::Vector3d(0.7141, -0.6421, 0.2787).normalized()};
  for (const Eigen::Vector3d& d : kDirs) {
    int crossings = 0;
    bool ambiguous = false;
    for (int f : c.triangles) {
      const auto& t = triangles_[static_cast<size_t>(f)];
      const Eigen::Vector3d& a = positions_[static_cast<size_t>(t[0])];
      const Eigen::Vector3d e1 = positions_[static_cast<size_t>(t[1])] - a,
                            e2 = positions_[static_cast<size_t>(t[2])] - a;
      const Eigen::Vector3d pv = d.cross(e2);
      const double det = e1.dot(pv);
      const double tol = 1e-9 * e1.norm() * e2.norm();
      if (std::abs(det) <= tol)
        continue;  // parallel: crosses only if it lies in the plane (caught below as an edge case)
      const Eigen::Vector3d tv = p - a;
      const double u = tv.dot(pv) / det;
      const Eigen::Vector3d qv = tv.cross(e1);
      const double v = d.dot(qv) / det, w = e2.dot(qv) / det;
      const double eps = 1e-9;
      if (u < -eps || v < -eps || u + v > 1 + eps || w < -eps * scale) continue;  // clearly missed
      if (u < eps || v < eps || u + v > 1 - eps || w < eps * scale) {
        ambiguous = true;  // near an edge, a vertex, or the point lies on the surface
        break;
      }
      ++crossings;
    }
    if (!ambiguous) return crossings % 2;
  }
  return -1;
}

bool ClosedSurfaces::Separates(const Eigen::Vector3d& point, const Eigen::AlignedBox3d& box, int* which) const {
  for (size_t i = 0; i < closed_.size(); ++i) {
    const Component& c = closed_[i];
    const int in_point = Inside(c, point);
    if (in_point < 0) continue;
    int in_box;
    if (box.isEmpty()) {
      in_box = 0;  // at infinity: outside every closed surface
    } else {
      // The box must not touch the bounds of any of the surface's triangles...
      bool touches = false;
      for (int f : c.triangles) {
        Eigen::AlignedBox3d tb;
        for (int k = 0; k < 3; ++k) tb.extend(positions_[static_cast<size_t>(triangles_[static_cast<size_t>(f)][k])]);
        if (tb.intersects(box)) {
          touches = true;
          break;
        }
      }
      if (touches) continue;
      // ... so all of it lies on the side of its centre.
      in_box = Inside(c, box.center());
      if (in_box < 0) continue;
    }
    if (in_point != in_box) {
      if (which) *which = static_cast<int>(i);
      return true;
    }
  }
  return false;
}

}  // namespace mr
