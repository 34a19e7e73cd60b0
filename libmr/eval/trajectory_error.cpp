#include "eval/trajectory_error.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <Eigen/SVD>

#include "core/error.h"
#include "core/parallel.h"
#include "core/sampling.h"

namespace mr {

namespace {

struct Stats {
  double rmse = 0, mean = 0, median = 0, max = 0, p90 = 0;
};

Stats Summarise(std::vector<double> e) {
  Stats s;
  if (e.empty()) return s;
  double sq = 0, sum = 0;
  for (double x : e) {
    sq += x * x;
    sum += x;
    s.max = std::max(s.max, x);
  }
  s.rmse = std::sqrt(sq / static_cast<double>(e.size()));
  s.mean = sum / static_cast<double>(e.size());
  std::sort(e.begin(), e.end());
  const size_t n = e.size();
  s.median = n % 2 ? e[n / 2] : 0.5 * (e[n / 2 - 1] + e[n / 2]);
  s.p90 = e[std::min(n - 1, static_cast<size_t>(0.9 * static_cast<double>(n)))];
  return s;
}

std::vector<std::pair<int, int>> Associate(const Trajectory& est, const Trajectory& ref, double max_dt) {
  std::vector<double> a, b;
  for (const auto& p : est.poses) a.push_back(p.timestamp);
  for (const auto& p : ref.poses) b.push_back(p.timestamp);
  return AssociateTimestamps(a, b, max_dt);
}

}  // namespace

Rigid3 AlignRigid(const std::vector<Eigen::Vector3d>& est, const std::vector<Eigen::Vector3d>& ref) {
  if (est.size() != ref.size() || est.empty()) ThrowError("rigid alignment needs equally many points (got {} and {})", est.size(), ref.size());
  Eigen::Vector3d me = Eigen::Vector3d::Zero(), mr_ = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < est.size(); ++i) {
    me += est[i];
    mr_ += ref[i];
  }
  me /= static_cast<double>(est.size());
  mr_ /= static_cast<double>(est.size());
  Eigen::Matrix3d W = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < est.size(); ++i) W += (ref[i] - mr_) * (est[i] - me).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(W, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) S(2, 2) = -1;
  const Eigen::Matrix3d R = svd.matrixU() * S * svd.matrixV().transpose();
  return Rigid3(Eigen::Quaterniond(R), mr_ - R * me);
}

AteResult ComputeAte(const Trajectory& estimate, const Trajectory& reference, double max_dt) {
  const auto pairs = Associate(estimate, reference, max_dt);
  if (pairs.size() < 3)
    ThrowError("only {} poses of the estimate are within {} s of a reference pose: too few for ATE", pairs.size(), max_dt);
  std::vector<Eigen::Vector3d> e, r;
  for (const auto& [i, j] : pairs) {
    e.push_back(estimate.poses[static_cast<size_t>(i)].world_from_cam.translation);
    r.push_back(reference.poses[static_cast<size_t>(j)].world_from_cam.translation);
  }
  AteResult res;
  res.ref_from_est = AlignRigid(e, r);
  std::vector<double> d;
  for (size_t k = 0; k < e.size(); ++k) d.push_back((res.ref_from_est * e[k] - r[k]).norm());
  const Stats s = Summarise(d);
  res.pairs = static_cast<int>(pairs.size());
  res.rmse = s.rmse;
  res.mean = s.mean;
  res.median = s.median;
  res.max = s.max;
  return res;
}

RpeResult ComputeRpe(const Trajectory& estimate, const Trajectory& reference, double delta, double max_dt) {
  const auto pairs = Associate(estimate, reference, max_dt);
  if (pairs.size() < 2) ThrowError("only {} poses of the estimate match the reference: too few for RPE", pairs.size());
  std::vector<double> times;
  for (const auto& [i, j] : pairs) times.push_back(reference.poses[static_cast<size_t>(j)].timestamp);
  std::vector<double> te, re;
  for (size_t a = 0; a < pairs.size(); ++a) {
    // The pair whose reference time is nearest times[a] + delta.
    const double want = times[a] + delta;
    auto it = std::lower_bound(times.begin(), times.end(), want);
    size_t b = static_cast<size_t>(it - times.begin());
    if (b == times.size() || (b > 0 && std::abs(times[b - 1] - want) < std::abs(times[b] - want))) --b;
    if (b <= a || b >= times.size()) continue;
    if (std::abs(times[b] - want) > std::max(max_dt, 0.5 * delta)) continue;
    const Rigid3& P0 = estimate.poses[static_cast<size_t>(pairs[a].first)].world_from_cam;
    const Rigid3& P1 = estimate.poses[static_cast<size_t>(pairs[b].first)].world_from_cam;
    const Rigid3& Q0 = reference.poses[static_cast<size_t>(pairs[a].second)].world_from_cam;
    const Rigid3& Q1 = reference.poses[static_cast<size_t>(pairs[b].second)].world_from_cam;
    const Rigid3 E = (Q0.Inverse() * Q1).Inverse() * (P0.Inverse() * P1);
    te.push_back(E.translation.norm());
    re.push_back(Eigen::AngleAxisd(E.rotation).angle() * 180 / M_PI);
  }
  if (te.empty()) ThrowError("no pose pairs are {} apart in time: RPE needs a smaller delta", delta);
  RpeResult r;
  r.pairs = static_cast<int>(te.size());
  const Stats t = Summarise(te), a = Summarise(re);
  r.trans_rmse = t.rmse;
  r.trans_mean = t.mean;
  r.trans_median = t.median;
  r.trans_max = t.max;
  r.rot_rmse_deg = a.rmse;
  r.rot_mean_deg = a.mean;
  return r;
}

namespace {

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5).
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

// Triangles bucketed in a uniform grid of `cell`-sized cells.
class TriangleGrid {
 public:
  TriangleGrid(const Mesh& m, double cell) : mesh_(m), cell_(cell) {
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      Eigen::AlignedBox3d box;
      for (int k = 0; k < 3; ++k) box.extend(m.positions[static_cast<size_t>(m.triangles[t][k])].cast<double>());
      const Eigen::Vector3i lo = Cell(box.min()), hi = Cell(box.max());
      for (int z = lo.z(); z <= hi.z(); ++z)
        for (int y = lo.y(); y <= hi.y(); ++y)
          for (int x = lo.x(); x <= hi.x(); ++x) cells_[Key({x, y, z})].push_back(static_cast<int32_t>(t));
    }
  }
  double Distance(const Eigen::Vector3d& p, double cutoff) const {
    const Eigen::Vector3i c = Cell(p);
    double best = cutoff * cutoff;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          auto it = cells_.find(Key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (int32_t t : it->second) {
            const Eigen::Vector3i& tri = mesh_.triangles[static_cast<size_t>(t)];
            const Eigen::Vector3d q = ClosestOnTriangle(p, mesh_.positions[static_cast<size_t>(tri[0])].cast<double>(),
                                                        mesh_.positions[static_cast<size_t>(tri[1])].cast<double>(),
                                                        mesh_.positions[static_cast<size_t>(tri[2])].cast<double>());
            best = std::min(best, (p - q).squaredNorm());
          }
        }
    return std::sqrt(best);
  }

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

std::vector<Eigen::Vector3d> SampleSurface(const Mesh& m, int64_t n, uint64_t seed, const Eigen::AlignedBox3f* region) {
  std::vector<double> cdf;
  double total = 0;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d a = m.positions[static_cast<size_t>(t[0])].cast<double>();
    const Eigen::Vector3d b = m.positions[static_cast<size_t>(t[1])].cast<double>();
    const Eigen::Vector3d c = m.positions[static_cast<size_t>(t[2])].cast<double>();
    total += 0.5 * (b - a).cross(c - a).norm();
    cdf.push_back(total);
  }
  std::vector<Eigen::Vector3d> out;
  if (total <= 0) return out;
  Pcg32 rng(seed, 7);
  for (int64_t i = 0; i < n; ++i) {
    const double u = rng.NextDouble() * total;
    const size_t t = std::min(cdf.size() - 1, static_cast<size_t>(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin()));
    double r1 = std::sqrt(rng.NextDouble()), r2 = rng.NextDouble();
    const auto& tri = m.triangles[t];
    const Eigen::Vector3d p = (1 - r1) * m.positions[static_cast<size_t>(tri[0])].cast<double>() +
                              r1 * (1 - r2) * m.positions[static_cast<size_t>(tri[1])].cast<double>() +
                              r1 * r2 * m.positions[static_cast<size_t>(tri[2])].cast<double>();
    if (region && !region->contains(p.cast<float>())) continue;
    out.push_back(p);
  }
  return out;
}

SurfaceDistance Distances(const std::vector<Eigen::Vector3d>& pts, const TriangleGrid& grid, double threshold,
                          double cutoff) {
  std::vector<double> d(pts.size());
  ParallelFor(0, static_cast<int64_t>(pts.size()),
              [&](int64_t i) { d[static_cast<size_t>(i)] = grid.Distance(pts[static_cast<size_t>(i)], cutoff); });
  SurfaceDistance s;
  s.samples = static_cast<int64_t>(d.size());
  int64_t within = 0;
  for (double x : d) within += x <= threshold;
  s.within = d.empty() ? 0 : static_cast<double>(within) / static_cast<double>(d.size());
  const Stats st = Summarise(d);
  s.mean = st.mean;
  s.median = st.median;
  s.rmse = st.rmse;
  s.p90 = st.p90;
  return s;
}

}  // namespace

MeshErrorResult CompareMeshes(const Mesh& estimate, const Mesh& reference, double threshold, double cutoff,
                              int64_t samples, uint64_t seed, const Eigen::AlignedBox3f* region) {
  MeshErrorResult r;
  r.threshold = threshold;
  r.cutoff = cutoff;
  const TriangleGrid ref_grid(reference, cutoff), est_grid(estimate, cutoff);
  r.accuracy = Distances(SampleSurface(estimate, samples, seed, region), ref_grid, threshold, cutoff);
  r.completeness = Distances(SampleSurface(reference, samples, seed + 1, region), est_grid, threshold, cutoff);
  const double p = r.accuracy.within, c = r.completeness.within;
  r.fscore = p + c > 0 ? 2 * p * c / (p + c) : 0;
  return r;
}

}  // namespace mr
