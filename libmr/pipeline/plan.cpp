// mr-pipeline's planner: a table of stages (Stages() at the end of this
// file), each one plan function over the shared plan state.  A stage
// function reads the part of the pipeline file its stage needs, in the
// order of the table (so that errors come in the file's order: the camera,
// the lighting, the room, the video, ...), fills its PipelineStage (tool,
// arguments, inputs, outputs, what it does, or why it is skipped) and
// leaves in the state what later stages take from it (the camera model, the
// maps, the poses, the fused room, the plate's gains, the scene).
#include <fnmatch.h>

#include <algorithm>
#include <optional>

#include "core/error.h"
#include "core/json_node.h"
#include "core/json_settings.h"
#include "core/video.h"
#include "pipeline/pipeline.h"
#include "render/method.h"
#include "scene/frames.h"
#include "scene/scene.h"

namespace mr {

namespace {

constexpr double kFusedRoomIcSpacingPx = 8;   // render.ic.min_spacing_px for a fused room
constexpr double kFusedRoomIcNormalDeg = 90;  // render.ic.normal_deg for a fused room

using Node = JsonNode;
using OptNode = std::optional<Node>;

// The blocks of pipeline.json that several stages read, each taken once by
// its first stage (JsonSettings: every key named where it is taken, absent
// ones empty, any other key an error listing these); later stages use the
// fields.
struct RootBlock {
  OptNode version, comment, work, camera, lighting, room, video, virtuals, render, output, reference, formfactor,
      outputs;
};
struct LightingBlock {
  OptNode environment, probe, light_video, sphere_in_plate, lights, environment_up, environment_rotation_deg,
      environment_scale;
};
struct ProbeBlock {
  OptNode photos, exposures, probe, sphere, fisheye, hdr, unwrap;
};
struct LightVideoBlock {
  OptNode frames, fisheye, exposures, plate_times, options;
};
struct PlateSphereBlock {
  OptNode centre, radius, reflectance, options;
};
struct RoomBlock {
  OptNode real, rgbd, planes, options;
};
struct VideoBlock {
  OptNode frames, frames_transfer, exposure, response, gains, poses, refine_poses;
};
struct OutputsBlock {
  OptNode render, sweep;
};

// A key of a block taken earlier, required where a stage first uses it (so
// that errors come in the order of the stages): "missing required key" at
// its path when absent.
const Node& Need(const OptNode& n, const Node& block, const char* key) {
  if (!n) block.Required(key);  // throws
  return *n;
}

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
  std::vector<std::string> Options(const OptNode& options) const {
    std::vector<std::string> a;
    if (!options) return a;
    const Node& n = *options;
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

// What the stages decide for the stages after them.
struct Plan {
  Plan(Pipeline* pipeline, const fs::path& f)
      : p(pipeline), file(f), name(f.string()), root(pipeline->json, "", &name), pl{pipeline, &name} {}
  Pipeline* p;
  fs::path file;
  std::string name;  // the pipeline file, for messages
  Node root;
  RootBlock r;
  Planner pl;
  fs::path w;  // the work folder
  Json scene = {{"version", 1}};
  // The scene camera (calibrate).
  fs::path camera_model;
  // The lighting (sphere, hdr, probe, plate_probe, lights).
  LightingBlock light;
  std::optional<ProbeBlock> probe;
  std::optional<LightVideoBlock> light_video;
  std::optional<PlateSphereBlock> plate_sphere;
  std::string no_probe;  // why the photograph stages have nothing to do
  fs::path env, probe_json, probe_raw;
  Json lighting;
  // The room (fuse).
  RoomBlock room;
  fs::path fused_mesh, fused_trajectory;
  fs::path colmap_poses, points;  // room.planes: the register stage's, in COLMAP's frame
  // The video, its camera section and the plate's gains (register).
  VideoBlock video;
  Json camera;
  fs::path gains_dir, fitted_gains;
  fs::path refined_poses;   // video.refine_poses: the radiometry stage's, which the render takes
  fs::path observations;    // the register stage's (COLMAP's keypoints and their points, the room's frame)
  double prior_weight = 0;  // video.refine_poses.prior_weight: COLMAP's points as a prior (0: none)
  std::string gains_skip;
  std::vector<std::string> gains_options;
  bool use_gains = false;
  fs::path poses;
  // The virtual objects and the render (formfactor, scene).
  std::string method;
  std::string ic_records_note;  // ", its records ..." where the plan set ic's tolerances and ic renders
  Json virtuals = Json::array();
  fs::path scene_file;
  // The per-frame light the scene names by pattern: its folders' content
  // decides the renders (scene.json itself does not change with it).
  std::vector<fs::path> per_frame;
  Json outputs;
  OutputsBlock outs;
};

RootBlock ReadRoot(const Node& root) {
  JsonSettings s(root);
  RootBlock r{.version = s.Take("version"),
              .comment = s.Take("comment"),
              .work = s.Take("work"),
              .camera = s.Take("camera"),
              .lighting = s.Take("lighting"),
              .room = s.Take("room"),
              .video = s.Take("video"),
              .virtuals = s.Take("virtual"),
              .render = s.Take("render"),
              .output = s.Take("output"),
              .reference = s.Take("reference"),
              .formfactor = s.Take("formfactor"),
              .outputs = s.Take("outputs")};
  s.Done();
  return r;
}

// ---------------------------------------------------------------------------
// The scene camera: a model, or calibrated from board photographs.

void PlanCalibrate(Plan& st, PipelineStage& s) {
  const Node& camera = Need(st.r.camera, st.root, "camera");
  JsonSettings cam(camera);
  const OptNode model = cam.Take("model"), boards = cam.Take("boards");
  cam.Done();
  if (model.has_value() == boards.has_value()) camera.Fail("give either camera.model or camera.boards");
  if (model) {
    st.camera_model = st.pl.Path(*model, "camera model");
    s.skip = "camera.model is given: " + st.camera_model.string();
    return;
  }
  JsonSettings b(*boards);
  const OptNode photos_node = b.Take("photos"), board_node = b.Take("board"), lensmodel = b.Take("lensmodel"),
                options = b.Take("options");
  b.Done();
  const auto photos = st.pl.Files(Need(photos_node, *boards, "photos"), "board photographs");
  const fs::path board = st.pl.Path(Need(board_node, *boards, "board"), "board definition");
  st.camera_model = st.w / "camera.cameramodel";
  s.args = {"camera", "--board", board.string(), "--out", st.camera_model.string()};
  if (lensmodel) Append(&s.args, {"--lensmodel", lensmodel->String()});
  Append(&s.args, st.pl.Options(options));
  AppendPaths(&s.args, photos);
  s.inputs = photos;
  s.inputs.push_back(board);
  s.outputs = {st.camera_model};
  s.does = fmt::format("the scene camera's intrinsics from {} board photographs (mrcal)", photos.size());
}

// ---------------------------------------------------------------------------
// The lighting: a map, or a probe (photographs -> HDR -> unwrapped map), a
// light camera's video, or the mirror sphere in the plate; and optionally
// lights extracted from it.

// The lighting section, read by its first stage.
void ReadLighting(Plan& st) {
  JsonSettings ls(Need(st.r.lighting, st.root, "lighting"));
  st.light = {.environment = ls.Take("environment"),
              .probe = ls.Take("probe"),
              .light_video = ls.Take("light_video"),
              .sphere_in_plate = ls.Take("sphere_in_plate"),
              .lights = ls.Take("lights"),
              .environment_up = ls.Take("environment_up"),
              .environment_rotation_deg = ls.Take("environment_rotation_deg"),
              .environment_scale = ls.Take("environment_scale")};
  ls.Done();
  const LightingBlock& light = st.light;
  if (light.environment.has_value() + light.probe.has_value() + light.light_video.has_value() +
          light.sphere_in_plate.has_value() !=
      1)
    st.r.lighting->Fail(
        "give one of lighting.environment, lighting.probe, lighting.light_video and lighting.sphere_in_plate");
  if (light.sphere_in_plate) {
    JsonSettings ps(*light.sphere_in_plate);
    st.plate_sphere = {.centre = ps.Take("centre"),
                       .radius = ps.Take("radius"),
                       .reflectance = ps.Take("reflectance"),
                       .options = ps.Take("options")};
    ps.Done();
    // Unwrapped after the plate's poses are known (the plate_probe stage).
    st.env = st.w / "env" / "%05d.exr";
  }
  if (light.light_video) {
    JsonSettings vs(*light.light_video);
    st.light_video = {.frames = vs.Take("frames"),
                      .fisheye = vs.Take("fisheye"),
                      .exposures = vs.Take("exposures"),
                      .plate_times = vs.Take("plate_times"),
                      .options = vs.Take("options")};
    vs.Done();
  }
  st.no_probe = st.light_video    ? "the light is a light camera's video (lighting.light_video)"
                : st.plate_sphere ? "the light is the mirror sphere in the plate (lighting.sphere_in_plate)"
                                  : "lighting.environment is given";
  if (light.probe) {
    JsonSettings ps(*light.probe);
    st.probe = {.photos = ps.Take("photos"),
                .exposures = ps.Take("exposures"),
                .probe = ps.Take("probe"),
                .sphere = ps.Take("sphere"),
                .fisheye = ps.Take("fisheye"),
                .hdr = ps.Take("hdr"),
                .unwrap = ps.Take("unwrap")};
    ps.Done();
  }
}

void PlanSphere(Plan& st, PipelineStage& s) {
  ReadLighting(st);
  const std::optional<ProbeBlock>& probe = st.probe;
  if (!probe) {
    s.skip = st.no_probe + ": no probe to locate";
  } else if (probe->fisheye) {
    s.skip = "the probe is a fish-eye view: no mirror sphere to locate";
  } else if (probe->probe) {
    st.probe_json = st.pl.Path(*probe->probe, "probe.json");
    s.skip = "lighting.probe.probe is given: " + st.probe_json.string();
  } else {
    if (!probe->sphere)
      st.light.probe->Fail("a mirror-sphere probe needs \"probe\" (probe.json) or \"sphere\" (its photographs)");
    const Node& sphere = *probe->sphere;
    JsonSettings sp(sphere);
    const OptNode camera = sp.Take("camera"), photos_node = sp.Take("photos"), radius_node = sp.Take("radius"),
                  options = sp.Take("options");
    sp.Done();
    const fs::path light_cam = st.pl.Path(Need(camera, sphere, "camera"), "light camera model");
    const auto photos = st.pl.Files(Need(photos_node, sphere, "photos"), "sphere photographs");
    const double radius = Need(radius_node, sphere, "radius").Number(1e-4, 10);
    st.probe_json = st.w / "probe.json";
    s.args = {"sphere",
              "--camera",
              light_cam.string(),
              "--radius",
              fmt::format("{}", radius),
              "--out",
              st.probe_json.string()};
    Append(&s.args, st.pl.Options(options));
    AppendPaths(&s.args, photos);
    s.inputs = photos;
    s.inputs.push_back(light_cam);
    s.outputs = {st.probe_json};
    s.does = "the mirror sphere's centre in the light camera (probe.json)";
  }
}

void PlanHdr(Plan& st, PipelineStage& s) {
  const std::optional<ProbeBlock>& probe = st.probe;
  if (!probe) {
    s.skip = st.no_probe + ": no photographs to merge";
    return;
  }
  const auto photos = st.pl.Files(Need(probe->photos, *st.light.probe, "photos"), "probe photographs");
  const std::string ext = LowerExtension(photos.front());
  if (photos.size() == 1 && (ext == ".exr" || ext == ".hdr")) {
    st.probe_raw = photos.front();
    s.skip = "one HDR photograph of the probe: nothing to merge";
    return;
  }
  st.probe_raw = st.w / "probe-raw.exr";
  s.args = {"--out", st.probe_raw.string(), "--save-response", (st.w / "probe-response.json").string()};
  s.inputs = photos;
  if (probe->exposures) {
    const fs::path e = st.pl.Path(*probe->exposures, "exposure list");
    Append(&s.args, {"--exposures", e.string()});
    s.inputs.push_back(e);
  }
  Append(&s.args, st.pl.Options(probe->hdr));
  AppendPaths(&s.args, photos);
  s.outputs = {st.probe_raw, st.w / "probe-response.json"};
  s.does = fmt::format("{} bracketed photographs of the probe merged into radiance", photos.size());
}

// One map per plate frame from the light camera's frames, matched by
// timestamp to the plate's poses; mr-probe keeps the maps whose light frames
// did not change.
void PlanLightVideo(Plan& st, PipelineStage& s) {
  const LightVideoBlock& lv = *st.light_video;
  const Node& block = *st.light.light_video;
  const fs::path frames = st.pl.Pattern(Need(lv.frames, block, "frames"), "light video frames");
  const fs::path fe = st.pl.Path(Need(lv.fisheye, block, "fisheye"), "light camera model");
  st.env = st.w / "env" / "%05d.exr";
  s.args = {"--light", frames.string(), "--fisheye", fe.string(), "--out", st.env.string()};
  s.inputs = {frames.string().find('%') != std::string::npos || LowerExtension(frames) == ".txt" ? frames.parent_path()
                                                                                                 : frames,
              fe};
  std::optional<fs::path> times;
  // Without plate_times, the plate's trajectory if given (video.poses.tum,
  // read by the register stage: looked up here).
  const Json video = st.r.video ? st.r.video->json() : Json::object();
  if (lv.plate_times) {
    times = st.pl.Path(*lv.plate_times, "plate trajectory");
  } else if (video.contains("poses") && video["poses"].contains("tum")) {
    times = st.pl.Path(st.r.video->Child("poses").Child("tum"), "trajectory");
  }
  if (times) {
    Append(&s.args, {"--plate-times", times->string()});
    s.inputs.push_back(*times);
  }
  if (lv.exposures) {
    const fs::path e = st.pl.Path(*lv.exposures, "light frames' exposure times");
    Append(&s.args, {"--exposures", e.string()});
    s.inputs.push_back(e);
  }
  Append(&s.args, st.pl.Options(lv.options));
  s.outputs = {st.w / "env"};
  s.does = times ? "the light camera's frames unwrapped, one map per plate frame matched by timestamp"
                 : "the light camera's frames unwrapped, one map per frame (no plate times: frame i is i)";
}

void PlanProbe(Plan& st, PipelineStage& s) {
  const std::optional<ProbeBlock>& probe = st.probe;
  if (st.light_video) {
    PlanLightVideo(st, s);
  } else if (st.plate_sphere) {
    s.skip = "the light is the mirror sphere in the plate: unwrapped by plate_probe, once the plate's poses are known";
  } else if (!probe) {
    st.env = st.pl.Pattern(*st.light.environment, "environment map");  // a map, one per frame, or a video
    s.skip = "lighting.environment is given: " + st.env.string();
  } else {
    st.env = st.w / "env.exr";
    s.args = {st.probe_raw.string(), "--out", st.env.string()};
    s.inputs = {st.probe_raw};
    if (probe->fisheye) {
      const fs::path fe = st.pl.Path(*probe->fisheye, "fish-eye camera model");
      Append(&s.args, {"--fisheye", fe.string()});
      s.inputs.push_back(fe);
      s.does = "the fish-eye view unwrapped into a world-aligned lat-long map";
    } else {
      Append(&s.args, {"--probe", st.probe_json.string()});
      s.inputs.push_back(st.probe_json);
      s.does = "the mirror sphere unwrapped into a world-aligned lat-long map";
    }
    Append(&s.args, st.pl.Options(probe->unwrap));
    s.outputs = {st.env};
  }
}

// ---------------------------------------------------------------------------
// The room: meshes given, or fused from an RGB-D recording.

// mr-fuse de-lights the albedo by the captured light (a map per frame: the
// first frame's) unless room.options says otherwise.
void AddDelightingMap(Plan& st, const std::vector<std::string>& opts, PipelineStage& s) {
  const Node& room = *st.r.room;  // taken by PlanFuse
  if (std::find(opts.begin(), opts.end(), "--no-albedo") != opts.end() ||
      std::find(opts.begin(), opts.end(), "--env") != opts.end())
    return;
  if (st.plate_sphere)
    room.Fail(
        "the room's albedo is de-lit by the captured light, and the sphere in the plate gives it only once the "
        "plate's poses are known, after the room: give room.options \"env\" (a map) or \"no-albedo\"");
  if (IsVideoFile(st.env))
    room.Fail(
        "the room's albedo is de-lit by a map, and lighting.environment is a video: give room.options "
        "\"env\" (a map) or \"no-albedo\"");
  const fs::path delight = st.env.string().find('%') != std::string::npos ? FramePath(st.env, 0) : st.env;
  std::error_code ec;
  // A given map must exist; the probe's and a light video's are made by their stage.
  if (st.light.environment && !fs::is_regular_file(delight, ec))
    st.light.environment->Fail(fmt::format("{}: no map for frame 0 to de-light the room by", delight.string()));
  Append(&s.args, {"--env", delight.string()});
  s.inputs.push_back(delight);
}

void PlanFuse(Plan& st, PipelineStage& s) {
  const Node& room_node = Need(st.r.room, st.root, "room");
  JsonSettings rs(room_node);
  st.room = {
      .real = rs.Take("real"), .rgbd = rs.Take("rgbd"), .planes = rs.Take("planes"), .options = rs.Take("options")};
  rs.Done();
  const RoomBlock& room = st.room;
  if (room.real.has_value() + room.rgbd.has_value() + room.planes.has_value() != 1)
    room_node.Fail(
        "give one of room.real (meshes), room.rgbd (a recording to fuse) or room.planes (the planes of the "
        "video's own points)");
  if (room.planes) {
    if (room.options) room.options->Fail("room.planes takes its options inside it: {\"height\", \"options\"}");
    s.skip = "room.planes: the room is the planes of the video's own points (the planes stage)";
    return;
  }
  if (room.real) {
    const Node& r = *room.real;
    Json reals = Json::array();
    auto rebase = [&](const Node& one) {
      Json e = Rebase(st.pl, one, {"mesh"});
      if (one.Has("material")) e["material"] = Rebase(st.pl, one.Child("material"), {"albedo_texture"});
      return e;
    };
    if (r.json().is_array()) {
      for (size_t i = 0; i < r.json().size(); ++i) reals.push_back(rebase(r.Index(i)));
    } else {
      reals.push_back(rebase(r));
    }
    st.scene["real"] = reals;
    s.skip = fmt::format("room.real gives {} mesh{}: no RGB-D recording to fuse", reals.size(),
                         reals.size() == 1 ? "" : "es");
    return;
  }
  const fs::path rgbd = st.pl.Path(*room.rgbd, "RGB-D recording");
  st.fused_mesh = st.w / "room" / "room.ply";
  st.fused_trajectory = st.w / "room" / "trajectory.txt";
  s.args = {rgbd.string(), "--out", (st.w / "room").string()};
  s.inputs = {rgbd};
  const auto opts = st.pl.Options(room.options);
  AddDelightingMap(st, opts, s);
  Append(&s.args, opts);
  s.outputs = {st.fused_mesh, st.fused_trajectory};
  s.does = "the room reconstructed from RGB-D (tracking, TSDF, mesh with de-lit albedo)";
}

// ---------------------------------------------------------------------------
// The video to augment, its poses and the plate's radiometric gains.

// The plate's gains: fitted (mr-eval plate) unless the video has none, they
// are given, turned off, or an exposure is hand-set for a display-space
// plate (where the two would say the same thing twice).  Linear plates are
// radiance, taken to be in the captured light's units: their gains are
// fitted as a check of the chain, not applied, unless asked ({"apply":
// true}).
void ReadGains(Plan& st) {
  const VideoBlock& video = st.video;
  st.gains_dir = st.w / "radiometry";
  st.fitted_gains = st.gains_dir / "gains.json";
  const std::string transfer = video.frames_transfer ? video.frames_transfer->String() : "";
  bool apply_gains = transfer != "linear";
  const bool display = transfer == "display";
  if (!video.frames) {
    st.gains_skip = "the video names no frames (a synthetic composite): there is no plate to fit";
  } else if (video.gains) {
    const Node& g = *video.gains;
    if (g.json().is_string()) {
      st.camera["gains"] = st.pl.Rel(st.pl.Path(g, "plate gains"));
      st.gains_skip = "video.gains names them: " + g.String();
    } else if (g.json().is_boolean()) {
      if (g.Bool()) g.Fail("expected false, a gains file, or {\"options\": {...}} (fitting is the default)");
      st.gains_skip = "video.gains is false";
    } else if (g.json().is_object()) {
      JsonSettings gs(g);
      const OptNode options = gs.Take("options");
      std::string scale;
      gs.OneOf("scale", &scale, {"render", "room"});
      gs.Bool("apply", &apply_gains);
      gs.Done();
      st.gains_options = st.pl.Options(options);
      if (!scale.empty()) st.camera["gains_scale"] = scale;
    } else {
      g.Fail("expected false, a gains file, or {\"options\": {...}}");
    }
    if (display && video.exposure && !st.gains_skip.empty() && g.json().is_string())
      video.exposure->Fail("with video.gains the gains scale the render: give one of the two");
    if (display && video.exposure && st.gains_skip.empty())
      video.exposure->Fail("a hand-set exposure and fitted gains both scale the render: give one of the two");
  } else if (display && video.exposure) {
    st.gains_skip = "video.exposure is hand-set for the display-space plate";
  }
  st.use_gains = st.gains_skip.empty() && apply_gains;
  if (st.use_gains) st.camera["gains"] = st.pl.Rel(st.fitted_gains);
  // video.refine_poses: the radiometry stage (mr-eval plate) refines each
  // fitted frame's pose against the room and the render takes its poses.
  bool refine = false;
  if (video.refine_poses && video.refine_poses->json().is_object()) {
    JsonSettings r(*video.refine_poses);
    r.Number("prior_weight", &st.prior_weight, 1e-6, 1e6);
    r.Done();
    refine = true;
  } else if (video.refine_poses) {
    refine = video.refine_poses->Bool();
  }
  if (refine) {
    if (!st.gains_skip.empty())
      video.refine_poses->Fail("refining the poses is the plate check's (mr-eval plate), which does not run here: " +
                               st.gains_skip);
    st.refined_poses = st.gains_dir / "poses.tum";
  }
}

// The video section: the scene's camera (model, frames, exposure,
// response) and the gains.
void ReadVideo(Plan& st) {
  JsonSettings vs(Need(st.r.video, st.root, "video"));
  st.video = {.frames = vs.Take("frames"),
              .frames_transfer = vs.Take("frames_transfer"),
              .exposure = vs.Take("exposure"),
              .response = vs.Take("response"),
              .gains = vs.Take("gains"),
              .poses = vs.Take("poses"),
              .refine_poses = vs.Take("refine_poses")};
  vs.Done();
  const VideoBlock& video = st.video;
  st.camera = {{"model", st.pl.Rel(st.camera_model)}};
  if (video.frames) st.camera["frames"] = st.pl.Rel(st.pl.Pattern(*video.frames, "video frames"));
  if (video.frames_transfer) st.camera["frames_transfer"] = video.frames_transfer->String();
  if (video.exposure) st.camera["exposure"] = video.exposure->json();
  if (video.response) st.camera["response"] = st.pl.Rel(st.pl.Path(*video.response, "camera response"));
  ReadGains(st);
}

// video.poses: one of a trajectory, the fused one, a COLMAP model to align,
// or registration by COLMAP, with mr-register's aligning settings.
struct PosesBlock {
  OptNode tum, fuse, colmap, register_, initial, options;
  bool refine_mesh = false;
};

// mr-register's aligning: to the fused trajectory (and, asked, refined
// against the fused mesh); with room meshes, to the meshes from a given
// start.
void AddAlignment(const Plan& st, const Node& node, const PosesBlock& ps, PipelineStage& s) {
  if (!st.fused_trajectory.empty()) {
    Append(&s.args, {"--trajectory", st.fused_trajectory.string()});
    s.inputs.push_back(st.fused_trajectory);
    if (ps.refine_mesh) {
      Append(&s.args, {"--mesh", st.fused_mesh.string()});
      s.inputs.push_back(st.fused_mesh);
    }
    return;
  }
  if (!ps.initial)
    node.Fail(
        "aligning COLMAP's poses to room meshes needs \"initial\": a rough similarity, 16 numbers "
        "(row-major [s*R t; 0 0 0 1], COLMAP's frame to the room's)");
  std::string list;
  for (double v : ps.initial->Numbers(16, -1e30, 1e30)) {
    if (!list.empty()) list += ',';
    list += fmt::format("{}", v);
  }
  Append(&s.args, {"--initial", list});
  for (const auto& r : st.scene["real"]) {
    const fs::path m = (st.w / r["mesh"].get<std::string>()).lexically_normal();
    Append(&s.args, {"--mesh", m.string()});
    s.inputs.push_back(m);
  }
}

// mr-register colmap's arguments: the frames, and video.poses.register's
// matcher settings when it is an object.
void AddColmap(const Plan& st, const Node& reg, PipelineStage& s) {
  const fs::path frames = st.pl.Pattern(*st.video.frames, "video frames");
  s.args = {"colmap",   frames.string(),         "--workspace", (st.w / "video" / "colmap").string(),
            "--camera", st.camera_model.string()};
  s.inputs = {frames.string().find('%') != std::string::npos ? frames.parent_path() : frames, st.camera_model};
  if (reg.json().is_object()) {
    JsonSettings r(reg);
    std::string matcher;
    int overlap = 0;
    r.OneOf("matcher", &matcher, {"sequential", "exhaustive"});
    r.Integer("overlap", &overlap, 1, 1000);
    r.Done();
    if (!matcher.empty()) Append(&s.args, {"--matcher", matcher});
    if (overlap) Append(&s.args, {"--overlap", std::to_string(overlap)});
  } else if (!reg.Bool()) {
    reg.Fail("expected true or {matcher, overlap}");
  }
  s.does =
      "the video's frames registered by COLMAP and aligned to the room (similarity to mr-fuse's trajectory, "
      "Ceres)";
}

void PlanRegister(Plan& st, PipelineStage& s) {
  ReadVideo(st);
  const VideoBlock& video = st.video;
  const Node& node = Need(video.poses, *st.r.video, "poses");
  JsonSettings pj(node);
  PosesBlock ps{.tum = pj.Take("tum"),
                .fuse = pj.Take("fuse"),
                .colmap = pj.Take("colmap"),
                .register_ = pj.Take("register"),
                .initial = pj.Take("initial")};
  pj.Bool("refine_mesh", &ps.refine_mesh);
  ps.options = pj.Take("options");
  pj.Done();
  const int given = ps.tum.has_value() + ps.fuse.has_value() + ps.colmap.has_value() + ps.register_.has_value();
  if (given != 1)
    node.Fail("give one of tum (a trajectory), fuse (the RGB-D recording's), colmap (a model to align) or register");
  if (ps.tum) {
    st.poses = st.pl.Path(*ps.tum, "trajectory");
    s.skip = "video.poses.tum is given: " + st.poses.string();
  } else if (ps.fuse) {
    if (st.fused_trajectory.empty()) ps.fuse->Fail("the room is not fused (room.rgbd): there is no fused trajectory");
    st.poses = st.fused_trajectory;
    s.skip = "the video is the RGB-D recording's colour: its poses are mr-fuse's trajectory";
  } else {
    st.poses = st.w / "video" / "poses.txt";
    const fs::path model_out = st.w / "video" / "colmap.cameramodel";
    if (ps.colmap) {
      const fs::path m = st.pl.Path(*ps.colmap, "COLMAP model");
      s.args = {"align", m.string()};
      s.inputs = {m};
      s.does = "the COLMAP model aligned to the room (similarity to mr-fuse's trajectory, Ceres)";
    } else {
      if (!video.frames) node.Fail("registration needs video.frames");
      AddColmap(st, *ps.register_, s);
    }
    if (st.room.planes) {  // no room yet to align to: COLMAP's frame, its points kept for the planes
      st.colmap_poses = st.poses;
      st.points = st.w / "video" / "points.ply";
      Append(&s.args, {"--points-out", st.points.string()});
      s.does = "the video's frames registered by COLMAP, its poses and points kept in COLMAP's frame for the planes";
    } else {
      AddAlignment(st, node, ps, s);
      st.observations = st.w / "video" / "observations.json";
      Append(&s.args, {"--observations-out", st.observations.string()});
    }
    Append(&s.args, {"--out", st.poses.string(), "--camera-out", model_out.string()});
    Append(&s.args, st.pl.Options(ps.options));
    s.outputs = {st.poses, model_out};
    if (!st.observations.empty()) s.outputs.push_back(st.observations);
    if (st.room.planes) {
      s.outputs.push_back(st.points);
      st.poses = st.w / "room" / "poses.txt";  // the planes stage's, scaled and turned to gravity
    }
  }
  if (st.room.planes && st.colmap_poses.empty())
    node.Fail("room.planes needs the video registered here: video.poses \"register\" or \"colmap\"");
  if (!st.poses.empty()) st.camera["poses"] = {{"format", "tum"}, {"path", st.pl.Rel(st.poses)}};
  st.scene["camera"] = st.camera;
  if (!st.refined_poses.empty()) {
    if (st.poses.empty()) video.refine_poses->Fail("refining the poses needs the video's poses (video.poses)");
    if (st.prior_weight > 0 && st.observations.empty())
      video.refine_poses->Fail(
          "prior_weight: COLMAP's points are a prior only where COLMAP registers the video here (video.poses "
          "\"register\" or \"colmap\", aligned to the room)");
    st.p->refined_poses = st.pl.Rel(st.refined_poses);
  }
}

// room.planes: the planes that COLMAP's points of the video support, in
// metres by the cameras' height over the floor (`height`), turned to
// gravity (+y up, the scene's default), albedo from the frames (mr-planes).
void PlanPlanes(Plan& st, PipelineStage& s) {
  if (!st.room.planes) {
    s.skip = "room.planes is not given";
    return;
  }
  const Node& block = *st.room.planes;
  JsonSettings ps(block);
  const auto height = ps.Take("height");
  const auto options = ps.Take("options");
  ps.Done();
  const double h = Need(height, block, "height").Number(0.01, 1000);
  const fs::path frames = st.pl.Pattern(*st.video.frames, "video frames");
  const fs::path mesh = st.w / "room" / "room.ply";
  s.args = {st.points.string(),
            "--poses",
            st.colmap_poses.string(),
            "--camera",
            st.camera_model.string(),
            "--frames",
            frames.string(),
            "--height",
            fmt::format("{}", h),
            "--world",
            "gravity",
            "--poses-out",
            st.poses.string(),
            "--out",
            mesh.string()};
  if (st.video.frames_transfer && st.video.frames_transfer->String() == "linear")
    Append(&s.args, {"--frames-transfer", "linear"});
  Append(&s.args, st.pl.Options(options));
  s.inputs = {st.points, st.colmap_poses, st.camera_model,
              frames.string().find('%') != std::string::npos ? frames.parent_path() : frames};
  s.outputs = {mesh, st.poses};
  s.does = "the room as the planes of the video's own points (RANSAC, turned to gravity, albedo from the frames)";
  st.scene["real"] = Json::array({{{"mesh", st.pl.Rel(mesh)}, {"material", {{"albedo_from_vertex_colors", true}}}}});
}

// The mirror sphere in the plate: each frame's sphere pixels unwrapped from
// the frame's pose into a map (mr-probe --sphere-in-plate), on the plate's
// own scene (its camera section alone, written first).
void PlanPlateProbe(Plan& st, PipelineStage& s) {
  if (!st.plate_sphere) {
    s.skip = "lighting.sphere_in_plate is not given";
    return;
  }
  const PlateSphereBlock& sp = *st.plate_sphere;
  const VideoBlock& video = st.video;
  if (!video.frames) st.light.sphere_in_plate->Fail("the sphere in the plate needs the plate (video.frames)");
  const Node& block = *st.light.sphere_in_plate;
  const std::vector<double> c = Need(sp.centre, block, "centre").Numbers(3, -1e6, 1e6);
  const double radius = Need(sp.radius, block, "radius").Number(1e-4, 100);
  const fs::path plate_scene = st.w / "plate.json";
  Json plate_camera = st.camera;
  if (st.use_gains) plate_camera.erase("gains");  // fitted by the radiometry stage, after this one
  s.writes_first = plate_scene;
  // The room's meshes too: a scene has geometry (mr-probe reads none of it).
  const Json reals = st.scene.contains("real") ? st.scene["real"] : Json::array({{{"mesh", st.pl.Rel(st.fused_mesh)}}});
  s.writes_first_json = {
      {"version", 1},
      {"comment",
       fmt::format("the plate and the room, for mr-probe (written by mr-pipeline from {})", st.file.string())},
      {"camera", plate_camera},
      {"real", reals}};
  s.args = {"--sphere-in-plate",
            plate_scene.string(),
            "--sphere",
            fmt::format("{},{},{},{}", c[0], c[1], c[2], radius),
            "--out",
            st.env.string()};
  if (sp.reflectance) Append(&s.args, {"--reflectance", fmt::format("{}", sp.reflectance->Number(1e-3, 1))});
  Append(&s.args, st.pl.Options(sp.options));
  const fs::path frames = st.pl.Pattern(*video.frames, "video frames");
  s.inputs = {frames.string().find('%') != std::string::npos ? frames.parent_path() : frames, st.camera_model};
  if (!st.poses.empty()) s.inputs.push_back(st.poses);
  if (video.response) s.inputs.push_back(st.pl.Path(*video.response, "camera response"));
  if (st.camera.contains("gains") && !st.use_gains) s.inputs.push_back(st.w / st.camera["gains"].get<std::string>());
  s.outputs = {st.w / "env"};
  s.does = "the mirror sphere in each plate frame unwrapped from the frame's pose into a map";
}

// lighting.lights.place: the lights that land on the room placed there
// (mr-lights --room), and the rest of the map the room's own light
// (scene.json lighting.probes): the probe's centre is the sphere in the
// plate's, in the world of the room's mesh (fused, or the one real mesh
// given).
// Returns the mesh, an input of the stage.
fs::path PlaceLights(const Plan& st, const Node& lights, PipelineStage* s) {
  if (!st.plate_sphere || !st.plate_sphere->centre)
    lights.Child("place").Fail(
        "lights are placed from the sphere in the plate (lighting.sphere_in_plate), whose centre is in the room's "
        "world; a separate probe's world is its camera's");
  if (st.light.environment_up || st.light.environment_rotation_deg)
    lights.Child("place").Fail(
        "placed lights stand in the world: the map must not be turned (environment_up, "
        "environment_rotation_deg)");
  fs::path mesh = st.fused_mesh;
  if (mesh.empty()) {
    const Json& reals = st.scene["real"];
    if (!reals.is_array() || reals.size() != 1 || !reals[0].contains("mesh"))
      lights.Child("place").Fail("lights are placed on one room mesh: give room.rgbd or a single room.real mesh");
    mesh = (st.w / reals[0]["mesh"].get<std::string>()).lexically_normal();
  }
  const Eigen::Vector3d c = st.plate_sphere->centre->Vec3(-1e9, 1e9);
  Append(&s->args, {"--method", "blobs", "--room", mesh.string(), "--probe-at",
                    fmt::format("{:.9g},{:.9g},{:.9g}", c.x(), c.y(), c.z())});
  return mesh;
}

// Lights extracted from the map (or a map per frame), and the scene's
// lighting section.
void PlanLights(Plan& st, PipelineStage& s) {
  const LightingBlock& light = st.light;
  st.lighting = {{"environment", st.pl.Rel(st.env)}};
  if (!light.lights) {
    s.skip = "lighting.lights is not asked for: the scene is lit by the environment map alone";
  } else if (light.lights->json().is_string()) {
    const fs::path l = st.pl.Pattern(*light.lights, "lights.json");  // a file, or one per frame
    st.lighting["lights"] = st.pl.Rel(l);
    s.skip = "lighting.lights is given: " + l.string();
  } else {
    const Node& l = *light.lights;
    JsonSettings ls(l);
    const OptNode options = ls.Take("options");
    bool place = false;
    ls.Bool("place", &place);
    ls.Done();
    if (IsVideoFile(st.env))
      l.Fail(
          "mr-lights extracts lights from maps, and lighting.environment is a video: give the maps as a "
          "pattern (env/%05d.exr)");
    const bool per_frame = st.env.string().find('%') != std::string::npos;
    // A map per frame: lights per frame, each keeping its name while it moves.
    const fs::path out = per_frame ? st.w / "lights" / "%05d.json" : st.w / "lights.json";
    const fs::path residual = per_frame ? st.w / "env-residual" / "%05d.exr" : st.w / "env-residual.exr";
    s.args = {st.env.string(), "--out", out.string(), "--residual", residual.string()};
    const fs::path room_mesh = place ? PlaceLights(st, l, &s) : fs::path();
    // With placed lights the residual is the sky alone; what the sphere saw
    // of the room is its own map (lighting.probes).
    const fs::path room_map = per_frame ? st.w / "env-room" / "%05d.exr" : st.w / "env-room.exr";
    if (place) Append(&s.args, {"--room-map", room_map.string()});
    Append(&s.args, st.pl.Options(options));
    s.inputs = {per_frame ? st.env.parent_path() : st.env};
    if (!room_mesh.empty()) s.inputs.push_back(room_mesh);
    s.outputs = per_frame ? std::vector<fs::path>{st.w / "lights", st.w / "env-residual"}
                          : std::vector<fs::path>{out, residual};
    if (place) s.outputs.push_back(per_frame ? room_map.parent_path() : room_map);
    s.does = per_frame ? "lights extracted from each frame's map (a light keeps its name across frames); the scene "
                         "is lit by them and each frame's residual map"
                       : "lights extracted from the map; the scene is lit by them and the residual map";
    st.lighting = {{"environment", st.pl.Rel(residual)}, {"lights", st.pl.Rel(out)}};
    if (place) {  // the rest of the map is the room's own light, seen from the sphere (lighting.probes)
      const Eigen::Vector3d c = st.plate_sphere->centre->Vec3(-1e9, 1e9);
      st.lighting["probes"] = Json::array({{{"at", {c.x(), c.y(), c.z()}}, {"map", st.pl.Rel(room_map)}}});
    }
  }
  // The map's orientation and scale: checked by the scene's parser.
  if (light.environment_up) st.lighting["environment_up"] = light.environment_up->json();
  if (light.environment_rotation_deg) st.lighting["environment_rotation_deg"] = light.environment_rotation_deg->json();
  if (light.environment_scale) st.lighting["environment_scale"] = light.environment_scale->json();
  st.scene["lighting"] = st.lighting;
}

// ---------------------------------------------------------------------------
// Virtual objects, with form factors where prt needs them; the scene.

void PlanFormfactor(Plan& st, PipelineStage& s) {
  const Json render = st.r.render ? st.r.render->json() : Json::object();
  st.method = render.value("method", "pt");
  bool uses_ffc = false;
  std::string ffc_methods;
  for (const MethodInfo& m : RenderMethodRegistry())
    if (m.uses_formfactors) {
      ffc_methods += (ffc_methods.empty() ? "" : ", ") + m.name;
      uses_ffc = uses_ffc || m.name == st.method;
    }
  const Node& v = Need(st.r.virtuals, st.root, "virtual");
  if (!v.json().is_array()) v.Fail("expected a list of virtual objects");
  const auto opts = st.pl.Options(st.r.formfactor);
  for (size_t i = 0; i < v.json().size(); ++i) {
    const Node o = v.Index(i);
    if (o.Has("light")) {  // a virtual light: passed through
      st.virtuals.push_back(o.json());
      continue;
    }
    Json e = Rebase(st.pl, o, {"mesh", "formfactors"});
    if (o.Has("material"))  // its texture, like the mesh, relative to the work folder
      e["material"] = Rebase(st.pl, o.Child("material"), {"albedo_texture"});
    // "formfactors": a file (named), true (asked for) or false; checked by the scene's parser.
    const Json ffc_value = o.json().value("formfactors", Json());
    const bool named_ffc = ffc_value.is_string();
    const bool asked_ffc = ffc_value.is_boolean() && ffc_value.get<bool>();
    const bool wants = uses_ffc ? !named_ffc : asked_ffc;
    if (ffc_value.is_boolean() && !asked_ffc) e.erase("formfactors");
    if (wants) {
      if (!s.args.empty()) o.Fail("form factors for more than one object: give each its own ffc file");
      const fs::path mesh = st.pl.Path(o.Required("mesh"), "mesh");
      const std::string nm = o.Has("name") ? o.Child("name").String() : fmt::format("object{}", i);
      const fs::path ffc = st.w / (nm + ".ffc");
      s.args = {mesh.string(), "--out", ffc.string()};
      Append(&s.args, opts);
      s.inputs = {mesh};
      s.outputs = {ffc};
      s.does = fmt::format("per-vertex form factors of {}", nm);
      e["formfactors"] = st.pl.Rel(ffc);
    }
    st.virtuals.push_back(e);
  }
  if (s.args.empty())
    s.skip = uses_ffc ? "every virtual object names its form factors"
                      : fmt::format("render.method is {}: form factors are only used by {}", st.method, ffc_methods);
  st.scene["virtual"] = st.virtuals;
  st.scene["render"] = render;
  // A fused room's facets are rough at the scale of its voxels, and ic's
  // records crowd there: to their lower clamp (spaced by 8 px they give the
  // same error in a third of the time) and to its normals' noise (a 90-degree
  // normal term gives 3% more error in 40% less time; docs/methods.md, "On a
  // reconstructed room").  Each of the user's own settings stands.
  Json& ic = st.scene["render"]["ic"];
  std::vector<std::string> set;
  if (!st.fused_mesh.empty() && !ic.contains("min_spacing_px")) {
    ic["min_spacing_px"] = kFusedRoomIcSpacingPx;
    set.push_back(fmt::format("spaced by {} px or more", kFusedRoomIcSpacingPx));
  }
  if (!st.fused_mesh.empty() && !ic.contains("normal_deg")) {
    ic["normal_deg"] = kFusedRoomIcNormalDeg;
    set.push_back(fmt::format("with a {}-degree normal term", kFusedRoomIcNormalDeg));
  }
  if (st.method == "ic" && !set.empty())
    st.ic_records_note =
        fmt::format(", its records {} on the fused room", set.size() == 2 ? set[0] + " and " + set[1] : set[0]);
  if (ic.empty()) st.scene["render"].erase("ic");
  Json output = st.r.output ? st.r.output->json() : Json::object();
  output["dir"] = "render";
  st.scene["output"] = output;
  if (st.r.reference) st.scene["reference"] = st.pl.Rel(st.pl.Pattern(*st.r.reference, "reference frames"));
  st.scene["comment"] = fmt::format("written by mr-pipeline from {}", st.file.string());
}

// scene.json, written by mr-pipeline itself (RunPipeline), checked now as
// mr-render would check it (files that stages make need not exist yet).
void PlanScene(Plan& st, PipelineStage& s) {
  st.scene_file = st.w / "scene.json";
  s.inputs = {st.file, st.camera_model, st.env};
  if (st.lighting.contains("lights")) s.inputs.push_back(st.w / st.lighting["lights"].get<std::string>());
  if (!st.fused_mesh.empty()) s.inputs.push_back(st.fused_mesh);
  if (!st.poses.empty()) s.inputs.push_back(st.poses);
  for (const auto& v : st.virtuals)
    if (v.contains("formfactors")) s.inputs.push_back(st.w / v["formfactors"].get<std::string>());
  s.outputs = {st.scene_file, st.w / "scene-plate.json"};
  s.does = st.fused_mesh.empty() ? "scene.json naming every input"
                                 : "scene.json naming every input (the fused room's per-vertex albedo)";
  if (!st.fused_mesh.empty()) {
    // The albedo is the fused mesh's mean, filled in when the scene stage runs.
    st.scene["real"] = Json::array({{{"mesh", st.pl.Rel(st.fused_mesh)}, {"material", {{"albedo", {0.5, 0.5, 0.5}}}}}});
    st.p->fused_room = st.fused_mesh;
  }
  CheckRenderSettings(ParseScene(st.scene, st.w, (st.w / "scene.json").string(), false));
  for (const char* k : {"environment", "lights"})
    if (st.lighting.contains(k) && st.lighting[k].get<std::string>().find('%') != std::string::npos)
      st.per_frame.push_back((st.w / st.lighting[k].get<std::string>()).lexically_normal().parent_path());
  st.outputs = st.r.outputs ? st.r.outputs->json() : Json{{"render", true}};
  JsonSettings os(Node(st.outputs, "outputs", &st.name));
  st.outs = {.render = os.Take("render"), .sweep = os.Take("sweep")};
  os.Done();
}

// ---------------------------------------------------------------------------
// What is made from the scene: the plate's gains, the render, the sweep.

void PlanRadiometry(Plan& st, PipelineStage& s) {
  if (!st.gains_skip.empty()) {
    s.skip = st.gains_skip;
    return;
  }
  // scene-plate.json: the scene without what the plate check does not read
  // (written beside scene.json by the scene stage).
  const fs::path plate_scene = st.w / "scene-plate.json";
  s.args = {"plate", plate_scene.string(), "--out", st.gains_dir.string()};
  if (!st.refined_poses.empty()) Append(&s.args, {"--refine-poses", st.refined_poses.string()});
  if (st.prior_weight > 0)
    Append(&s.args, {"--prior-points", st.observations.string(), "--prior-weight", fmt::format("{}", st.prior_weight)});
  Append(&s.args, st.gains_options);
  s.inputs = {plate_scene};
  if (st.prior_weight > 0) s.inputs.push_back(st.observations);
  Append(&s.inputs, st.per_frame);
  s.outputs = {st.gains_dir};
  s.does = st.use_gains
               ? "the plate's gains fitted against the rendered room, and the capture chain's re-rendering error"
               : "the capture chain's re-rendering error and the plate's gains, as a check (a linear plate "
                 "is not rescaled: video.gains {\"apply\": true} applies them)";
}

void PlanRender(Plan& st, PipelineStage& s) {
  if (st.outs.render && !st.outs.render->Bool()) {
    s.skip = "outputs.render is false";
    return;
  }
  // --resume: the frames whose inputs (by content) and settings are those of
  // an earlier run are kept, from the first frame to the first changed.
  s.args = {st.scene_file.string(), "--out", (st.w / "render").string(), "--resume"};
  s.inputs = {st.scene_file};
  Append(&s.inputs, st.per_frame);
  if (st.use_gains) s.inputs.push_back(st.fitted_gains);
  if (!st.refined_poses.empty()) s.inputs.push_back(st.refined_poses);
  s.outputs = {st.w / "render"};
  s.does =
      fmt::format("the virtual objects rendered into every frame ({}) and composited{}", st.method, st.ic_records_note);
}

void PlanSweep(Plan& st, PipelineStage& s) {
  if (!st.outs.sweep) {
    s.skip = "outputs.sweep is not asked for";
    return;
  }
  if (!st.r.reference) {
    s.skip = "no reference frames (reference): there is nothing to measure error against";
    return;
  }
  const Node& sw = *st.outs.sweep;
  if (sw.json().is_boolean() && !sw.Bool()) {
    s.skip = "outputs.sweep is false";
    return;
  }
  s.args = {"sweep", st.scene_file.string(), "--out", (st.w / "sweep").string()};
  if (sw.json().is_object()) {
    JsonSettings ss(sw);
    const OptNode options = ss.Take("options");
    ss.Done();
    Append(&s.args, st.pl.Options(options));
  }
  s.inputs = {st.scene_file};
  Append(&s.inputs, st.per_frame);
  if (st.use_gains) s.inputs.push_back(st.fitted_gains);
  s.outputs = {st.w / "sweep"};
  s.does = "error against run time of the rendering methods against the reference";
}

// ---------------------------------------------------------------------------
// The stages, in the order they run: the name (pipeline.json, --until,
// --force, the report), the tool (empty: mr-pipeline itself) and the plan
// function.  Adding a stage is one function above and one line here.

struct StageDef {
  const char* name;
  const char* tool;
  void (*plan)(Plan&, PipelineStage&);
};

const std::vector<StageDef>& Stages() {
  static const std::vector<StageDef> stages = {
      {"calibrate", "mr-calibrate", PlanCalibrate},
      {"sphere", "mr-calibrate", PlanSphere},
      {"hdr", "mr-hdr", PlanHdr},
      {"probe", "mr-probe", PlanProbe},
      {"fuse", "mr-fuse", PlanFuse},
      {"register", "mr-register", PlanRegister},
      {"planes", "mr-planes", PlanPlanes},
      {"plate_probe", "mr-probe", PlanPlateProbe},
      {"lights", "mr-lights", PlanLights},
      {"formfactor", "mr-formfactor", PlanFormfactor},
      {"scene", "", PlanScene},
      {"radiometry", "mr-eval", PlanRadiometry},
      {"render", "mr-render", PlanRender},
      {"sweep", "mr-eval", PlanSweep},
  };
  return stages;
}

}  // namespace

const std::vector<std::string>& PipelineStageNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const StageDef& d : Stages()) n.push_back(d.name);
    return n;
  }();
  return names;
}

Pipeline PlanPipeline(const fs::path& file) {
  Pipeline p;
  p.file = file;
  p.base = file.parent_path().empty() ? fs::path(".") : file.parent_path();
  p.base = fs::absolute(p.base).lexically_normal();
  // ParseJsonStrict: every JSON error (a number too large for a double too,
  // found by fuzz/fuzz_pipeline) as one mr::Error naming the file.
  p.json = ReadJsonFile(file);
  Plan st(&p, file);
  st.r = ReadRoot(st.root);
  if (Need(st.r.version, st.root, "version").Integer(1, 1) != 1) st.root.Fail("version must be 1");
  p.work = (p.base / (st.r.work ? st.r.work->String() : std::string("work"))).lexically_normal();
  st.w = p.work;
  for (const StageDef& d : Stages()) {
    p.stages.push_back({});
    PipelineStage& s = p.stages.back();
    s.name = d.name;
    s.tool = d.tool;
    s.report = p.work / "reports" / (s.name + ".json");
    d.plan(st, s);
  }
  p.scene = st.scene;
  return p;
}

}  // namespace mr
