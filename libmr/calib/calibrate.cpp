#include "calib/calibrate.h"

#include <suitesparse/cholmod.h>
extern "C" {
#include <mrcal/mrcal.h>
#include <mrcal/mrcal-internal.h>
}

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>

#include <cmath>

#include "core/error.h"
#include "core/math.h"

namespace mr {

namespace {

mrcal_lensmodel_t Lensmodel(const std::string& name) {
  mrcal_lensmodel_t m;
  if (!mrcal_lensmodel_from_name(&m, name.c_str()) || !mrcal_lensmodel_type_is_valid(m.type))
    throw UsageError(fmt::format("unknown lens model \"{}\"", name));
  mrcal_lensmodel_metadata_t meta = mrcal_lensmodel_metadata(&m);
  if (!meta.has_core) throw UsageError(fmt::format("lens model {} has no intrinsics core; mr-calibrate needs one", name));
  return m;
}

struct Problem {
  int nx = 0, ny = 0;
  double spacing = 0;
  std::vector<mrcal_observation_board_t> obs;
  std::vector<mrcal_point3_t> pool;  // (Nobs, ny, nx): x, y, weight (< 0 outlier)
  std::vector<mrcal_pose_t> frames;  // board -> camera (the reference)
  std::vector<int> view_of_obs;
};

// What a stage solves: the board poses always, the camera fixed at the
// reference (one camera, no extrinsics), the board flat.
mrcal_problem_selections_t Selections(bool core, bool distortions, bool regularize, bool outliers) {
  mrcal_problem_selections_t sel{};
  sel.do_optimize_intrinsics_core = core;
  sel.do_optimize_intrinsics_distortions = distortions;
  sel.do_optimize_extrinsics = false;
  sel.do_optimize_frames = true;
  sel.do_optimize_calobject_warp = false;
  sel.do_apply_regularization = regularize;
  sel.do_apply_outlier_rejection = outliers;
  return sel;
}

// No discrete points: their range limits are unused.
mrcal_problem_constants_t Constants() {
  mrcal_problem_constants_t c{};
  c.point_min_range = -1;
  c.point_max_range = -1;
  return c;
}

mrcal_stats_t Solve(Problem* p, const mrcal_lensmodel_t& lens, std::vector<double>* intrinsics, int w, int h,
                    const mrcal_problem_selections_t& sel) {
  const mrcal_problem_constants_t constants = Constants();
  const int imagersize[2] = {w, h};
  return mrcal_optimize(nullptr, 0, nullptr, 0, intrinsics->data(), nullptr, p->frames.data(), nullptr, nullptr, 1, 0,
                        static_cast<int>(p->frames.size()), 0, 0, p->obs.data(), nullptr, static_cast<int>(p->obs.size()),
                        0, p->pool.data(), &lens, imagersize, sel, &constants, p->spacing, p->nx, p->ny, false, false);
}

Eigen::Matrix3d Rodrigues(const Eigen::Vector3d& r) {
  const double a = r.norm();
  return a > 0 ? Eigen::AngleAxisd(a, r / a).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

// Var(state) of the solved problem in physical units (intrinsics, then 6 per frame).
Eigen::MatrixXd StateCovariance(Problem* p, const mrcal_lensmodel_t& lens, std::vector<double>* intrinsics, int w, int h,
                                double* noise) {
  const mrcal_problem_selections_t sel = Selections(true, true, true, false);
  const int F = static_cast<int>(p->frames.size()), N = static_cast<int>(p->obs.size());
  const int n_state = mrcal_num_states(1, 0, F, 0, 0, N, sel, &lens);
  const int n_meas = mrcal_num_measurements(N, 0, p->nx, p->ny, 1, 0, F, 0, 0, sel, &lens);
  const int nnz = _mrcal_num_j_nonzero(N, 0, p->nx, p->ny, 1, 0, F, 0, 0, p->obs.data(), nullptr, sel, &lens);
  std::vector<int> jp(static_cast<size_t>(n_meas) + 1), ji(static_cast<size_t>(nnz));
  std::vector<double> jx(static_cast<size_t>(nnz)), b(static_cast<size_t>(n_state)), x(static_cast<size_t>(n_meas));
  cholmod_sparse jt{};
  jt.nrow = static_cast<size_t>(n_state);
  jt.ncol = static_cast<size_t>(n_meas);
  jt.nzmax = static_cast<size_t>(nnz);
  jt.p = jp.data();
  jt.i = ji.data();
  jt.x = jx.data();
  jt.stype = 0;
  jt.itype = CHOLMOD_INT;
  jt.xtype = CHOLMOD_REAL;
  jt.dtype = CHOLMOD_DOUBLE;
  jt.sorted = 1;
  jt.packed = 1;
  const mrcal_problem_constants_t constants = Constants();
  const int imagersize[2] = {w, h};
  if (!mrcal_optimizer_callback(b.data(), n_state * static_cast<int>(sizeof(double)), x.data(),
                                n_meas * static_cast<int>(sizeof(double)), &jt, intrinsics->data(), nullptr,
                                p->frames.data(), nullptr, nullptr, 1, 0, F, 0, 0, p->obs.data(), nullptr, N, 0,
                                p->pool.data(), &lens, imagersize, sel, &constants, p->spacing, p->nx, p->ny, false))
    ThrowError("mrcal could not evaluate the solution's Jacobian");
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(n_meas, n_state);
  for (int c = 0; c < n_meas; ++c)
    for (int k = jp[static_cast<size_t>(c)]; k < jp[static_cast<size_t>(c) + 1]; ++k)
      J(c, ji[static_cast<size_t>(k)]) = jx[static_cast<size_t>(k)];
  const int n_obs = mrcal_num_measurements_boards(N, p->nx, p->ny);
  // Observation noise: per coordinate, over the inlier corners.
  double sum2 = 0;
  int coords = 0;
  for (size_t i = 0; i < p->pool.size(); ++i)
    if (p->pool[i].z > 0) {
      sum2 += x[2 * i] * x[2 * i] + x[2 * i + 1] * x[2 * i + 1];
      coords += 2;
    }
  *noise = coords > 0 ? std::sqrt(sum2 / coords) : 0;
  const Eigen::MatrixXd JtJ = J.transpose() * J;
  const Eigen::MatrixXd Jo = J.topRows(n_obs);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(JtJ);
  const Eigen::MatrixXd A = ldlt.solve(Eigen::MatrixXd::Identity(n_state, n_state));
  Eigen::MatrixXd var = (*noise) * (*noise) * A * (Jo.transpose() * Jo) * A;
  // Packed (unitless) state to physical units: unpacking scales each element.
  std::vector<double> scale(static_cast<size_t>(n_state), 1.0);
  mrcal_unpack_solver_state_vector(scale.data(), 1, 0, F, 0, 0, sel, &lens);
  for (int i = 0; i < n_state; ++i)
    for (int j = 0; j < n_state; ++j) var(i, j) *= scale[static_cast<size_t>(i)] * scale[static_cast<size_t>(j)];
  return var;
}

}  // namespace

ProjectionUncertainty::ProjectionUncertainty(std::string lensmodel, std::vector<double> intrinsics,
                                             std::vector<double> frames_rt, Eigen::MatrixXd var_state)
    : lensmodel_(std::move(lensmodel)), intrinsics_(std::move(intrinsics)), frames_rt_(std::move(frames_rt)),
      var_(std::move(var_state)) {}

Eigen::Vector2d ProjectionUncertainty::ProjectPerturbed(const Eigen::Vector3d& dir_cam, const Eigen::VectorXd& state) const {
  const size_t n = intrinsics_.size(), F = frames_rt_.size() / 6;
  // The direction in each board's frame (solution), back through the
  // perturbed pose, averaged: mrcal's mean-frames reference (rotations only
  // for a point at infinity).
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t f = 0; f < F; ++f) {
    const Eigen::Vector3d r0(frames_rt_[6 * f], frames_rt_[6 * f + 1], frames_rt_[6 * f + 2]);
    const Eigen::Vector3d r1(state[static_cast<Eigen::Index>(n + 6 * f)], state[static_cast<Eigen::Index>(n + 6 * f + 1)],
                             state[static_cast<Eigen::Index>(n + 6 * f + 2)]);
    mean += Rodrigues(r1) * (Rodrigues(r0).transpose() * dir_cam);
  }
  std::vector<double> k(n);
  for (size_t i = 0; i < n; ++i) k[i] = state[static_cast<Eigen::Index>(i)];
  const CameraModel m(lensmodel_, k, 1, 1);
  Eigen::Vector2d q(NAN, NAN);
  m.Project(mean / static_cast<double>(F), &q);
  return q;
}

double ProjectionUncertainty::StdevPx(const Eigen::Vector2d& q, const CameraModel& model) const {
  Eigen::Vector3d d;
  if (!model.Unproject(q, &d)) return NAN;
  d.normalize();
  const Eigen::Index n = static_cast<Eigen::Index>(intrinsics_.size() + frames_rt_.size());
  Eigen::VectorXd s0(n);
  for (size_t i = 0; i < intrinsics_.size(); ++i) s0[static_cast<Eigen::Index>(i)] = intrinsics_[i];
  for (size_t i = 0; i < frames_rt_.size(); ++i) s0[static_cast<Eigen::Index>(intrinsics_.size() + i)] = frames_rt_[i];
  Eigen::MatrixXd G(2, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double h = 1e-6 * std::max(1.0, std::abs(s0[i]));
    Eigen::VectorXd a = s0, b = s0;
    a[i] += h;
    b[i] -= h;
    G.col(i) = (ProjectPerturbed(d, a) - ProjectPerturbed(d, b)) / (2 * h);
  }
  const Eigen::Matrix2d var = G * var_.topLeftCorner(n, n) * G.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(var);
  return std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
}

CalibrationResult CalibrateCamera(const BoardSpec& board, std::vector<CornerDetection> detections, int width,
                                  int height, const CalibrationOptions& o) {
  const mrcal_lensmodel_t target = Lensmodel(o.lensmodel);
  mrcal_lensmodel_t stereo;
  mrcal_lensmodel_from_name(&stereo, "LENSMODEL_STEREOGRAPHIC");
  const double f0 = o.focal_px > 0 ? o.focal_px : 0.5 * width;
  const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1);
  const CameraModel seed("LENSMODEL_STEREOGRAPHIC", {f0, f0, cx, cy}, width, height);
  const auto object = board.ObjectPoints();

  CalibrationResult r;
  Problem p;
  p.nx = board.inner_x;
  p.ny = board.inner_y;
  p.spacing = board.square_m;
  for (size_t v = 0; v < detections.size(); ++v) {
    CalibrationView view;
    view.detection = std::move(detections[v]);
    const CornerDetection& d = view.detection;
    if (!d.found) {
      view.reason = d.reason;
      r.views.push_back(view);
      continue;
    }
    // Seed pose: the corners' rays through the stereographic seed, those
    // within 75 degrees of the axis as normalised pinhole points.
    std::vector<cv::Point3d> obj;
    std::vector<cv::Point2d> img;
    for (size_t i = 0; i < d.pixels.size(); ++i) {
      Eigen::Vector3d ray;
      if (!seed.Unproject(d.pixels[i], &ray) || ray.normalized().z() < std::cos(75 * kDegToRad)) continue;
      const Eigen::Vector3d& P = object[static_cast<size_t>(d.ids[i])];
      obj.emplace_back(P.x(), P.y(), P.z());
      img.emplace_back(ray.x() / ray.z(), ray.y() / ray.z());
    }
    cv::Mat rvec, tvec;
    if (obj.size() < 6 || !cv::solvePnP(obj, img, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec, false, cv::SOLVEPNP_ITERATIVE) ||
        tvec.at<double>(2) <= 0) {
      view.reason = fmt::format("no seed pose ({} corners within 75 degrees of the seed's axis)", obj.size());
      r.views.push_back(view);
      continue;
    }
    mrcal_pose_t pose;
    for (int k = 0; k < 3; ++k) {
      pose.r.xyz[k] = rvec.at<double>(k);
      pose.t.xyz[k] = tvec.at<double>(k);
    }
    mrcal_observation_board_t ob{};
    ob.icam.intrinsics = 0;
    ob.icam.extrinsics = -1;
    ob.iframe = static_cast<int>(p.frames.size());
    p.obs.push_back(ob);
    p.frames.push_back(pose);
    const size_t base = p.pool.size();
    p.pool.resize(base + static_cast<size_t>(p.nx * p.ny), mrcal_point3_t{{0, 0, -1}});  // missing corners: weight < 0
    for (size_t i = 0; i < d.pixels.size(); ++i) {
      mrcal_point3_t& q = p.pool[base + static_cast<size_t>(d.ids[i])];
      q.x = d.pixels[i].x();
      q.y = d.pixels[i].y();
      q.z = 1.0;
    }
    p.view_of_obs.push_back(static_cast<int>(r.views.size()));
    view.used = true;
    r.views.push_back(view);
  }
  if (static_cast<int>(p.obs.size()) < o.min_views) {
    int found = 0;
    for (const auto& v : r.views) found += v.detection.found;
    throw UsageError(fmt::format("{} usable views of the board ({} photographs, the board found in {}); at least {} "
                                 "are needed, from different angles and covering the image",
                                 p.obs.size(), r.views.size(), found, o.min_views));
  }

  // Stage 1: the stereographic seed's core and the board poses.
  std::vector<double> core = {f0, f0, cx, cy};
  mrcal_stats_t s = Solve(&p, stereo, &core, width, height, Selections(true, false, false, false));
  r.stages.push_back(fmt::format("stereographic core and board poses: RMS {:.3f} px", s.rms_reproj_error__pixels));
  // Stage 2: the target model, its distortions at zero (for the splined
  // stereographic models, zero is the stereographic lens itself).
  const int n_params = mrcal_lensmodel_num_params(&target);
  std::vector<double> intrinsics(static_cast<size_t>(n_params), 0.0);
  for (int k = 0; k < 4; ++k) intrinsics[static_cast<size_t>(k)] = core[static_cast<size_t>(k)];
  s = Solve(&p, target, &intrinsics, width, height, Selections(true, false, false, false));
  r.stages.push_back(fmt::format("{} core, no distortion: RMS {:.3f} px", o.lensmodel, s.rms_reproj_error__pixels));
  // Stage 3: everything, with regularisation and outlier rejection.
  s = Solve(&p, target, &intrinsics, width, height, Selections(true, true, true, true));
  r.stages.push_back(fmt::format("{} in full, regularised, outliers rejected: RMS {:.3f} px, {} outliers",
                                 o.lensmodel, s.rms_reproj_error__pixels, s.Noutliers));
  for (double v : intrinsics)
    if (!std::isfinite(v)) ThrowError("the solve diverged (non-finite intrinsics); try --focal closer to the lens's focal length in pixels");
  r.model = CameraModel(o.lensmodel, intrinsics, width, height);
  {
    const Eigen::MatrixXd var = StateCovariance(&p, target, &intrinsics, width, height, &r.noise_px);
    std::vector<double> rt;  // the state's layout: r then t per frame (t does not act at infinity)
    for (const auto& f : p.frames) {
      for (int k = 0; k < 3; ++k) rt.push_back(f.r.xyz[k]);
      for (int k = 0; k < 3; ++k) rt.push_back(f.t.xyz[k]);
    }
    r.uncertainty = std::make_shared<ProjectionUncertainty>(o.lensmodel, intrinsics, rt, var);
    Json obs = Json::array();
    for (const auto& q : p.pool) obs.push_back({q.x, q.y, q.z});
    r.problem = {{"lensmodel", o.lensmodel}, {"imagersize", {width, height}}, {"intrinsics", intrinsics},
                 {"frames_rt_toref", rt}, {"observations_board", obs}, {"spacing", p.spacing},
                 {"nx", p.nx}, {"ny", p.ny}, {"noise_px", r.noise_px}};
  }

  // Residuals per view, from the solution.
  double sum2 = 0;
  for (size_t k = 0; k < p.obs.size(); ++k) {
    CalibrationView& view = r.views[static_cast<size_t>(p.view_of_obs[k])];
    const mrcal_pose_t& f = p.frames[k];
    const Eigen::Vector3d t(f.t.x, f.t.y, f.t.z);
    const Eigen::Matrix3d R = Rodrigues(Eigen::Vector3d(f.r.x, f.r.y, f.r.z));
    double view2 = 0;
    int n = 0;
    for (int i = 0; i < p.nx * p.ny; ++i) {
      const mrcal_point3_t& q = p.pool[k * static_cast<size_t>(p.nx * p.ny) + static_cast<size_t>(i)];
      if (q.z < 0) {
        if (q.z != -1 || q.x != 0 || q.y != 0) ++view.outliers;  // a real corner marked an outlier
        continue;
      }
      Eigen::Vector2d proj;
      if (!r.model.Project(R * object[static_cast<size_t>(i)] + t, &proj)) continue;
      const double e2 = (proj - Eigen::Vector2d(q.x, q.y)).squaredNorm();
      view2 += e2;
      sum2 += e2;
      r.worst_px = std::max(r.worst_px, std::sqrt(e2));
      ++n;
    }
    view.rms_px = n > 0 ? std::sqrt(view2 / n) : 0;
    r.corners += n;
    r.outliers += view.outliers;
  }
  r.rms_px = r.corners > 0 ? std::sqrt(sum2 / r.corners) : 0;
  return r;
}

}  // namespace mr
