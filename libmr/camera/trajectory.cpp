#include "camera/trajectory.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <regex>
#include <sstream>

#include "core/error.h"
#include "core/math.h"

namespace mr {

double Trajectory::Duration() const { return poses.empty() ? 0.0 : poses.back().timestamp - poses.front().timestamp; }

double Trajectory::PathLength() const {
  CompensatedSum<double> s;
  for (size_t i = 1; i < poses.size(); ++i)
    s += (poses[i].world_from_cam.translation - poses[i - 1].world_from_cam.translation).norm();
  return s.Value();
}

namespace {

// Splits a line into numbers; returns false on anything that is not one.
bool ParseNumbers(const std::string& line, std::vector<double>* out, std::string* bad) {
  out->clear();
  std::istringstream ss(line);
  ss.imbue(std::locale::classic());
  std::string tok;
  while (ss >> tok) {
    char* end = nullptr;
    double v = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0') {
      *bad = tok;
      return false;
    }
    out->push_back(v);
  }
  return true;
}

std::string StripComment(const std::string& line) {
  auto pos = line.find('#');
  return pos == std::string::npos ? line : line.substr(0, pos);
}

bool IsBlank(const std::string& s) {
  return std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isspace(c); });
}

}  // namespace

Trajectory ReadTum(std::istream& in, const std::string& name) {
  Trajectory t;
  std::string line;
  int lineno = 0;
  std::vector<double> v;
  std::string bad;
  while (std::getline(in, line)) {
    ++lineno;
    std::string s = StripComment(line);
    if (IsBlank(s)) continue;
    FileLoc loc{name, lineno};
    if (!ParseNumbers(s, &v, &bad)) ThrowErrorAt(loc, "\"{}\" is not a number", bad);
    if (v.size() != 8) ThrowErrorAt(loc, "expected 8 numbers (timestamp tx ty tz qx qy qz qw), got {}", v.size());
    if (!AllFinite(v.begin(), v.end())) ThrowErrorAt(loc, "NaN or Inf in pose");
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    const double n = q.norm();
    if (std::abs(n - 1.0) > 1e-3) ThrowErrorAt(loc, "quaternion norm is {:.6g}, not 1 (wrong column order?)", n);
    if (!t.poses.empty() && v[0] < t.poses.back().timestamp)
      ThrowErrorAt(loc, "timestamp {} goes back in time (previous {})", v[0], t.poses.back().timestamp);
    t.poses.push_back({v[0], Rigid3(q, Eigen::Vector3d(v[1], v[2], v[3]))});
  }
  if (in.bad()) ThrowErrorAt(FileLoc{name}, "read failed");
  if (t.poses.empty()) ThrowErrorAt(FileLoc{name}, "no poses in TUM trajectory");
  return t;
}

Trajectory ReadTum(const fs::path& path) {
  std::istringstream in(ReadTextFile(path));
  return ReadTum(in, path.string());
}

void WriteTum(std::ostream& out, const Trajectory& t) {
  out.imbue(std::locale::classic());
  out << "# TUM trajectory written by mr: camera-to-world (world_from_cam)\n"
      << "# timestamp tx ty tz qx qy qz qw\n";
  out << std::setprecision(17);
  for (const auto& p : t.poses) {
    const auto& q = p.world_from_cam.rotation;
    const auto& tr = p.world_from_cam.translation;
    out << p.timestamp << ' ' << tr.x() << ' ' << tr.y() << ' ' << tr.z() << ' ' << q.x() << ' ' << q.y() << ' '
        << q.z() << ' ' << q.w() << '\n';
  }
}

void WriteTum(const fs::path& path, const Trajectory& t) {
  std::ostringstream ss;
  WriteTum(ss, t);
  WriteTextFile(path, ss.str());
}

Rigid3 Read7ScenesPose(std::istream& in, const std::string& name, double* orthonormality_error) {
  std::vector<double> all, v;
  std::string line, bad;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::string s = StripComment(line);
    if (IsBlank(s)) continue;
    if (!ParseNumbers(s, &v, &bad)) ThrowErrorAt(FileLoc{name, lineno}, "\"{}\" is not a number", bad);
    if (v.size() != 4) ThrowErrorAt(FileLoc{name, lineno}, "expected 4 numbers per row, got {}", v.size());
    all.insert(all.end(), v.begin(), v.end());
  }
  if (all.size() != 16) ThrowErrorAt(FileLoc{name}, "expected a 4x4 matrix (16 numbers), got {}", all.size());
  if (!AllFinite(all.begin(), all.end())) ThrowErrorAt(FileLoc{name}, "NaN or Inf in pose");
  Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>> m(all.data());
  if (std::abs(m(3, 0)) > 1e-9 || std::abs(m(3, 1)) > 1e-9 || std::abs(m(3, 2)) > 1e-9 || std::abs(m(3, 3) - 1) > 1e-9)
    ThrowErrorAt(FileLoc{name, 4}, "last row must be 0 0 0 1");
  double err = 0;
  Rigid3 r = Rigid3::FromMatrix(m.topRows<3>(), &err);
  if (err > 0.1) ThrowErrorAt(FileLoc{name}, "rotation block is far from a rotation (distance {:.3g})", err);
  if (orthonormality_error) *orthonormality_error = err;
  return r;
}

Rigid3 Read7ScenesPose(const fs::path& path, double* orthonormality_error) {
  std::istringstream in(ReadTextFile(path));
  return Read7ScenesPose(in, path.string(), orthonormality_error);
}

void Write7ScenesPose(const fs::path& path, const Rigid3& world_from_cam) {
  std::ostringstream ss;
  ss.imbue(std::locale::classic());
  ss << std::setprecision(17);
  Eigen::Matrix4d m = world_from_cam.ToMatrix();
  for (int r = 0; r < 4; ++r) ss << m(r, 0) << '\t' << m(r, 1) << '\t' << m(r, 2) << '\t' << m(r, 3) << '\n';
  WriteTextFile(path, ss.str());
}

Trajectory Read7ScenesFolder(const fs::path& dir) {
  if (!fs::is_directory(dir)) ThrowErrorAt(FileLoc{dir.string()}, "not a folder");
  static const std::regex kName(R"(frame-(\d+)\.pose\.txt)");
  std::vector<std::pair<long, fs::path>> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::smatch m;
    std::string fname = e.path().filename().string();
    if (std::regex_match(fname, m, kName)) files.emplace_back(std::stol(m[1]), e.path());
  }
  if (files.empty()) ThrowErrorAt(FileLoc{dir.string()}, "no frame-NNNNNN.pose.txt files");
  std::sort(files.begin(), files.end());
  Trajectory t;
  for (const auto& [idx, path] : files) {
    double err = 0;
    Rigid3 pose = Read7ScenesPose(path, &err);
    t.max_orthonormality_error = std::max(t.max_orthonormality_error, err);
    t.poses.push_back({static_cast<double>(idx), pose});
  }
  return t;
}

std::vector<std::pair<int, int>> AssociateTimestamps(const std::vector<double>& a, const std::vector<double>& b,
                                                     double max_dt) {
  // Candidates within max_dt (b sorted by time for the window search).
  std::vector<int> bo(b.size());
  for (size_t i = 0; i < b.size(); ++i) bo[i] = static_cast<int>(i);
  std::sort(bo.begin(), bo.end(), [&](int x, int y) { return b[x] < b[y] || (b[x] == b[y] && x < y); });
  std::vector<double> bs(b.size());
  for (size_t i = 0; i < b.size(); ++i) bs[i] = b[bo[i]];
  struct Cand {
    double d;
    int i, j;
  };
  std::vector<Cand> cands;
  constexpr int kNearest = 8;
  const auto nb = static_cast<ptrdiff_t>(bs.size());
  for (size_t i = 0; i < a.size(); ++i) {
    // Outwards from a[i]'s place in bs, the nearer side first (left on a tie).
    ptrdiff_t r = std::lower_bound(bs.begin(), bs.end(), a[i]) - bs.begin(), l = r - 1;
    for (int k = 0; k < kNearest; ++k) {
      const double dl = l >= 0 ? a[i] - bs[static_cast<size_t>(l)] : INFINITY;
      const double dr = r < nb ? bs[static_cast<size_t>(r)] - a[i] : INFINITY;
      if (!(std::min(dl, dr) <= max_dt)) break;
      const ptrdiff_t take = dl <= dr ? l-- : r++;
      const int j = bo[static_cast<size_t>(take)];
      cands.push_back({std::abs(a[i] - b[j]), static_cast<int>(i), j});
    }
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& x, const Cand& y) {
    return x.d < y.d || (x.d == y.d && (x.i < y.i || (x.i == y.i && x.j < y.j)));
  });
  std::vector<char> used_a(a.size(), 0), used_b(b.size(), 0);
  std::vector<std::pair<int, int>> out;
  for (const Cand& c : cands) {
    if (used_a[c.i] || used_b[c.j]) continue;
    used_a[c.i] = used_b[c.j] = 1;
    out.emplace_back(c.i, c.j);
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string DetectPoseFormat(const fs::path& path) {
  std::string text = ReadTextFile(path);
  std::istringstream in(text);
  std::string line, bad;
  std::vector<double> v;
  int rows = 0;
  size_t cols = 0;
  while (std::getline(in, line)) {
    std::string s = StripComment(line);
    if (IsBlank(s)) continue;
    if (!ParseNumbers(s, &v, &bad)) return "";
    if (rows == 0) cols = v.size();
    ++rows;
    if (rows > 5) break;
  }
  if (cols == 8) return "tum";
  if (cols == 4 && rows == 4) return "7scenes";
  return "";
}

}  // namespace mr
