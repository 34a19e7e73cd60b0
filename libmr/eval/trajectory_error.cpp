#include "eval/trajectory_error.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <Eigen/SVD>

#include "core/error.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "geometry/closest_point.h"

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
  if (est.size() != ref.size() || est.empty())
    ThrowError("rigid alignment needs equally many points (got {} and {})", est.size(), ref.size());
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
    ThrowError("only {} poses of the estimate are within {} s of a reference pose: too few for ATE", pairs.size(),
               max_dt);
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
    const size_t t =
        std::min(cdf.size() - 1, static_cast<size_t>(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin()));
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
