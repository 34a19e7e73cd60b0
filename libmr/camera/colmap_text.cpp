#include "camera/colmap_text.h"

#include <iomanip>
#include <sstream>

#include "core/error.h"
#include "core/math.h"

namespace mr {

namespace {

// Parameter count and the index of cx (cy follows) per COLMAP model.
struct ModelInfo {
  int num_params;
  int cx_index;
};
const std::map<std::string, ModelInfo>& ColmapModels() {
  static const std::map<std::string, ModelInfo> m = {{"SIMPLE_PINHOLE", {3, 1}},
                                                     {"PINHOLE", {4, 2}},
                                                     {"SIMPLE_RADIAL", {4, 1}},
                                                     {"RADIAL", {5, 1}},
                                                     {"OPENCV", {8, 2}},
                                                     {"OPENCV_FISHEYE", {8, 2}},
                                                     {"FULL_OPENCV", {12, 2}},
                                                     {"FOV", {5, 2}},
                                                     {"SIMPLE_RADIAL_FISHEYE", {4, 1}},
                                                     {"RADIAL_FISHEYE", {5, 1}},
                                                     {"THIN_PRISM_FISHEYE", {12, 2}}};
  return m;
}

struct LineReader {
  std::istringstream in;
  std::string name;
  int lineno = 0;
  LineReader(const std::string& text, std::string n) : in(text), name(std::move(n)) {
    in.imbue(std::locale::classic());
  }
  // Next non-comment, non-blank line; false at the end.
  bool Next(std::string* line) {
    while (std::getline(in, *line)) {
      ++lineno;
      auto first = line->find_first_not_of(" \t\r");
      if (first == std::string::npos || (*line)[first] == '#') continue;
      return true;
    }
    return false;
  }
  FileLoc Loc() const { return FileLoc{name, lineno}; }
};

std::vector<std::string> Tokens(const std::string& line) {
  std::istringstream ss(line);
  std::vector<std::string> t;
  std::string s;
  while (ss >> s) t.push_back(s);
  return t;
}

double ToDouble(const std::string& s, const FileLoc& loc) {
  char* end = nullptr;
  double v = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || *end != '\0') ThrowErrorAt(loc, "\"{}\" is not a number", s);
  if (!std::isfinite(v)) ThrowErrorAt(loc, "non-finite number \"{}\"", s);
  return v;
}

int64_t ToInt(const std::string& s, const FileLoc& loc) {
  char* end = nullptr;
  errno = 0;
  long long v = std::strtoll(s.c_str(), &end, 10);
  if (end == s.c_str() || *end != '\0' || errno == ERANGE) ThrowErrorAt(loc, "\"{}\" is not an integer", s);
  return v;
}

std::ostringstream Stream() {
  std::ostringstream ss;
  ss.imbue(std::locale::classic());
  ss << std::setprecision(17);
  return ss;
}

}  // namespace

std::map<int64_t, ColmapCamera> ParseColmapCameras(const std::string& text, const std::string& name) {
  std::map<int64_t, ColmapCamera> cams;
  LineReader r(text, name);
  std::string line;
  while (r.Next(&line)) {
    auto t = Tokens(line);
    if (t.size() < 4) ThrowErrorAt(r.Loc(), "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
    ColmapCamera c;
    c.id = ToInt(t[0], r.Loc());
    c.model = t[1];
    auto it = ColmapModels().find(c.model);
    if (it == ColmapModels().end()) ThrowErrorAt(r.Loc(), "unknown COLMAP camera model \"{}\"", c.model);
    c.width = static_cast<int>(ToInt(t[2], r.Loc()));
    c.height = static_cast<int>(ToInt(t[3], r.Loc()));
    if (c.width <= 0 || c.height <= 0) ThrowErrorAt(r.Loc(), "image size must be positive");
    for (size_t i = 4; i < t.size(); ++i) c.params.push_back(ToDouble(t[i], r.Loc()));
    if (static_cast<int>(c.params.size()) != it->second.num_params)
      ThrowErrorAt(r.Loc(), "{} takes {} parameters, got {}", c.model, it->second.num_params, c.params.size());
    c.params[static_cast<size_t>(it->second.cx_index)] -= 0.5;
    c.params[static_cast<size_t>(it->second.cx_index + 1)] -= 0.5;
    if (!cams.emplace(c.id, c).second) ThrowErrorAt(r.Loc(), "duplicate camera id {}", c.id);
  }
  return cams;
}

std::string FormatColmapCameras(const std::map<int64_t, ColmapCamera>& cameras) {
  auto ss = Stream();
  ss << "# Camera list with one line of data per camera:\n"
     << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
     << "# Number of cameras: " << cameras.size() << "\n";
  for (const auto& [id, c] : cameras) {
    auto it = ColmapModels().find(c.model);
    MR_CHECK(it != ColmapModels().end());
    ss << id << ' ' << c.model << ' ' << c.width << ' ' << c.height;
    for (size_t i = 0; i < c.params.size(); ++i) {
      double v = c.params[i];
      if (static_cast<int>(i) == it->second.cx_index || static_cast<int>(i) == it->second.cx_index + 1) v += 0.5;
      ss << ' ' << v;
    }
    ss << '\n';
  }
  return ss.str();
}

std::map<int64_t, ColmapImage> ParseColmapImages(const std::string& text, const std::string& name) {
  std::map<int64_t, ColmapImage> images;
  LineReader r(text, name);
  std::string line;
  while (r.Next(&line)) {
    auto t = Tokens(line);
    if (t.size() != 10)
      ThrowErrorAt(r.Loc(), "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, got {} fields", t.size());
    ColmapImage im;
    im.id = ToInt(t[0], r.Loc());
    Eigen::Quaterniond q(ToDouble(t[1], r.Loc()), ToDouble(t[2], r.Loc()), ToDouble(t[3], r.Loc()),
                         ToDouble(t[4], r.Loc()));
    if (std::abs(q.norm() - 1) > 1e-3) ThrowErrorAt(r.Loc(), "quaternion norm is {:.6g}, not 1", q.norm());
    im.cam_from_world =
        Rigid3(q, Eigen::Vector3d(ToDouble(t[5], r.Loc()), ToDouble(t[6], r.Loc()), ToDouble(t[7], r.Loc())));
    im.camera_id = ToInt(t[8], r.Loc());
    im.name = t[9];
    const FileLoc header_loc = r.Loc();
    // The POINTS2D line follows; it may be empty, which LineReader would skip,
    // so read it raw.
    std::string pts;
    if (!std::getline(r.in, pts)) ThrowErrorAt(header_loc, "missing POINTS2D line after image {}", im.id);
    ++r.lineno;
    auto p = Tokens(pts);
    if (p.size() % 3 != 0) ThrowErrorAt(r.Loc(), "POINTS2D must be triples X Y POINT3D_ID");
    for (size_t i = 0; i < p.size(); i += 3) {
      ColmapObservation o;
      o.xy = PixelFromColmap(Eigen::Vector2d(ToDouble(p[i], r.Loc()), ToDouble(p[i + 1], r.Loc())));
      o.point3d_id = ToInt(p[i + 2], r.Loc());
      im.points2d.push_back(o);
    }
    if (!images.emplace(im.id, im).second) ThrowErrorAt(header_loc, "duplicate image id {}", im.id);
  }
  return images;
}

std::string FormatColmapImages(const std::map<int64_t, ColmapImage>& images) {
  auto ss = Stream();
  ss << "# Image list with two lines of data per image:\n"
     << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
     << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
     << "# Number of images: " << images.size() << "\n";
  for (const auto& [id, im] : images) {
    const auto& q = im.cam_from_world.rotation;
    const auto& t = im.cam_from_world.translation;
    ss << id << ' ' << q.w() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << t.x() << ' ' << t.y() << ' '
       << t.z() << ' ' << im.camera_id << ' ' << im.name << '\n';
    for (size_t i = 0; i < im.points2d.size(); ++i) {
      Eigen::Vector2d c = PixelToColmap(im.points2d[i].xy);
      ss << (i ? " " : "") << c.x() << ' ' << c.y() << ' ' << im.points2d[i].point3d_id;
    }
    ss << '\n';
  }
  return ss.str();
}

std::map<int64_t, ColmapPoint3D> ParseColmapPoints3D(const std::string& text, const std::string& name) {
  std::map<int64_t, ColmapPoint3D> pts;
  LineReader r(text, name);
  std::string line;
  while (r.Next(&line)) {
    auto t = Tokens(line);
    if (t.size() < 8 || (t.size() - 8) % 2 != 0)
      ThrowErrorAt(r.Loc(), "expected POINT3D_ID X Y Z R G B ERROR TRACK[] as (IMAGE_ID POINT2D_IDX)");
    ColmapPoint3D p;
    p.id = ToInt(t[0], r.Loc());
    p.xyz = Eigen::Vector3d(ToDouble(t[1], r.Loc()), ToDouble(t[2], r.Loc()), ToDouble(t[3], r.Loc()));
    for (int k = 0; k < 3; ++k) {
      int64_t v = ToInt(t[4 + static_cast<size_t>(k)], r.Loc());
      if (v < 0 || v > 255) ThrowErrorAt(r.Loc(), "colour component {} outside 0..255", v);
      p.rgb[k] = static_cast<uint8_t>(v);
    }
    p.error = ToDouble(t[7], r.Loc());
    for (size_t i = 8; i < t.size(); i += 2) p.track.push_back({ToInt(t[i], r.Loc()), ToInt(t[i + 1], r.Loc())});
    if (!pts.emplace(p.id, p).second) ThrowErrorAt(r.Loc(), "duplicate point id {}", p.id);
  }
  return pts;
}

std::string FormatColmapPoints3D(const std::map<int64_t, ColmapPoint3D>& points) {
  auto ss = Stream();
  ss << "# 3D point list with one line of data per point:\n"
     << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
     << "# Number of points: " << points.size() << "\n";
  for (const auto& [id, p] : points) {
    ss << id << ' ' << p.xyz.x() << ' ' << p.xyz.y() << ' ' << p.xyz.z() << ' ' << int(p.rgb[0]) << ' ' << int(p.rgb[1])
       << ' ' << int(p.rgb[2]) << ' ' << p.error;
    for (const auto& e : p.track) ss << ' ' << e.image_id << ' ' << e.point2d_idx;
    ss << '\n';
  }
  return ss.str();
}

ColmapModel ReadColmapText(const fs::path& dir) {
  ColmapModel m;
  m.cameras = ParseColmapCameras(ReadTextFile(dir / "cameras.txt"), (dir / "cameras.txt").string());
  const std::string images_name = (dir / "images.txt").string();
  m.images = ParseColmapImages(ReadTextFile(dir / "images.txt"), images_name);
  if (fs::exists(dir / "points3D.txt"))
    m.points3d = ParseColmapPoints3D(ReadTextFile(dir / "points3D.txt"), (dir / "points3D.txt").string());
  for (const auto& [id, im] : m.images) {
    if (!m.cameras.count(im.camera_id))
      ThrowErrorAt(FileLoc{images_name}, "image {} names camera {}, which cameras.txt lacks", id, im.camera_id);
    if (!m.points3d.empty())
      for (const auto& o : im.points2d)
        if (o.point3d_id >= 0 && !m.points3d.count(o.point3d_id))
          ThrowErrorAt(FileLoc{images_name}, "image {} observes point {}, which points3D.txt lacks", id, o.point3d_id);
  }
  return m;
}

void WriteColmapText(const fs::path& dir, const ColmapModel& model) {
  if (!fs::is_directory(dir)) ThrowErrorAt(FileLoc{dir.string()}, "not a folder");
  WriteTextFile(dir / "cameras.txt", FormatColmapCameras(model.cameras));
  WriteTextFile(dir / "images.txt", FormatColmapImages(model.images));
  WriteTextFile(dir / "points3D.txt", FormatColmapPoints3D(model.points3d));
}

CameraModel ToCameraModel(const ColmapCamera& c) {
  const auto& p = c.params;
  if (c.model == "SIMPLE_PINHOLE") return CameraModel("LENSMODEL_PINHOLE", {p[0], p[0], p[1], p[2]}, c.width, c.height);
  if (c.model == "PINHOLE") return CameraModel("LENSMODEL_PINHOLE", {p[0], p[1], p[2], p[3]}, c.width, c.height);
  if (c.model == "SIMPLE_RADIAL")
    return CameraModel("LENSMODEL_OPENCV4", {p[0], p[0], p[1], p[2], p[3], 0, 0, 0}, c.width, c.height);
  if (c.model == "RADIAL")
    return CameraModel("LENSMODEL_OPENCV4", {p[0], p[0], p[1], p[2], p[3], p[4], 0, 0}, c.width, c.height);
  if (c.model == "OPENCV")
    return CameraModel("LENSMODEL_OPENCV4", {p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]}, c.width, c.height);
  if (c.model == "FULL_OPENCV")
    return CameraModel("LENSMODEL_OPENCV8", std::vector<double>(p.begin(), p.end()), c.width, c.height);
  ThrowError("COLMAP camera model {} has no mrcal equivalent", c.model);
}

}  // namespace mr
