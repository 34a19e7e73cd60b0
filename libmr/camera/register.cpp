#include "camera/register.h"

#include "core/check.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <spdlog/spdlog.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <set>

#include "core/color.h"
#include "core/error.h"
#include "core/json.h"
#include "core/math.h"
#include "core/process.h"
#include "geometry/closest_point.h"

extern char** environ;

namespace mr {

Rigid3 Similarity3::Apply(const Rigid3& world_from_cam) const {
  return Rigid3(rotation * world_from_cam.rotation, Apply(world_from_cam.translation));
}

namespace {

// Residual of one pair: the centre (3) and the orientation (3, scaled).
struct PairResidual {
  PairResidual(const PosePair& p, double weight) : ca(p.a.translation), cb(p.b.translation), w(weight) {
    // R_b R_a^T is what R should be; the residual is log(R R_a R_b^T).
    Ra = p.a.rotation.toRotationMatrix();
    Rb = p.b.rotation.toRotationMatrix();
  }
  template <typename T>
  bool operator()(const T* r, const T* log_s, const T* t, T* res) const {
    T p[3] = {T(ca.x()), T(ca.y()), T(ca.z())}, q[3];
    ceres::AngleAxisRotatePoint(r, p, q);
    const T s = exp(log_s[0]);
    for (int i = 0; i < 3; ++i) res[i] = s * q[i] + t[i] - T(cb[i]);
    if (w > 0) {
      T R[9];
      ceres::AngleAxisToRotationMatrix(r, R);  // column major
      // M = R * Ra * Rb^T
      T M[9];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          T acc = T(0);
          for (int k = 0; k < 3; ++k) {
            T rak = T(0);  // (Ra Rb^T)(k, j)
            for (int l = 0; l < 3; ++l) rak += T(Ra(k, l) * Rb(j, l));
            acc += R[k * 3 + i] * rak;  // R(i, k), column major
          }
          M[j * 3 + i] = acc;  // column major
        }
      T aa[3];
      ceres::RotationMatrixToAngleAxis(M, aa);
      for (int i = 0; i < 3; ++i) res[3 + i] = T(w) * aa[i];
    } else {
      for (int i = 0; i < 3; ++i) res[3 + i] = T(0);
    }
    return true;
  }
  Eigen::Vector3d ca, cb;
  Eigen::Matrix3d Ra, Rb;
  double w;
};

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

SimilarityFit FitSimilarity(const std::vector<PosePair>& pairs, const SimilarityFitOptions& o) {
  const size_t n = pairs.size();
  if (n < 3) throw Error(FileLoc{}, fmt::format("a similarity needs at least 3 corresponding cameras, got {}", n));
  // Start: rotation from the chordal mean of R_b R_a^T (robust to collinear
  // centres), then scale and translation by least squares on the centres.
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d ma = Eigen::Vector3d::Zero(), mb = Eigen::Vector3d::Zero();
  for (const auto& p : pairs) {
    sum += p.b.rotation.toRotationMatrix() * p.a.rotation.toRotationMatrix().transpose();
    ma += p.a.translation;
    mb += p.b.translation;
  }
  ma /= static_cast<double>(n);
  mb /= static_cast<double>(n);
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  const Eigen::Matrix3d R0 = svd.matrixU() * D * svd.matrixV().transpose();
  double num = 0, den = 0;
  for (const auto& p : pairs) {
    const Eigen::Vector3d da = R0 * (p.a.translation - ma), db = p.b.translation - mb;
    num += da.dot(db);
    den += da.squaredNorm();
  }
  if (!(den > 1e-18) || !(num > 0))
    throw Error(FileLoc{},
                "the cameras' centres do not fix the scale (they "
                "coincide, or run opposite ways in the two frames)");
  const double s0 = num / den;
  const Eigen::Vector3d t0 = mb - s0 * R0 * ma;

  Eigen::AngleAxisd aa0(R0);
  double r[3] = {aa0.angle() * aa0.axis().x(), aa0.angle() * aa0.axis().y(), aa0.angle() * aa0.axis().z()};
  double log_s = std::log(s0);
  double t[3] = {t0.x(), t0.y(), t0.z()};
  ceres::Problem problem;
  // Cauchy loss on the stacked residual; its scale mixes the two (centre in
  // metres, orientation in weight x radians).
  const double w = o.rotation_weight_m;
  const double loss = std::hypot(o.centre_loss_m, w * o.rotation_loss_deg * kDegToRad);
  for (const auto& p : pairs)
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PairResidual, 6, 3, 1, 3>(new PairResidual(p, w)),
                             new ceres::CauchyLoss(loss), r, &log_s, t);
  // The robust loss makes every residual cheap far away, and a scale near 0
  // maps all centres to one point: keep the scale within x2 of its start.
  problem.SetParameterLowerBound(&log_s, 0, std::log(s0) - std::log(2.0));
  problem.SetParameterUpperBound(&log_s, 0, std::log(s0) + std::log(2.0));
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 100;
  so.num_threads = 1;  // tiny problem; deterministic
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);

  SimilarityFit fit;
  fit.iterations = static_cast<int>(summary.iterations.size());
  const Eigen::Vector3d rv(r[0], r[1], r[2]);
  fit.b_from_a.rotation = rv.norm() > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(rv.norm(), rv.normalized()))
                                        : Eigen::Quaterniond::Identity();
  fit.b_from_a.scale = std::exp(log_s);
  fit.b_from_a.translation = Eigen::Vector3d(t[0], t[1], t[2]);
  double se = 0, sr = 0;
  for (const auto& p : pairs) {
    const Rigid3 moved = fit.b_from_a.Apply(p.a);
    const double e = (moved.translation - p.b.translation).norm();
    const double a = moved.rotation.angularDistance(p.b.rotation) / kDegToRad;
    fit.centre_residual_m.push_back(e);
    fit.rotation_residual_deg.push_back(a);
    se += e * e;
    sr += a * a;
  }
  fit.centre_rmse_m = std::sqrt(se / static_cast<double>(n));
  fit.rotation_rmse_deg = std::sqrt(sr / static_cast<double>(n));
  fit.centre_median_m = Median(fit.centre_residual_m);
  fit.start_scale = s0;
  fit.scale_at_bound = std::abs(std::log(fit.b_from_a.scale / s0)) > std::log(2.0) - 1e-6;
  return fit;
}

namespace {

// n . (s R a + t - q): the point's distance along the mesh's normal.
struct PointPlaneResidual {
  PointPlaneResidual(const Eigen::Vector3d& point, const Eigen::Vector3d& closest, const Eigen::Vector3d& normal)
      : a(point), q(closest), n(normal) {}
  template <typename T>
  bool operator()(const T* r, const T* log_s, const T* t, T* res) const {
    T p[3] = {T(a.x()), T(a.y()), T(a.z())}, x[3];
    ceres::AngleAxisRotatePoint(r, p, x);
    const T s = exp(log_s[0]);
    res[0] = T(0);
    for (int i = 0; i < 3; ++i) res[0] += T(n[i]) * (s * x[i] + t[i] - T(q[i]));
    return true;
  }
  Eigen::Vector3d a, q, n;
};

}  // namespace

MeshFit RefineSimilarityToMesh(const std::vector<Eigen::Vector3d>& points, const Mesh& mesh, const Similarity3& start,
                               const MeshFitOptions& o) {
  const TriangleGrid grid(mesh, o.gate_m);
  Eigen::AngleAxisd aa0(start.rotation);
  double r[3] = {aa0.angle() * aa0.axis().x(), aa0.angle() * aa0.axis().y(), aa0.angle() * aa0.axis().z()};
  double log_s = std::log(start.scale);
  double t[3] = {start.translation.x(), start.translation.y(), start.translation.z()};
  auto current = [&] {
    Similarity3 s;
    const Eigen::Vector3d rv(r[0], r[1], r[2]);
    s.rotation = rv.norm() > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(rv.norm(), rv.normalized()))
                               : Eigen::Quaterniond::Identity();
    s.scale = std::exp(log_s);
    s.translation = Eigen::Vector3d(t[0], t[1], t[2]);
    return s;
  };
  MeshFit fit;
  fit.points = static_cast<int>(points.size());
  {
    std::vector<double> d0;
    for (const auto& a : points) {
      const ClosestPoint c = grid.Closest(start.Apply(a), o.gate_m);
      if (c.triangle >= 0) d0.push_back(c.distance);
    }
    fit.start_median_m = Median(d0);
    fit.start_inliers = static_cast<int>(d0.size());
  }
  for (int it = 0; it < o.max_iterations; ++it) {
    const Similarity3 s = current();
    ceres::Problem problem;
    int used = 0;
    for (const auto& a : points) {
      const ClosestPoint c = grid.Closest(s.Apply(a), o.gate_m);
      if (c.triangle < 0) continue;
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<PointPlaneResidual, 1, 3, 1, 3>(new PointPlaneResidual(a, c.point, c.normal)),
          new ceres::CauchyLoss(o.loss_m), r, &log_s, t);
      ++used;
    }
    if (used < 6)
      throw Error(FileLoc{}, fmt::format("only {} of {} points lie within {} m of the "
                                         "mesh: the start is too far off "
                                         "(give a better initial similarity)",
                                         used, points.size(), o.gate_m));
    // Point-to-plane distances shrink with the scale: without a bound,
    // a poor start can collapse every point onto one surface.
    problem.SetParameterLowerBound(&log_s, 0, std::log(start.scale) - std::log(1.25));
    problem.SetParameterUpperBound(&log_s, 0, std::log(start.scale) + std::log(1.25));
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 10;
    so.num_threads = 1;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    fit.iterations = it + 1;
    const Similarity3 after = current();
    double moved = 0;
    for (const auto& a : points) moved = std::max(moved, (after.Apply(a) - s.Apply(a)).norm());
    if (moved < 1e-5) break;  // a hundredth of a millimetre: settled
  }
  fit.b_from_a = current();
  if (std::abs(std::log(fit.b_from_a.scale / start.scale)) > std::log(1.25) - 1e-6)
    throw Error(FileLoc{}, fmt::format("the mesh alignment ran to the bound of its scale "
                                       "(start x 1.25^{:+.0f}): the start "
                                       "is too far off (give a better initial similarity)",
                                       std::log(fit.b_from_a.scale / start.scale) / std::log(1.25)));
  std::vector<double> d;
  int close = 0;
  double se = 0;
  for (const auto& a : points) {
    const ClosestPoint c = grid.Closest(fit.b_from_a.Apply(a), o.gate_m);
    if (c.triangle < 0) continue;
    d.push_back(c.distance);
    se += c.distance * c.distance;
    close += c.distance <= 0.05;
  }
  fit.inliers = static_cast<int>(d.size());
  fit.median_m = Median(d);
  fit.rmse_m = d.empty() ? 0 : std::sqrt(se / static_cast<double>(d.size()));
  fit.within_5cm = points.empty() ? 0 : static_cast<double>(close) / static_cast<double>(points.size());
  return fit;
}

int FrameNumberOf(const std::string& name) {
  const std::string stem = fs::path(name).stem().string();
  int end = static_cast<int>(stem.size());
  while (end > 0 && !std::isdigit(static_cast<unsigned char>(stem[static_cast<size_t>(end - 1)]))) --end;
  int begin = end;
  while (begin > 0 && std::isdigit(static_cast<unsigned char>(stem[static_cast<size_t>(begin - 1)]))) --begin;
  if (begin == end || end - begin > 9) return -1;
  return std::stoi(stem.substr(static_cast<size_t>(begin), static_cast<size_t>(end - begin)));
}

namespace {

Rigid3 Interpolate(const Rigid3& a, const Rigid3& b, double u) {
  return Rigid3(a.rotation.slerp(u, b.rotation), (1 - u) * a.translation + u * b.translation);
}

}  // namespace

namespace {

Trajectory ReadPoses(const fs::path& p) { return fs::is_directory(p) ? Read7ScenesFolder(p) : ReadTum(p); }

}  // namespace

namespace {

// The alignment refined by COLMAP's well-observed 3D points against the
// room's mesh, from `start`.
Similarity3 RefineByMesh(const ColmapModel& model, const RegisterOptions& o, const Similarity3& start, Report* report) {
  Similarity3 world_from_colmap = start;
  std::vector<Eigen::Vector3d> pts;
  for (const auto& [id, p] : model.points3d)
    if (static_cast<int>(p.track.size()) >= o.mesh_fit.min_track && p.error <= o.mesh_fit.max_error_px)
      pts.push_back(p.xyz);
  if (pts.size() < 6)
    throw Error(FileLoc{}, fmt::format("the COLMAP model has {} well-observed 3D points "
                                       "(points3D.txt; track >= {}, "
                                       "error <= {} px): too few to align to the mesh",
                                       pts.size(), o.mesh_fit.min_track, o.mesh_fit.max_error_px));
  const MeshFit mf = RefineSimilarityToMesh(pts, *o.mesh, world_from_colmap, o.mesh_fit);
  world_from_colmap = mf.b_from_a;
  report->SetMetric("alignment.mesh.points", mf.points);
  report->SetMetric("alignment.mesh.inliers", mf.inliers);
  report->SetMetric("alignment.mesh.median_m", mf.median_m);
  report->SetMetric("alignment.mesh.rmse_m", mf.rmse_m);
  report->SetMetric("alignment.mesh.within_5cm", mf.within_5cm);
  report->SetMetric("alignment.mesh.iterations", mf.iterations);
  report->SetMetric("alignment.mesh.start_median_m", mf.start_median_m);
  report->SetMetric("alignment.mesh.start_inliers", mf.start_inliers);
  report->SetMetric("alignment.scale", mf.b_from_a.scale);
  return world_from_colmap;
}

// The well-observed points in the room's frame (RegisterOptions::out_points).
void WritePoints(const ColmapModel& model, const Similarity3& world_from_colmap, const RegisterOptions& o,
                 Report* report) {
  Mesh cloud;
  Mesh::Scalar track{"track", {}}, error{"error_px", {}};
  for (const auto& [id, p] : model.points3d) {
    if (static_cast<int>(p.track.size()) < o.mesh_fit.min_track || !(p.error <= o.mesh_fit.max_error_px)) continue;
    cloud.positions.push_back(world_from_colmap.Apply(p.xyz).cast<float>());
    Eigen::Vector3f c;
    for (int k = 0; k < 3; ++k) c[k] = SrgbToLinear(static_cast<float>(p.rgb[k]) / 255.0f);
    cloud.colors.push_back(c);
    track.values.push_back(static_cast<float>(p.track.size()));
    error.values.push_back(static_cast<float>(p.error));
  }
  if (cloud.positions.empty())
    throw Error(FileLoc{}, fmt::format("the COLMAP model has no well-observed 3D points to write (track >= {}, "
                                       "error <= {} px)",
                                       o.mesh_fit.min_track, o.mesh_fit.max_error_px));
  cloud.scalars = {std::move(track), std::move(error)};
  WritePly(o.out_points, cloud, "COLMAP's 3D points in the room's frame (mr-register)");
  report->SetMetric("points.written", static_cast<int64_t>(cloud.positions.size()));
  report->SetMetric("points.in_model", static_cast<int64_t>(model.points3d.size()));
  report->AddOutput(o.out_points.string());
}

// The registered frames' observations of the well-observed points, the
// points moved into the room's frame (RegisterOptions::out_observations).
void WriteObservations(const ColmapModel& model, const Similarity3& world_from_colmap, const RegisterOptions& o,
                       Report* report) {
  Json frames = Json::object();
  int64_t n = 0;
  for (const auto& [id, im] : model.images) {
    const int f = FrameNumberOf(im.name);
    if (f < 0) continue;
    Json list = Json::array();
    for (const ColmapObservation& ob : im.points2d) {
      const auto it = model.points3d.find(ob.point3d_id);
      if (ob.point3d_id < 0 || it == model.points3d.end()) continue;
      const ColmapPoint3D& p = it->second;
      if (static_cast<int>(p.track.size()) < o.mesh_fit.min_track || !(p.error <= o.mesh_fit.max_error_px)) continue;
      const Eigen::Vector3d X = world_from_colmap.Apply(p.xyz);
      list.push_back({ob.xy.x(), ob.xy.y(), X.x(), X.y(), X.z()});
      ++n;
    }
    frames[std::to_string(f)] = std::move(list);
  }
  WriteTextFile(o.out_observations,
                Json({{"version", 1},
                      {"comment",
                       "COLMAP's observations of its well-observed points, the points in the room's "
                       "frame (mr-register)"},
                      {"frames", frames}})
                        .dump() +
                    "\n");
  report->SetMetric("points.observations_written", n);
  report->AddOutput(o.out_observations.string());
}

// Without a trajectory nothing checks COLMAP's model; a video's camera
// moves smoothly, so a run of steps between consecutive registered frames
// far longer than the median is a model whose scale folds (seen on 30
// kitchen frames with sequential matching: 3.4x, where a consistent model's
// largest is 1.6x).  Reported, and warned of above kStepRatioWarn.
constexpr double kStepRatioWarn = 2.5;
void CheckSteps(const std::map<int, Rigid3>& poses, Report* report) {
  std::vector<double> steps;
  std::vector<int> at;
  for (auto a = poses.begin(), b = std::next(a); b != poses.end(); ++a, ++b) {
    steps.push_back((b->second.translation - a->second.translation).norm() / (b->first - a->first));
    at.push_back(a->first);
  }
  if (steps.size() < 4) return;
  std::vector<double> sorted = steps;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  const double median = sorted[sorted.size() / 2];
  if (!(median > 0)) return;
  const auto worst = std::max_element(steps.begin(), steps.end()) - steps.begin();
  const double ratio = steps[static_cast<size_t>(worst)] / median;
  report->SetMetric("model.step_ratio_max", ratio);
  if (ratio > kStepRatioWarn)
    report->Warn(
        fmt::format("COLMAP's model may fold its scale: the camera's step after frame {} is {:.1f}x the "
                    "median step (no trajectory checks the model; exhaustive matching, or another seed, "
                    "may build a consistent one)",
                    at[static_cast<size_t>(worst)], ratio));
}

// Every frame's pose: registered ones moved, the rest interpolated.
Trajectory EveryFramePose(const std::map<int, Rigid3>& colmap_poses, const Similarity3& world_from_colmap,
                          int frames_wanted, Report* report) {
  const int last = colmap_poses.rbegin()->first;
  const int frames = frames_wanted > 0 ? frames_wanted : last + 1;
  Trajectory out;
  std::vector<int> filled;
  for (int f = 0; f < frames; ++f) {
    Rigid3 pose;
    auto hi = colmap_poses.lower_bound(f);
    if (hi != colmap_poses.end() && hi->first == f) {
      pose = hi->second;
    } else {
      filled.push_back(f);
      if (hi == colmap_poses.begin())
        pose = hi->second;
      else if (hi == colmap_poses.end())
        pose = std::prev(hi)->second;
      else {
        const auto lo = std::prev(hi);
        pose = Interpolate(lo->second, hi->second, static_cast<double>(f - lo->first) / (hi->first - lo->first));
      }
    }
    out.poses.push_back({static_cast<double>(f), world_from_colmap.Apply(pose)});
  }
  report->SetMetric("frames", frames);
  report->SetMetric("registered", static_cast<int>(colmap_poses.size()));
  if (!filled.empty()) {
    report->Warn(
        fmt::format("{} of {} frames were not registered by COLMAP; "
                    "their poses are interpolated",
                    filled.size(), frames));
    report->SetMetric("interpolated_frames", filled);
  }
  return out;
}

// The poses' error against the truth's (same timestamps).
void ReportPoseError(const Trajectory& out, const fs::path& truth_file, Report* report) {
  const Trajectory truth = ReadPoses(truth_file);
  double se = 0, sr = 0;
  int n = 0;
  for (const auto& p : out.poses)
    for (const auto& tp : truth.poses)
      if (std::abs(tp.timestamp - p.timestamp) < 1e-6) {
        se += (p.world_from_cam.translation - tp.world_from_cam.translation).squaredNorm();
        const double a = p.world_from_cam.rotation.angularDistance(tp.world_from_cam.rotation) / kDegToRad;
        sr += a * a;
        ++n;
      }
  if (n == 0) ThrowErrorAt(FileLoc{truth_file.string()}, "no pose with a frame number's timestamp");
  report->SetMetric("pose_error.frames", n);
  report->SetMetric("pose_error.centre_rmse_m", std::sqrt(se / n));
  report->SetMetric("pose_error.rotation_rmse_deg", std::sqrt(sr / n));
  report->AddInput(truth_file.string());
}

}  // namespace

void RegisterOptions::Check() const {
  if (match != "auto" && match != "timestamp" && match != "index")
    throw UsageError(fmt::format("--match \"{}\": timestamp, index or auto", match));
  if (mesh && !trajectory && !initial)
    throw UsageError("aligning to a mesh needs a start: --trajectory, or --initial (a rough similarity)");
  if (!(max_rotation_rmse_deg > 0) || !(max_centre_median_fraction > 0))
    throw UsageError("the alignment's limits must be positive");
}

void AlignColmapModel(const ColmapModel& model, const RegisterOptions& o, Report* report) {
  o.Check();
  if (model.images.empty()) throw Error(FileLoc{}, "the COLMAP model has no registered images");
  // Registered frames: frame number -> world_from_cam in COLMAP's frame.
  std::map<int, Rigid3> colmap_poses;
  std::set<int64_t> camera_ids;
  for (const auto& [id, im] : model.images) {
    const int f = FrameNumberOf(im.name);
    if (f < 0) throw Error(FileLoc{}, fmt::format("image {} has no frame number in its name", im.name));
    if (colmap_poses.count(f)) throw Error(FileLoc{}, fmt::format("two images of frame {} (one is {})", f, im.name));
    colmap_poses[f] = im.cam_from_world.Inverse();
    camera_ids.insert(im.camera_id);
  }
  if (camera_ids.size() != 1)
    throw Error(FileLoc{}, fmt::format("the video's frames use {} COLMAP cameras; one "
                                       "camera is expected (single_camera)",
                                       camera_ids.size()));
  const ColmapCamera& cam = model.cameras.at(*camera_ids.begin());
  Similarity3 world_from_colmap;
  if (o.trajectory) {
    const Trajectory traj = ReadPoses(*o.trajectory);
    std::vector<PosePair> by_timestamp, by_index;
    for (const auto& [f, pose] : colmap_poses) {
      for (const auto& tp : traj.poses)
        if (std::abs(tp.timestamp - f) < 1e-6) {
          by_timestamp.push_back({pose, tp.world_from_cam});
          break;
        }
      if (f < static_cast<int>(traj.poses.size()))
        by_index.push_back({pose, traj.poses[static_cast<size_t>(f)].world_from_cam});
    }
    std::string match = o.match;
    if (match == "auto") match = by_timestamp.size() >= by_index.size() ? "timestamp" : "index";
    const auto& pairs = match == "timestamp" ? by_timestamp : by_index;
    if (pairs.size() < 3)
      ThrowErrorAt(FileLoc{o.trajectory->string()},
                   "only {} registered frames meet a pose of the trajectory (match: {})", pairs.size(), match);
    const SimilarityFit fit = FitSimilarity(pairs, o.fit);
    world_from_colmap = fit.b_from_a;
    // A COLMAP model that does not fit the trajectory (a broken
    // reconstruction; RANSAC occasionally builds one) is refused rather
    // than written: the scale ran to its bound, the orientations disagree,
    // or the centres miss by more than a tenth of the path's extent.
    Eigen::AlignedBox3d extent;
    for (const auto& pp : pairs) extent.extend(pp.b.translation);
    const double size = extent.diagonal().norm();
    std::string bad;
    if (fit.scale_at_bound)
      bad = fmt::format("the scale ran from {:.4g} to its bound {:.4g}", fit.start_scale, fit.b_from_a.scale);
    else if (fit.rotation_rmse_deg > o.max_rotation_rmse_deg)
      bad = fmt::format("orientations differ by {:.1f} degrees RMS (at most {})", fit.rotation_rmse_deg,
                        o.max_rotation_rmse_deg);
    else if (fit.centre_median_m > o.max_centre_median_fraction * size)
      bad = fmt::format(
          "camera centres miss by {:.3f} m (median; at most {} of "
          "the path's extent {:.3f} m)",
          fit.centre_median_m, o.max_centre_median_fraction, size);
    if (!bad.empty())
      throw AlignmentError(FileLoc{o.trajectory->string()}, "the COLMAP model does not fit this trajectory: " + bad);
    report->SetMetric("alignment.match", match);
    report->SetMetric("alignment.pairs", static_cast<int>(pairs.size()));
    report->SetMetric("alignment.scale", fit.b_from_a.scale);
    report->SetMetric("alignment.centre_rmse_m", fit.centre_rmse_m);
    report->SetMetric("alignment.centre_median_m", fit.centre_median_m);
    report->SetMetric("alignment.centre_max_m",
                      *std::max_element(fit.centre_residual_m.begin(), fit.centre_residual_m.end()));
    report->SetMetric("alignment.rotation_rmse_deg", fit.rotation_rmse_deg);
    report->SetMetric("alignment.iterations", fit.iterations);
    report->AddInput(o.trajectory->string());
  } else if (o.initial) {
    world_from_colmap = *o.initial;
  } else {
    MR_CHECK(!o.mesh);  // RegisterOptions::Check
    report->Skip("alignment",
                 "no trajectory given: the poses stay in COLMAP's "
                 "frame (arbitrary scale)");
    CheckSteps(colmap_poses, report);
  }
  if (o.mesh) world_from_colmap = RefineByMesh(model, o, world_from_colmap, report);
  const Trajectory out = EveryFramePose(colmap_poses, world_from_colmap, o.frames, report);
  if (o.truth) ReportPoseError(out, *o.truth, report);
  std::error_code ec;
  for (const fs::path& f : {o.out_poses, o.out_camera})
    if (!f.empty() && !f.parent_path().empty()) fs::create_directories(f.parent_path(), ec);
  WriteTum(o.out_poses, out);
  report->AddOutput(o.out_poses.string());
  if (!o.out_points.empty()) WritePoints(model, world_from_colmap, o, report);
  if (!o.out_observations.empty()) WriteObservations(model, world_from_colmap, o, report);
  if (!o.out_camera.empty()) {
    ToCameraModel(cam).Write(o.out_camera, o.note);
    report->AddOutput(o.out_camera.string());
  }
}

// ---------------------------------------------------------------------------

void ColmapRunOptions::Check() const {
  if (matcher != "sequential" && matcher != "exhaustive")
    throw UsageError(fmt::format("matcher \"{}\": sequential or exhaustive", matcher));
  if (overlap < 1) throw UsageError(fmt::format("--overlap {} must be at least 1", overlap));
  if (!(timeout_s >= 0)) throw UsageError("--colmap-timeout must be 0 (none) or positive");
}

ColmapModel RunColmap(const std::vector<fs::path>& images, const ColmapRunOptions& o, Report* report) {
  if (images.size() < 3) throw Error(FileLoc{}, fmt::format("COLMAP needs at least 3 frames, got {}", images.size()));
  o.Check();
  const fs::path ws = o.workspace;
  std::error_code ec;
  fs::remove_all(ws / "sparse", ec);
  fs::remove(ws / "database.db", ec);
  fs::create_directories(ws / "sparse", ec);
  fs::create_directories(ws / "text", ec);
  if (!fs::is_directory(ws / "sparse")) ThrowErrorAt(FileLoc{ws.string()}, "cannot create the COLMAP workspace");
  // The frames by name, relative to their (common) folder.
  const fs::path dir = images.front().parent_path();
  std::string list;
  for (const auto& f : images) {
    if (f.parent_path() != dir)
      ThrowErrorAt(FileLoc{f.string()}, "the frames must share one folder ({})", dir.string());
    list += f.filename().string() + "\n";
  }
  WriteTextFile(ws / "images.txt", list);
  const fs::path log = ws / "colmap.log";
  fs::remove(log, ec);
  auto step = [&](const std::string& name, std::vector<std::string> args) {
    args.insert(args.begin(), {o.colmap, name});
    ScopedTimer t(report, "colmap " + name);
    const int rc = RunProcess(args, log, true, o.timeout_s);
    if (rc == kProcessTimedOut)
      ThrowErrorAt(FileLoc{log.string()},
                   "colmap {} ran past the time limit of {} s and was ended; its output is in "
                   "this log",
                   name, o.timeout_s);
    if (rc != 0)
      ThrowErrorAt(FileLoc{log.string()}, "colmap {} failed ({}{}); its output is in this log", name,
                   DescribeExitStatus(rc), rc == 127 ? ": apt install colmap" : "");
  };
  const std::string db = (ws / "database.db").string();
  std::vector<std::string> fe = {"--database_path",
                                 db,
                                 "--image_path",
                                 dir.string(),
                                 "--image_list_path",
                                 (ws / "images.txt").string(),
                                 "--ImageReader.single_camera",
                                 "1",
                                 "--SiftExtraction.use_gpu",
                                 "0",
                                 "--SiftExtraction.num_threads",
                                 "-1",
                                 "--random_seed",
                                 std::to_string(o.seed)};
  bool fixed = false;
  if (o.camera) {
    const CameraModel m = CameraModel::Read(*o.camera);
    const auto& k = m.intrinsics();
    // mrcal's pixel centres are at integers, COLMAP's at +0.5.
    if (m.lensmodel() == "LENSMODEL_PINHOLE") {
      fe.insert(fe.end(), {"--ImageReader.camera_model", "PINHOLE", "--ImageReader.camera_params",
                           fmt::format("{},{},{},{}", k[0], k[1], k[2] + 0.5, k[3] + 0.5)});
      fixed = true;
    } else if (m.lensmodel() == "LENSMODEL_OPENCV4") {
      fe.insert(fe.end(),
                {"--ImageReader.camera_model", "OPENCV", "--ImageReader.camera_params",
                 fmt::format("{},{},{},{},{},{},{},{}", k[0], k[1], k[2] + 0.5, k[3] + 0.5, k[4], k[5], k[6], k[7])});
      fixed = true;
    } else {
      report->Warn(
          fmt::format("{}: COLMAP has no equivalent of {}; COLMAP "
                      "estimates the intrinsics (OPENCV)",
                      o.camera->string(), m.lensmodel()));
      fe.insert(fe.end(), {"--ImageReader.camera_model", "OPENCV"});
    }
  } else {
    fe.insert(fe.end(), {"--ImageReader.camera_model", "OPENCV"});
  }
  step("feature_extractor", fe);
  if (o.matcher == "sequential")
    step("sequential_matcher", {"--database_path", db, "--SiftMatching.use_gpu", "0", "--SequentialMatching.overlap",
                                std::to_string(o.overlap), "--random_seed", std::to_string(o.seed)});
  else
    step("exhaustive_matcher",
         {"--database_path", db, "--SiftMatching.use_gpu", "0", "--random_seed", std::to_string(o.seed)});
  std::vector<std::string> mapper = {
      "--database_path",      db,   "--image_path",  dir.string(),          "--output_path", (ws / "sparse").string(),
      "--Mapper.num_threads", "-1", "--random_seed", std::to_string(o.seed)};
  if (fixed)
    mapper.insert(mapper.end(), {"--Mapper.ba_refine_focal_length", "0", "--Mapper.ba_refine_principal_point", "0",
                                 "--Mapper.ba_refine_extra_params", "0"});
  step("mapper", mapper);
  // The largest model (COLMAP may split a video into several).
  fs::path best;
  size_t best_images = 0;
  int models = 0;
  for (const auto& e : fs::directory_iterator(ws / "sparse")) {
    if (!e.is_directory()) continue;
    ++models;
    const fs::path txt = ws / "text" / e.path().filename();
    fs::create_directories(txt, ec);
    step("model_converter", {"--input_path", e.path().string(), "--output_path", txt.string(), "--output_type", "TXT"});
    const ColmapModel m = ReadColmapText(txt);
    if (m.images.size() > best_images) {
      best_images = m.images.size();
      best = txt;
    }
  }
  if (best.empty()) ThrowErrorAt(FileLoc{log.string()}, "COLMAP registered no model from {} frames", images.size());
  report->SetMetric("colmap.models", models);
  report->SetMetric("colmap.registered", static_cast<int>(best_images));
  report->SetMetric("colmap.frames", static_cast<int>(images.size()));
  report->SetMetric("colmap.intrinsics", fixed ? "fixed to the given camera model" : "estimated by COLMAP");
  if (models > 1)
    report->Warn(
        fmt::format("COLMAP split the frames into {} models; the "
                    "largest ({} frames) is used",
                    models, best_images));
  return ReadColmapText(best);
}

void RegisterFrames(const std::vector<fs::path>& images, ColmapRunOptions co, const RegisterOptions& ro, int attempts,
                    Report* report) {
  for (int attempt = 1;; ++attempt) {
    co.seed = attempt;
    const ColmapModel model = RunColmap(images, co, report);
    report->SetMetric("colmap.attempts", attempt);
    try {
      AlignColmapModel(model, ro, report);
      return;
    } catch (const AlignmentError& e) {
      if (attempt >= attempts) throw;
      report->Warn(fmt::format("COLMAP attempt {} (seed {}): {}; running it again", attempt, co.seed, e.message()));
    }
  }
}

}  // namespace mr
