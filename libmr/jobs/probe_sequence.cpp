#include "jobs/probe_sequence.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <sstream>

#include "camera/camera_model.h"
#include "camera/trajectory.h"
#include "core/error.h"
#include "core/hash.h"
#include "core/image.h"
#include "core/progress.h"
#include "core/video.h"
#include "hdr/exposure_merge.h"
#include "hdr/exposures_file.h"
#include "render/frame_io.h"
#include "scene/frames.h"
#include "scene/scene.h"

namespace mr {

void ProbeSequenceOptions::Check() const {
  const bool camera = !light.empty(), sphere = !scene.empty();
  if (camera == sphere) throw UsageError("give a light camera's frames or a scene whose plate shows the sphere");
  if (camera && fisheye.empty()) throw UsageError("a light camera's frames need its camera model (--fisheye)");
  if (sphere && !(sphere_radius > 0 && std::isfinite(sphere_radius) && sphere_centre.allFinite()))
    throw UsageError("the sphere in the plate needs its world centre and a positive radius (--sphere X,Y,Z,R)");
  if (!(fps > 0) || !std::isfinite(fps)) throw UsageError(fmt::format("frame rate {} must be positive", fps));
  if (!std::isfinite(time_offset)) throw UsageError("the time offset must be finite");
  if (!(max_dt >= 0)) throw UsageError("the maximum time difference must be >= 0");
  if (out.string().find('%') == std::string::npos)
    throw UsageError(fmt::format("{}: a sequence's maps need a printf pattern (env/%05d.exr)", out.string()));
  if (begin < 0 || (end >= 0 && end <= begin)) throw UsageError("the frame range is empty");
  unwrap.Check();
  filter.Check();
}

std::vector<LightFrameFile> ListLightFrames(const std::string& light, double fps, double time_offset,
                                            double* video_fps) {
  std::vector<LightFrameFile> frames;
  const fs::path p(light);
  const std::string ext = p.extension().string();
  if (light.find('%') != std::string::npos) {
    for (int i = 0;; ++i) {
      const fs::path f = FramePath(p, i);
      if (!fs::exists(f)) break;
      frames.push_back({i / fps + time_offset, f, -1});
    }
    if (frames.empty()) ThrowErrorAt(FileLoc{FramePath(p, 0).string()}, "the light sequence's first frame is missing");
    return frames;
  }
  if (!fs::exists(p)) ThrowErrorAt(FileLoc{light}, "no such file");
  if (ext == ".txt") {
    std::istringstream in(ReadTextFile(p));
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) {
      if (const size_t h = line.find('#'); h != std::string::npos) line.resize(h);
      std::istringstream ls(line);
      std::vector<std::string> words;
      for (std::string w; ls >> w;) words.push_back(w);
      if (words.empty()) continue;
      const std::string where = fmt::format("{}:{}", light, n);
      if (words.size() != 2) ThrowErrorAt(FileLoc{where}, "expected TIMESTAMP PATH, got {} words", words.size());
      double t = 0;
      size_t used = 0;
      try {
        t = std::stod(words[0], &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != words[0].size() || !std::isfinite(t))
        ThrowErrorAt(FileLoc{where}, "\"{}\" is not a timestamp", words[0]);
      const fs::path f = fs::path(words[1]).is_absolute() ? fs::path(words[1]) : p.parent_path() / words[1];
      if (!fs::exists(f)) ThrowErrorAt(FileLoc{where}, "{}: no such file", f.string());
      frames.push_back({t + time_offset, f, -1});
    }
    if (frames.empty()) ThrowErrorAt(FileLoc{light}, "lists no light frames");
    for (size_t i = 1; i < frames.size(); ++i)
      if (frames[i].time < frames[i - 1].time)
        ThrowErrorAt(FileLoc{light}, "timestamps go backwards at {} ({:.6f} after {:.6f})",
                     frames[i].path.filename().string(), frames[i].time, frames[i - 1].time);
    return frames;
  }
  // A video: its own frame rate.
  VideoReader video(p);
  const double vfps = video.fps() > 0 ? video.fps() : fps;
  if (video_fps) *video_fps = vfps;
  for (int i = 0; i < video.frame_count(); ++i) frames.push_back({i / vfps + time_offset, {}, i});
  if (frames.empty()) ThrowErrorAt(FileLoc{light}, "the video holds no frames");
  return frames;
}

namespace {

struct FrameOut {
  Image map;
  LightFrameReport filter;
  int light_frame = -1;
  std::string light_file;  // the light frame's file (light camera)
  double dt = 0;
};

// The key an earlier run wrote into a map ("" when none, or no map).
std::string MapKey(const fs::path& path) {
  if (!fs::exists(path)) return "";
  try {
    int w = 0, h = 0;
    std::vector<std::string> ch;
    const ImageFileInfo info = ReadImageHeader(path, &w, &h, &ch);
    const auto it = info.attributes.find("mr:light_key");
    return it == info.attributes.end() || ch.size() != 4 ? "" : it->second;
  } catch (const Error&) {
    return "";  // unreadable: made again
  }
}

void WriteMap(const ProbeSequenceOptions& o, int f, const Image& map, Report* report, const std::string& key = "") {
  ImageWriteOptions wo;
  if (!key.empty()) wo.attributes["mr:light_key"] = key;
  wo.tool = o.tool;
  wo.command_line = o.command_line;
  wo.attributes["textureformat"] = "LatLong Environment";
  const fs::path path = FramePath(o.out, f);
  std::error_code ec;
  if (!path.parent_path().empty()) fs::create_directories(path.parent_path(), ec);
  WriteImage(path, map, wo);
  report->AddOutput(path.string());
}

Json FrameJson(int f, const FrameOut& fo, bool reused) {
  return {{"frame", f},
          {"light_frame", fo.light_frame},
          {"light_file", fo.light_file},
          {"dt_s", fo.dt},
          {"reused", reused},
          {"exposure", fo.filter.exposure},
          {"alpha", fo.filter.alpha},
          {"seen_fraction", fo.filter.seen_fraction},
          {"filled_fraction", fo.filter.filled_fraction},
          {"jump_fraction", fo.filter.jump_fraction},
          {"jump", fo.filter.jump}};
}

void StateSkips(const ProbeSequenceOptions& o, Report* report) {
  if (o.filter.time_constant_s <= 0) report->Skip("temporal filter", "time constant 0: every frame as it is");
  if (!o.filter.recover_exposure) report->Skip("exposure recovery", "exposures read (or 1), not recovered");
}

void Summarise(const std::vector<Json>& frames, Report* report) {
  Json list = Json::array();
  int jumps = 0, reused = 0;
  for (const Json& j : frames) {
    list.push_back(j);
    jumps += j["jump"].get<bool>();
    reused += j["reused"].get<bool>();
  }
  report->SetMetric("frames", list);
  report->SetMetric("abrupt_changes", jumps);
  report->SetMetric("reused_maps", reused);
  if (reused > 0)
    report->Warn(fmt::format("{} frame(s) have no light frame of their own and reuse the last map", reused));
}

// Which light frame each output frame takes (-1: none within max_dt): by
// the plate's timestamps, else one output frame per light frame. *plate
// gets the plate's times (empty without them).
std::vector<int> LightOfOutputFrame(const ProbeSequenceOptions& o, const std::vector<double>& light_times,
                                    std::vector<double>* plate, Report* report) {
  std::vector<int> light_of;
  if (o.plate_times) {
    const Trajectory traj = ReadTum(*o.plate_times);
    report->AddInput(o.plate_times->string());
    for (const auto& p : traj.poses) plate->push_back(p.timestamp);
    const TimeMatch m = MatchLightToPlate(light_times, *plate, o.max_dt, o.light, o.plate_times->string());
    light_of = m.light_of_plate;
    report->SetMetric(
        "time_match",
        {{"max_dt_s", o.max_dt}, {"largest_dt_s", m.max_dt_seen}, {"unmatched_plate_frames", m.unmatched}});
  } else {
    for (size_t i = 0; i < light_times.size(); ++i) light_of.push_back(static_cast<int>(i));
    report->Skip("matching by timestamp", "no plate times given: one map per light frame");
  }
  return light_of;
}

// Exposure times from --exposures (0 where it has none, and without it:
// then metadata, else 1, decide).
std::vector<double> ExposureTimesFromFile(const ProbeSequenceOptions& o, const std::vector<LightFrameFile>& lf,
                                          Report* report) {
  if (!o.exposures) return std::vector<double>(lf.size(), 0);
  std::vector<std::string> names;
  for (const auto& f : lf) names.push_back(f.path.string());
  if (lf[0].path.empty())
    ThrowErrorAt(FileLoc{o.exposures->string()},
                 "exposure times of a video's frames: give "
                 "its frames as files");
  std::vector<double> times = ReadExposures(o.exposures->string(), names);
  report->AddInput(o.exposures->string());
  return times;
}

// The key of every option a light camera's map depends on.
uint64_t LightOptionsKey(const ProbeSequenceOptions& o, int first) {
  return HashCombine(ContentHash(o.fisheye),
                     HashString(fmt::format(
                         "mr-probe light 1 {} {} {} {} {} {} {} {} {} {} {}", o.unwrap.width, o.unwrap.reflectance,
                         o.unwrap.camera_cone_deg, fmt::join(o.unwrap.rotate.data(), o.unwrap.rotate.data() + 9, ","),
                         o.filter.time_constant_s, o.filter.jump_ratio, o.filter.jump_floor,
                         o.filter.jump_report_fraction, o.filter.recover_exposure, o.filter.confidence_keep, first)));
}

// An 8-bit frame with a clipped pixel (a lower bound of its light).
bool AnyClipped(const Image& photo) {
  for (int64_t i = 0; i < photo.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c)
      if (photo.values()[static_cast<size_t>(i * photo.channels() + c)] >= 0.99f) return true;
  return false;
}

// The light camera's frames.
void RunLightCamera(const ProbeSequenceOptions& o, Report* report) {
  double video_fps = 0;
  const std::vector<LightFrameFile> lf = ListLightFrames(o.light, o.fps, o.time_offset, &video_fps);
  report->AddInput(o.light);
  const CameraModel cam = CameraModel::Read(o.fisheye);
  report->AddInput(o.fisheye.string());
  const Eigen::Matrix3d world_from_cam = cam.cam_from_ref().rotation.conjugate().toRotationMatrix();
  std::vector<double> light_times;
  for (const auto& f : lf) light_times.push_back(f.time);

  // Which light frame each output frame takes.
  std::vector<double> plate;
  const std::vector<int> light_of = LightOfOutputFrame(o, light_times, &plate, report);
  const int n_out = static_cast<int>(light_of.size());
  const int begin = std::min(o.begin, n_out), end = o.end < 0 ? n_out : std::min(o.end, n_out);
  if (begin >= end) ThrowErrorAt(FileLoc{o.light}, "no frame in the range {}:{} ({} frames)", o.begin, o.end, n_out);
  int first = -1, last = -1;
  for (int p = begin; p < end; ++p)
    if (light_of[static_cast<size_t>(p)] >= 0) {
      if (first < 0) first = light_of[static_cast<size_t>(p)];
      last = light_of[static_cast<size_t>(p)];
    }
  if (first < 0) ThrowErrorAt(FileLoc{o.light}, "no light frame matches the plate frames {} to {}", begin, end - 1);

  std::vector<double> times = ExposureTimesFromFile(o, lf, report);

  std::unique_ptr<VideoReader> video;
  if (lf[0].path.empty()) video = std::make_unique<VideoReader>(o.light);
  LightFilter filter(o.filter);
  StateSkips(o, report);

  // The map each output frame shows: its light frame's, else the last
  // matched one's (a dropped light frame), else the first's.
  std::vector<int> source(static_cast<size_t>(n_out), -1);
  std::vector<std::vector<int>> emit(static_cast<size_t>(last + 1));
  for (int p = begin, prev = first; p < end; ++p) {
    const int j = light_of[static_cast<size_t>(p)];
    if (j >= 0) prev = j;
    source[static_cast<size_t>(p)] = prev;
    emit[static_cast<size_t>(prev)].push_back(p);
  }

  // Each map's key: a chain over the options and every light frame up to
  // it (content, time, exposure), so that a re-run keeps the maps whose
  // inputs did not change and redoes the rest (docs/methods.md).
  const uint64_t options_key = LightOptionsKey(o, first);
  const uint64_t video_key = video ? ContentHash(o.light) : 0;
  uint64_t key = options_key;
  double t0 = 0;
  Progress progress("light frames", last - first + 1);
  int clipped_frames = 0, kept = 0;
  std::vector<Json> frames;
  for (int j = first; j <= last; ++j) {
    const LightFrameFile& f = lf[static_cast<size_t>(j)];
    const std::string name = f.path.empty() ? fmt::format("{} frame {}", o.light, j) : f.path.string();
    double time = times[static_cast<size_t>(j)];
    if (!(time > 0) && !f.path.empty()) {
      int w = 0, h = 0;
      std::vector<std::string> ch;
      std::string how;
      time = ExposureFromMetadata(ReadImageHeader(f.path, &w, &h, &ch).attributes, &how);
    }
    if (!(time > 0)) time = 1;
    if (j == first) t0 = time;
    key = HashCombine(key, f.path.empty() ? HashCombine(video_key, static_cast<uint64_t>(j)) : ContentHash(f.path));
    key = HashCombine(key, HashCombine(std::bit_cast<uint64_t>(f.time), std::bit_cast<uint64_t>(time / t0)));
    const std::string key_hex = fmt::format("{:016x}", key);
    const std::vector<int>& shows = emit[static_cast<size_t>(j)];

    FrameOut fo;
    fo.light_frame = j;
    fo.light_file = f.path.empty() ? fmt::format("{}#{}", o.light, f.video_index) : f.path.filename().string();
    bool restored = !shows.empty();
    for (int p : shows) restored = restored && MapKey(FramePath(o.out, p)) == key_hex;
    if (restored) {  // an earlier run made these maps from the same inputs
      ScopedTimer t(report, "read");
      fo.map = ReadImage(FramePath(o.out, shows.front()));
      filter.Restore(fo.map, f.time);
      ++kept;
    } else {
      Image photo;
      ImageFileInfo info;
      {
        ScopedTimer t(report, "read");
        photo = f.path.empty() ? video->Frame(f.video_index) : ReadImage(f.path, {}, &info);
      }
      // 8-bit frames: a clipped pixel is a lower bound; count them.
      if ((f.path.empty() || info.decoded_from_ldr) && AnyClipped(photo)) ++clipped_frames;
      Image map;
      {
        ScopedTimer t(report, "unwrap");
        map = UnwrapFisheye(photo, cam, world_from_cam, o.unwrap, name);
      }
      ScopedTimer t(report, "filter");
      fo.map = filter.Add(map, f.time, time / t0, &fo.filter);
    }
    for (int p : shows) {
      FrameOut shown = fo;
      shown.dt = plate.empty() ? 0 : f.time - plate[static_cast<size_t>(p)];
      if (!restored) {
        ScopedTimer t(report, "write");
        WriteMap(o, p, fo.map, report, key_hex);
      } else {
        report->AddOutput(FramePath(o.out, p).string());
      }
      Json jf = FrameJson(p, shown, light_of[static_cast<size_t>(p)] < 0);
      jf["kept"] = restored;
      frames.push_back(jf);
    }
    progress.Update(j - first + 1);
  }
  progress.Done();
  std::sort(frames.begin(), frames.end(),
            [](const Json& a, const Json& b) { return a["frame"].get<int>() < b["frame"].get<int>(); });
  if (clipped_frames > 0)
    report->Warn(
        fmt::format("{} light frame(s) are 8-bit with clipped pixels: those directions are lower bounds "
                    "(an HDR light camera, or a shorter exposure, keeps the sun)",
                    clipped_frames));
  if (first > 0) report->Skip("light frames before the plate", fmt::format("{} frame(s)", first));
  if (kept > 0)
    report->Skip("unwrapping and filtering",
                 fmt::format("{} light frame(s): their maps are up to date (same inputs and options as the maps' "
                             "keys say)",
                             kept));
  report->SetMetric("light_frames_read", last - first + 1 - kept);
  report->SetMetric("light_frames_kept", kept);
  Summarise(frames, report);
}

// The sphere in the plate.
void RunPlateSphere(const ProbeSequenceOptions& o, Report* report) {
  const Scene scene = ReadScene(o.scene);
  report->AddInput(o.scene.string());
  if (!scene.camera.frames) ThrowErrorAt(FileLoc{o.scene.string()}, "camera.frames: the scene names no plate");
  const CameraModel cam = CameraModel::Read(scene.camera.model);
  const std::vector<Rigid3> poses = LoadScenePoses(scene);
  const FrameDecoding decoding = FrameDecoding::FromScene(scene, report);
  FrameReader reader(scene, cam, decoding);
  const int n = static_cast<int>(poses.size());
  const int begin = std::min(o.begin, n), end = o.end < 0 ? n : std::min(o.end, n);
  if (begin >= end)
    ThrowErrorAt(FileLoc{o.scene.string()}, "no frame in the range {}:{} ({} poses)", o.begin, o.end, n);
  LightFilter filter(o.filter);
  StateSkips(o, report);
  report->Skip("matching by timestamp", "the sphere is in the plate: every frame has its own");
  // Each map's key chains every earlier frame's (the filter carries them):
  // the options, the scene (its decoding: transfer, exposure, response,
  // gains), then per frame the plate frame's content and its pose.  A re-run
  // keeps the maps up to the first frame whose inputs changed.
  uint64_t key = HashString(fmt::format(
      "mr-probe sphere 1 {} {} {} {} {} {} {} {} {} {} {} {} {} {} {}", o.unwrap.width, o.unwrap.reflectance,
      o.unwrap.camera_cone_deg, fmt::join(o.unwrap.rotate.data(), o.unwrap.rotate.data() + 9, ","),
      o.filter.time_constant_s, o.filter.jump_ratio, o.filter.jump_floor, o.filter.jump_report_fraction,
      o.filter.recover_exposure, o.filter.confidence_keep, o.fps, begin, o.sphere_radius,
      fmt::join(o.sphere_centre.data(), o.sphere_centre.data() + 3, ","), scene.camera.frames_are_video));
  key = HashCombine(key, ContentHash(o.scene));
  key = HashCombine(key, ContentHash(scene.camera.model));
  for (const auto& file : {scene.camera.response, scene.camera.gains})
    if (file) key = HashCombine(key, ContentHash(*file));
  const uint64_t video_key = scene.camera.frames_are_video ? ContentHash(*scene.camera.frames) : 0;
  std::vector<Json> frames;
  Image last;
  int outside = 0, kept = 0, clipped_frames = 0;
  bool restoring = true;  // from the first frame on, while the maps' keys match
  Progress progress("plate frames", end - begin);
  for (int f = begin; f < end; ++f) {
    const Rigid3& pose = poses[static_cast<size_t>(f)];
    key = HashCombine(key, scene.camera.frames_are_video ? HashCombine(video_key, static_cast<uint64_t>(f))
                                                         : ContentHash(FramePath(*scene.camera.frames, f)));
    for (double v : {pose.translation.x(), pose.translation.y(), pose.translation.z(), pose.rotation.w(),
                     pose.rotation.x(), pose.rotation.y(), pose.rotation.z()})
      key = HashCombine(key, std::bit_cast<uint64_t>(v));
    const std::string key_hex = fmt::format("{:016x}", key);
    const fs::path out = FramePath(o.out, f);
    restoring = restoring && MapKey(out) == key_hex;
    if (restoring) {  // an earlier run made this map from the same inputs
      FrameOut fo;
      fo.light_frame = f;
      {
        ScopedTimer t(report, "read");
        fo.map = ReadImage(out);
      }
      filter.Restore(fo.map, f / o.fps);
      report->AddOutput(out.string());
      Json j = FrameJson(f, fo, false);
      j["kept"] = true;
      frames.push_back(j);
      ++kept;
      progress.Update(f - begin + 1);
      continue;
    }
    std::optional<Image> photo;
    PhotoEncoding encoding;
    {
      ScopedTimer t(report, "read");
      photo = reader.Photo(f, &encoding);
    }
    if (!photo) ThrowErrorAt(FileLoc{scene.camera.frames->string()}, "frame {} is missing", f);
    const Image radiance = decoding.ForFrame(f).ToRadiance(*photo);
    // Where the plate's codes clipped (8/16-bit plates, as mr-probe's
    // photographs: 97% of full scale): counted on the sphere, a lower bound.
    std::vector<uint8_t> clipped(static_cast<size_t>(photo->pixel_count()), 0);
    if (encoding.has_codes) {
      const Image codes = decoding.ForFrame(f).ToCodes(radiance, encoding);
      for (int64_t p = 0; p < codes.pixel_count(); ++p)
        for (int c = 0; c < 3; ++c)
          if (codes.values()[static_cast<size_t>(p * codes.channels() + c)] >= 0.97f)
            clipped[static_cast<size_t>(p)] = 1;
    }
    ProbeGeometry g;
    g.path = o.scene;
    g.camera = cam;
    g.radius_m = o.sphere_radius;
    const Rigid3 cam_from_world = poses[static_cast<size_t>(f)].Inverse();
    g.centre_cam = cam_from_world * o.sphere_centre;
    g.world_from_cam = poses[static_cast<size_t>(f)].rotation.toRotationMatrix();
    Image map;
    UnwrapReport ur;
    Eigen::Vector2d q;
    const bool in_view = g.centre_cam.z() > o.sphere_radius && cam.Project(g.centre_cam.normalized(), &q) &&
                         q.x() >= 0 && q.y() >= 0 && q.x() < cam.width() && q.y() < cam.height();
    {
      ScopedTimer t(report, "unwrap");
      if (in_view) {
        map = UnwrapMirrorSphere(radiance, g, o.unwrap, fmt::format("{} frame {}", o.scene.string(), f), &ur, &clipped);
        if (ur.clipped_pixels > 0) {
          ++clipped_frames;
          Image rgbc(map.width(), map.height(), {"R", "G", "B", "confidence.Y"});  // the filter keeps four layers
          for (int64_t p = 0; p < map.pixel_count(); ++p)
            for (int c = 0; c < 4; ++c)
              rgbc.values()[static_cast<size_t>(p * 4 + c)] = map.values()[static_cast<size_t>(p * map.channels() + c)];
          map = std::move(rgbc);
        }
      } else {  // nothing seen: every direction from history
        map = Image(o.unwrap.width, o.unwrap.width / 2, {"R", "G", "B", "confidence.Y"});
        ++outside;
      }
    }
    FrameOut fo;
    fo.light_frame = f;
    {
      ScopedTimer t(report, "filter");
      fo.map = filter.Add(map, f / o.fps, 1.0, &fo.filter);
    }
    {
      ScopedTimer t(report, "write");
      WriteMap(o, f, fo.map, report, key_hex);
    }
    Json j = FrameJson(f, fo, false);
    j["sphere_in_view"] = in_view;
    j["kept"] = false;
    frames.push_back(j);
    progress.Update(f - begin + 1);
  }
  progress.Done();
  if (outside > 0)
    report->Warn(fmt::format("the sphere is out of view in {} frame(s): their maps are the earlier frames'", outside));
  if (clipped_frames > 0)
    report->Warn(
        fmt::format("the sphere shows clipped plate pixels in {} frame(s): those directions are lower bounds "
                    "(a shorter exposure, or an HDR plate, keeps the lamps)",
                    clipped_frames));
  if (kept > 0)
    report->Skip("unwrapping and filtering",
                 fmt::format("{} plate frame(s): their maps are up to date (same inputs and options as the maps' "
                             "keys say)",
                             kept));
  report->SetMetric("plate_frames_kept", kept);
  Summarise(frames, report);
}

}  // namespace

void RunProbeSequence(const ProbeSequenceOptions& o, Report* report) {
  o.Check();
  report->SetMetric("time_constant_s", o.filter.time_constant_s);
  report->SetMetric("source", o.scene.empty() ? "light camera" : "sphere in the plate");
  if (o.scene.empty())
    RunLightCamera(o, report);
  else
    RunPlateSphere(o, report);
}

}  // namespace mr
