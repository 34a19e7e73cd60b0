#include "camera/camera_model.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

extern "C" {
#include <mrcal/mrcal.h>
}

#include "core/error.h"
#include "core/math.h"
#include "core/stderr_capture.h"

namespace mr {

struct CameraModel::Impl {
  mrcal_lensmodel_t lensmodel;
};

namespace {

mrcal_lensmodel_t ParseLensModel(const std::string& name) {
  mrcal_lensmodel_t m;
  if (!mrcal_lensmodel_from_name(&m, name.c_str())) ThrowError("unknown or misconfigured lens model \"{}\"", name);
  return m;
}

std::string LensModelName(const mrcal_lensmodel_t& m) {
  char buf[256];
  if (!mrcal_lensmodel_name(buf, sizeof(buf), &m)) ThrowError("lens model name too long");
  return buf;
}

struct CameramodelDeleter {
  void operator()(mrcal_cameramodel_t* p) const { mrcal_free_cameramodel(&p); }
};

CameraModel FromMrcal(const mrcal_cameramodel_t& cm) {
  const int n = mrcal_lensmodel_num_params(&cm.lensmodel);
  std::vector<double> intrinsics(cm.intrinsics, cm.intrinsics + n);
  return CameraModel(LensModelName(cm.lensmodel), std::move(intrinsics), static_cast<int>(cm.imagersize[0]),
                     static_cast<int>(cm.imagersize[1]), Rigid3::FromRt(cm.rt_cam_ref));
}

bool IsStereographicFamily(mrcal_lensmodel_type_t t) {
  return t == MRCAL_LENSMODEL_STEREOGRAPHIC || t == MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC ||
         t == MRCAL_LENSMODEL_LONLAT || t == MRCAL_LENSMODEL_LATLON;
}

}  // namespace

CameraModel::CameraModel() = default;

CameraModel::CameraModel(const std::string& lensmodel, std::vector<double> intrinsics, int width, int height,
                         const Rigid3& cam_from_ref)
    : intrinsics_(std::move(intrinsics)), width_(width), height_(height), cam_from_ref_(cam_from_ref) {
  auto impl = std::make_shared<Impl>();
  impl->lensmodel = ParseLensModel(lensmodel);
  lensmodel_ = LensModelName(impl->lensmodel);
  const int n = mrcal_lensmodel_num_params(&impl->lensmodel);
  if (static_cast<int>(intrinsics_.size()) != n)
    ThrowError("{} takes {} intrinsics, got {}", lensmodel_, n, intrinsics_.size());
  if (!AllFinite(intrinsics_.begin(), intrinsics_.end())) ThrowError("{}: intrinsics contain NaN or Inf", lensmodel_);
  if (width <= 0 || height <= 0) ThrowError("image size {}x{} is not positive", width, height);
  if (intrinsics_[0] <= 0 || intrinsics_[1] <= 0)
    ThrowError("{}: focal lengths must be positive, got {} and {}", lensmodel_, intrinsics_[0], intrinsics_[1]);
  impl_ = std::move(impl);
}

namespace {

// Checks that `text` is a well-formed .cameramodel dict literal before
// libmrcal sees it: libmrcal 2.2's lexer reads past the buffer on an
// unterminated string (found by fuzz/fuzz_cameramodel).  Grammar:
//   model := '{' (string ':' value ','?)* '}'    value := string | number | list
//   list  := '[' (value ','?)* ']'               comments run from '#' to the line end.
class DictLiteralChecker {
 public:
  DictLiteralChecker(const std::string& t, const std::string& name) : t_(t), name_(name) {}
  // Returns the text without comments and with a final newline: libmrcal
  // 2.2 also reads past the end of a comment that ends the file.
  std::string Check() {
    Skip();
    Expect('{');
    for (;;) {
      Skip();
      if (Peek() == '}') break;
      String();
      Skip();
      Expect(':');
      Value(0);
      Skip();
      if (Peek() == ',') Take();
    }
    Take();
    Skip();
    if (i_ != t_.size()) Fail("trailing characters after the closing brace");
    return clean_ + "\n";
  }

 private:
  [[noreturn]] void Fail(const std::string& what) const {
    int line =
        1 + static_cast<int>(std::count(t_.begin(), t_.begin() + static_cast<long>(std::min(i_, t_.size())), '\n'));
    throw Error(FileLoc{name_, line}, "not a valid .cameramodel: " + what);
  }
  void Take() { clean_ += t_[i_++]; }
  char Peek() const { return i_ < t_.size() ? t_[i_] : '\0'; }
  void Skip() {
    while (i_ < t_.size()) {
      if (std::isspace(static_cast<unsigned char>(t_[i_]))) {
        clean_ += t_[i_++];
      } else if (t_[i_] == '#') {
        while (i_ < t_.size() && t_[i_] != '\n') ++i_;  // comments are dropped
      } else {
        break;
      }
    }
  }
  void Expect(char c) {
    if (Peek() != c) Fail(fmt::format("expected '{}'", c));
    Take();
  }
  void String() {
    char q = Peek();
    if (q != '\'' && q != '"') Fail("expected a quoted string");
    for (Take(); i_ < t_.size() && t_[i_] != q; Take())
      if (t_[i_] == '\n' || t_[i_] == '\\') Fail("unterminated or escaped string");
    if (i_ >= t_.size()) Fail("unterminated string");
    Take();
  }
  void Value(int depth) {
    if (depth > 8) Fail("lists nested too deeply");
    Skip();
    char c = Peek();
    if (c == '\'' || c == '"') return String();
    if (c == 'b' && i_ + 1 < t_.size() &&
        (t_[i_ + 1] == '\'' || t_[i_ + 1] == '"')) {  // Python bytes: mrcal's optimization_inputs
      Take();
      return String();
    }
    if (c == '[') {
      Take();
      for (;;) {
        Skip();
        if (Peek() == ']') {
          Take();
          return;
        }
        Value(depth + 1);
        Skip();
        if (Peek() == ',')
          Take();
        else if (Peek() != ']')
          Fail("expected ',' or ']'");
      }
    }
    size_t start = i_;
    while (i_ < t_.size() &&
           (std::isalnum(static_cast<unsigned char>(t_[i_])) || t_[i_] == '.' || t_[i_] == '-' || t_[i_] == '+'))
      Take();
    if (i_ == start) Fail("expected a string, a number or a list");
  }
  const std::string& t_;
  const std::string& name_;
  size_t i_ = 0;
  std::string clean_;
};

}  // namespace

CameraModel CameraModel::FromString(const std::string& text, const std::string& name) {
  // A .cameramodel is text.  libmrcal 2.2's parser reads past the buffer on
  // embedded NUL bytes (found by fuzz/fuzz_cameramodel), so refuse them here
  // and hand it a NUL-terminated string.
  if (const auto nul = text.find('\0'); nul != std::string::npos)
    ThrowErrorAt(FileLoc{name}, "not a text file (NUL byte at offset {})", nul);
  if (text.size() > (size_t{1} << 30)) ThrowErrorAt(FileLoc{name}, "file too large for a camera model");
  const std::string clean = DictLiteralChecker(text, name).Check();
  // libmrcal prints its parse diagnostics to stderr and returns NULL: they
  // go into the message instead of before it.
  StderrCapture library_lines;
  std::unique_ptr<mrcal_cameramodel_t, CameramodelDeleter> cm(mrcal_read_cameramodel_string(clean.c_str(), 0));
  if (!cm) {
    const std::string printed = library_lines.Take();
    ThrowErrorAt(FileLoc{name}, "not a valid mrcal .cameramodel (libmrcal's parser rejected it{}{})",
                 printed.empty() ? "" : ": ", printed);
  }
  try {
    return FromMrcal(*cm);
  } catch (const Error& e) {
    ThrowErrorAt(FileLoc{name}, "{}", e.message());
  }
}

CameraModel CameraModel::Read(const fs::path& path) { return FromString(ReadTextFile(path), path.string()); }

std::string CameraModel::ToString(const std::string& note) const {
  // mrcal's .cameramodel text (a Python dict literal).  Written here rather
  // than by libmrcal's writer, which prints 6 decimals and so loses the
  // small coefficients of splined models (tested in camera_model_test).
  std::string s;
  if (!note.empty()) {
    size_t start = 0;
    while (start <= note.size()) {
      size_t nl = note.find('\n', start);
      s += "# " + note.substr(start, nl == std::string::npos ? std::string::npos : nl - start) + "\n";
      if (nl == std::string::npos) break;
      start = nl + 1;
    }
  }
  double rt[6];
  cam_from_ref_.ToRt(rt);
  auto list = [](const double* v, size_t n) {
    std::string out = "[";
    for (size_t i = 0; i < n; ++i) out += fmt::format(" {:.17g},", v[i]);
    return out + " ]";
  };
  s += "{\n";
  s += fmt::format("    'lensmodel':  '{}',\n", lensmodel_);
  s += "    # intrinsics are fx,fy,cx,cy,distortion0,distortion1,....\n";
  s += fmt::format("    'intrinsics': {},\n", list(intrinsics_.data(), intrinsics_.size()));
  s += "    # extrinsics are rt_fromref\n";
  s += fmt::format("    'extrinsics': {},\n", list(rt, 6));
  s += fmt::format("    'imagersize': [ {}, {}, ],\n", width_, height_);
  if (!optimization_inputs_.empty()) {
    s += fmt::format("    'icam_intrinsics': {},\n", icam_intrinsics_);
    s += "    # mrcal's optimisation inputs: every observation of the solve, as a base-85 .npz\n";
    s += fmt::format("    'optimization_inputs': b'{}',\n", optimization_inputs_);
  }
  s += "}\n";
  return s;
}

void CameraModel::Write(const fs::path& path, const std::string& note) const {
  MR_CHECK(impl_);
  const std::string text = ToString(note);
  // Check that libmrcal reads back what we wrote before replacing anything.
  FromString(text, path.string());
  WriteTextFile(path, text);
}

bool CameraModel::SeesBehind() const {
  MR_CHECK(impl_);
  return IsStereographicFamily(impl_->lensmodel.type);
}

Eigen::Vector4d CameraModel::Core() const { return {intrinsics_[0], intrinsics_[1], intrinsics_[2], intrinsics_[3]}; }

bool CameraModel::Project(const Eigen::Vector3d& p, Eigen::Vector2d* q) const {
  MR_CHECK(impl_);
  if (!p.allFinite() || p.squaredNorm() == 0) return false;
  const auto type = impl_->lensmodel.type;
  if (!IsStereographicFamily(type) && p.z() <= 0) return false;
  // The stereographic projection is singular straight backwards.
  if (IsStereographicFamily(type) && p.z() < 0 && p.head<2>().norm() <= 1e-12 * -p.z()) return false;
  mrcal_point3_t pm = {{p.x(), p.y(), p.z()}};
  mrcal_point2_t qm;
  if (!mrcal_project(&qm, nullptr, nullptr, &pm, 1, &impl_->lensmodel, intrinsics_.data())) return false;
  if (!std::isfinite(qm.x) || !std::isfinite(qm.y)) return false;
  *q = Eigen::Vector2d(qm.x, qm.y);
  return true;
}

void CameraModel::Project(const std::vector<Eigen::Vector3d>& p, std::vector<Eigen::Vector2d>* q,
                          std::vector<char>* ok) const {
  q->resize(p.size());
  if (ok) ok->resize(p.size());
  for (size_t i = 0; i < p.size(); ++i) {
    bool good = Project(p[i], &(*q)[i]);
    if (!good) (*q)[i].setConstant(std::numeric_limits<double>::quiet_NaN());
    if (ok) (*ok)[i] = good;
  }
}

bool CameraModel::Unproject(const Eigen::Vector2d& q, Eigen::Vector3d* dir) const {
  MR_CHECK(impl_);
  if (!q.allFinite()) return false;
  Eigen::Vector3d v;
  if (impl_->lensmodel.type == MRCAL_LENSMODEL_CAHVORE) {
    // libmrcal cannot unproject CAHVORE: Gauss-Newton on the stereographic
    // coordinates u of the direction, with a central-difference Jacobian,
    // started from the pinhole core.
    const Eigen::Vector4d c = Core();
    auto dir_from_u = [](const Eigen::Vector2d& u) -> Eigen::Vector3d {
      const double n2 = u.squaredNorm();
      return Eigen::Vector3d(4 * u.x(), 4 * u.y(), 4 - n2) / (4 + n2);
    };
    Eigen::Vector2d pin((q.x() - c[2]) / c[0], (q.y() - c[3]) / c[1]);
    Eigen::Vector3d d0 = Eigen::Vector3d(pin.x(), pin.y(), 1).normalized();
    Eigen::Vector2d u = 2 * d0.head<2>() / (1 + d0.z());
    bool converged = false;
    for (int it = 0; it < 50 && !converged; ++it) {
      Eigen::Vector2d q0;
      if (!Project(dir_from_u(u), &q0)) return false;
      Eigen::Vector2d r = q0 - q;
      if (r.norm() < 1e-9) {
        converged = true;
        break;
      }
      Eigen::Matrix2d J;
      const double h = 1e-6;
      for (int k = 0; k < 2; ++k) {
        Eigen::Vector2d up = u, um = u, qp, qm;
        up[k] += h;
        um[k] -= h;
        if (!Project(dir_from_u(up), &qp) || !Project(dir_from_u(um), &qm)) return false;
        J.col(k) = (qp - qm) / (2 * h);
      }
      if (std::abs(J.determinant()) < 1e-300) return false;
      u -= J.inverse() * r;
    }
    v = dir_from_u(u);
  } else {
    mrcal_point2_t qm = {{q.x(), q.y()}};
    mrcal_point3_t vm;
    if (!mrcal_unproject(&vm, &qm, 1, &impl_->lensmodel, intrinsics_.data())) return false;
    v = Eigen::Vector3d(vm.x, vm.y, vm.z);
  }
  if (!v.allFinite() || v.squaredNorm() == 0) return false;
  v.normalize();
  // Accept only a direction that projects back onto q (the solver can stall
  // outside the model's domain and return an arbitrary vector).
  Eigen::Vector2d back;
  if (!Project(v, &back) || (back - q).norm() > 1e-3 * std::max(1.0, Core()[0] / 1000.0)) return false;
  *dir = v;
  return true;
}

bool CameraModel::UnprojectNear(const Eigen::Vector2d& q, const Eigen::Vector3d& near, Eigen::Vector3d* dir) const {
  MR_CHECK(impl_);
  if (!q.allFinite()) return false;
  // Newton on the stereographic coordinates u of the direction (regular
  // everywhere but straight backwards): dir = (4 u, 4 - |u|^2) / (4 + |u|^2).
  // libmrcal unprojects the pinhole, stereographic and lon/lat models in
  // closed form, and CAHVORE not at all (Unproject has its own solve).
  const auto type = impl_->lensmodel.type;
  const bool closed_form = type == MRCAL_LENSMODEL_PINHOLE || type == MRCAL_LENSMODEL_STEREOGRAPHIC ||
                           type == MRCAL_LENSMODEL_LONLAT || type == MRCAL_LENSMODEL_LATLON;
  const Eigen::Vector3d n0 = near.normalized();
  if (closed_form || type == MRCAL_LENSMODEL_CAHVORE || !n0.allFinite() || n0.z() <= -0.9) return Unproject(q, dir);
  Eigen::Vector2d u = 2 * n0.head<2>() / (1 + n0.z());
  for (int it = 0; it < 6; ++it) {
    const double n2 = u.squaredNorm(), s = 4 + n2;
    const Eigen::Vector3d num(4 * u.x(), 4 * u.y(), 4 - n2), v = num / s;
    if (!IsStereographicFamily(impl_->lensmodel.type) && v.z() <= 0) break;
    mrcal_point3_t pm = {{v.x(), v.y(), v.z()}}, dq_dp[2];
    mrcal_point2_t qm;
    if (!mrcal_project(&qm, dq_dp, nullptr, &pm, 1, &impl_->lensmodel, intrinsics_.data())) break;
    const Eigen::Vector2d r(qm.x - q.x(), qm.y - q.y());
    if (!r.allFinite()) break;
    if (r.norm() < 1e-8) {
      *dir = v;  // unit by construction
      return true;
    }
    Eigen::Matrix<double, 2, 3> dq_dv;
    dq_dv << dq_dp[0].x, dq_dp[0].y, dq_dp[0].z, dq_dp[1].x, dq_dp[1].y, dq_dp[1].z;
    Eigen::Matrix<double, 3, 2> dv_du;
    dv_du.col(0) = Eigen::Vector3d(4, 0, -2 * u.x()) / s - num * (2 * u.x()) / (s * s);
    dv_du.col(1) = Eigen::Vector3d(0, 4, -2 * u.y()) / s - num * (2 * u.y()) / (s * s);
    const Eigen::Matrix2d J = dq_dv * dv_du;
    if (!(std::abs(J.determinant()) > 1e-300)) break;
    u -= J.inverse() * r;
  }
  return Unproject(q, dir);
}

namespace {
double FovBetween(const CameraModel& m, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                  const Eigen::Vector2d& centre) {
  Eigen::Vector3d da, db, dc;
  if (!m.Unproject(a, &da) || !m.Unproject(b, &db)) return std::numeric_limits<double>::quiet_NaN();
  // Through the centre: sum of the two half angles, so that > 180 deg works.
  if (m.Unproject(centre, &dc)) return (AngleBetween(da, dc) + AngleBetween(dc, db)) * kRadToDeg;
  return AngleBetween(da, db) * kRadToDeg;
}
}  // namespace

double CameraModel::HorizontalFovDeg() const {
  const double y = (height_ - 1) / 2.0;
  return FovBetween(*this, {-0.5, y}, {width_ - 0.5, y}, {Core()[2], y});
}

double CameraModel::VerticalFovDeg() const {
  const double x = (width_ - 1) / 2.0;
  return FovBetween(*this, {x, -0.5}, {x, height_ - 0.5}, {x, Core()[3]});
}

std::string CameraModel::Describe() const {
  return fmt::format("{} {}x{}, fov {:.1f} x {:.1f} deg", lensmodel_, width_, height_, HorizontalFovDeg(),
                     VerticalFovDeg());
}

std::vector<std::string> SupportedLensModels() {
  std::vector<std::string> names;
  for (const char* const* p = mrcal_supported_lensmodel_names(); *p; ++p) names.emplace_back(*p);
  return names;
}

}  // namespace mr
