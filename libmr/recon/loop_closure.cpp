#include "recon/loop_closure.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include <ceres/ceres.h>

#include "core/parallel.h"

namespace mr {

namespace {

double AngleDeg(const Eigen::Quaterniond& q) { return Eigen::AngleAxisd(q).angle() * 180 / M_PI; }

// Ceres' pose-graph residual (examples/slam/pose_graph_3d): the measured
// a_from_b against the estimate's, translation and twice the quaternion
// difference's vector part (the small-angle rotation), each over its sigma.
struct EdgeResidual {
  Eigen::Vector3d t;
  Eigen::Quaterniond q;
  double wt, wr;
  template <typename T>
  bool operator()(const T* pa, const T* qa, const T* pb, const T* qb, T* r) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> Pa(pa), Pb(pb);
    const Eigen::Map<const Eigen::Quaternion<T>> Qa(qa), Qb(qb);
    const Eigen::Quaternion<T> qa_inv = Qa.conjugate();
    const Eigen::Matrix<T, 3, 1> t_est = qa_inv * (Pb - Pa);
    const Eigen::Quaternion<T> dq = q.template cast<T>() * (qa_inv * Qb).conjugate();
    const Eigen::Matrix<T, 3, 1> et = (t_est - t.template cast<T>()) * T(wt);
    const Eigen::Matrix<T, 3, 1> er = dq.vec() * T(2 * wr);
    for (int k = 0; k < 3; ++k) {
      r[k] = et[k];
      r[3 + k] = er[k];
    }
    return true;
  }
};

// How many of the source's points land within `gate` of the model's surface
// (point-to-plane, normals within 37 degrees) when the source camera is at
// `pose` in the model camera's frame (projective association, as ICP's),
// less those that land in the model's free space.
int Agreement(const PointMaps& src, const PointMaps& model, const PinholeIntrinsics& K, const Rigid3& pose,
              float gate) {
  const Eigen::Matrix3f R = pose.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f t = pose.translation.cast<float>();
  int n = 0;
  for (size_t i = 0; i < src.vertices.size(); ++i) {
    if (!(src.vertices[i].x() == src.vertices[i].x())) continue;
    const Eigen::Vector3f p = R * src.vertices[i] + t;
    if (p.z() <= 0) continue;
    const float u = static_cast<float>(K.fx) * p.x() / p.z() + static_cast<float>(K.cx) + 0.5f;
    const float v = static_cast<float>(K.fy) * p.y() / p.z() + static_cast<float>(K.cy) + 0.5f;
    if (!(u >= 0 && v >= 0 && u < static_cast<float>(model.width) && v < static_cast<float>(model.height))) continue;
    const size_t j = static_cast<size_t>(v) * model.width + static_cast<size_t>(u);
    // A point well in front of the surface the model saw along this ray is
    // in space the model saw empty: evidence against the pose.
    if (model.vertices[j].z() == model.vertices[j].z() && p.z() < model.vertices[j].z() - 3 * gate) {
      --n;
      continue;
    }
    const Eigen::Vector3f& N = model.normals[j];
    if (!(N.x() == N.x()) || !(src.normals[i].x() == src.normals[i].x())) continue;
    const Eigen::Vector3f d = p - model.vertices[j];
    n += std::abs(N.dot(d)) < gate && d.squaredNorm() < 4 * gate * gate && (R * src.normals[i]).dot(N) > 0.8f;
  }
  return n;
}

// Starting poses for ICP: the tracked guess moved over a grid, scored by
// Agreement on about 1200 points of the coarsest level.  First translations
// every `step` within `radius`; then, around the best five, rotations of 0
// and +-angle about each camera axis with translations of 0 and +-step.  The
// best `keep`, at least 1.5 steps apart.  Projective ICP converges from
// about a decimetre; after 30 cm of drift the guess is outside that basin.
std::vector<Rigid3> Seeds(const PointMaps& src, const PointMaps& model, const PinholeIntrinsics& K, const Rigid3& guess,
                          double radius, double step, double angle, int keep) {
  const int stride = std::max(1, static_cast<int>(std::sqrt(src.width * src.height / 1200.0)));
  PointMaps sub;
  for (int y = 0; y < src.height; y += stride)
    for (int x = 0; x < src.width; x += stride) {
      sub.vertices.push_back(src.vertices[static_cast<size_t>(y) * src.width + x]);
      sub.normals.push_back(src.normals[static_cast<size_t>(y) * src.width + x]);
    }
  // Scores in parallel, sorted best first (ties in the order made: deterministic).
  auto score = [&](std::vector<Rigid3> hs) {
    std::vector<int> sc(hs.size());
    ParallelFor(0, static_cast<int64_t>(hs.size()), [&](int64_t i) {
      sc[static_cast<size_t>(i)] = Agreement(sub, model, K, hs[static_cast<size_t>(i)], 0.03f);
    });
    std::vector<size_t> order(hs.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return sc[a] > sc[b]; });
    std::vector<Rigid3> sorted;
    for (size_t i : order) sorted.push_back(hs[i]);
    return sorted;
  };
  auto moved = [&](const Rigid3& from, const Eigen::Vector3d& rot, const Eigen::Vector3d& dt) {
    Eigen::Matrix<double, 6, 1> xi;
    xi << from.rotation * rot, dt;  // rotations about the source camera's axes
    return ApplyIncrement(xi, from);
  };
  std::vector<Rigid3> hs;
  const int n = static_cast<int>(std::floor(radius / step));
  for (int x = -n; x <= n; ++x)
    for (int y = -n; y <= n; ++y)
      for (int z = -n; z <= n; ++z)
        if (Eigen::Vector3d(x, y, z).norm() * step <= radius + 1e-9)
          hs.push_back(moved(guess, Eigen::Vector3d::Zero(), step * Eigen::Vector3d(x, y, z)));
  const std::vector<Rigid3> coarse = score(hs);
  hs.clear();
  for (size_t b = 0; b < std::min<size_t>(5, coarse.size()); ++b)
    for (int r = 0; r < 27; ++r)
      for (int t = 0; t < 7; ++t) {
        const Eigen::Vector3d rot = angle * Eigen::Vector3d(r % 3 - 1, r / 3 % 3 - 1, r / 9 - 1);
        Eigen::Vector3d dt = Eigen::Vector3d::Zero();
        if (t > 0) dt((t - 1) / 2) = (t % 2 ? -0.5 : 0.5) * step;
        hs.push_back(moved(coarse[b], rot, dt));
      }
  std::vector<Rigid3> seeds;
  for (const Rigid3& h : score(hs)) {
    bool apart = true;
    for (const Rigid3& s : seeds) apart &= (s.translation - h.translation).norm() >= 1.5 * step;
    if (apart) seeds.push_back(h);
    if (static_cast<int>(seeds.size()) >= keep) break;
  }
  return seeds;
}

}  // namespace

void OptimisePoseGraph(std::vector<Rigid3>* nodes, const std::vector<PoseEdge>& edges, double sigma_t,
                       double sigma_r_rad) {
  if (nodes->size() < 2 || edges.empty()) return;
  std::vector<Eigen::Vector3d> t(nodes->size());
  std::vector<Eigen::Quaterniond> q(nodes->size());
  for (size_t i = 0; i < nodes->size(); ++i) {
    t[i] = (*nodes)[i].translation;
    q[i] = (*nodes)[i].rotation.normalized();
  }
  ceres::Problem problem;
  for (const PoseEdge& e : edges) {
    auto* f = new ceres::AutoDiffCostFunction<EdgeResidual, 6, 3, 4, 3, 4>(
        new EdgeResidual{e.b_in_a.translation, e.b_in_a.rotation, 1 / sigma_t, 1 / sigma_r_rad});
    const auto a = static_cast<size_t>(e.a), b = static_cast<size_t>(e.b);
    problem.AddResidualBlock(f, nullptr, t[a].data(), q[a].coeffs().data(), t[b].data(), q[b].coeffs().data());
  }
  for (size_t i = 0; i < nodes->size(); ++i)
    if (problem.HasParameterBlock(q[i].coeffs().data()))
      problem.SetManifold(q[i].coeffs().data(), new ceres::EigenQuaternionManifold);
  if (!problem.HasParameterBlock(t[0].data())) return;
  problem.SetParameterBlockConstant(t[0].data());
  problem.SetParameterBlockConstant(q[0].coeffs().data());
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.max_num_iterations = 50;
  so.num_threads = 1;  // deterministic
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  for (size_t i = 0; i < nodes->size(); ++i) (*nodes)[i] = Rigid3(q[i].normalized(), t[i]);
}

struct LoopCloser::Pending {
  int kf_new = 0, kf_old = 0;
  LoopRecord record;
  bool accepted = false;
};

struct LoopCloser::Impl {
  struct Keyframe {
    int frame = 0;
    Rigid3 pose;     // world_from_cam, current estimate
    PointMaps maps;  // camera frame, at options.model_level
    PinholeIntrinsics K;
  };
  struct Hang {
    int keyframe = 0;
    Rigid3 kf_from_cam;
  };
  std::vector<Keyframe> keyframes;
  std::vector<Hang> frames;
  std::vector<PoseEdge> edges;
  std::vector<Pending> pending;  // measured loops not yet confirmed
};

LoopCloser::LoopCloser(const LoopOptions& options) : options_(options), impl_(std::make_unique<Impl>()) {}
LoopCloser::~LoopCloser() = default;

size_t LoopCloser::size() const { return impl_->frames.size(); }
int LoopCloser::keyframes() const { return static_cast<int>(impl_->keyframes.size()); }

bool LoopCloser::IsKeyframe(int frame) const {
  for (const auto& k : impl_->keyframes)
    if (k.frame == frame) return true;
  return false;
}

Rigid3 LoopCloser::pose(size_t k) const {
  const Impl::Hang& h = impl_->frames[k];
  return impl_->keyframes[static_cast<size_t>(h.keyframe)].pose * h.kf_from_cam;
}

bool LoopCloser::Add(int frame, const FramePyramid& pyramid, const Rigid3& world_from_cam) {
  auto& kfs = impl_->keyframes;
  if (!kfs.empty()) {
    const Rigid3& last = kfs.back().pose;
    const bool moved = (world_from_cam.translation - last.translation).norm() >= options_.keyframe_translation_m ||
                       AngleDeg(last.rotation.conjugate() * world_from_cam.rotation) >= options_.keyframe_rotation_deg;
    if (!moved) {
      impl_->frames.push_back({static_cast<int>(kfs.size()) - 1, last.Inverse() * world_from_cam});
      return false;
    }
  }
  const int level = std::clamp(options_.model_level, 0, static_cast<int>(pyramid.maps.size()) - 1);
  Impl::Keyframe kf{frame, world_from_cam, pyramid.maps[static_cast<size_t>(level)],
                    pyramid.K[static_cast<size_t>(level)]};
  const int id = static_cast<int>(kfs.size());
  if (id > 0) impl_->edges.push_back({id - 1, id, kfs.back().pose.Inverse() * world_from_cam});
  kfs.push_back(std::move(kf));
  impl_->frames.push_back({id, Rigid3()});

  // Candidates: old enough, near enough, nearest first.
  std::vector<std::pair<double, int>> near;
  for (int k = 0; k + 1 < id; ++k) {
    const Impl::Keyframe& c = kfs[static_cast<size_t>(k)];
    if (frame - c.frame < options_.min_frame_gap) continue;
    const double d = (c.pose.translation - world_from_cam.translation).norm();
    const double a = AngleDeg(c.pose.rotation.conjugate() * world_from_cam.rotation);
    if (d > options_.search_radius_m || a > options_.search_angle_deg) continue;
    near.push_back({d / options_.search_radius_m + a / options_.search_angle_deg, k});
  }
  std::sort(near.begin(), near.end());
  if (near.size() > static_cast<size_t>(options_.max_candidates)) near.resize(options_.max_candidates);
  // A measured loop is accepted once one from another keyframe agrees with
  // it: a single ICP can settle in a wrong minimum with figures as good as
  // the right one's, and two measurements from the same frame tend to share
  // its mistake.
  bool closed = false;
  for (const auto& [score, k] : near) {
    std::optional<Pending> m = Measure(id, k, pyramid);
    if (!m) continue;
    std::vector<Pending> accept;
    std::vector<int> from;  // the other keyframes whose measurements agree
    for (const Pending& p : impl_->pending) {
      if (p.kf_new == id || !Consistent(p, *m)) continue;
      if (std::find(from.begin(), from.end(), p.kf_new) == from.end()) from.push_back(p.kf_new);
      if (!p.accepted) accept.push_back(p);
    }
    impl_->pending.push_back(*m);
    if (static_cast<int>(from.size()) < options_.confirmations) continue;
    accept.push_back(*m);
    impl_->pending.back().accepted = true;
    Accept(accept);
    closed = true;
  }
  // Unconfirmed measurements expire after `window` keyframes.
  std::erase_if(impl_->pending, [&](const Pending& p) { return p.kf_new <= id - options_.window; });
  return closed;
}

// A frame aligned to a keyframe `c`: ICP in the keyframe's camera frame (its
// maps are the model, seen from the identity; the result is
// keyframe_from_frame), started from the best seeds around `guess`, the one
// that agrees with the most points kept, and only when unique: no pose
// elsewhere (beyond twice the consistency distance) agrees nearly as well
// (along a direction the views barely constrain, ICP stops where it started
// and the seeds spread along it score alike).
static std::optional<IcpResult> AlignToKeyframe(const PointMaps& maps, const PinholeIntrinsics& K,
                                                const FramePyramid& pyramid, const Rigid3& guess,
                                                const LoopOptions& o) {
  std::vector<std::pair<int, IcpResult>> found;
  for (const Rigid3& seed :
       Seeds(pyramid.maps.back(), maps, K, guess, o.search_radius_m, o.seed_step_m, o.seed_angle_deg * M_PI / 180, 3)) {
    IcpOptions icp;
    icp.iterations.assign(pyramid.maps.size(), 10);
    icp.max_distance = 0.05;
    icp.max_jump_m = 0.2;  // from the seed
    icp.max_jump_deg = 15;
    icp.max_rms = o.max_rms;
    icp.min_inlier_ratio = o.min_inlier_ratio;
    IcpResult ri = TrackIcp(pyramid, maps, K, Rigid3(), seed, icp);
    if (!ri.ok || ri.weak_directions > 0) continue;
    found.push_back({Agreement(pyramid.maps[0], maps, K, ri.world_from_cam, 0.02f), ri});
  }
  if (found.empty()) return std::nullopt;
  std::stable_sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  const IcpResult& r = found[0].second;
  for (size_t j = 1; j < found.size(); ++j)
    if ((found[j].second.world_from_cam.translation - r.world_from_cam.translation).norm() > 2 * o.consistency_m &&
        found[j].first > o.uniqueness * found[0].first)
      return std::nullopt;
  return r;
}

std::optional<LoopCloser::Pending> LoopCloser::Measure(int id, int k, const FramePyramid& pyramid) {
  const auto t0 = std::chrono::steady_clock::now();
  ++tried_;
  const auto& kfs = impl_->keyframes;
  const Impl::Keyframe& c = kfs[static_cast<size_t>(k)];
  const std::optional<IcpResult> r =
      AlignToKeyframe(c.maps, c.K, pyramid, c.pose.Inverse() * kfs[static_cast<size_t>(id)].pose, options_);
  if (!r) return std::nullopt;
  Pending p;
  p.kf_new = id;
  p.kf_old = k;
  p.record.frame = kfs[static_cast<size_t>(id)].frame;
  p.record.keyframe_frame = c.frame;
  p.record.measured = r->world_from_cam;
  p.record.rms = r->rms;
  p.record.inlier_ratio = r->inlier_ratio;
  p.record.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return p;
}

std::optional<std::pair<Rigid3, int>> LoopCloser::Relocalise(const FramePyramid& pyramid, const Rigid3& near) {
  std::vector<std::pair<double, size_t>> order;
  const auto& kfs = impl_->keyframes;
  for (size_t k = 0; k < kfs.size(); ++k) {
    const double d = (kfs[k].pose.translation - near.translation).norm();
    const double a = AngleDeg(kfs[k].pose.rotation.conjugate() * near.rotation);
    if (d <= options_.search_radius_m && a <= options_.search_angle_deg)
      order.push_back({d / options_.search_radius_m + a / options_.search_angle_deg, k});
  }
  std::sort(order.begin(), order.end());
  if (order.size() > static_cast<size_t>(options_.relocalise_candidates))
    order.resize(static_cast<size_t>(options_.relocalise_candidates));
  for (const auto& [score, k] : order) {
    const Impl::Keyframe& c = kfs[k];
    if (const std::optional<IcpResult> r = AlignToKeyframe(c.maps, c.K, pyramid, c.pose.Inverse() * near, options_))
      return std::pair{c.pose * r->world_from_cam, c.frame};
  }
  return std::nullopt;
}

// Two loops (new keyframe i to old a, measured a_from_i; j to b, b_from_j)
// agree when they give the same a_from_j through the graph's a_from_b and
// i_from_j (both short chains: old keyframes among themselves, recent ones
// among themselves).
bool LoopCloser::Consistent(const Pending& p, const Pending& q) const {
  const auto& kfs = impl_->keyframes;
  auto at = [&](int i) { return kfs[static_cast<size_t>(i)].pose; };
  const Rigid3 via_p = p.record.measured * (at(p.kf_new).Inverse() * at(q.kf_new));
  const Rigid3 via_q = (at(p.kf_old).Inverse() * at(q.kf_old)) * q.record.measured;
  return (via_p.translation - via_q.translation).norm() < options_.consistency_m &&
         AngleDeg(via_p.rotation.conjugate() * via_q.rotation) < options_.consistency_deg;
}

void LoopCloser::Accept(const std::vector<Pending>& loops) {
  auto& kfs = impl_->keyframes;
  const Rigid3 before = kfs.back().pose;
  for (const Pending& l : loops) impl_->edges.push_back({l.kf_old, l.kf_new, l.record.measured});
  std::vector<Rigid3> nodes;
  for (const auto& f : kfs) nodes.push_back(f.pose);
  OptimisePoseGraph(&nodes, impl_->edges, options_.sigma_t, options_.sigma_r_deg * M_PI / 180);
  for (size_t i = 0; i < kfs.size(); ++i) kfs[i].pose = nodes[i];
  for (const Pending& l : loops) {
    LoopRecord rec = l.record;
    rec.correction_m = (kfs.back().pose.translation - before.translation).norm();
    rec.correction_deg = AngleDeg(before.rotation.conjugate() * kfs.back().pose.rotation);
    loops_.push_back(rec);
  }
  for (Pending& p : impl_->pending)
    for (const Pending& l : loops) p.accepted |= p.kf_new == l.kf_new && p.kf_old == l.kf_old;
}

}  // namespace mr
