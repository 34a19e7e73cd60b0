#include "pipeline/pipeline.h"

#include <fnmatch.h>
#include <unistd.h>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/hash.h"
#include "core/json_node.h"
#include "core/process.h"
#include "core/version.h"
#include "core/video.h"
#include "geometry/mesh.h"
#include "render/method.h"
#include "scene/frames.h"
#include "scene/scene.h"

namespace mr {

const std::vector<std::string>& PipelineStageNames() {
  static const std::vector<std::string> n = {"calibrate",  "sphere",      "hdr",    "probe",      "fuse",
                                             "register",   "plate_probe", "lights", "formfactor", "scene",
                                             "radiometry", "render",      "sweep"};
  return n;
}

// ---------------------------------------------------------------------------
// Content hashes

namespace {

// FNV-1a over 8-byte words with a final avalanche (splitmix64): fast enough
// for gigabytes of recordings, and any changed byte changes the hash.
std::string Hex(uint64_t v) { return fmt::format("{:016x}", v); }

}  // namespace

// ---------------------------------------------------------------------------
// Planning

namespace {

using Node = JsonNode;

struct Planner {
  Pipeline* p;
  const std::string* name;

  fs::path Path(const Node& n, const char* what) const {
    fs::path f = n.String();
    if (f.empty()) n.Fail("empty path");
    if (f.is_relative()) f = p->base / f;
    std::error_code ec;
    if (!fs::exists(f, ec)) n.Fail(fmt::format("{} {} does not exist", what, f.string()));
    return f.lexically_normal();
  }
  // A path that a stage may write, or a frame pattern (printf-style): only
  // its folder has to exist.
  fs::path Pattern(const Node& n, const char* what) const {
    fs::path f = n.String();
    if (f.empty()) n.Fail("empty path");
    if (f.is_relative()) f = p->base / f;
    std::error_code ec;
    if (f.string().find('%') == std::string::npos) return Path(n, what);
    if (!fs::is_directory(f.parent_path(), ec)) n.Fail(fmt::format("the folder of {} does not exist", f.string()));
    return f.lexically_normal();
  }
  // One path, or a list of paths; '*' and '?' in a file name match files of
  // its folder (sorted).  An empty match is an error.
  std::vector<fs::path> Files(const Node& n, const char* what) const {
    std::vector<fs::path> out;
    auto one = [&](const Node& e) {
      fs::path f = e.String();
      if (f.is_relative()) f = p->base / f;
      const std::string pattern = f.filename().string();
      if (pattern.find_first_of("*?[") == std::string::npos) {
        out.push_back(Path(e, what));
        return;
      }
      std::vector<fs::path> m;
      std::error_code ec;
      if (fs::is_directory(f.parent_path(), ec))
        for (const auto& d : fs::directory_iterator(f.parent_path()))
          if (d.is_regular_file() && fnmatch(pattern.c_str(), d.path().filename().c_str(), 0) == 0)
            m.push_back(d.path().lexically_normal());
      if (m.empty()) e.Fail(fmt::format("no {} match {}", what, f.string()));
      std::sort(m.begin(), m.end());
      out.insert(out.end(), m.begin(), m.end());
    };
    if (n.json().is_array()) {
      if (n.json().empty()) n.Fail(fmt::format("an empty list of {}", what));
      for (size_t i = 0; i < n.json().size(); ++i) one(n.Index(i));
    } else {
      one(n);
    }
    return out;
  }
  // "options": {"albedo-rays": 64, "no-albedo": true} -> --albedo-rays 64 --no-albedo.
  // The tool checks them (unknown flags are its usage errors).
  std::vector<std::string> Options(const Node& parent, const char* key = "options") const {
    std::vector<std::string> a;
    if (!parent.Has(key)) return a;
    const Node n = parent.Child(key);
    if (!n.json().is_object()) n.Fail("expected an object of tool options, e.g. {\"width\": 256}");
    for (auto& [k, v] : n.json().items()) {
      if (k.empty() || k[0] == '-') n.Child(k).Fail("option names go without the leading --");
      if (v.is_boolean()) {
        if (v.get<bool>()) a.push_back("--" + k);
      } else if (v.is_string()) {
        a.insert(a.end(), {"--" + k, v.get<std::string>()});
      } else if (v.is_number()) {
        a.insert(a.end(), {"--" + k, v.dump()});
      } else if (v.is_array()) {
        std::string list;
        for (const auto& e : v) list += (list.empty() ? "" : ",") + (e.is_string() ? e.get<std::string>() : e.dump());
        a.insert(a.end(), {"--" + k, list});
      } else {
        n.Child(k).Fail("expected a string, number, true/false or a list");
      }
    }
    return a;
  }
  std::string Rel(const fs::path& f) const { return f.lexically_relative(p->work).generic_string(); }
};

void Append(std::vector<std::string>* a, const std::vector<std::string>& b) { a->insert(a->end(), b.begin(), b.end()); }
void Append(std::vector<fs::path>* a, const std::vector<fs::path>& b) { a->insert(a->end(), b.begin(), b.end()); }
void AppendPaths(std::vector<std::string>* a, const std::vector<fs::path>& b) {
  for (const auto& f : b) a->push_back(f.string());
}

// A scene entry ("real" or "virtual") with its paths rebased to the work folder.
Json Rebase(const Planner& pl, const Node& n, const std::vector<std::string>& path_keys) {
  Json out = n.json();
  if (!out.is_object()) n.Fail("expected an object");
  for (const std::string& k : path_keys)
    if (n.Has(k.c_str()) && n.Child(k).json().is_string()) out[k] = pl.Rel(pl.Path(n.Child(k), k.c_str()));
  return out;
}

}  // namespace

Pipeline PlanPipeline(const fs::path& file) {
  Pipeline p;
  p.file = file;
  p.base = file.parent_path().empty() ? fs::path(".") : file.parent_path();
  p.base = fs::absolute(p.base).lexically_normal();
  // ParseJsonStrict: every JSON error (a number too large for a double
  // too, found by fuzz/fuzz_pipeline) as one mr::Error naming the file.
  p.json = ReadJsonFile(file);
  const std::string name = file.string();
  const Node root(p.json, "", &name);
  root.RequireObject({"version", "comment", "work", "camera", "lighting", "room", "video", "virtual", "render",
                      "output", "reference", "formfactor", "outputs"});
  if (root.Required("version").Integer(1, 1) != 1) root.Fail("version must be 1");
  Planner pl{&p, &name};
  p.work = (p.base / (root.Has("work") ? root.Child("work").String() : std::string("work"))).lexically_normal();
  const fs::path& w = p.work;
  auto stage = [&](const std::string& n) -> PipelineStage& {
    p.stages.push_back({});
    PipelineStage& s = p.stages.back();
    s.name = n;
    s.report = w / "reports" / (n + ".json");
    return s;
  };
  Json scene = {{"version", 1}};

  // The scene camera: a model, or calibrated from board photographs.
  const Node cam = root.Required("camera");
  cam.RequireObject({"model", "boards"});
  fs::path camera_model;
  {
    PipelineStage& s = stage("calibrate");
    s.tool = "mr-calibrate";
    if (cam.Has("model") == cam.Has("boards")) cam.Fail("give either camera.model or camera.boards");
    if (cam.Has("model")) {
      camera_model = pl.Path(cam.Child("model"), "camera model");
      s.skip = "camera.model is given: " + camera_model.string();
    } else {
      const Node b = cam.Child("boards");
      b.RequireObject({"photos", "board", "lensmodel", "options"});
      const auto photos = pl.Files(b.Required("photos"), "board photographs");
      const fs::path board = pl.Path(b.Required("board"), "board definition");
      camera_model = w / "camera.cameramodel";
      s.args = {"camera", "--board", board.string(), "--out", camera_model.string()};
      if (b.Has("lensmodel")) Append(&s.args, {"--lensmodel", b.Child("lensmodel").String()});
      Append(&s.args, pl.Options(b));
      AppendPaths(&s.args, photos);
      s.inputs = photos;
      s.inputs.push_back(board);
      s.outputs = {camera_model};
      s.does = fmt::format("the scene camera's intrinsics from {} board photographs (mrcal)", photos.size());
    }
  }

  // The lighting: a map, or a probe (photographs -> HDR -> unwrapped map),
  // and optionally lights extracted from it.
  const Node light = root.Required("lighting");
  light.RequireObject({"environment", "probe", "light_video", "sphere_in_plate", "lights", "environment_up",
                       "environment_rotation_deg", "environment_scale"});
  if (light.Has("environment") + light.Has("probe") + light.Has("light_video") + light.Has("sphere_in_plate") != 1)
    light.Fail("give one of lighting.environment, lighting.probe, lighting.light_video and lighting.sphere_in_plate");
  fs::path env, probe_json, probe_raw;
  std::optional<Node> probe, light_video, plate_sphere;
  if (light.Has("sphere_in_plate")) {
    plate_sphere.emplace(light.Child("sphere_in_plate"));
    plate_sphere->RequireObject({"centre", "radius", "reflectance", "options"});
    // Unwrapped after the plate's poses are known (the plate_probe stage).
    env = w / "env" / "%05d.exr";
  }
  if (light.Has("light_video")) {
    light_video.emplace(light.Child("light_video"));
    light_video->RequireObject({"frames", "fisheye", "exposures", "plate_times", "options"});
  }
  // Why the photograph stages have nothing to do without a probe.
  const std::string no_probe = light_video    ? "the light is a light camera's video (lighting.light_video)"
                               : plate_sphere ? "the light is the mirror sphere in the plate (lighting.sphere_in_plate)"
                                              : "lighting.environment is given";
  if (light.Has("probe")) {
    probe.emplace(light.Child("probe"));
    probe->RequireObject({"photos", "exposures", "probe", "sphere", "fisheye", "hdr", "unwrap"});
  }
  {
    PipelineStage& s = stage("sphere");
    s.tool = "mr-calibrate";
    if (!probe) {
      s.skip = no_probe + ": no probe to locate";
    } else if (probe->Has("fisheye")) {
      s.skip = "the probe is a fish-eye view: no mirror sphere to locate";
    } else if (probe->Has("probe")) {
      probe_json = pl.Path(probe->Child("probe"), "probe.json");
      s.skip = "lighting.probe.probe is given: " + probe_json.string();
    } else {
      if (!probe->Has("sphere"))
        probe->Fail("a mirror-sphere probe needs \"probe\" (probe.json) or \"sphere\" (its photographs)");
      const Node sp = probe->Child("sphere");
      sp.RequireObject({"camera", "photos", "radius", "options"});
      const fs::path light_cam = pl.Path(sp.Required("camera"), "light camera model");
      const auto photos = pl.Files(sp.Required("photos"), "sphere photographs");
      const double radius = sp.Required("radius").Number(1e-4, 10);
      probe_json = w / "probe.json";
      s.args = {"sphere", "--camera",         light_cam.string(), "--radius", fmt::format("{}", radius),
                "--out",  probe_json.string()};
      Append(&s.args, pl.Options(sp));
      AppendPaths(&s.args, photos);
      s.inputs = photos;
      s.inputs.push_back(light_cam);
      s.outputs = {probe_json};
      s.does = "the mirror sphere's centre in the light camera (probe.json)";
    }
  }
  {
    PipelineStage& s = stage("hdr");
    s.tool = "mr-hdr";
    if (!probe) {
      s.skip = no_probe + ": no photographs to merge";
    } else {
      const auto photos = pl.Files(probe->Required("photos"), "probe photographs");
      const std::string ext = LowerExtension(photos.front());
      if (photos.size() == 1 && (ext == ".exr" || ext == ".hdr")) {
        probe_raw = photos.front();
        s.skip = "one HDR photograph of the probe: nothing to merge";
      } else {
        probe_raw = w / "probe-raw.exr";
        s.args = {"--out", probe_raw.string(), "--save-response", (w / "probe-response.json").string()};
        s.inputs = photos;
        if (probe->Has("exposures")) {
          const fs::path e = pl.Path(probe->Child("exposures"), "exposure list");
          Append(&s.args, {"--exposures", e.string()});
          s.inputs.push_back(e);
        }
        Append(&s.args, pl.Options(*probe, "hdr"));
        AppendPaths(&s.args, photos);
        s.outputs = {probe_raw, w / "probe-response.json"};
        s.does = fmt::format("{} bracketed photographs of the probe merged into radiance", photos.size());
      }
    }
  }
  {
    PipelineStage& s = stage("probe");
    s.tool = "mr-probe";
    if (light_video) {
      // One map per plate frame from the light camera's frames, matched by
      // timestamp to the plate's poses; mr-probe keeps the maps whose light
      // frames did not change.
      const Node& lv = *light_video;
      const fs::path frames = pl.Pattern(lv.Required("frames"), "light video frames");
      const fs::path fe = pl.Path(lv.Required("fisheye"), "light camera model");
      env = w / "env" / "%05d.exr";
      s.args = {"--light", frames.string(), "--fisheye", fe.string(), "--out", env.string()};
      s.inputs = {frames.string().find('%') != std::string::npos || LowerExtension(frames) == ".txt"
                      ? frames.parent_path()
                      : frames,
                  fe};
      std::optional<fs::path> times;
      if (lv.Has("plate_times")) {
        times = pl.Path(lv.Child("plate_times"), "plate trajectory");
      } else if (root.Has("video") && root.Child("video").Has("poses") &&
                 root.Child("video").Child("poses").Has("tum")) {
        times = pl.Path(root.Child("video").Child("poses").Child("tum"), "trajectory");
      }
      if (times) {
        Append(&s.args, {"--plate-times", times->string()});
        s.inputs.push_back(*times);
      }
      if (lv.Has("exposures")) {
        const fs::path e = pl.Path(lv.Child("exposures"), "light frames' exposure times");
        Append(&s.args, {"--exposures", e.string()});
        s.inputs.push_back(e);
      }
      Append(&s.args, pl.Options(lv));
      s.outputs = {w / "env"};
      s.does = times ? "the light camera's frames unwrapped, one map per plate frame matched by timestamp"
                     : "the light camera's frames unwrapped, one map per frame (no plate times: frame i is i)";
    } else if (plate_sphere) {
      s.skip =
          "the light is the mirror sphere in the plate: unwrapped by plate_probe, once the plate's poses are known";
    } else if (!probe) {
      env = pl.Pattern(light.Child("environment"), "environment map");  // a map, one per frame, or a video
      s.skip = "lighting.environment is given: " + env.string();
    } else {
      env = w / "env.exr";
      s.args = {probe_raw.string(), "--out", env.string()};
      s.inputs = {probe_raw};
      if (probe->Has("fisheye")) {
        const fs::path fe = pl.Path(probe->Child("fisheye"), "fish-eye camera model");
        Append(&s.args, {"--fisheye", fe.string()});
        s.inputs.push_back(fe);
        s.does = "the fish-eye view unwrapped into a world-aligned lat-long map";
      } else {
        Append(&s.args, {"--probe", probe_json.string()});
        s.inputs.push_back(probe_json);
        s.does = "the mirror sphere unwrapped into a world-aligned lat-long map";
      }
      Append(&s.args, pl.Options(*probe, "unwrap"));
      s.outputs = {env};
    }
  }

  // The room: meshes given, or fused from an RGB-D recording.
  const Node room = root.Required("room");
  room.RequireObject({"real", "rgbd", "options"});
  if (room.Has("real") == room.Has("rgbd"))
    room.Fail("give either room.real (meshes) or room.rgbd (a recording to fuse)");
  fs::path fused_mesh, fused_trajectory;
  {
    PipelineStage& s = stage("fuse");
    s.tool = "mr-fuse";
    if (room.Has("real")) {
      const Node r = room.Child("real");
      Json reals = Json::array();
      auto rebase = [&](const Node& one) {
        Json e = Rebase(pl, one, {"mesh"});
        if (one.Has("material")) e["material"] = Rebase(pl, one.Child("material"), {"albedo_texture"});
        return e;
      };
      if (r.json().is_array()) {
        for (size_t i = 0; i < r.json().size(); ++i) reals.push_back(rebase(r.Index(i)));
      } else {
        reals.push_back(rebase(r));
      }
      scene["real"] = reals;
      s.skip = fmt::format("room.real gives {} mesh{}: no RGB-D recording to fuse", reals.size(),
                           reals.size() == 1 ? "" : "es");
    } else {
      const fs::path rgbd = pl.Path(room.Child("rgbd"), "RGB-D recording");
      fused_mesh = w / "room" / "room.ply";
      fused_trajectory = w / "room" / "trajectory.txt";
      s.args = {rgbd.string(), "--out", (w / "room").string()};
      s.inputs = {rgbd};
      const auto opts = pl.Options(room);
      if (std::find(opts.begin(), opts.end(), "--no-albedo") == opts.end() &&
          std::find(opts.begin(), opts.end(), "--env") == opts.end()) {
        // Albedo de-lit by the captured light (a map per frame: the first frame's).
        if (plate_sphere)
          room.Fail(
              "the room's albedo is de-lit by the captured light, and the sphere in the plate gives it only once the "
              "plate's poses are known, after the room: give room.options \"env\" (a map) or \"no-albedo\"");
        if (IsVideoFile(env))
          room.Fail(
              "the room's albedo is de-lit by a map, and lighting.environment is a video: give room.options "
              "\"env\" (a map) or \"no-albedo\"");
        const fs::path delight = env.string().find('%') != std::string::npos ? FramePath(env, 0) : env;
        std::error_code ec;
        // A given map must exist; the probe's and a light video's are made by their stage.
        if (light.Has("environment") && !fs::is_regular_file(delight, ec))
          light.Child("environment")
              .Fail(fmt::format("{}: no map for frame 0 to de-light the room by", delight.string()));
        Append(&s.args, {"--env", delight.string()});
        s.inputs.push_back(delight);
      }
      Append(&s.args, opts);
      s.outputs = {fused_mesh, fused_trajectory};
      s.does = "the room reconstructed from RGB-D (tracking, TSDF, mesh with de-lit albedo)";
    }
  }

  // The video to augment and its poses.
  const Node video = root.Required("video");
  video.RequireObject({"frames", "frames_transfer", "exposure", "response", "gains", "poses"});
  Json camera = {{"model", pl.Rel(camera_model)}};
  if (video.Has("frames")) camera["frames"] = pl.Rel(pl.Pattern(video.Child("frames"), "video frames"));
  if (video.Has("frames_transfer")) camera["frames_transfer"] = video.Child("frames_transfer").String();
  if (video.Has("exposure")) camera["exposure"] = video.Child("exposure").json();
  if (video.Has("response")) camera["response"] = pl.Rel(pl.Path(video.Child("response"), "camera response"));
  // The plate's radiometric gains: fitted (mr-eval plate) unless the video
  // has none, they are given, turned off, or an exposure is hand-set for a
  // display-space plate (where the two would say the same thing twice).
  const fs::path gains_dir = w / "radiometry", fitted_gains = gains_dir / "gains.json";
  std::string gains_skip;
  std::vector<std::string> gains_options;
  // Linear plates are radiance, taken to be in the captured light's units:
  // their gains are fitted as a check of the chain, not applied, unless
  // asked ({"apply": true}).
  const bool linear = video.Has("frames_transfer") && video.Child("frames_transfer").String() == "linear";
  bool apply_gains = !linear;
  const bool display = video.Has("frames_transfer") && video.Child("frames_transfer").String() == "display";
  if (!video.Has("frames")) {
    gains_skip = "the video names no frames (a synthetic composite): there is no plate to fit";
  } else if (video.Has("gains")) {
    const Node g = video.Child("gains");
    if (g.json().is_string()) {
      camera["gains"] = pl.Rel(pl.Path(g, "plate gains"));
      gains_skip = "video.gains names them: " + g.String();
    } else if (g.json().is_boolean()) {
      if (g.Bool()) g.Fail("expected false, a gains file, or {\"options\": {...}} (fitting is the default)");
      gains_skip = "video.gains is false";
    } else if (g.json().is_object()) {
      g.RequireObject({"options", "scale", "apply"});
      gains_options = pl.Options(g);
      if (g.Has("apply")) apply_gains = g.Child("apply").Bool();
      if (g.Has("scale")) camera["gains_scale"] = g.Child("scale").OneOf({"render", "room"});
    } else {
      g.Fail("expected false, a gains file, or {\"options\": {...}}");
    }
    if (display && video.Has("exposure") && !gains_skip.empty() && g.json().is_string())
      video.Child("exposure").Fail("with video.gains the gains scale the render: give one of the two");
    if (display && video.Has("exposure") && gains_skip.empty())
      video.Child("exposure").Fail("a hand-set exposure and fitted gains both scale the render: give one of the two");
  } else if (display && video.Has("exposure")) {
    gains_skip = "video.exposure is hand-set for the display-space plate";
  }
  const bool use_gains = gains_skip.empty() && apply_gains;
  if (use_gains) camera["gains"] = pl.Rel(fitted_gains);
  fs::path poses;
  {
    PipelineStage& s = stage("register");
    s.tool = "mr-register";
    const Node ps = video.Required("poses");
    ps.RequireObject({"tum", "fuse", "colmap", "register", "initial", "refine_mesh", "options"});
    const int given = ps.Has("tum") + ps.Has("fuse") + ps.Has("colmap") + ps.Has("register");
    if (given != 1)
      ps.Fail("give one of tum (a trajectory), fuse (the RGB-D recording's), colmap (a model to align) or register");
    if (ps.Has("tum")) {
      poses = pl.Path(ps.Child("tum"), "trajectory");
      s.skip = "video.poses.tum is given: " + poses.string();
    } else if (ps.Has("fuse")) {
      if (fused_trajectory.empty())
        ps.Child("fuse").Fail("the room is not fused (room.rgbd): there is no fused trajectory");
      poses = fused_trajectory;
      s.skip = "the video is the RGB-D recording's colour: its poses are mr-fuse's trajectory";
    } else {
      poses = w / "video" / "poses.txt";
      const fs::path model_out = w / "video" / "colmap.cameramodel";
      if (ps.Has("colmap")) {
        const fs::path m = pl.Path(ps.Child("colmap"), "COLMAP model");
        s.args = {"align", m.string()};
        s.inputs = {m};
        s.does = "the COLMAP model aligned to the room (similarity to mr-fuse's trajectory, Ceres)";
      } else {
        if (!video.Has("frames")) ps.Fail("registration needs video.frames");
        const fs::path frames = pl.Pattern(video.Child("frames"), "video frames");
        s.args = {"colmap",   frames.string(),      "--workspace", (w / "video" / "colmap").string(),
                  "--camera", camera_model.string()};
        s.inputs = {frames.string().find('%') != std::string::npos ? frames.parent_path() : frames, camera_model};
        if (ps.Child("register").json().is_object()) {
          const Node r = ps.Child("register");
          r.RequireObject({"matcher", "overlap"});
          if (r.Has("matcher")) Append(&s.args, {"--matcher", r.Child("matcher").OneOf({"sequential", "exhaustive"})});
          if (r.Has("overlap")) Append(&s.args, {"--overlap", std::to_string(r.Child("overlap").Integer(1, 1000))});
        } else if (!ps.Child("register").Bool()) {
          ps.Child("register").Fail("expected true or {matcher, overlap}");
        }
        s.does =
            "the video's frames registered by COLMAP and aligned to the room (similarity to mr-fuse's trajectory, "
            "Ceres)";
      }
      // Aligned to the fused trajectory (and, asked, refined against the
      // fused mesh); with room meshes, to the meshes from a given start.
      if (!fused_trajectory.empty()) {
        Append(&s.args, {"--trajectory", fused_trajectory.string()});
        s.inputs.push_back(fused_trajectory);
        if (ps.Has("refine_mesh") && ps.Child("refine_mesh").Bool()) {
          Append(&s.args, {"--mesh", fused_mesh.string()});
          s.inputs.push_back(fused_mesh);
        }
      } else {
        if (!ps.Has("initial"))
          ps.Fail(
              "aligning COLMAP's poses to room meshes needs \"initial\": a rough similarity, 16 numbers "
              "(row-major [s*R t; 0 0 0 1], COLMAP's frame to the room's)");
        std::string list;
        for (double v : ps.Child("initial").Numbers(16, -1e30, 1e30))
          list += (list.empty() ? "" : ",") + fmt::format("{}", v);
        Append(&s.args, {"--initial", list});
        for (const auto& r : scene["real"]) {
          const fs::path m = (w / r["mesh"].get<std::string>()).lexically_normal();
          Append(&s.args, {"--mesh", m.string()});
          s.inputs.push_back(m);
        }
      }
      Append(&s.args, {"--out", poses.string(), "--camera-out", model_out.string()});
      Append(&s.args, pl.Options(ps));
      s.outputs = {poses, model_out};
    }
    if (!poses.empty()) camera["poses"] = {{"format", "tum"}, {"path", pl.Rel(poses)}};
  }
  scene["camera"] = camera;

  {
    // The mirror sphere in the plate: each frame's sphere pixels unwrapped
    // from the frame's pose into a map (mr-probe --sphere-in-plate), on the
    // plate's own scene (its camera section alone, written first).
    PipelineStage& s = stage("plate_probe");
    s.tool = "mr-probe";
    if (!plate_sphere) {
      s.skip = "lighting.sphere_in_plate is not given";
    } else {
      const Node& sp = *plate_sphere;
      if (!video.Has("frames")) sp.Fail("the sphere in the plate needs the plate (video.frames)");
      const std::vector<double> c = sp.Required("centre").Numbers(3, -1e6, 1e6);
      const double radius = sp.Required("radius").Number(1e-4, 100);
      const fs::path plate_scene = w / "plate.json";
      Json plate_camera = camera;
      if (use_gains) plate_camera.erase("gains");  // fitted by the radiometry stage, after this one
      s.writes_first = plate_scene;
      // The room's meshes too: a scene has geometry (mr-probe reads none of it).
      const Json reals = scene.contains("real") ? scene["real"] : Json::array({{{"mesh", pl.Rel(fused_mesh)}}});
      s.writes_first_json = {{"version", 1},
                             {"comment", fmt::format("the plate and the room, for mr-probe (written by mr-pipeline "
                                                     "from {})",
                                                     file.string())},
                             {"camera", plate_camera},
                             {"real", reals}};
      s.args = {"--sphere-in-plate",
                plate_scene.string(),
                "--sphere",
                fmt::format("{},{},{},{}", c[0], c[1], c[2], radius),
                "--out",
                env.string()};
      if (sp.Has("reflectance"))
        Append(&s.args, {"--reflectance", fmt::format("{}", sp.Child("reflectance").Number(1e-3, 1))});
      Append(&s.args, pl.Options(sp));
      const fs::path frames = pl.Pattern(video.Child("frames"), "video frames");
      s.inputs = {frames.string().find('%') != std::string::npos ? frames.parent_path() : frames, camera_model};
      if (!poses.empty()) s.inputs.push_back(poses);
      if (video.Has("response")) s.inputs.push_back(pl.Path(video.Child("response"), "camera response"));
      if (camera.contains("gains") && !use_gains) s.inputs.push_back(w / camera["gains"].get<std::string>());
      s.outputs = {w / "env"};
      s.does = "the mirror sphere in each plate frame unwrapped from the frame's pose into a map";
    }
  }

  Json lighting = {{"environment", pl.Rel(env)}};
  {
    PipelineStage& s = stage("lights");
    s.tool = "mr-lights";
    if (!light.Has("lights")) {
      s.skip = "lighting.lights is not asked for: the scene is lit by the environment map alone";
    } else if (light.Child("lights").json().is_string()) {
      const fs::path l = pl.Pattern(light.Child("lights"), "lights.json");  // a file, or one per frame
      lighting["lights"] = pl.Rel(l);
      s.skip = "lighting.lights is given: " + l.string();
    } else {
      const Node l = light.Child("lights");
      l.RequireObject({"options"});
      if (IsVideoFile(env))
        l.Fail(
            "mr-lights extracts lights from maps, and lighting.environment is a video: give the maps as a "
            "pattern (env/%05d.exr)");
      const bool per_frame = env.string().find('%') != std::string::npos;
      // A map per frame: lights per frame, each keeping its name while it moves.
      const fs::path out = per_frame ? w / "lights" / "%05d.json" : w / "lights.json";
      const fs::path residual = per_frame ? w / "env-residual" / "%05d.exr" : w / "env-residual.exr";
      s.args = {env.string(), "--out", out.string(), "--residual", residual.string()};
      Append(&s.args, pl.Options(l));
      s.inputs = {per_frame ? env.parent_path() : env};
      s.outputs =
          per_frame ? std::vector<fs::path>{w / "lights", w / "env-residual"} : std::vector<fs::path>{out, residual};
      s.does = per_frame ? "lights extracted from each frame's map (a light keeps its name across frames); the scene "
                           "is lit by them and each frame's residual map"
                         : "lights extracted from the map; the scene is lit by them and the residual map";
      lighting = {{"environment", pl.Rel(residual)}, {"lights", pl.Rel(out)}};
    }
  }
  for (const char* k : {"environment_up", "environment_rotation_deg", "environment_scale"})
    if (light.Has(k)) lighting[k] = light.Child(k).json();
  scene["lighting"] = lighting;

  // Virtual objects, with form factors where prt needs them.
  const Json render = root.Has("render") ? root.Child("render").json() : Json::object();
  const std::string method = render.value("method", "pt");
  Json virtuals = Json::array();
  {
    PipelineStage& s = stage("formfactor");
    s.tool = "mr-formfactor";
    bool uses_ffc = false;
    std::string ffc_methods;
    for (const MethodInfo& m : RenderMethodRegistry())
      if (m.uses_formfactors) {
        ffc_methods += (ffc_methods.empty() ? "" : ", ") + m.name;
        uses_ffc = uses_ffc || m.name == method;
      }
    const Node v = root.Required("virtual");
    if (!v.json().is_array()) v.Fail("expected a list of virtual objects");
    const auto opts = root.Has("formfactor") ? pl.Options(root, "formfactor") : std::vector<std::string>();
    for (size_t i = 0; i < v.json().size(); ++i) {
      const Node o = v.Index(i);
      if (o.Has("light")) {  // a virtual light: passed through
        virtuals.push_back(o.json());
        continue;
      }
      Json e = Rebase(pl, o, {"mesh", "formfactors"});
      if (o.Has("material"))  // its texture, like the mesh, relative to the work folder
        e["material"] = Rebase(pl, o.Child("material"), {"albedo_texture"});
      const bool wants = uses_ffc ? !(o.Has("formfactors") && o.Child("formfactors").json().is_string())
                                  : o.Has("formfactors") && o.Child("formfactors").json().is_boolean() &&
                                        o.Child("formfactors").Bool();
      if (o.Has("formfactors") && o.Child("formfactors").json().is_boolean() && !o.Child("formfactors").Bool())
        e.erase("formfactors");
      if (wants) {
        if (!s.args.empty()) o.Fail("form factors for more than one object: give each its own ffc file");
        const fs::path mesh = pl.Path(o.Required("mesh"), "mesh");
        const std::string nm = o.Has("name") ? o.Child("name").String() : fmt::format("object{}", i);
        const fs::path ffc = w / (nm + ".ffc");
        s.args = {mesh.string(), "--out", ffc.string()};
        Append(&s.args, opts);
        s.inputs = {mesh};
        s.outputs = {ffc};
        s.does = fmt::format("per-vertex form factors of {}", nm);
        e["formfactors"] = pl.Rel(ffc);
      }
      virtuals.push_back(e);
    }
    if (s.args.empty())
      s.skip = uses_ffc ? "every virtual object names its form factors"
                        : fmt::format("render.method is {}: form factors are only used by {}", method, ffc_methods);
  }
  scene["virtual"] = virtuals;
  scene["render"] = render;
  Json output = root.Has("output") ? root.Child("output").json() : Json::object();
  output["dir"] = "render";
  scene["output"] = output;
  if (root.Has("reference")) scene["reference"] = pl.Rel(pl.Pattern(root.Child("reference"), "reference frames"));
  scene["comment"] = fmt::format("written by mr-pipeline from {}", file.string());
  const fs::path scene_file = w / "scene.json";
  {
    PipelineStage& s = stage("scene");
    s.args = {};
    s.inputs = {file, camera_model, env};
    if (lighting.contains("lights")) s.inputs.push_back(w / lighting["lights"].get<std::string>());
    if (!fused_mesh.empty()) s.inputs.push_back(fused_mesh);
    if (!poses.empty()) s.inputs.push_back(poses);
    for (const auto& v2 : virtuals)
      if (v2.contains("formfactors")) s.inputs.push_back(w / v2["formfactors"].get<std::string>());
    s.outputs = {scene_file};
    s.does = fused_mesh.empty() ? "scene.json naming every input"
                                : "scene.json naming every input (the fused room's per-vertex albedo)";
  }
  if (!fused_mesh.empty()) {
    // The albedo is the fused mesh's mean, filled in when the scene stage runs.
    scene["real"] = Json::array({{{"mesh", pl.Rel(fused_mesh)}, {"material", {{"albedo", {0.5, 0.5, 0.5}}}}}});
    p.fused_room = fused_mesh;
  }
  // Validate the assembled scene now (files that stages make need not exist yet).
  CheckRenderSettings(ParseScene(scene, w, (w / "scene.json").string(), false));
  p.scene = scene;

  // The per-frame light the scene names by pattern: its folders' content
  // decides the renders (scene.json itself does not change with it).
  std::vector<fs::path> per_frame;
  for (const char* k : {"environment", "lights"})
    if (lighting.contains(k) && lighting[k].get<std::string>().find('%') != std::string::npos)
      per_frame.push_back((w / lighting[k].get<std::string>()).lexically_normal().parent_path());
  const Json outputs = root.Has("outputs") ? root.Child("outputs").json() : Json{{"render", true}};
  const Node outs(outputs, "outputs", &name);
  outs.RequireObject({"render", "sweep"});
  {
    PipelineStage& s = stage("radiometry");
    s.tool = "mr-eval";
    if (!gains_skip.empty()) {
      s.skip = gains_skip;
    } else {
      s.args = {"plate", scene_file.string(), "--out", gains_dir.string()};
      Append(&s.args, gains_options);
      s.inputs = {scene_file};
      Append(&s.inputs, per_frame);
      s.outputs = {gains_dir};
      s.does = use_gains
                   ? "the plate's gains fitted against the rendered room, and the capture chain's re-rendering error"
                   : "the capture chain's re-rendering error and the plate's gains, as a check (a linear plate "
                     "is not rescaled: video.gains {\"apply\": true} applies them)";
    }
  }
  {
    PipelineStage& s = stage("render");
    s.tool = "mr-render";
    if (outs.Has("render") && !outs.Child("render").Bool()) {
      s.skip = "outputs.render is false";
    } else {
      // --resume: the frames whose inputs (by content) and settings are those
      // of an earlier run are kept, from the first frame to the first changed.
      s.args = {scene_file.string(), "--out", (w / "render").string(), "--resume"};
      s.inputs = {scene_file};
      Append(&s.inputs, per_frame);
      if (use_gains) s.inputs.push_back(fitted_gains);
      s.outputs = {w / "render"};
      s.does = fmt::format("the virtual objects rendered into every frame ({}) and composited", method);
    }
  }
  {
    PipelineStage& s = stage("sweep");
    s.tool = "mr-eval";
    if (!outs.Has("sweep")) {
      s.skip = "outputs.sweep is not asked for";
    } else if (!root.Has("reference")) {
      s.skip = "no reference frames (reference): there is nothing to measure error against";
    } else {
      const Node sw = outs.Child("sweep");
      if (sw.json().is_boolean() && !sw.Bool()) {
        s.skip = "outputs.sweep is false";
      } else {
        s.args = {"sweep", scene_file.string(), "--out", (w / "sweep").string()};
        if (sw.json().is_object()) {
          sw.RequireObject({"options"});
          Append(&s.args, pl.Options(sw));
        }
        s.inputs = {scene_file};
        Append(&s.inputs, per_frame);
        if (use_gains) s.inputs.push_back(fitted_gains);
        s.outputs = {w / "sweep"};
        s.does = "error against run time of the rendering methods against the reference";
      }
    }
  }
  return p;
}

// ---------------------------------------------------------------------------
// Running

namespace {

fs::path ToolPath(const std::string& tool, const fs::path& bin_dir) {
  if (!bin_dir.empty()) return bin_dir / tool;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec && fs::exists(self.parent_path() / tool)) return self.parent_path() / tool;
  return tool;  // PATH
}

// The tool's own error lines from its log (the last few).
std::string ErrorLines(const fs::path& log) {
  std::ifstream in(log);
  std::vector<std::string> lines, errors;
  for (std::string l; std::getline(in, l);) {
    lines.push_back(l);
    if (l.find("error") != std::string::npos) errors.push_back(l);
  }
  const auto& pick = errors.empty() ? lines : errors;
  std::string out;
  for (size_t i = pick.size() > 3 ? pick.size() - 3 : 0; i < pick.size(); ++i) {
    if (!out.empty()) out += "\n  ";
    out += pick[i];
  }
  return out;
}

std::string Quote(const std::string& s) {
  if (s.find_first_of(" \t'\"$\\*?") == std::string::npos && !s.empty()) return s;
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// The scene stage: scene.json, with the fused room's own albedo (its
// vertex colours, mr-fuse's de-lit albedo) for every render method.
void WriteSceneJson(const Pipeline& p) {
  Json scene = p.scene;
  if (!p.fused_room.empty()) {
    Json& r = scene["real"][0];
    const Mesh m = ReadMesh(p.fused_room);
    if (m.colors.size() != m.positions.size())
      ThrowErrorAt(FileLoc{p.fused_room.string()}, "the fused room has no vertex colours (albedo)");
    r["material"]["albedo_from_vertex_colors"] = true;
  }
  CheckRenderSettings(ParseScene(scene, p.work, (p.work / "scene.json").string(), true));
  WriteTextFile(p.work / "scene.json", scene.dump(2) + "\n");
}

}  // namespace

void RunPipeline(const Pipeline& p, const PipelineRunOptions& o, Report* report) {
  const auto& names = PipelineStageNames();
  auto known = [&](const std::string& s, const char* flag) {
    if (std::find(names.begin(), names.end(), s) == names.end())
      throw UsageError(fmt::format("{} {}: no such stage (stages: {})", flag, s, fmt::join(names, ", ")));
  };
  if (!o.until.empty()) known(o.until, "--until");
  for (const auto& f : o.force) known(f, "--force");
  report->AddInput(p.file.string());
  std::error_code ec;
  if (!o.dry_run) {
    fs::create_directories(p.work / ".mr-pipeline", ec);
    fs::create_directories(p.work / "reports", ec);
    fs::create_directories(p.work / "logs", ec);
    if (!fs::is_directory(p.work / "logs"))
      ThrowErrorAt(FileLoc{p.work.string()}, "cannot create the work folder{}", ec ? ": " + ec.message() : "");
    // A stage killed before it could clean up (SIGKILL, power loss) leaves
    // temporaries beside its outputs; its outputs themselves are whole (every
    // write is atomic) and the stage is not recorded as done, so it runs again.
    int stale = 0;
    for (auto it = fs::recursive_directory_iterator(p.work, ec); !ec && it != fs::recursive_directory_iterator();
         it.increment(ec))
      if (it->is_directory()) stale += RemoveStaleTemporaries(it->path());
    stale += RemoveStaleTemporaries(p.work);
    if (stale > 0)
      report->Warn(fmt::format("removed {} temporary files that killed runs left in {}", stale, p.work.string()));
  }
  Json stages = Json::array();
  std::set<std::string> remade;  // outputs of stages that run (or would) in this invocation
  bool past_until = false;
  int ran = 0, current = 0, skipped = 0;
  for (const PipelineStage& s : p.stages) {
    ++current;
    Json sj = {{"stage", s.name}, {"tool", s.tool.empty() ? "mr-pipeline" : s.tool}};
    auto finish = [&](const std::string& status, const std::string& why) {
      sj["status"] = status;
      if (!why.empty()) sj["why"] = why;
      stages.push_back(sj);
      if (o.dry_run)
        std::printf("%-11s %-11s %s\n", s.name.c_str(), status.c_str(), why.c_str());
      else if (!o.quiet)
        spdlog::info("[{}/{}] {}: {}{}", current, p.stages.size(), s.name, status, why.empty() ? "" : " (" + why + ")");
    };
    // --until STAGE holds even when STAGE itself is left out.
    const bool after_until = past_until;
    if (s.name == o.until) past_until = true;
    if (!s.skip.empty()) {
      report->Skip(s.name, s.skip);
      ++skipped;
      finish("skipped", s.skip);
      continue;
    }
    if (after_until) {
      const std::string why = fmt::format("after --until {}", o.until);
      report->Skip(s.name, why);
      finish("skipped", why);
      continue;
    }
    std::vector<std::string> argv;
    if (!s.tool.empty()) {
      argv.push_back(ToolPath(s.tool, o.bin_dir).string());
      Append(&argv, s.args);
      Append(&argv, {"--report", s.report.string()});
      if (o.threads > 0) Append(&argv, {"--threads", std::to_string(o.threads)});
    }
    std::string cmd;
    for (const auto& a : argv) {
      if (!cmd.empty()) cmd += ' ';
      cmd += Quote(a);
    }
    sj["command"] = s.tool.empty() ? "(mr-pipeline writes " + s.outputs.front().string() + ")" : cmd;
    sj["does"] = s.does;
    // Up to date?
    const bool forced = std::find(o.force.begin(), o.force.end(), s.name) != o.force.end();
    std::string upstream;
    for (const auto& in : s.inputs)
      if (remade.count(in.string())) upstream = in.string();
    const fs::path stamp = p.work / ".mr-pipeline" / (s.name + ".json");
    std::string why_run;
    Hasher key;
    key.String(kVersion);
    key.String(s.name);
    bool inputs_ready = true;
    if (!s.tool.empty()) {
      const fs::path tool = argv[0];
      if (fs::exists(tool, ec)) HashFile(tool, &key);
      for (const auto& a : s.args) key.String(a);
      if (!s.writes_first.empty()) key.String(s.writes_first_json.dump());
    } else {
      key.String(p.scene.dump());
    }
    for (const auto& in : s.inputs) {
      key.String(in.string());
      if (fs::exists(in, ec))
        key.Word(ContentHash(in));
      else
        inputs_ready = false;
    }
    const std::string key_hex = Hex(key.Final());
    Json old;
    if (fs::exists(stamp, ec)) {
      try {
        old = Json::parse(ReadTextFile(stamp));
      } catch (const std::exception&) {
        old = Json();
      }
    }
    if (forced) {
      why_run = "--force";
    } else if (!inputs_ready || !upstream.empty()) {
      why_run = upstream.empty() ? "inputs are made by an earlier stage" : "an input is re-made: " + upstream;
    } else if (!old.is_object()) {
      why_run = "not run before";
    } else if (old.value("key", "") != key_hex) {
      why_run = "inputs, options or the tool changed";
    } else {
      for (const auto& out : s.outputs) {
        const std::string k = out.string();
        if (!fs::exists(out, ec)) {
          why_run = "output missing: " + k;
          break;
        }
        if (!old["outputs"].contains(k) || old["outputs"][k] != Hex(ContentHash(out))) {
          why_run = "output changed since: " + k;
          break;
        }
      }
    }
    if (why_run.empty()) {
      if (fs::exists(s.report, ec)) {
        try {
          sj["report"] = Json::parse(ReadTextFile(s.report));
        } catch (const std::exception&) {
        }
      }
      finish("up to date", "");
      continue;
    }
    for (const auto& out : s.outputs) remade.insert(out.string());
    if (o.dry_run) {
      finish("would run", why_run);
      std::printf("%-23s %s\n", "", s.tool.empty() ? s.does.c_str() : cmd.c_str());
      continue;
    }
    if (!o.quiet) spdlog::info("[{}/{}] {}: running ({}): {}", current, p.stages.size(), s.name, why_run, s.does);
    const auto t0 = std::chrono::steady_clock::now();
    const fs::path log = p.work / "logs" / (s.name + ".log");
    fs::remove(stamp, ec);
    if (s.tool.empty()) {
      WriteSceneJson(p);
    } else {
      if (!s.writes_first.empty()) WriteTextFile(s.writes_first, s.writes_first_json.dump(2) + "\n");
      const int rc = RunProcess(argv, log);
      if (rc != 0) {
        report->SetMetric("stages", stages);
        throw Error(FileLoc{p.file.string(), 0, 0, s.name},
                    fmt::format("stage {} failed ({} {}):\n  {}\n  full log: {}; finished stages' outputs are kept",
                                s.name, s.tool, rc < 127 ? fmt::format("exited with {}", rc) : DescribeExitStatus(rc),
                                ErrorLines(log), log.string()));
      }
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    report->AddTiming(s.name, seconds);
    sj["seconds"] = seconds;
    sj["why_run"] = why_run;
    if (fs::exists(s.report, ec)) {
      sj["report"] = Json::parse(ReadTextFile(s.report));
      for (const auto& w : sj["report"]["warnings"]) report->Warn(s.name + ": " + w.get<std::string>());
    }
    Json stamp_json = {{"key", key_hex}, {"command", cmd}, {"outputs", Json::object()}};
    for (const auto& out : s.outputs) {
      if (!fs::exists(out, ec))
        throw Error(FileLoc{p.file.string(), 0, 0, s.name},
                    fmt::format("stage {} finished but did not write {}", s.name, out.string()));
      stamp_json["outputs"][out.string()] = Hex(ContentHash(out));
      report->AddOutput(out.string());
    }
    WriteTextFile(stamp, stamp_json.dump(2) + "\n");
    ++ran;
    finish("ran", fmt::format("{:.1f} s", seconds));
  }
  report->SetMetric("stages", stages);
  report->SetMetric("ran", ran);
  report->SetMetric("left_out", skipped);
  report->SetMetric("work", p.work.string());
}

}  // namespace mr
