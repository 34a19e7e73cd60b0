#include "geometry/planes.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "core/error.h"
#include "core/sampling.h"

namespace mr {

void PlaneOptions::Check() const {
  if (!(distance > 0)) throw UsageError("planes: --distance must be positive");
  if (min_points < 3) throw UsageError("planes: --min-points must be at least 3");
  if (!(min_fraction >= 0 && min_fraction < 1)) throw UsageError("planes: --min-fraction must be in [0, 1)");
  if (max_planes < 1) throw UsageError("planes: --max-planes must be at least 1");
  if (hypotheses < 1) throw UsageError("planes: --hypotheses must be at least 1");
  if (!(snap_deg >= 0 && snap_deg < 45)) throw UsageError("planes: --snap-deg must be in [0, 45)");
  if (!(up_hint_deg > 0 && up_hint_deg <= 90)) throw UsageError("planes: --up-hint-deg must be in (0, 90]");
  if (!(merge_distance >= 0)) throw UsageError("planes: --merge-distance must not be negative");
  if (!up_hint.allFinite()) throw UsageError("planes: --up must be finite");
}

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

// Least-squares plane through the points (the smallest principal axis).
void FitPlane(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& idx, Eigen::Vector3d* normal,
              double* offset) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i : idx) mean += points[static_cast<size_t>(i)];
  mean /= static_cast<double>(idx.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i : idx) {
    const Eigen::Vector3d d = points[static_cast<size_t>(i)] - mean;
    cov += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  *normal = eig.eigenvectors().col(0).normalized();
  *offset = normal->dot(mean);
}

// The indices among `pool` within `distance` of the plane.
std::vector<int> Inliers(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& pool,
                         const Eigen::Vector3d& n, double d, double distance) {
  std::vector<int> in;
  for (int i : pool)
    if (std::abs(n.dot(points[static_cast<size_t>(i)]) - d) <= distance) in.push_back(i);
  return in;
}

// A hypothesis' normal turned to gravity (`up` unit; zero: none): level
// or upright when within snap_deg of it, else kept as it is, "slanted".
std::string Turn(const Eigen::Vector3d& up, const PlaneOptions& options, Eigen::Vector3d* n) {
  if (up.squaredNorm() == 0) return "slanted";
  const double from_up = std::acos(std::clamp(std::abs(n->dot(up)), 0.0, 1.0)) / kDeg;
  if (from_up <= options.snap_deg) {
    *n = up;  // level planes face up (the viewpoints may turn them after)
    return "horizontal";
  }
  if (from_up >= 90 - options.snap_deg) {
    *n = (*n - n->dot(up) * up).normalized();
    return "vertical";
  }
  return "slanted";
}

// The best three-point hypothesis over `pool`, refitted to its inliers
// twice: with gravity (`up` not zero) each hypothesis is turned to it
// before it is scored (level and upright slabs are what is counted) and
// slanted ones are skipped unless kept; the refit then moves the offset
// only.  Deterministic: the hypotheses come from (seed, stream).
Plane RansacPlane(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& pool, const PlaneOptions& options,
                  const Eigen::Vector3d& up, uint64_t stream) {
  Pcg32 rng(options.seed, stream);
  const auto n_pool = static_cast<uint32_t>(pool.size());
  Eigen::Vector3d best_n = Eigen::Vector3d::UnitY();
  double best_d = 0;
  size_t best_count = 0;
  std::string best_kind = "slanted";
  for (int h = 0; h < options.hypotheses; ++h) {
    const Eigen::Vector3d& a = points[static_cast<size_t>(pool[rng.NextU32() % n_pool])];
    const Eigen::Vector3d& b = points[static_cast<size_t>(pool[rng.NextU32() % n_pool])];
    const Eigen::Vector3d& c = points[static_cast<size_t>(pool[rng.NextU32() % n_pool])];
    const Eigen::Vector3d cross = (b - a).cross(c - a);
    const double len = cross.norm();
    // Nearly collinear triples give no plane (relative to the triangle's size).
    if (!(len > 1e-9 * (b - a).squaredNorm() + 1e-300)) continue;
    Eigen::Vector3d n = cross / len;
    const std::string kind = Turn(up, options, &n);
    if (kind == "slanted" && up.squaredNorm() > 0 && !options.keep_slanted) continue;
    const double d = n.dot((a + b + c) / 3);
    size_t count = 0;
    for (int i : pool)
      if (std::abs(n.dot(points[static_cast<size_t>(i)]) - d) <= options.distance) ++count;
    if (count > best_count) {
      best_count = count;
      best_n = n;
      best_d = d;
      best_kind = kind;
    }
  }
  Plane p;
  p.normal = best_n;
  p.offset = best_d;
  p.kind = best_kind;
  p.inliers = Inliers(points, pool, best_n, best_d, options.distance);
  for (int k = 0; k < 2 && p.inliers.size() >= 3; ++k) {
    if (p.kind == "slanted") {
      FitPlane(points, p.inliers, &p.normal, &p.offset);
    } else {
      double sum = 0;
      for (int i : p.inliers) sum += p.normal.dot(points[static_cast<size_t>(i)]);
      p.offset = sum / static_cast<double>(p.inliers.size());
    }
    p.inliers = Inliers(points, pool, p.normal, p.offset, options.distance);
  }
  if (p.inliers.size() >= 3) {  // how far the points' own fit is from the turned plane
    Eigen::Vector3d fitted;
    double unused;
    FitPlane(points, p.inliers, &fitted, &unused);
    p.tilt_deg = std::acos(std::clamp(std::abs(fitted.dot(p.normal)), 0.0, 1.0)) / kDeg;
  }
  double ss = 0;
  for (int i : p.inliers) ss += std::pow(p.normal.dot(points[static_cast<size_t>(i)]) - p.offset, 2);
  p.rms = p.inliers.empty() ? 0 : std::sqrt(ss / static_cast<double>(p.inliers.size()));
  return p;
}

// The box of a plane's inliers in a basis (u, v) on it.
Eigen::AlignedBox2d BoxOn(const std::vector<Eigen::Vector3d>& points, const Plane& p, const Eigen::Vector3d& u,
                          const Eigen::Vector3d& v) {
  Eigen::AlignedBox2d box;
  for (int k : p.inliers) {
    const Eigen::Vector3d& x = points[static_cast<size_t>(k)];
    box.extend(Eigen::Vector2d(u.dot(x), v.dot(x)));
  }
  return box;
}

// Level (or upright, facing the same way) planes closer than
// merge_distance whose points overlap on the plane are one surface whose
// points RANSAC split into slabs (SfM points of a table scatter by a
// centimetre or more along the rays): the smaller joins the larger, the
// offset refitted to all their points.  Planes side by side (a table and a
// counter beyond it) stay apart.
void MergeParallel(const std::vector<Eigen::Vector3d>& points, const PlaneOptions& options, PlaneSet* set) {
  if (!(options.merge_distance > 0)) return;
  std::vector<Plane>& planes = set->planes;
  for (size_t i = 0; i < planes.size(); ++i)
    for (size_t j = i + 1; j < planes.size();) {
      Plane& a = planes[i];
      const Plane& b = planes[j];
      const Eigen::Vector3d u = a.normal.unitOrthogonal(), v = a.normal.cross(u);
      if (a.kind == "slanted" || a.kind != b.kind || a.normal.dot(b.normal) < std::cos(1 * kDeg) ||
          std::abs(a.offset - b.offset) >= options.merge_distance ||
          !BoxOn(points, a, u, v).intersects(BoxOn(points, b, u, v))) {
        ++j;
        continue;
      }
      a.inliers.insert(a.inliers.end(), b.inliers.begin(), b.inliers.end());
      std::sort(a.inliers.begin(), a.inliers.end());
      double sum = 0, ss = 0;
      for (int k : a.inliers) sum += a.normal.dot(points[static_cast<size_t>(k)]);
      a.offset = sum / static_cast<double>(a.inliers.size());
      for (int k : a.inliers) ss += std::pow(a.normal.dot(points[static_cast<size_t>(k)]) - a.offset, 2);
      a.rms = std::sqrt(ss / static_cast<double>(a.inliers.size()));
      planes.erase(planes.begin() + static_cast<long>(j));
      ++set->merged;
    }
}

std::vector<int> Without(const std::vector<int>& pool, const std::vector<int>& taken) {
  std::vector<int> rest;
  std::set_difference(pool.begin(), pool.end(), taken.begin(), taken.end(), std::back_inserter(rest));
  return rest;
}

}  // namespace

PlaneSet DetectPlanes(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& viewpoints,
                      const PlaneOptions& options) {
  options.Check();
  for (const Eigen::Vector3d& p : points)
    if (!p.allFinite()) ThrowError("planes: the points hold a non-finite coordinate");
  const auto needed = static_cast<size_t>(
      std::max<double>(options.min_points, std::ceil(options.min_fraction * static_cast<double>(points.size()))));
  std::vector<int> all(points.size());
  std::iota(all.begin(), all.end(), 0);
  // Sequential RANSAC over the points not yet taken, largest plane first.
  auto sequence = [&](const Eigen::Vector3d& up, uint64_t stream0, std::vector<int>* pool) {
    std::vector<Plane> found;
    while (static_cast<int>(found.size()) < options.max_planes && pool->size() >= needed) {
      Plane p = RansacPlane(points, *pool, options, up, stream0 + found.size());
      if (p.inliers.size() < needed) break;
      *pool = Without(*pool, p.inliers);
      found.push_back(std::move(p));
    }
    return found;
  };
  // 1. Planes as the points have them, for gravity.
  std::vector<int> pool = all;
  const std::vector<Plane> free = sequence(Eigen::Vector3d::Zero(), 1, &pool);
  if (free.empty())
    ThrowError(
        "planes: the points support no plane: of {} points, none has {} within {:.3g} of one plane "
        "(--min-points {}, --min-fraction {:.3g}, --distance {:.3g})",
        points.size(), needed, options.distance, options.min_points, options.min_fraction, options.distance);
  // 2. Gravity: the largest plane near the hint, else the hint.
  PlaneSet set;
  set.points = static_cast<int>(points.size());
  set.up_from = "none";
  if (options.up_hint.squaredNorm() > 0) {
    const Eigen::Vector3d hint = options.up_hint.normalized();
    set.up = hint;
    set.up_from = "hint";
    for (const Plane& p : free)  // largest first
      if (std::acos(std::clamp(std::abs(p.normal.dot(hint)), 0.0, 1.0)) <= options.up_hint_deg * kDeg) {
        set.up = p.normal.dot(hint) >= 0 ? p.normal : Eigen::Vector3d(-p.normal);
        set.up_from = "plane";
        break;
      }
  }
  // 3. With gravity, the planes again from all the points, each hypothesis
  // turned to it before it is scored; without, the planes of step 1.
  if (set.up.squaredNorm() > 0) {
    pool = all;
    set.planes = sequence(set.up, 1001, &pool);
    if (set.planes.empty()) ThrowError("planes: no level or upright plane has {} points", needed);
  } else {
    set.planes = free;
  }
  Eigen::Vector3d eye = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& v : viewpoints) eye += v;
  if (!viewpoints.empty()) eye /= static_cast<double>(viewpoints.size());
  for (Plane& p : set.planes)
    if (!viewpoints.empty() && p.normal.dot(eye) < p.offset) {
      p.normal = -p.normal;
      p.offset = -p.offset;
    }
  // Slanted planes of step 1 that gravity left out are listed.
  if (set.up.squaredNorm() > 0 && !options.keep_slanted)
    for (Plane p : free) {
      Eigen::Vector3d n = p.normal;
      if (Turn(set.up, options, &n) == "slanted") {
        p.kind = "slanted";
        set.dropped.push_back(std::move(p));
      }
    }
  MergeParallel(points, options, &set);
  std::stable_sort(set.planes.begin(), set.planes.end(),
                   [](const Plane& a, const Plane& b) { return a.inliers.size() > b.inliers.size(); });
  set.unexplained = static_cast<int>(pool.size());
  return set;
}

namespace {

// A grid over one plane: (u, v) axes on it, origin at the inliers' corner.
struct PlaneGrid {
  Eigen::Vector3d u, v, origin;
  int nu = 0, nv = 0;
  std::vector<uint8_t> on;  // cell (i, j) at j * nu + i
  int At(int i, int j) const { return on[static_cast<size_t>(j * nu + i)]; }
};

PlaneGrid GridOf(const std::vector<Eigen::Vector3d>& points, const Plane& p, const PlaneMeshOptions& o,
                 std::vector<std::pair<int, int>>* cells) {
  PlaneGrid g;
  const Eigen::Vector3d n = p.normal;
  g.u = (std::abs(n.y()) < 0.9 ? n.cross(Eigen::Vector3d::UnitY()) : n.cross(Eigen::Vector3d::UnitX())).normalized();
  g.v = n.cross(g.u);
  double u0 = INFINITY, v0 = INFINITY, u1 = -INFINITY, v1 = -INFINITY;
  for (int i : p.inliers) {
    const Eigen::Vector3d& x = points[static_cast<size_t>(i)];
    u0 = std::min(u0, g.u.dot(x)), u1 = std::max(u1, g.u.dot(x));
    v0 = std::min(v0, g.v.dot(x)), v1 = std::max(v1, g.v.dot(x));
  }
  u0 -= o.grow + o.cell, v0 -= o.grow + o.cell;
  const double span = std::max(u1 - u0, v1 - v0) + o.grow + o.cell;
  if (span / o.cell > 4096)
    ThrowError("planes: a plane spans {:.3g} units, {:.0f} cells of {:.3g}: give a larger --cell", span, span / o.cell,
               o.cell);
  g.nu = static_cast<int>(std::ceil((u1 + o.grow + o.cell - u0) / o.cell));
  g.nv = static_cast<int>(std::ceil((v1 + o.grow + o.cell - v0) / o.cell));
  g.origin = p.offset * n + u0 * g.u + v0 * g.v;
  g.on.assign(static_cast<size_t>(g.nu * g.nv), 0);
  for (int i : p.inliers) {
    const Eigen::Vector3d d = points[static_cast<size_t>(i)] - g.origin;
    cells->emplace_back(std::clamp(static_cast<int>(g.u.dot(d) / o.cell), 0, g.nu - 1),
                        std::clamp(static_cast<int>(g.v.dot(d) / o.cell), 0, g.nv - 1));
  }
  return g;
}

// Cells within `grow` of an inlier's cell (a disc), then every cell the
// outside cannot reach (holes) filled.
void Occupy(const std::vector<std::pair<int, int>>& cells, const PlaneMeshOptions& o, PlaneGrid* g) {
  const int r = static_cast<int>(std::ceil(o.grow / o.cell));
  for (const auto& [ci, cj] : cells)
    for (int dj = -r; dj <= r; ++dj)
      for (int di = -r; di <= r; ++di) {
        const int i = ci + di, j = cj + dj;
        if (i >= 0 && j >= 0 && i < g->nu && j < g->nv && di * di + dj * dj <= r * r)
          g->on[static_cast<size_t>(j * g->nu + i)] = 1;
      }
  std::vector<uint8_t> outside(g->on.size(), 0);
  std::vector<int> stack;
  auto push = [&](int i, int j) {
    const auto k = static_cast<size_t>(j * g->nu + i);
    if (!g->on[k] && !outside[k]) outside[k] = 1, stack.push_back(static_cast<int>(k));
  };
  for (int i = 0; i < g->nu; ++i) push(i, 0), push(i, g->nv - 1);
  for (int j = 0; j < g->nv; ++j) push(0, j), push(g->nu - 1, j);
  while (!stack.empty()) {
    const int k = stack.back();
    stack.pop_back();
    const int i = k % g->nu, j = k / g->nu;
    if (i > 0) push(i - 1, j);
    if (i + 1 < g->nu) push(i + 1, j);
    if (j > 0) push(i, j - 1);
    if (j + 1 < g->nv) push(i, j + 1);
  }
  for (size_t k = 0; k < g->on.size(); ++k) g->on[k] = outside[k] ? 0 : 1;
}

// Keeps the 4-connected parts holding at least min_points inliers; returns
// the inliers kept.
int DropSmallParts(const std::vector<std::pair<int, int>>& cells, int min_points, PlaneGrid* g) {
  std::vector<int> part(g->on.size(), -1), count;
  for (size_t s = 0; s < g->on.size(); ++s) {
    if (!g->on[s] || part[s] >= 0) continue;
    const int id = static_cast<int>(count.size());
    count.push_back(0);
    std::vector<int> stack{static_cast<int>(s)};
    part[s] = id;
    while (!stack.empty()) {
      const int k = stack.back();
      stack.pop_back();
      const int i = k % g->nu, j = k / g->nu;
      const int next[4][2] = {{i - 1, j}, {i + 1, j}, {i, j - 1}, {i, j + 1}};
      for (const auto& [a, b] : next) {
        if (a < 0 || b < 0 || a >= g->nu || b >= g->nv) continue;
        const auto m = static_cast<size_t>(b * g->nu + a);
        if (g->on[m] && part[m] < 0) part[m] = id, stack.push_back(static_cast<int>(m));
      }
    }
  }
  for (const auto& [i, j] : cells) {
    const int id = part[static_cast<size_t>(j * g->nu + i)];
    if (id >= 0) ++count[static_cast<size_t>(id)];
  }
  int kept = 0;
  for (size_t k = 0; k < g->on.size(); ++k)
    if (g->on[k] && count[static_cast<size_t>(part[k])] < min_points) g->on[k] = 0;
  for (const auto& [i, j] : cells)
    if (g->At(i, j)) ++kept;
  return kept;
}

}  // namespace

Mesh MeshPlanes(const std::vector<Eigen::Vector3d>& points, const PlaneSet& set, const PlaneMeshOptions& options,
                std::vector<int>* kept) {
  if (!(options.cell > 0) || !(options.grow >= 0))
    throw UsageError("planes: --cell must be positive and --grow not negative");
  Mesh mesh;
  Mesh::Scalar plane_index{"plane", {}};
  if (kept) kept->clear();
  for (size_t pi = 0; pi < set.planes.size(); ++pi) {
    const Plane& p = set.planes[pi];
    std::vector<std::pair<int, int>> cells;
    PlaneGrid g = GridOf(points, p, options, &cells);
    Occupy(cells, options, &g);
    const int k = DropSmallParts(cells, options.min_points, &g);
    if (kept) kept->push_back(k);
    // Vertices at the corners of surface cells, shared between cells.
    std::vector<int> vertex(static_cast<size_t>((g.nu + 1) * (g.nv + 1)), -1);
    auto corner = [&](int i, int j) {
      int& id = vertex[static_cast<size_t>(j * (g.nu + 1) + i)];
      if (id < 0) {
        id = static_cast<int>(mesh.positions.size());
        mesh.positions.push_back((g.origin + options.cell * (i * g.u + j * g.v)).cast<float>());
        mesh.normals.push_back(p.normal.cast<float>());
        plane_index.values.push_back(static_cast<float>(pi));
      }
      return id;
    };
    for (int j = 0; j < g.nv; ++j)
      for (int i = 0; i < g.nu; ++i) {
        if (!g.At(i, j)) continue;
        const int a = corner(i, j), b = corner(i + 1, j), c = corner(i + 1, j + 1), d = corner(i, j + 1);
        // u x v = n: (a, b, c) runs counter-clockwise seen from the normal's side.
        mesh.triangles.emplace_back(a, b, c);
        mesh.triangles.emplace_back(a, c, d);
      }
  }
  mesh.scalars.push_back(std::move(plane_index));
  return mesh;
}

}  // namespace mr
