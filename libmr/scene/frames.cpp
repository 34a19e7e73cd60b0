#include "scene/frames.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>

#include <fmt/format.h>
#include <string>
#include <utility>

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

std::vector<Rigid3> LoadScenePoses(const Scene& s) {
  std::vector<Rigid3> world_from_cam;
  if (!s.camera.poses) return {Rigid3()};
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

}  // namespace mr
