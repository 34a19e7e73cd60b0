// RGB-D recordings: the TUM RGB-D layout, the 7-Scenes layout and a plain
// folder with a .cameramodel; depth maps in metres.
//
// TUM:      rgb/, depth/, rgb.txt, depth.txt ("timestamp file" lines);
//           colour and depth are paired as TUM's associate.py does
//           (greedy by smallest time difference, at most max_dt apart);
//           groundtruth.txt, when present, is the reference trajectory.
// 7-Scenes: frame-NNNNNN.depth.png, .color.{png,jpg}, .pose.txt and
//           camera-intrinsics.txt (3x3); the poses are the reference.
// Plain:    depth/*.png (and rgb/*.png or color/*.png paired by sorted
//           name) beside a .cameramodel; timestamps are frame indices;
//           groundtruth.txt (TUM, timestamp = frame index), when present,
//           is the reference trajectory.
// Intrinsics: camera-intrinsics.txt, a .cameramodel in the folder (pinhole
// models only: depth must be undistorted), or given by the caller.  Pixel
// centres are at integer coordinates (mrcal's convention).
#pragma once

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "camera/trajectory.h"
#include "core/file.h"
#include "core/image.h"

namespace mr {

struct PinholeIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
  // The same camera at 1/2^level resolution (pixel centres stay consistent).
  PinholeIntrinsics Level(int level) const;
};

struct RgbdFrame {
  int index = 0;          // position in the sequence
  double timestamp = 0;   // seconds (7-Scenes and plain folders: frame number)
  fs::path depth, color;  // color empty when the recording has none
};

struct RgbdOpenOptions {
  std::string layout = "auto";                  // auto | tum | 7scenes | plain
  double depth_scale = 0;                       // depth units per metre; 0: the layout's (TUM 5000, others 1000)
  double max_dt = 0.02;                         // TUM association: largest colour-depth time difference (s)
  std::optional<PinholeIntrinsics> intrinsics;  // overrides the folder's
};

struct RgbdSequence {
  fs::path dir;
  std::string layout;  // tum | 7scenes | plain
  PinholeIntrinsics K;
  double depth_scale = 1000;
  std::vector<RgbdFrame> frames;
  Trajectory reference;    // empty when the recording has none
  int unpaired_depth = 0;  // TUM depth images without a colour image within max_dt
  bool has_color() const { return !frames.empty() && !frames.front().color.empty(); }
};

// TUM's rgb.txt / depth.txt: "timestamp filename" per line, '#' comments.
// Throws mr::Error naming `name` and the line on a malformed one.
struct TimestampedFile {
  double t = 0;
  std::string file;
};
std::vector<TimestampedFile> ReadTimestampList(std::istream& in, const std::string& name);

// Throws mr::Error naming the folder or file when the layout is not
// recognised, a list file is malformed or intrinsics are missing.
RgbdSequence OpenRgbdSequence(const fs::path& dir, const RgbdOpenOptions& options = {});

// A depth map in metres; 0 marks no measurement.
struct DepthMap {
  int width = 0, height = 0;
  std::vector<float> z;
  float at(int x, int y) const { return z[static_cast<size_t>(y) * width + x]; }
  float& at(int x, int y) { return z[static_cast<size_t>(y) * width + x]; }
  bool empty() const { return z.empty(); }
};

struct DepthReadStats {
  int64_t valid = 0;
  int64_t invalid_markers = 0;  // 0 and 65535 codes
  int64_t rejected = 0;         // NaN/Inf, negative, or outside [min_m, max_m]
  double median_m = 0;          // of the valid depths (before range rejection)
};

struct DepthReadOptions {
  double scale = 1000;               // units per metre
  double min_m = 0.1, max_m = 10.0;  // plausible range; others are rejected
};

// A 16-bit PNG/TIFF in units of 1/scale metres, or a float image (EXR/TIFF)
// in the same units (a float file in metres needs scale 1).  `expect_*`
// (when non-zero) is the size the intrinsics say.  NaN/Inf and values
// outside the plausible range become 0 and are counted.
DepthMap ReadDepth(const fs::path& path, const DepthReadOptions& options, int expect_width, int expect_height,
                   DepthReadStats* stats = nullptr);

// Room-scale sensors see a median depth of 0.4 .. 8 m.  When `median_m`
// (read at `scale` units per metre) is outside that, the common scale
// (1000, 5000, 10000, 100, 1 units per metre) that brings it nearest 2 m;
// 0 when the median looks right or no common scale helps.
double SuggestDepthScale(double median_m, double scale);

// SuggestDepthScale on the median of the first `frames` depth maps' medians.
double CheckDepthScale(const RgbdSequence& seq, const DepthReadOptions& options, int frames = 5);

// Colour as linear RGB, resampled to width x height (nearest) when its size
// differs.  Throws naming the file.
Image ReadColor(const fs::path& path, int width, int height);

}  // namespace mr
