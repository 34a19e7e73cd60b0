#include "calib/calibrate.h"

#include <suitesparse/cholmod.h>
extern "C" {
#include <mrcal/mrcal.h>
// clang-format off: mrcal-internal.h needs mrcal.h's types first
#include <mrcal/mrcal-internal.h>
// clang-format on
}

#include <spdlog/spdlog.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>

#include <cmath>

#include "core/error.h"
#include "core/math.h"
#include "core/npz.h"
#include "core/stderr_capture.h"

namespace mr {

namespace {

mrcal_lensmodel_t Lensmodel(const std::string& name) {
  mrcal_lensmodel_t m;
  if (!mrcal_lensmodel_from_name(&m, name.c_str()) || !mrcal_lensmodel_type_is_valid(m.type))
    throw UsageError(fmt::format("unknown lens model \"{}\"", name));
  mrcal_lensmodel_metadata_t meta = mrcal_lensmodel_metadata(&m);
  if (!meta.has_core)
    throw UsageError(fmt::format("lens model {} has no intrinsics core; mr-calibrate needs one", name));
  return m;
}

}  // namespace

void CalibrationOptions::Check() const {
  Lensmodel(lensmodel);
  if (!(focal_px >= 0))
    throw UsageError(fmt::format("--focal {} must be positive (0: half the image width)", focal_px));
  if (min_views < 1) throw UsageError(fmt::format("min_views {} must be at least 1", min_views));
}

namespace {

// A problem in mrcal's terms: Ncams cameras sharing one lens model, camera 0
// at the reference (extrinsics for cameras 1..), one frame per instant the
// board was seen, one observation per camera and frame.
struct Problem {
  int nx = 0, ny = 0, ncams = 1;
  double spacing = 0;
  std::vector<Eigen::Vector2i> sizes;    // per camera
  std::vector<double> intrinsics;        // Ncams x n
  std::vector<mrcal_pose_t> extrinsics;  // cameras 1.., rt_cam_fromref
  std::vector<mrcal_pose_t> frames;      // board -> reference
  std::vector<mrcal_observation_board_t> obs;
  std::vector<mrcal_point3_t> pool;              // (Nobs, ny, nx): x, y, weight (< 0 outlier)
  std::vector<std::pair<int, int>> view_of_obs;  // (camera, view)

  int Ncams_extrinsics() const { return ncams - 1; }
  int F() const { return static_cast<int>(frames.size()); }
  int N() const { return static_cast<int>(obs.size()); }
  std::vector<int> Imagersizes() const {
    std::vector<int> v;
    for (const auto& s : sizes) {
      v.push_back(s.x());
      v.push_back(s.y());
    }
    return v;
  }
};

// What a stage solves: the board poses always, the board flat.
mrcal_problem_selections_t Selections(bool intrinsics, bool distortions, bool extrinsics, bool regularize,
                                      bool outliers) {
  mrcal_problem_selections_t sel{};
  sel.do_optimize_intrinsics_core = intrinsics;
  sel.do_optimize_intrinsics_distortions = distortions;
  sel.do_optimize_extrinsics = extrinsics;
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

// mrcal prints its progress to stderr ("mrcal.c(5351): Threw out some
// outliers ..."): held here and passed on as debug lines (the outliers it
// threw out are in the report's counts).
mrcal_stats_t Solve(Problem* p, const mrcal_lensmodel_t& lens, const mrcal_problem_selections_t& sel) {
  const mrcal_problem_constants_t constants = Constants();
  const std::vector<int> imagersizes = p->Imagersizes();
  StderrCapture mrcal_lines;
  const mrcal_stats_t stats = mrcal_optimize(
      nullptr, 0, nullptr, 0, p->intrinsics.data(), p->extrinsics.data(), p->frames.data(), nullptr, nullptr, p->ncams,
      p->Ncams_extrinsics(), p->F(), 0, 0, p->obs.data(), nullptr, p->N(), 0, p->pool.data(), &lens, imagersizes.data(),
      sel, &constants, p->spacing, p->nx, p->ny, false, false);
  const std::string printed = mrcal_lines.Take();
  if (!printed.empty()) spdlog::debug("mrcal: {}", printed);
  return stats;
}

Eigen::Matrix3d Rodrigues(const Eigen::Vector3d& r) {
  const double a = r.norm();
  return a > 0 ? Eigen::AngleAxisd(a, r / a).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

mrcal_pose_t ToPose(const Rigid3& x) {
  double rt[6];
  x.ToRt(rt);
  mrcal_pose_t p;
  for (int k = 0; k < 3; ++k) {
    p.r.xyz[k] = rt[k];
    p.t.xyz[k] = rt[3 + k];
  }
  return p;
}

Rigid3 FromPose(const mrcal_pose_t& p) {
  const double rt[6] = {p.r.x, p.r.y, p.r.z, p.t.x, p.t.y, p.t.z};
  return Rigid3::FromRt(rt);
}

// The full selection whose state the covariance and the uncertainty use.
mrcal_problem_selections_t FullSelection(const Problem& p) { return Selections(true, true, p.ncams > 1, true, false); }

// The solution as mrcal's state vector, in physical units.
Eigen::VectorXd PhysicalState(const Problem& p, const mrcal_lensmodel_t& lens) {
  const mrcal_problem_selections_t sel = FullSelection(p);
  const int n_state = mrcal_num_states(p.ncams, p.Ncams_extrinsics(), p.F(), 0, 0, p.N(), sel, &lens);
  Eigen::VectorXd s(n_state);
  Eigen::Index k = 0;
  for (double v : p.intrinsics) s[k++] = v;
  for (const auto& e : p.extrinsics)
    for (double v : {e.r.x, e.r.y, e.r.z, e.t.x, e.t.y, e.t.z}) s[k++] = v;
  for (const auto& f : p.frames)
    for (double v : {f.r.x, f.r.y, f.r.z, f.t.x, f.t.y, f.t.z}) s[k++] = v;
  MR_CHECK(k == n_state);
  return s;
}

// Var(state) of the solved problem in physical units, and the observation
// noise (per coordinate, over the inlier corners) it assumes.
Eigen::MatrixXd StateCovariance(Problem* p, const mrcal_lensmodel_t& lens, double* noise) {
  const mrcal_problem_selections_t sel = FullSelection(*p);
  const int C = p->ncams, E = p->Ncams_extrinsics(), F = p->F(), N = p->N();
  const int n_state = mrcal_num_states(C, E, F, 0, 0, N, sel, &lens);
  const int n_meas = mrcal_num_measurements(N, 0, p->nx, p->ny, C, E, F, 0, 0, sel, &lens);
  const int nnz = _mrcal_num_j_nonzero(N, 0, p->nx, p->ny, C, E, F, 0, 0, p->obs.data(), nullptr, sel, &lens);
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
  const std::vector<int> imagersizes = p->Imagersizes();
  if (!mrcal_optimizer_callback(b.data(), n_state * static_cast<int>(sizeof(double)), x.data(),
                                n_meas * static_cast<int>(sizeof(double)), &jt, p->intrinsics.data(),
                                p->extrinsics.data(), p->frames.data(), nullptr, nullptr, C, E, F, 0, 0, p->obs.data(),
                                nullptr, N, 0, p->pool.data(), &lens, imagersizes.data(), sel, &constants, p->spacing,
                                p->nx, p->ny, false))
    ThrowError("mrcal could not evaluate the solution's Jacobian");
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(n_meas, n_state);
  for (int c = 0; c < n_meas; ++c)
    for (int k = jp[static_cast<size_t>(c)]; k < jp[static_cast<size_t>(c) + 1]; ++k)
      J(c, ji[static_cast<size_t>(k)]) = jx[static_cast<size_t>(k)];
  const int n_obs = mrcal_num_measurements_boards(N, p->nx, p->ny);
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
  mrcal_unpack_solver_state_vector(scale.data(), C, E, F, 0, 0, sel, &lens);
  for (int i = 0; i < n_state; ++i)
    for (int j = 0; j < n_state; ++j) var(i, j) *= scale[static_cast<size_t>(i)] * scale[static_cast<size_t>(j)];
  return var;
}

// mrcal's optimization_inputs for the solved problem, as mrcal serialises
// them in a .cameramodel (cameramodel.py: numpy savez_compressed, base 85).
std::string OptimizationInputs(const Problem& p, const std::string& lensmodel) {
  NpzWriter z;
  const int64_t C = p.ncams, n = static_cast<int64_t>(p.intrinsics.size()) / C;
  z.AddF64("intrinsics", {C, n}, p.intrinsics);
  std::vector<double> ext, frames, obs;
  for (const auto& e : p.extrinsics)
    for (double v : {e.r.x, e.r.y, e.r.z, e.t.x, e.t.y, e.t.z}) ext.push_back(v);
  for (const auto& f : p.frames)
    for (double v : {f.r.x, f.r.y, f.r.z, f.t.x, f.t.y, f.t.z}) frames.push_back(v);
  for (const auto& q : p.pool)
    for (double v : {q.x, q.y, q.z}) obs.push_back(v);
  std::vector<int32_t> indices;
  for (const auto& o : p.obs)
    for (int v : {o.iframe, o.icam.intrinsics, o.icam.extrinsics}) indices.push_back(v);
  z.AddF64("extrinsics_rt_fromref", {C - 1, 6}, ext);
  z.AddF64("frames_rt_toref", {p.F(), 6}, frames);
  z.AddString("points", "");
  z.AddF64("observations_board", {p.N(), p.ny, p.nx, 3}, obs);
  z.AddI32("indices_frame_camintrinsics_camextrinsics", {p.N(), 3}, indices);
  z.AddString("observations_point", "");
  z.AddString("indices_point_camintrinsics_camextrinsics", "");
  z.AddString("lensmodel", lensmodel);
  const std::vector<int> sizes = p.Imagersizes();
  z.AddI32("imagersizes", {C, 2}, std::vector<int32_t>(sizes.begin(), sizes.end()));
  z.AddString("calobject_warp", "");
  z.AddBool("do_optimize_intrinsics_core", true);
  z.AddBool("do_optimize_intrinsics_distortions", true);
  z.AddBool("do_optimize_extrinsics", true);
  z.AddBool("do_optimize_frames", true);
  z.AddBool("do_optimize_calobject_warp", false);
  z.AddBool("do_apply_regularization", true);
  z.AddBool("do_apply_outlier_rejection", false);  // the outliers are marked (weight < 0)
  z.AddScalar("calibration_object_spacing", p.spacing);
  z.AddScalar("point_min_range", -1);
  z.AddScalar("point_max_range", -1);
  z.AddBool("verbose", false);
  return Base85Encode(z.Bytes());
}

// Residuals per view from the solution, into `r` (camera c's result).
void Residuals(const Problem& p, const BoardSpec& board, int c, CalibrationResult* r) {
  const auto object = board.ObjectPoints();
  double sum2 = 0;
  for (size_t k = 0; k < p.obs.size(); ++k) {
    if (p.view_of_obs[k].first != c) continue;
    CalibrationView& view = r->views[static_cast<size_t>(p.view_of_obs[k].second)];
    const int e = p.obs[k].icam.extrinsics;
    const Rigid3 cam_from_ref = e < 0 ? Rigid3() : FromPose(p.extrinsics[static_cast<size_t>(e)]);
    const Rigid3 pose = cam_from_ref * FromPose(p.frames[static_cast<size_t>(p.obs[k].iframe)]);
    view.cam_from_board = pose;
    double view2 = 0;
    int n = 0;
    view.outliers = 0;
    for (int i = 0; i < p.nx * p.ny; ++i) {
      const mrcal_point3_t& q = p.pool[k * static_cast<size_t>(p.nx * p.ny) + static_cast<size_t>(i)];
      if (q.z < 0) {
        if (q.z != -1 || q.x != 0 || q.y != 0) ++view.outliers;  // a real corner marked an outlier
        continue;
      }
      Eigen::Vector2d proj;
      if (!r->model.Project(pose * object[static_cast<size_t>(i)], &proj)) continue;
      const double e2 = (proj - Eigen::Vector2d(q.x, q.y)).squaredNorm();
      view2 += e2;
      sum2 += e2;
      r->worst_px = std::max(r->worst_px, std::sqrt(e2));
      ++n;
    }
    view.rms_px = n > 0 ? std::sqrt(view2 / n) : 0;
    r->corners += n;
    r->outliers += view.outliers;
  }
  r->rms_px = r->corners > 0 ? std::sqrt(sum2 / r->corners) : 0;
}

// Camera c's model, uncertainty and residuals from the solved problem.
void Finish(Problem* p, const BoardSpec& board, const std::string& lensmodel, const mrcal_lensmodel_t& lens,
            const Eigen::VectorXd& state, const Eigen::MatrixXd& var, double noise, const std::string& inputs, int c,
            CalibrationResult* r) {
  const size_t n = p->intrinsics.size() / static_cast<size_t>(p->ncams);
  std::vector<double> k(p->intrinsics.begin() + static_cast<long>(n * static_cast<size_t>(c)),
                        p->intrinsics.begin() + static_cast<long>(n * static_cast<size_t>(c + 1)));
  for (double v : k)
    if (!std::isfinite(v))
      ThrowError("the solve diverged (non-finite intrinsics); try --focal closer to the lens's focal length in pixels");
  const Rigid3 cam_from_ref = c == 0 ? Rigid3() : FromPose(p->extrinsics[static_cast<size_t>(c - 1)]);
  r->model = CameraModel(lensmodel, k, p->sizes[static_cast<size_t>(c)].x(), p->sizes[static_cast<size_t>(c)].y(),
                         cam_from_ref);
  r->model.set_optimization_inputs(inputs, c);
  r->noise_px = noise;
  const mrcal_problem_selections_t sel = FullSelection(*p);
  ProjectionUncertainty::Layout l;
  l.intrinsics = mrcal_state_index_intrinsics(c, p->ncams, p->Ncams_extrinsics(), p->F(), 0, 0, p->N(), sel, &lens);
  l.n_intrinsics = static_cast<int>(n);
  l.extrinsics =
      c == 0 ? -1
             : mrcal_state_index_extrinsics(c - 1, p->ncams, p->Ncams_extrinsics(), p->F(), 0, 0, p->N(), sel, &lens);
  l.frames = mrcal_state_index_frames(0, p->ncams, p->Ncams_extrinsics(), p->F(), 0, 0, p->N(), sel, &lens);
  l.n_frames = p->F();
  r->uncertainty = std::make_shared<ProjectionUncertainty>(lensmodel, state, var, l);
  Residuals(*p, board, c, r);
}

// The board's pose (camera from board) by OpenCV's solvePnP on the
// corners' rays through `camera`, those within 75 degrees of its axis taken
// as normalised pinhole points.  False (with the number of such rays) when
// fewer than 6 or the board is not in front.
bool PoseFromRays(const BoardSpec& board, const CameraModel& camera, const CornerDetection& d, Rigid3* pose,
                  int* rays) {
  const auto object = board.ObjectPoints();
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  for (size_t i = 0; i < d.pixels.size(); ++i) {
    Eigen::Vector3d ray;
    if (!camera.Unproject(d.pixels[i], &ray) || ray.normalized().z() < std::cos(75 * kDegToRad)) continue;
    const Eigen::Vector3d& P = object[static_cast<size_t>(d.ids[i])];
    obj.emplace_back(P.x(), P.y(), P.z());
    img.emplace_back(ray.x() / ray.z(), ray.y() / ray.z());
  }
  *rays = static_cast<int>(obj.size());
  cv::Mat rvec, tvec;
  if (obj.size() < 6 ||
      !cv::solvePnP(obj, img, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec, false, cv::SOLVEPNP_ITERATIVE) ||
      tvec.at<double>(2) <= 0)
    return false;
  const double rt[6] = {rvec.at<double>(0), rvec.at<double>(1), rvec.at<double>(2),
                        tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)};
  *pose = Rigid3::FromRt(rt);
  return true;
}

// One camera's observations and seeds: corners to mrcal's pool, a board
// pose per view from the stereographic seed's rays (solvePnP), the views
// that cannot be used marked with the reason.
void AddCameraViews(const BoardSpec& board, std::vector<CornerDetection> detections, const CameraModel& seed,
                    Problem* p, CalibrationResult* r) {
  for (size_t v = 0; v < detections.size(); ++v) {
    CalibrationView view;
    view.detection = std::move(detections[v]);
    const CornerDetection& d = view.detection;
    if (!d.found) {
      view.reason = d.reason;
      r->views.push_back(view);
      continue;
    }
    // Seed pose from the corners' rays through the stereographic seed.
    Rigid3 seed_pose;
    int rays = 0;
    if (!PoseFromRays(board, seed, d, &seed_pose, &rays)) {
      view.reason = fmt::format("no seed pose ({} corners within 75 degrees of the seed's axis)", rays);
      r->views.push_back(view);
      continue;
    }
    const mrcal_pose_t pose = ToPose(seed_pose);
    mrcal_observation_board_t ob{};
    ob.icam.intrinsics = 0;
    ob.icam.extrinsics = -1;
    ob.iframe = p->F();
    p->obs.push_back(ob);
    p->frames.push_back(pose);
    const size_t base = p->pool.size();
    p->pool.resize(base + static_cast<size_t>(p->nx * p->ny),
                   mrcal_point3_t{{0, 0, -1}});  // missing corners: weight < 0
    for (size_t i = 0; i < d.pixels.size(); ++i) {
      mrcal_point3_t& q = p->pool[base + static_cast<size_t>(d.ids[i])];
      q.x = d.pixels[i].x();
      q.y = d.pixels[i].y();
      q.z = 1.0;
    }
    p->view_of_obs.emplace_back(0, static_cast<int>(r->views.size()));
    view.used = true;
    r->views.push_back(view);
  }
}

std::string Stage(const std::string& what, const mrcal_stats_t& s) {
  return fmt::format("{}: RMS {:.3f} px, {} outliers", what, s.rms_reproj_error__pixels, s.Noutliers);
}

}  // namespace

ProjectionUncertainty::ProjectionUncertainty(std::string lensmodel, Eigen::VectorXd state, Eigen::MatrixXd var,
                                             Layout layout)
    : lensmodel_(std::move(lensmodel)), state_(std::move(state)), var_(std::move(var)), layout_(layout) {
  for (int i = 0; i < layout_.n_intrinsics; ++i) used_.push_back(layout_.intrinsics + i);
  if (layout_.extrinsics >= 0)
    for (int i = 0; i < 6; ++i) used_.push_back(layout_.extrinsics + i);
  for (int i = 0; i < 6 * layout_.n_frames; ++i) used_.push_back(layout_.frames + i);
}

Eigen::Vector2d ProjectionUncertainty::ProjectPerturbed(const Eigen::Vector3d& dir_cam,
                                                        const Eigen::VectorXd& s) const {
  auto r_at = [](const Eigen::VectorXd& v, int i) { return Eigen::Vector3d(v[i], v[i + 1], v[i + 2]); };
  // Rotations only: a point at infinity.  Camera to reference with the
  // solution; into each board's frame with the solution and back with the
  // perturbed pose, averaged (mrcal's mean-frames reference); to the
  // camera with the perturbed extrinsics.
  const int e = layout_.extrinsics;
  const Eigen::Vector3d d_ref = e < 0 ? dir_cam : Eigen::Vector3d(Rodrigues(r_at(state_, e)).transpose() * dir_cam);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int f = 0; f < layout_.n_frames; ++f) {
    const int i = layout_.frames + 6 * f;
    mean += Rodrigues(r_at(s, i)) * (Rodrigues(r_at(state_, i)).transpose() * d_ref);
  }
  mean /= layout_.n_frames;
  if (e >= 0) mean = Rodrigues(r_at(s, e)) * mean;
  const std::vector<double> k(s.data() + layout_.intrinsics, s.data() + layout_.intrinsics + layout_.n_intrinsics);
  const CameraModel m(lensmodel_, k, 1, 1);
  Eigen::Vector2d q(NAN, NAN);
  m.Project(mean, &q);
  return q;
}

double ProjectionUncertainty::StdevPx(const Eigen::Vector2d& q, const CameraModel& model) const {
  Eigen::Vector3d d;
  if (!model.Unproject(q, &d)) return NAN;
  d.normalize();
  const Eigen::Index n = static_cast<Eigen::Index>(used_.size());
  Eigen::MatrixXd G(2, n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const Eigen::Index i = used_[static_cast<size_t>(j)];
    const double h = 1e-6 * std::max(1.0, std::abs(state_[i]));
    Eigen::VectorXd a = state_, b = state_;
    a[i] += h;
    b[i] -= h;
    G.col(j) = (ProjectPerturbed(d, a) - ProjectPerturbed(d, b)) / (2 * h);
  }
  const Eigen::Matrix2d var = G * var_(used_, used_) * G.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(var);
  return std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
}

CalibrationResult CalibrateCamera(const BoardSpec& board, std::vector<CornerDetection> detections, int width,
                                  int height, const CalibrationOptions& o) {
  o.Check();
  const mrcal_lensmodel_t target = Lensmodel(o.lensmodel);
  mrcal_lensmodel_t stereo;
  mrcal_lensmodel_from_name(&stereo, "LENSMODEL_STEREOGRAPHIC");
  const double f0 = o.focal_px > 0 ? o.focal_px : 0.5 * width;
  const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1);
  const CameraModel seed("LENSMODEL_STEREOGRAPHIC", {f0, f0, cx, cy}, width, height);

  CalibrationResult r;
  Problem p;
  p.nx = board.inner_x;
  p.ny = board.inner_y;
  p.spacing = board.square_m;
  p.sizes = {Eigen::Vector2i(width, height)};
  AddCameraViews(board, std::move(detections), seed, &p, &r);
  if (p.N() < o.min_views) {
    int found = 0;
    for (const auto& v : r.views) found += v.detection.found;
    throw Error(
        fmt::format("{} usable views of the board ({} photographs, the board found in {}); at least {} "
                    "are needed, from different angles and covering the image",
                    p.N(), r.views.size(), found, o.min_views));
  }

  // Stage 1: the stereographic seed's core and the board poses.
  p.intrinsics = {f0, f0, cx, cy};
  r.stages.push_back(
      Stage("stereographic core and board poses", Solve(&p, stereo, Selections(true, false, false, false, false))));
  // Stage 2: the target model, its distortions at zero (for the splined
  // stereographic models, zero is the stereographic lens itself).
  std::vector<double> core = p.intrinsics;
  p.intrinsics.assign(static_cast<size_t>(mrcal_lensmodel_num_params(&target)), 0.0);
  std::copy(core.begin(), core.end(), p.intrinsics.begin());
  r.stages.push_back(
      Stage(o.lensmodel + " core, no distortion", Solve(&p, target, Selections(true, false, false, false, false))));
  // Stage 3: everything, with regularisation and outlier rejection.
  r.stages.push_back(Stage(o.lensmodel + " in full, regularised, outliers rejected",
                           Solve(&p, target, Selections(true, true, false, true, true))));
  for (double v : p.intrinsics)
    if (!std::isfinite(v))
      ThrowError("the solve diverged (non-finite intrinsics); try --focal closer to the lens's focal length in pixels");
  double noise = 0;
  const Eigen::MatrixXd var = StateCovariance(&p, target, &noise);
  Finish(&p, board, o.lensmodel, target, PhysicalState(p, target), var, noise, OptimizationInputs(p, o.lensmodel), 0,
         &r);
  return r;
}

Rigid3 BoardPose(const BoardSpec& board, const CameraModel& camera, const CornerDetection& d) {
  if (!d.found) ThrowErrorAt(FileLoc{d.image}, "no board pose: {}", d.reason);
  Rigid3 pose;
  int rays = 0;
  if (!PoseFromRays(board, camera, d, &pose, &rays))
    ThrowErrorAt(FileLoc{d.image}, "no board pose ({} corners within 75 degrees of the axis)", rays);
  return pose;
}

Rigid3 WorldFromCamByFlatBoard(const Rigid3& cam_from_board) {
  // Board frame: x along rows, y along columns, z into the printed side.
  Eigen::Matrix3d world_from_board;
  world_from_board << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  return Rigid3(Eigen::Quaterniond(world_from_board), Eigen::Vector3d::Zero()) * cam_from_board.Inverse();
}

RigCalibrationResult CalibrateRig(const BoardSpec& board, std::vector<std::vector<CornerDetection>> detections,
                                  const std::vector<Eigen::Vector2i>& sizes, const CalibrationOptions& o) {
  const int C = static_cast<int>(detections.size());
  if (C < 2) throw UsageError("a rig needs two or more cameras");
  MR_CHECK(static_cast<int>(sizes.size()) == C);
  const size_t instants = detections[0].size();
  for (int c = 1; c < C; ++c)
    if (detections[static_cast<size_t>(c)].size() != instants)
      throw Error(
          fmt::format("camera {} has {} photographs and camera 0 has {}: a rig's cameras photograph "
                      "the board at the same instants, one photograph each",
                      c, detections[static_cast<size_t>(c)].size(), instants));
  const mrcal_lensmodel_t lens = Lensmodel(o.lensmodel);
  RigCalibrationResult rig;
  // Each camera alone: its intrinsics and the board's pose in its frame.
  for (int c = 0; c < C; ++c) {
    try {
      rig.cameras.push_back(CalibrateCamera(board, detections[static_cast<size_t>(c)],
                                            sizes[static_cast<size_t>(c)].x(), sizes[static_cast<size_t>(c)].y(), o));
    } catch (const UsageError& e) {
      throw UsageError(fmt::format("camera {}: {}", c, e.what()));
    } catch (const Error& e) {
      throw Error(fmt::format("camera {}: {}", c, e.what()));
    }
    rig.stages.push_back(fmt::format("camera {} alone: {}", c, rig.cameras.back().stages.back()));
  }
  // Extrinsics seeds: cam_c_from_cam0 = cam_c_from_board * (cam0_from_board)^-1
  // over the instants both saw, averaged (rotations as sign-aligned
  // quaternions).
  std::vector<Rigid3> cam_from_ref(static_cast<size_t>(C));
  const auto& v0 = rig.cameras[0].views;
  for (int c = 1; c < C; ++c) {
    const auto& vc = rig.cameras[static_cast<size_t>(c)].views;
    Eigen::Vector4d q_sum = Eigen::Vector4d::Zero();
    Eigen::Vector3d t_sum = Eigen::Vector3d::Zero();
    Eigen::Quaterniond q_ref = Eigen::Quaterniond::Identity();
    int shared = 0;
    for (size_t i = 0; i < instants; ++i) {
      if (!v0[i].used || !vc[i].used) continue;
      const Rigid3 x = vc[i].cam_from_board * v0[i].cam_from_board.Inverse();
      if (shared == 0) q_ref = x.rotation;
      Eigen::Vector4d q = x.rotation.coeffs();
      if (q.dot(q_ref.coeffs()) < 0) q = -q;
      q_sum += q;
      t_sum += x.translation;
      ++shared;
    }
    if (shared == 0)
      throw Error(
          fmt::format("camera {} saw the board at no instant at which camera 0 saw it; the extrinsics "
                      "need photographs where both cameras see the whole board",
                      c));
    cam_from_ref[static_cast<size_t>(c)] =
        Rigid3(Eigen::Quaterniond(Eigen::Vector4d(q_sum.normalized())), t_sum / shared);
  }
  // The joint problem: a frame per instant some camera saw the board,
  // seeded from the first camera that saw it.
  Problem p;
  p.nx = board.inner_x;
  p.ny = board.inner_y;
  p.spacing = board.square_m;
  p.ncams = C;
  p.sizes = sizes;
  for (int c = 0; c < C; ++c) {
    const auto& k = rig.cameras[static_cast<size_t>(c)].model.intrinsics();
    p.intrinsics.insert(p.intrinsics.end(), k.begin(), k.end());
    if (c > 0) p.extrinsics.push_back(ToPose(cam_from_ref[static_cast<size_t>(c)]));
  }
  const int per_view = p.nx * p.ny;
  for (size_t i = 0; i < instants; ++i) {
    int seen = 0;
    for (int c = 0; c < C; ++c) {
      const CalibrationResult& cam = rig.cameras[static_cast<size_t>(c)];
      const CalibrationView& v = cam.views[i];
      if (!v.used) continue;
      if (seen++ == 0) p.frames.push_back(ToPose(cam_from_ref[static_cast<size_t>(c)].Inverse() * v.cam_from_board));
      mrcal_observation_board_t ob{};
      ob.icam.intrinsics = c;
      ob.icam.extrinsics = c - 1;
      ob.iframe = p.F() - 1;
      p.obs.push_back(ob);
      p.view_of_obs.emplace_back(c, static_cast<int>(i));
      const size_t base = p.pool.size();
      p.pool.resize(base + static_cast<size_t>(per_view), mrcal_point3_t{{0, 0, -1}});
      const CornerDetection& d = v.detection;
      for (size_t j = 0; j < d.pixels.size(); ++j) {
        mrcal_point3_t& q = p.pool[base + static_cast<size_t>(d.ids[j])];
        q.x = d.pixels[j].x();
        q.y = d.pixels[j].y();
        q.z = 1.0;
      }
    }
    rig.instants += seen > 0;
    rig.shared_instants += seen > 1;
  }
  rig.stages.push_back(Stage("extrinsics and board poses, intrinsics held",
                             Solve(&p, lens, Selections(false, false, true, false, false))));
  rig.stages.push_back(Stage("everything jointly, regularised, outliers rejected",
                             Solve(&p, lens, Selections(true, true, true, true, true))));
  double noise = 0;
  const Eigen::MatrixXd var = StateCovariance(&p, lens, &noise);
  const Eigen::VectorXd state = PhysicalState(p, lens);
  const std::string inputs = OptimizationInputs(p, o.lensmodel);
  const mrcal_problem_selections_t sel = FullSelection(p);
  double sum2 = 0;
  int corners = 0;
  for (int c = 0; c < C; ++c) {
    CalibrationResult& r = rig.cameras[static_cast<size_t>(c)];
    r.rms_px = r.worst_px = 0;
    r.corners = r.outliers = 0;
    Finish(&p, board, o.lensmodel, lens, state, var, noise, inputs, c, &r);
    sum2 += r.rms_px * r.rms_px * r.corners;
    corners += r.corners;
    Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Zero();
    if (c > 0) {
      const int e = mrcal_state_index_extrinsics(c - 1, C, C - 1, p.F(), 0, 0, p.N(), sel, &lens);
      cov = var.block<6, 6>(e, e);
    }
    rig.extrinsics_covariance.push_back(cov);
  }
  rig.rms_px = corners > 0 ? std::sqrt(sum2 / corners) : 0;
  rig.noise_px = noise;
  return rig;
}

}  // namespace mr
