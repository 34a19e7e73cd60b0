#include "scene/frames.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>

#include <fmt/format.h>
#include <string>
#include <tuple>
#include <utility>

#include "camera/camera_model.h"
#include "camera/colmap_text.h"
#include "camera/trajectory.h"
#include "core/error.h"
#include "core/image.h"
#include "core/video.h"

namespace mr {

fs::path FramePath(const fs::path& pattern, int i) {
  const std::string p = pattern.string();
  if (p.find('%') == std::string::npos) return pattern;
  std::vector<char> buf(p.size() + 32);
  std::snprintf(buf.data(), buf.size(), p.c_str(), i);
  return fs::path(buf.data());
}

std::optional<fs::path> PerFrameFile(const fs::path& pattern, int f, int* from) {
  std::error_code ec;
  if (pattern.string().find('%') == std::string::npos) {
    if (from) *from = f;
    return pattern;
  }
  for (int g = f; g >= 0; --g) {
    const fs::path p = FramePath(pattern, g);
    if (fs::is_regular_file(p, ec)) {
      if (from) *from = g;
      return p;
    }
  }
  return std::nullopt;
}

std::vector<fs::path> ListFrameFiles(const std::string& frames, const fs::path& workspace) {
  std::vector<fs::path> out;
  std::error_code ec;
  if (fs::is_directory(frames, ec)) {
    for (const auto& e : fs::directory_iterator(frames)) {
      const std::string x = LowerExtension(e.path());
      if (e.is_regular_file() && (x == ".png" || x == ".jpg" || x == ".jpeg" || x == ".tif" || x == ".tiff"))
        out.push_back(e.path());
    }
    std::sort(out.begin(), out.end());
  } else if (frames.find('%') != std::string::npos) {
    for (int f = 0;; ++f) {
      const fs::path p = FramePath(frames, f);
      if (!fs::exists(p, ec)) break;
      const std::string x = LowerExtension(p);
      if (x == ".exr" || x == ".hdr")
        ThrowErrorAt(FileLoc{p.string()}, "COLMAP reads 8/16-bit images; give the PNG or JPEG frames");
      out.push_back(p);
    }
  } else if (fs::is_regular_file(frames, ec)) {
    VideoReader video(frames);
    const fs::path dir = workspace / "frames";
    fs::create_directories(dir, ec);
    for (int f = 0; f < video.frame_count(); ++f) {
      Image im;
      try {
        im = video.Frame(f);
      } catch (const Error&) {
        break;  // the container's count may be approximate
      }
      const fs::path p = dir / fmt::format("{:05d}.png", f);
      WriteImage(p, im);
      out.push_back(p);
    }
  } else {
    ThrowErrorAt(FileLoc{frames}, "not a folder, a frame pattern or a video");
  }
  if (out.empty()) ThrowErrorAt(FileLoc{frames}, "no frames found");
  return out;
}

bool ParseFrameRange(const std::string& s, int* begin, int* end, std::string* why) {
  bool ok = true;
  auto parse = [&](const std::string& t, int dflt) {
    if (t.empty()) return dflt;
    char* e = nullptr;
    const long v = std::strtol(t.c_str(), &e, 10);
    if (*e != '\0' || v < 0 || v > 100000000 || !std::isdigit(static_cast<unsigned char>(t[0]))) {
      ok = false;
      return 0;
    }
    return static_cast<int>(v);
  };
  int b = 0, e = -1;
  const auto colon = s.find(':');
  if (s.empty()) {
    ok = false;
  } else if (colon == std::string::npos) {
    b = parse(s, 0);
    e = b + 1;
  } else {
    b = parse(s.substr(0, colon), 0);
    e = parse(s.substr(colon + 1), -1);
  }
  if (!ok) {
    if (why) *why = fmt::format("\"{}\" is not of the form A:B with 0 <= A < B", s);
    return false;
  }
  if (e != -1 && e <= b) {
    if (why) *why = fmt::format("\"{}\": the range is empty", s);
    return false;
  }
  *begin = b;
  *end = e;
  return true;
}

std::string ScenePoseSource(const Scene& s) {
  if (!s.camera.poses) return "the camera model's extrinsics (the scene gives no camera.poses)";
  return s.camera.poses_of_rig ? "camera.poses of the rig, composed with the camera model's extrinsics"
                               : "camera.poses of the camera (the model's extrinsics unused)";
}

std::vector<Rigid3> LoadScenePoses(const Scene& s) {
  std::vector<Rigid3> world_from_cam;
  if (!s.camera.poses || s.camera.poses_of_rig) {
    const Rigid3 ref_from_cam = CameraModel::Read(s.camera.model).cam_from_ref().Inverse();
    if (!s.camera.poses) return {ref_from_cam};
    Scene camera_poses = s;
    camera_poses.camera.poses_of_rig = false;
    std::vector<Rigid3> world_from_ref = LoadScenePoses(camera_poses);
    for (Rigid3& p : world_from_ref) p = p * ref_from_cam;
    return world_from_ref;
  }
  switch (s.camera.pose_format) {
    case PoseFormat::kTum:
      for (const auto& p : ReadTum(*s.camera.poses).poses) world_from_cam.push_back(p.world_from_cam);
      break;
    case PoseFormat::k7Scenes:
      for (const auto& p : Read7ScenesFolder(*s.camera.poses).poses) world_from_cam.push_back(p.world_from_cam);
      break;
    case PoseFormat::kColmap: {
      ColmapModel m = ReadColmapText(*s.camera.poses);
      std::vector<std::pair<std::string, Rigid3>> byname;
      for (const auto& [id, im] : m.images) byname.emplace_back(im.name, im.cam_from_world.Inverse());
      std::sort(byname.begin(), byname.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      for (auto& [n, p] : byname) world_from_cam.push_back(p);
      break;
    }
  }
  return world_from_cam;
}

SceneInputCheck CheckSceneInputs(const Scene& s, int width, int height, int begin, int end) {
  SceneInputCheck out;
  const std::string camera_name = s.camera.model.string();
  if (width <= 0 || height <= 0)
    ThrowErrorAt(FileLoc{camera_name}, "camera is {}x{} pixels: no image to render", width, height);
  const int64_t pixels = static_cast<int64_t>(width) * height;
  if (pixels > kMaxCameraPixels)
    ThrowErrorAt(FileLoc{camera_name}, "camera is {}x{} = {:.3g} pixels, more than mr renders ({:.0e}; corrupt model?)",
                 width, height, static_cast<double>(pixels), static_cast<double>(kMaxCameraPixels));
  // Light per frame: the first frame needs a file at or before it (later
  // frames without their own reuse the last one).
  for (const auto& [pattern, per_frame, what] :
       {std::tuple{s.lighting.environment, s.lighting.environment_per_frame, "environment map"},
        std::tuple{s.lighting.lights, s.lighting.lights_per_frame, "lights file"}})
    if (per_frame && pattern && !PerFrameFile(*pattern, std::max(0, begin), nullptr))
      ThrowErrorAt(FileLoc{pattern->string()}, "no {} for frame {} or any frame before it", what, std::max(0, begin));
  out.poses = static_cast<int>(LoadScenePoses(s).size());
  const std::string poses_name = s.camera.poses ? s.camera.poses->string() : std::string("the scene");
  if (end < 0) end = out.poses;
  if (end > out.poses) {
    out.warnings.push_back(fmt::format("frames {}:{} asked for, but {} has {} poses: frames {}:{} are rendered", begin,
                                       end, poses_name, out.poses, begin, out.poses));
    end = out.poses;
  }
  // Every frame of a pattern in [begin, end): present, and of the camera's size.
  auto check_pattern = [&](const fs::path& pattern, const char* what) {
    std::error_code ec;
    for (int f = begin; f < end; ++f) {
      const fs::path p = FramePath(pattern, f);
      if (!fs::is_regular_file(p, ec))
        ThrowErrorAt(FileLoc{p.string()}, "{} {} is missing ({} names {} frames from {}, one per pose)", what, f,
                     pattern.string(), end - begin, begin);
      int w = 0, h = 0;
      ReadImageHeader(p, &w, &h, nullptr);
      if (w != width || h != height)
        ThrowErrorAt(FileLoc{p.string()}, "{} {} is {}x{}, the camera model {} says {}x{}", what, f, w, h, camera_name,
                     width, height);
    }
  };
  if (s.camera.frames && !s.camera.frames_are_video) {
    const fs::path& pattern = *s.camera.frames;
    check_pattern(pattern, "frame");
    if (pattern.string().find('%') != std::string::npos) {
      std::error_code ec;
      int n = end;
      while (n < end + 1000000 && fs::exists(FramePath(pattern, n), ec)) ++n;
      out.frames = n;
      if (n > out.poses)
        out.warnings.push_back(
            fmt::format("{} has frames past the {} poses of {}: frames {} and later are not rendered", pattern.string(),
                        out.poses, poses_name, out.poses));
    } else {
      out.frames = 1;
    }
  } else if (s.camera.frames) {
    VideoReader video(*s.camera.frames);
    out.frames = video.frame_count();
    if (video.width() != width || video.height() != height)
      ThrowErrorAt(FileLoc{s.camera.frames->string()}, "video is {}x{}, the camera model {} says {}x{}", video.width(),
                   video.height(), camera_name, width, height);
    if (out.frames < end)
      ThrowErrorAt(FileLoc{s.camera.frames->string()},
                   "video holds {} frames, but frames {}:{} are to be rendered ({} has {} poses)", out.frames, begin,
                   end, poses_name, out.poses);
    if (out.frames > out.poses)
      out.warnings.push_back(fmt::format("{} holds {} frames, {} has {} poses: frames {} and later are not rendered",
                                         s.camera.frames->string(), out.frames, poses_name, out.poses, out.poses));
  }
  if (s.reference) check_pattern(*s.reference, "reference frame");
  return out;
}

}  // namespace mr
