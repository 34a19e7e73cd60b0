#include "recon/rgbd.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "camera/camera_model.h"
#include "core/error.h"
#include "core/image_format.h"
#include "core/png_check.h"

namespace mr {

namespace {

// OpenCV's imread picks its decoder by the file's bytes, not its name, and
// some of those decoders (GDCM's DICOM reader) abort the process on a
// malformed file (found by fuzz/fuzz_depth).  Depth maps are PNG, TIFF, EXR
// or PFM: any other file is refused before a decoder sees it.
void CheckDepthSignature(const fs::path& path) {
  const std::string f = ImageFormatOf(path);
  if (f != "png" && f != "tiff" && f != "pnm" && f != "openexr")
    ThrowErrorAt(FileLoc{path.string()}, "is not a PNG, TIFF, EXR or PFM depth image");
}

// cv::imread, with OpenCV's exceptions (its PFM reader asserts on a malformed
// header; found by fuzz/fuzz_depth) as an mr::Error naming the file.
cv::Mat ReadDepthPixels(const fs::path& path, int flags) {
  CheckDepthSignature(path);
  CheckPngChunks(path);
  try {
    return cv::imread(path.string(), flags);
  } catch (const cv::Exception& e) {
    ThrowErrorAt(FileLoc{path.string()}, "cannot be read as a depth image: {}", e.err);
  }
}

}  // namespace

PinholeIntrinsics PinholeIntrinsics::Level(int level) const {
  PinholeIntrinsics k = *this;
  for (int i = 0; i < level; ++i) {
    // Pixel (x, y) of the half-size image averages full-size pixels 2x, 2x+1:
    // its centre is at 2x + 0.5 in full-size coordinates.
    k.fx *= 0.5;
    k.fy *= 0.5;
    k.cx = (k.cx - 0.5) * 0.5;
    k.cy = (k.cy - 0.5) * 0.5;
    k.width /= 2;
    k.height /= 2;
  }
  return k;
}

namespace {

std::vector<TimestampedFile> ReadTumList(const fs::path& path) {
  std::istringstream in(ReadTextFile(path));
  return ReadTimestampList(in, path.string());
}

PinholeIntrinsics ReadIntrinsicsTxt(const fs::path& path) {
  std::istringstream in(ReadTextFile(path));
  in.imbue(std::locale::classic());
  std::vector<double> v;
  for (double x; in >> x;) v.push_back(x);
  if (!in.eof()) ThrowErrorAt(FileLoc{path.string()}, "expected numbers only");
  if (v.size() != 9 || v[1] != 0 || v[3] != 0 || v[6] != 0 || v[7] != 0 || v[8] != 1 || v[0] <= 0 || v[4] <= 0)
    ThrowErrorAt(FileLoc{path.string()}, "expected a 3x3 pinhole matrix [fx 0 cx; 0 fy cy; 0 0 1]");
  PinholeIntrinsics k;
  k.fx = v[0];
  k.fy = v[4];
  k.cx = v[2];
  k.cy = v[5];
  return k;
}

PinholeIntrinsics FromCameraModel(const fs::path& path) {
  CameraModel m = CameraModel::Read(path);
  const std::string& lm = m.lensmodel();
  bool pinhole = lm == "LENSMODEL_PINHOLE";
  if (!pinhole && lm.rfind("LENSMODEL_OPENCV", 0) == 0) {
    pinhole = true;  // OpenCV models with all-zero distortion are pinholes
    for (size_t i = 4; i < m.intrinsics().size(); ++i) pinhole = pinhole && m.intrinsics()[i] == 0;
  }
  if (!pinhole)
    ThrowErrorAt(FileLoc{path.string()}, "is {}: depth cameras must be pinhole (undistort the depth maps first)", lm);
  Eigen::Vector4d c = m.Core();
  PinholeIntrinsics k;
  k.fx = c[0];
  k.fy = c[1];
  k.cx = c[2];
  k.cy = c[3];
  k.width = m.width();
  k.height = m.height();
  return k;
}

std::vector<fs::path> Glob(const fs::path& dir, const std::regex& re) {
  std::vector<fs::path> out;
  if (!fs::is_directory(dir)) return out;
  for (const auto& e : fs::directory_iterator(dir))
    if (std::regex_match(e.path().filename().string(), re)) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

std::string DetectLayout(const fs::path& dir) {
  if (fs::exists(dir / "depth.txt")) return "tum";
  if (!Glob(dir, std::regex(R"(frame-\d+\.depth\.png)")).empty()) return "7scenes";
  if (fs::is_directory(dir / "depth")) return "plain";
  ThrowErrorAt(FileLoc{dir.string()},
               "is not an RGB-D recording: expected depth.txt (TUM), frame-NNNNNN.depth.png "
               "(7-Scenes) or a depth/ folder beside a .cameramodel");
}

}  // namespace

std::vector<TimestampedFile> ReadTimestampList(std::istream& in, const std::string& name) {
  std::vector<TimestampedFile> out;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (auto h = line.find('#'); h != std::string::npos) line.resize(h);
    std::istringstream ls(line);
    ls.imbue(std::locale::classic());
    TimestampedFile e;
    std::string ts;
    if (!(ls >> ts)) continue;
    try {
      size_t used = 0;
      e.t = std::stod(ts, &used);
      if (used != ts.size() || !std::isfinite(e.t)) throw std::invalid_argument(ts);
    } catch (const std::exception&) {
      ThrowErrorAt(FileLoc{name, n}, "\"{}\" is not a timestamp", ts);
    }
    if (!(ls >> e.file)) ThrowErrorAt(FileLoc{name, n}, "expected \"timestamp filename\"");
    out.push_back(e);
  }
  if (out.empty()) ThrowErrorAt(FileLoc{name}, "lists no images");
  return out;
}

RgbdSequence OpenRgbdSequence(const fs::path& dir, const RgbdOpenOptions& options) {
  if (!fs::is_directory(dir)) ThrowErrorAt(FileLoc{dir.string()}, "is not a folder");
  RgbdSequence seq;
  seq.dir = dir;
  seq.layout = options.layout == "auto" ? DetectLayout(dir) : options.layout;
  std::optional<PinholeIntrinsics> K = options.intrinsics;
  const std::vector<fs::path> models = Glob(dir, std::regex(R"(.*\.cameramodel)"));
  if (!K && fs::exists(dir / "camera-intrinsics.txt")) K = ReadIntrinsicsTxt(dir / "camera-intrinsics.txt");
  if (!K && models.size() == 1) K = FromCameraModel(models.front());
  if (!K && models.size() > 1)
    ThrowErrorAt(FileLoc{dir.string()}, "holds {} .cameramodel files: give the depth camera's with --intrinsics",
                 models.size());

  if (seq.layout == "tum") {
    seq.depth_scale = 5000;
    const std::vector<TimestampedFile> depth = ReadTumList(dir / "depth.txt");
    std::vector<TimestampedFile> rgb;
    if (fs::exists(dir / "rgb.txt")) rgb = ReadTumList(dir / "rgb.txt");
    std::vector<double> td, tr;
    for (const auto& e : depth) td.push_back(e.t);
    for (const auto& e : rgb) tr.push_back(e.t);
    if (rgb.empty()) {
      for (size_t i = 0; i < depth.size(); ++i)
        seq.frames.push_back({static_cast<int>(i), depth[i].t, dir / depth[i].file, {}});
    } else {
      const auto pairs = AssociateTimestamps(td, tr, options.max_dt);
      seq.unpaired_depth = static_cast<int>(depth.size() - pairs.size());
      for (const auto& [i, j] : pairs)
        seq.frames.push_back({static_cast<int>(seq.frames.size()), depth[i].t, dir / depth[i].file, dir / rgb[j].file});
    }
    if (fs::exists(dir / "groundtruth.txt")) seq.reference = ReadTum(dir / "groundtruth.txt");
  } else if (seq.layout == "7scenes") {
    seq.depth_scale = 1000;
    static const std::regex kDepth(R"(frame-(\d+)\.depth\.png)");
    for (const fs::path& p : Glob(dir, kDepth)) {
      const std::string name = p.filename().string();
      const std::string stem = name.substr(0, name.size() - std::string(".depth.png").size());
      RgbdFrame f;
      f.index = static_cast<int>(seq.frames.size());
      f.timestamp = std::stod(stem.substr(6));
      f.depth = p;
      for (const char* ext : {".color.png", ".color.jpg"})
        if (fs::exists(dir / (stem + ext))) f.color = dir / (stem + ext);
      seq.frames.push_back(f);
    }
    bool all_colour = true;
    for (const auto& f : seq.frames) all_colour = all_colour && !f.color.empty();
    if (!all_colour)
      for (auto& f : seq.frames) f.color.clear();
    if (fs::exists(dir / "frame-000000.pose.txt") || !Glob(dir, std::regex(R"(frame-\d+\.pose\.txt)")).empty())
      seq.reference = Read7ScenesFolder(dir);
    if (!K) {  // 7-Scenes' published intrinsics
      K = PinholeIntrinsics{585, 585, 320, 240, 640, 480};
    }
  } else if (seq.layout == "plain") {
    seq.depth_scale = 1000;
    static const std::regex kImage(R"(.*\.(png|tif|tiff|exr))", std::regex::icase);
    static const std::regex kColor(R"(.*\.(png|jpg|jpeg|tif|tiff|exr))", std::regex::icase);
    const std::vector<fs::path> depth = Glob(dir / "depth", kImage);
    if (depth.empty()) ThrowErrorAt(FileLoc{(dir / "depth").string()}, "holds no depth images");
    std::vector<fs::path> color = Glob(dir / "rgb", kColor);
    if (color.empty()) color = Glob(dir / "color", kColor);
    if (!color.empty() && color.size() != depth.size())
      ThrowErrorAt(FileLoc{dir.string()}, "has {} depth but {} colour images", depth.size(), color.size());
    for (size_t i = 0; i < depth.size(); ++i)
      seq.frames.push_back(
          {static_cast<int>(i), static_cast<double>(i), depth[i], color.empty() ? fs::path() : color[i]});
    if (!K) ThrowErrorAt(FileLoc{dir.string()}, "has no .cameramodel for the depth camera");
    if (fs::exists(dir / "groundtruth.txt")) seq.reference = ReadTum(dir / "groundtruth.txt");
  } else {
    ThrowError("unknown RGB-D layout \"{}\" (expected auto, tum, 7scenes or plain)", seq.layout);
  }
  if (options.depth_scale > 0) seq.depth_scale = options.depth_scale;
  if (!K)
    ThrowErrorAt(FileLoc{dir.string()},
                 "has no intrinsics: add camera-intrinsics.txt or a .cameramodel, or pass --intrinsics");
  if (seq.frames.empty()) ThrowErrorAt(FileLoc{dir.string()}, "holds no frames");
  seq.K = *K;
  if (seq.K.width <= 0 || seq.K.height <= 0) {  // size from the first depth map
    cv::Mat d = ReadDepthPixels(seq.frames.front().depth, cv::IMREAD_ANYDEPTH);
    if (d.empty()) ThrowErrorAt(FileLoc{seq.frames.front().depth.string()}, "cannot be read as an image");
    seq.K.width = d.cols;
    seq.K.height = d.rows;
  }
  return seq;
}

DepthMap ReadDepth(const fs::path& path, const DepthReadOptions& options, int expect_width, int expect_height,
                   DepthReadStats* stats) {
  RequireFile(path, "depth map");
  cv::Mat raw = ReadDepthPixels(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
  if (raw.empty()) ThrowErrorAt(FileLoc{path.string()}, "cannot be read as a depth image");
  if (raw.channels() != 1) ThrowErrorAt(FileLoc{path.string()}, "has {} channels, depth needs 1", raw.channels());
  if (raw.depth() == CV_8U)
    ThrowErrorAt(FileLoc{path.string()}, "is 8-bit: depth maps must be 16-bit integers or floats");
  if (expect_width > 0 && (raw.cols != expect_width || raw.rows != expect_height))
    ThrowErrorAt(FileLoc{path.string()}, "is {}x{}, the intrinsics say {}x{}", raw.cols, raw.rows, expect_width,
                 expect_height);
  cv::Mat f;
  const bool integer = raw.depth() == CV_16U;
  raw.convertTo(f, CV_32F);
  DepthMap d;
  d.width = f.cols;
  d.height = f.rows;
  d.z.assign(static_cast<size_t>(f.total()), 0.0f);
  DepthReadStats s;
  std::vector<float> valid;
  valid.reserve(d.z.size());
  const float inv = static_cast<float>(1.0 / options.scale);
  for (int y = 0; y < f.rows; ++y) {
    const float* row = f.ptr<float>(y);
    for (int x = 0; x < f.cols; ++x) {
      const float v = row[x];
      if (integer && (v == 0.0f || v == 65535.0f)) {
        ++s.invalid_markers;
        continue;
      }
      if (!integer && v == 0.0f) {
        ++s.invalid_markers;
        continue;
      }
      if (!std::isfinite(v) || v < 0) {
        ++s.rejected;
        continue;
      }
      valid.push_back(v * inv);
    }
  }
  if (!valid.empty()) {
    auto mid = valid.begin() + static_cast<std::ptrdiff_t>(valid.size() / 2);
    std::nth_element(valid.begin(), mid, valid.end());
    s.median_m = *mid;
  }
  for (int y = 0; y < f.rows; ++y) {
    const float* row = f.ptr<float>(y);
    for (int x = 0; x < f.cols; ++x) {
      const float v = row[x];
      if (v == 0.0f || (integer && v == 65535.0f) || !std::isfinite(v) || v < 0) continue;
      const float m = v * inv;
      if (m < options.min_m || m > options.max_m) {
        ++s.rejected;
        continue;
      }
      d.at(x, y) = m;
      ++s.valid;
    }
  }
  if (stats) *stats = s;
  return d;
}

double SuggestDepthScale(double median_m, double scale) {
  if (!(median_m > 0) || (median_m >= 0.4 && median_m <= 8)) return 0;
  double best = 0, best_err = 1e300;
  for (double cand : {1000.0, 5000.0, 10000.0, 100.0, 1.0}) {
    const double m = median_m * scale / cand;
    const double err = std::abs(std::log(m / 2.0));
    if (m >= 0.4 && m <= 8 && err < best_err) {
      best = cand;
      best_err = err;
    }
  }
  return best;
}

double CheckDepthScale(const RgbdSequence& seq, const DepthReadOptions& options, int frames) {
  std::vector<double> medians;
  for (size_t i = 0; i < seq.frames.size() && static_cast<int>(medians.size()) < frames; ++i) {
    DepthReadStats st;
    ReadDepth(seq.frames[i].depth, options, seq.K.width, seq.K.height, &st);
    if (st.median_m > 0) medians.push_back(st.median_m);
  }
  if (medians.empty()) return 0;
  std::nth_element(medians.begin(), medians.begin() + static_cast<std::ptrdiff_t>(medians.size() / 2), medians.end());
  return SuggestDepthScale(medians[medians.size() / 2], options.scale);
}

Image ReadColor(const fs::path& path, int width, int height) {
  Image c = ReadImage(path);
  if (c.channels() < 3) {
    Image rgb = Image::Rgb(c.width(), c.height());
    for (int y = 0; y < c.height(); ++y)
      for (int x = 0; x < c.width(); ++x)
        for (int k = 0; k < 3; ++k) rgb.at(x, y, k) = c.at(x, y, 0);
    c = std::move(rgb);
  }
  if (c.width() == width && c.height() == height && c.channels() == 3) return c;
  Image out = Image::Rgb(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const int sx = std::min(c.width() - 1, static_cast<int>((x + 0.5) * c.width() / width));
      const int sy = std::min(c.height() - 1, static_cast<int>((y + 0.5) * c.height() / height));
      for (int k = 0; k < 3; ++k) out.at(x, y, k) = c.at(sx, sy, k);
    }
  return out;
}

}  // namespace mr
