#include "eval/registration.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "camera/camera_model.h"
#include "core/check.h"
#include "render/render_scene.h"

namespace mr {

Json RegistrationResult::ToJson() const {
  Json j = {{"measurable", measurable}, {"region_pixels", region_pixels}, {"usable_pixels", usable_pixels}};
  if (!measurable) {
    j["why"] = why;
    return j;
  }
  j["mean_px"] = mean_px;
  j["p90_px"] = p90_px;
  j["stderr_px"] = stderr_px;
  j["mean_flow_px"] = Json::array({mean_flow.x(), mean_flow.y()});
  j["median_px"] = median_px;
  j["median_flow_px"] = Json::array({median_flow.x(), median_flow.y()});
  return j;
}

RegistrationResult MeasureRegistration(const Image& rendered, const Image& plate, const Image& where,
                                       const RegistrationOptions& o) {
  const FlowField mt = MatchImages(rendered, plate, &where, o.flow);
  const int w = plate.width(), h = plate.height();
  RegistrationResult r;
  r.region_pixels = mt.region_pixels;
  r.usable_pixels = static_cast<int64_t>(mt.usable.size());
  if (r.usable_pixels < o.min_pixels) {
    r.why = r.region_pixels == 0 ? "the room covers no pixel of the frame"
            : mt.textured < o.min_pixels
                ? fmt::format("textureless: {} of the room's {} pixels carry texture or edges (at least {} needed)",
                              mt.textured, r.region_pixels, o.min_pixels)
                : fmt::format("{} of the room's {} textured pixels agree forward and back (at least {} needed)",
                              r.usable_pixels, mt.textured, o.min_pixels);
    return r;
  }
  std::vector<float> mags, fx, fy;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  const int tiles_x = (w + o.tile_px - 1) / o.tile_px, tiles_y = (h + o.tile_px - 1) / o.tile_px;
  std::vector<double> tile_sum(static_cast<size_t>(tiles_x) * tiles_y, 0.0);
  std::vector<int> tile_n(tile_sum.size(), 0);
  for (const Eigen::Vector2i& p : mt.usable) {
    const Eigen::Vector2f f = mt.flow[static_cast<size_t>(p.y()) * w + p.x()];
    const float m = f.norm();
    mags.push_back(m);
    fx.push_back(f.x());
    fy.push_back(f.y());
    sum += f.cast<double>();
    const size_t t = static_cast<size_t>(p.y() / o.tile_px) * tiles_x + static_cast<size_t>(p.x() / o.tile_px);
    tile_sum[t] += m;
    ++tile_n[t];
  }
  r.measurable = true;
  double total = 0;
  for (float m : mags) total += m;
  r.mean_px = total / static_cast<double>(mags.size());
  r.mean_flow = sum / static_cast<double>(mags.size());
  auto median = [](std::vector<float>& v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return static_cast<double>(v[v.size() / 2]);
  };
  r.median_flow = Eigen::Vector2d(median(fx), median(fy));
  r.median_px = median(mags);
  const size_t k = static_cast<size_t>(0.9 * static_cast<double>(mags.size() - 1));
  std::nth_element(mags.begin(), mags.begin() + static_cast<std::ptrdiff_t>(k), mags.end());
  r.p90_px = mags[k];
  // The standard error over tiles (neighbouring pixels' flow is one
  // estimate, not independent ones): the spread of the tiles' means.
  std::vector<double> means;
  for (size_t t = 0; t < tile_sum.size(); ++t)
    if (tile_n[t] >= 16) means.push_back(tile_sum[t] / tile_n[t]);
  if (means.size() >= 2) {
    double m = 0, v = 0;
    for (double x : means) m += x;
    m /= static_cast<double>(means.size());
    for (double x : means) v += (x - m) * (x - m);
    r.stderr_px = std::sqrt(v / static_cast<double>(means.size() - 1) / static_cast<double>(means.size()));
  }
  return r;
}

double Swim(const FlowField& flow, const Eigen::Vector2d& from, const Eigen::Vector2d& to) {
  if (!(from.x() >= 0 && from.y() >= 0 && from.x() <= flow.width - 1 && from.y() <= flow.height - 1))
    return std::numeric_limits<double>::quiet_NaN();
  return (to - from - flow.At(from.x(), from.y()).cast<double>()).norm();
}

namespace {

// pose * Exp(delta): delta = (rotation vector, translation) in the camera's frame.
Rigid3 Step(const Rigid3& pose, const Eigen::Matrix<double, 6, 1>& delta) {
  const Eigen::Vector3d w = delta.head<3>();
  const double a = w.norm();
  const Eigen::Quaterniond q = a > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(a, w / a)) : Eigen::Quaterniond::Identity();
  return pose * Rigid3(q, delta.tail<3>());
}

// The matches' residuals (projection - observed), 2 per point, with every
// group's pose corrected by `c` (pose * c); a point that does not project
// gives a large residual (weighed down by Huber).
Eigen::VectorXd Residuals(const CameraModel& camera, const std::vector<RoomMatches>& groups, const Rigid3& c) {
  Eigen::Index n = 0;
  for (const RoomMatches& g : groups) n += 2 * static_cast<Eigen::Index>(g.X.size());
  Eigen::VectorXd r(n);
  Eigen::Index k = 0;
  for (const RoomMatches& g : groups) {
    const Rigid3 cam_from_world = (g.pose * c).Inverse();
    for (size_t i = 0; i < g.X.size(); ++i, k += 2) {
      Eigen::Vector2d q;
      if (!camera.Project(cam_from_world * g.X[i], &q)) q = g.u[i] + Eigen::Vector2d(1e3, 1e3);
      r.segment<2>(k) = q - g.u[i];
    }
  }
  return r;
}

double WeightedRms(const Eigen::VectorXd& r, double k) {
  double s = 0, wsum = 0;
  for (Eigen::Index i = 0; i < r.size() / 2; ++i) {
    const double e = r.segment<2>(2 * i).norm(), w = e <= k ? 1 : k / e;
    s += w * e * e;
    wsum += w;
  }
  return wsum > 0 ? std::sqrt(s / wsum) : 0;
}

// The correction: the pose step c and, with intrinsics, k = the log of the
// focal scale.
struct Correction {
  Rigid3 c;
  double k = 0;
  Eigen::MatrixXd covariance;  // of the parameters' last step (6 or 7)
};

CameraModel Corrected(const CameraModel& camera, double k) {
  return WithIntrinsicsCorrection(camera, std::exp(k), Eigen::Vector2d::Zero());
}

// Gauss-Newton with Huber weights (IRLS) for the correction, from `x`: 6
// parameters (the pose step, right-multiplied) or, with `intrinsics`, 7;
// numeric derivatives.  The covariance is the weighted residual variance
// times the inverse normal matrix at the end.
Correction Solve(const CameraModel& camera, const std::vector<RoomMatches>& groups, Correction x, double huber,
                 bool intrinsics) {
  const int n = intrinsics ? 7 : 6;
  auto residuals = [&](const Correction& y) {
    return Residuals(intrinsics ? Corrected(camera, y.k) : camera, groups, y.c);
  };
  auto moved = [&](const Correction& y, const Eigen::VectorXd& d) {
    Correction z = y;
    z.c = Step(y.c, d.head<6>());
    if (intrinsics) z.k += d[6];
    return z;
  };
  std::vector<double> gw;  // each point's group weight
  for (const RoomMatches& g : groups) gw.insert(gw.end(), g.X.size(), g.weight);
  Eigen::MatrixXd H(n, n);
  double chi2 = 0, wsum = 0;
  for (int it = 0; it < 15; ++it) {
    const Eigen::VectorXd r = residuals(x);
    Eigen::MatrixXd J(r.size(), n);
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
      d[j] = 1e-6;
      J.col(j) = (residuals(moved(x, d)) - r) / 1e-6;
    }
    H.setZero();
    Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
    chi2 = wsum = 0;
    for (Eigen::Index i = 0; i < r.size() / 2; ++i) {
      const double e = r.segment<2>(2 * i).norm(), w = gw[static_cast<size_t>(i)] * (e <= huber ? 1 : huber / e);
      const auto Ji = J.middleRows(2 * i, 2);
      H += w * Ji.transpose() * Ji;
      g += w * Ji.transpose() * r.segment<2>(2 * i);
      chi2 += w * e * e;
      wsum += w;
    }
    const Eigen::VectorXd step = -H.ldlt().solve(g);
    if (!step.allFinite()) break;
    x = moved(x, step);
    if (step.norm() < 1e-9) break;
  }
  // The residual variance per coordinate: chi2 over the coordinates less
  // the parameters, each match counted by its Huber weight.
  const double dof = std::max(1.0, 2 * wsum - n);
  x.covariance = (chi2 / dof) * H.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
  return x;
}

}  // namespace

CameraModel WithIntrinsicsCorrection(const CameraModel& camera, double focal_scale,
                                     const Eigen::Vector2d& principal_shift_px) {
  std::vector<double> k = camera.intrinsics();
  MR_CHECK(k.size() >= 4);
  k[0] *= focal_scale;
  k[1] *= focal_scale;
  k[2] += principal_shift_px.x();
  k[3] += principal_shift_px.y();
  return CameraModel(camera.lensmodel(), k, camera.width(), camera.height(), camera.cam_from_ref());
}

Json PoseRefinement::ToJson() const {
  Json j = {{"refined", refined}, {"points", points}};
  if (!refined) j["why"] = why;
  j["rms_before_px"] = rms_before_px;
  j["rms_after_px"] = rms_after_px;
  j["rotation_deg"] = rotation_deg;
  j["translation_m"] = translation_m;
  if (intrinsics_refined || !intrinsics_why.empty()) {
    j["intrinsics"] = {
        {"refined", intrinsics_refined}, {"focal_scale", focal_scale}, {"focal_scale_sigma", focal_scale_sigma}};
    if (!intrinsics_refined) j["intrinsics"]["why"] = intrinsics_why;
  }
  return j;
}

RoomMatches MatchRoom(const Image& rendered, const Image& where, const RenderScene& rs, const CameraModel& camera,
                      const Rigid3& pose, const Image& plate, const PoseRefineOptions& o) {
  RoomMatches m;
  m.pose = pose;
  const FlowField mt = MatchImages(rendered, plate, &where, o.matching.flow);
  if (static_cast<int>(mt.usable.size()) < o.matching.min_pixels) {
    m.why = fmt::format("{} usable matches (at least {} needed: a textureless view)", mt.usable.size(),
                        o.matching.min_pixels);
    return m;
  }
  // The matches' 3D points: the rays through the rendered pixels' centres.
  const size_t every = std::max<size_t>(1, mt.usable.size() / static_cast<size_t>(o.max_points));
  for (size_t i = 0; i < mt.usable.size(); i += every) {
    const Eigen::Vector2i& p = mt.usable[i];
    Eigen::Vector3d dir;
    if (!camera.Unproject(p.cast<double>(), &dir)) continue;
    Ray ray;
    ray.origin = pose.translation.cast<float>();
    ray.direction = (pose.rotation * dir).normalized().cast<float>();
    ray.mask = kMaskReal;
    Hit hit;
    if (!rs.embree().Intersect(ray, &hit)) continue;
    m.X.push_back(pose.translation + static_cast<double>(hit.t) * ray.direction.cast<double>());
    m.u.push_back(p.cast<double>() + mt.flow[static_cast<size_t>(p.y()) * camera.width() + p.x()].cast<double>());
  }
  if (m.X.size() < 6) {
    m.X.clear();
    m.u.clear();
    m.why = "the matches meet no room geometry";
  }
  return m;
}

PoseRefinement SolveCorrection(const CameraModel& camera, const std::vector<RoomMatches>& groups, const Rigid3& start,
                               const PoseRefineOptions& o) {
  PoseRefinement out;
  std::vector<RoomMatches> used;
  for (const RoomMatches& g : groups)
    if (!g.X.empty()) used.push_back(g);
  if (used.empty()) {
    out.why = groups.empty() ? "no frame" : groups.front().why;
    return out;
  }
  for (const RoomMatches& g : used) out.points += static_cast<int>(g.X.size());
  out.rms_before_px = WeightedRms(Residuals(camera, used, start), o.huber_px);
  Correction x;
  x.c = start;
  x = Solve(camera, used, x, o.huber_px, false);
  if (o.intrinsics && used.size() < 2) {
    out.intrinsics_why = "one frame: its pose and the intrinsics are not told apart";
  } else if (o.intrinsics) {
    const Correction xi = Solve(camera, used, x, o.huber_px, true);
    out.focal_scale = std::exp(xi.k);
    out.focal_scale_sigma = out.focal_scale * std::sqrt(std::max(0.0, xi.covariance(6, 6)));
    const double corner = 0.5 * std::hypot(camera.width(), camera.height());
    const bool determined = std::abs(out.focal_scale - 1) > 3 * out.focal_scale_sigma;
    const bool visible = std::abs(out.focal_scale - 1) * corner >= o.min_intrinsics_px;
    if (std::isfinite(xi.k) && determined && visible) {
      x = xi;
      out.intrinsics_refined = true;
    } else {
      out.intrinsics_why = fmt::format("{}: focal scale {:.5f} +- {:.5f}",
                                       determined ? fmt::format("moves no pixel by {} px", o.min_intrinsics_px)
                                                  : "not determined (within 3 standard deviations)",
                                       out.focal_scale, out.focal_scale_sigma);
    }
  }
  const Rigid3 c = x.c;
  const CameraModel after = out.intrinsics_refined ? Corrected(camera, x.k) : camera;
  out.rms_after_px = WeightedRms(Residuals(after, used, c), o.huber_px);
  out.rotation_deg = Eigen::AngleAxisd(c.rotation).angle() * 180 / std::numbers::pi;
  out.translation_m = c.translation.norm();
  out.pose = c;
  if (out.rotation_deg > o.max_rotation_deg || out.translation_m > o.max_translation_m) {
    out.why = fmt::format("the step ({:.2f} degrees, {:.3f} m) is larger than --max-step allows: the matches failed",
                          out.rotation_deg, out.translation_m);
    out.pose = Rigid3();
    return out;
  }
  out.refined = true;
  return out;
}

PoseRefinement RefinePose(const std::function<Image(const Rigid3&)>& render,
                          const std::function<Image(const Rigid3&)>& room, const RenderScene& rs,
                          const CameraModel& camera, const Rigid3& pose, const Image& plate,
                          const PoseRefineOptions& options, const RoomMatches* prior) {
  PoseRefineOptions o = options;
  o.intrinsics = false;  // one frame's pose and the intrinsics are not told apart
  PoseRefinement out;
  Rigid3 c;  // the correction so far: pose * c
  double rms_before = -1;
  for (int round = 0; round < o.rounds; ++round) {
    const Rigid3 current = pose * c;
    RoomMatches m = MatchRoom(render(current), room(current), rs, camera, current, plate, o);
    if (m.X.empty()) {
      out.why = m.why;
      out.pose = pose;
      return out;
    }
    m.pose = pose;  // the correction is solved from the input pose
    std::vector<RoomMatches> groups = {m};
    if (prior && !prior->X.empty()) {
      groups.push_back(*prior);
      groups.back().pose = pose;
    }
    out = SolveCorrection(camera, groups, c, o);
    if (rms_before < 0) rms_before = out.rms_before_px;
    if (!out.refined) {
      out.pose = pose;
      return out;
    }
    c = out.pose;
  }
  out.rms_before_px = rms_before;
  out.pose = pose * c;
  return out;
}

std::vector<Rigid3> SmoothOverTime(const std::vector<std::optional<Rigid3>>& c, double sigma) {
  const Rigid3* first = nullptr;
  for (const auto& ci : c)
    if (ci && !first) first = &*ci;
  MR_CHECK(first != nullptr && sigma > 0);
  std::vector<Rigid3> out(c.size());
  for (size_t i = 0; i < c.size(); ++i) {
    Eigen::Vector4d q = Eigen::Vector4d::Zero();
    Eigen::Vector3d t = Eigen::Vector3d::Zero();
    double wsum = 0;
    for (size_t k = 0; k < c.size(); ++k) {
      if (!c[k]) continue;
      const double d = (static_cast<double>(k) - static_cast<double>(i)) / sigma, w = std::exp(-0.5 * d * d);
      Eigen::Vector4d qk = c[k]->rotation.coeffs();
      if (qk.dot(first->rotation.coeffs()) < 0) qk = -qk;
      q += w * qk;
      t += w * c[k]->translation;
      wsum += w;
    }
    out[i] = wsum > 0 ? Rigid3(Eigen::Quaterniond(q / wsum), t / wsum) : *first;
  }
  return out;
}

}  // namespace mr
