#include "scene/scene.h"

#include <algorithm>
#include <set>

#include "core/error.h"
#include "core/json_node.h"
#include "core/math.h"
#include "core/video.h"
#include "scene/frames.h"

namespace mr {

const std::vector<std::string>& OutputLayers() {
  static const std::vector<std::string> l = {"composite",  "mixed",    "real",    "mask",
                                             "difference", "variance", "samples", "photo"};
  return l;
}

namespace {

using Node = JsonNode;

constexpr double kHuge = 1e30;

fs::path ResolveFile(const Node& n, const fs::path& base, bool check, const char* what) {
  fs::path p = n.String();
  if (p.empty()) n.Fail("empty path");
  if (p.is_relative()) p = base / p;
  if (check) {
    std::error_code ec;
    if (!fs::exists(p, ec)) n.Fail(fmt::format("{} {} does not exist", what, p.string()));
  }
  return p;
}

Material ParseMaterial(const Node& n, const fs::path& base, bool check) {
  n.RequireObject({"albedo", "specular", "roughness", "emission", "albedo_from_vertex_colors", "albedo_texture"});
  Material m;
  if (n.Has("albedo")) m.albedo = n.Child("albedo").Vec3(0, 1);
  if (n.Has("specular")) m.specular = n.Child("specular").Vec3(0, 1);
  if (n.Has("roughness")) m.roughness = n.Child("roughness").Number(1e-3, 1);
  if (n.Has("emission")) m.emission = n.Child("emission").Vec3(0, kHuge);
  if (n.Has("albedo_from_vertex_colors")) m.albedo_from_vertex_colors = n.Child("albedo_from_vertex_colors").Bool();
  if (n.Has("albedo_texture")) {
    m.albedo_texture = ResolveFile(n.Child("albedo_texture"), base, check, "albedo texture");
    if (m.albedo_from_vertex_colors)
      n.Child("albedo_texture").Fail("give albedo_from_vertex_colors or albedo_texture, not both");
  }
  for (int c = 0; c < 3; ++c)
    if (m.albedo[c] + m.specular[c] > 1.0)
      n.Fail(fmt::format("albedo + specular is {:.4g} in channel {}: a surface cannot reflect more than it receives",
                         m.albedo[c] + m.specular[c], c));
  return m;
}

Eigen::Affine3d ParseTransform(const Node& n) {
  n.RequireObject({"matrix", "translation", "rotation_deg", "scale"});
  if (n.Has("matrix")) {
    if (n.Has("translation") || n.Has("rotation_deg") || n.Has("scale"))
      n.Fail("give either matrix or translation/rotation_deg/scale, not both");
    Node m = n.Child("matrix");
    auto v = m.Numbers(16, -kHuge, kHuge);
    Eigen::Matrix4d mat = Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(v.data());
    if ((mat.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-12)
      m.Fail("last row of a 4x4 affine matrix must be 0 0 0 1");
    if (std::abs(mat.topLeftCorner<3, 3>().determinant()) < 1e-12) m.Fail("matrix is singular");
    Eigen::Affine3d a;
    a.matrix() = mat;
    return a;
  }
  Eigen::Affine3d a = Eigen::Affine3d::Identity();
  if (n.Has("translation")) a.translate(n.Child("translation").Vec3(-kHuge, kHuge));
  if (n.Has("rotation_deg")) {
    // Rotations about the world x, then y, then z axes: R = Rz * Ry * Rx.
    Eigen::Vector3d r = n.Child("rotation_deg").Vec3(-360, 360) * kDegToRad;
    a.rotate(Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
             Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()));
  }
  if (n.Has("scale")) {
    Node s = n.Child("scale");
    if (s.json().is_number())
      a.scale(s.Number(1e-9, kHuge));
    else
      a.scale(s.Vec3(1e-9, kHuge));
  }
  return a;
}

bool IsFramePattern(const std::string& s) { return s.find('%') != std::string::npos; }

// A printf pattern with exactly one %d-style conversion ("frames/%05d.png");
// checks only that its folder exists.
// A trajectory: keyframes {frame, translation, rotation_deg, scale}, frames
// strictly increasing.  A matrix cannot be interpolated (refused).
std::vector<ObjectKeyframe> ParseTrajectory(const Node& n) {
  if (!n.json().is_array() || n.json().empty())
    n.Fail(fmt::format("expected an array of keyframes {{frame, translation, rotation_deg, scale}}, got {}",
                       n.TypeName()));
  std::vector<ObjectKeyframe> out;
  for (size_t i = 0; i < n.json().size(); ++i) {
    const Node k = n.Index(i);
    if (k.json().is_object() && k.json().contains("matrix"))
      k.Child("matrix").Fail("a keyframe takes translation, rotation_deg and scale: a matrix cannot be interpolated");
    k.RequireObject({"frame", "translation", "rotation_deg", "scale"});
    ObjectKeyframe f;
    f.frame = k.Required("frame").Number(0, 1e9);
    if (!out.empty() && !(f.frame > out.back().frame))
      k.Child("frame").Fail(
          fmt::format("keyframes must be in increasing frame order: {} after {}", f.frame, out.back().frame));
    if (k.Has("translation")) f.translation = k.Child("translation").Vec3(-kHuge, kHuge);
    if (k.Has("rotation_deg")) {
      const Eigen::Vector3d r = k.Child("rotation_deg").Vec3(-360, 360) * kDegToRad;
      f.rotation = Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX());
    }
    if (k.Has("scale")) {
      const Node sc = k.Child("scale");
      f.scale = sc.json().is_number() ? Eigen::Vector3d::Constant(sc.Number(0, kHuge)) : sc.Vec3(0, kHuge);
    }
    out.push_back(f);
  }
  return out;
}

fs::path ResolvePattern(const Node& n, const fs::path& base, bool check) {
  const std::string v = n.String();
  int conversions = 0;
  for (size_t i = 0; i + 1 < v.size(); ++i)
    if (v[i] == '%') {
      if (v[i + 1] == '%') {
        ++i;
        continue;
      }
      size_t k = i + 1;
      while (k < v.size() && std::isdigit(static_cast<unsigned char>(v[k]))) ++k;
      if (k >= v.size() || v[k] != 'd') n.Fail("frame pattern must use one %d-style conversion, e.g. frames/%05d.png");
      ++conversions;
    }
  if (conversions != 1) n.Fail("frame pattern must use exactly one %d-style conversion");
  fs::path p = v;
  if (p.is_relative()) p = base / p;
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  if (check && !fs::is_directory(dir)) n.Fail(fmt::format("frame folder {} does not exist", dir.string()));
  return p;
}

}  // namespace

namespace {

// camera: the model, the plate and its decoding, the gains, shutter, lens, poses.
void ParseCamera(const Node& cam, const fs::path& base, bool check, SceneCamera* out) {
  SceneCamera& c = *out;
  cam.RequireObject({"model", "frames", "frames_transfer", "exposure", "response", "gains", "gains_scale", "poses",
                     "shutter", "lens"});
  c.model = ResolveFile(cam.Required("model"), base, check, "camera model");
  if (cam.Has("frames")) {
    Node f = cam.Child("frames");
    std::string v = f.String();
    if (IsFramePattern(v)) {
      c.frames = ResolvePattern(f, base, check);
    } else {
      c.frames = ResolveFile(f, base, check, "video");
      c.frames_are_video = true;
    }
  }
  if (cam.Has("frames_transfer"))
    c.frames_transfer = cam.Child("frames_transfer").OneOf({"srgb", "linear", "display", "response"});
  if (cam.Has("response")) c.response = ResolveFile(cam.Child("response"), base, check, "camera response");
  if ((c.frames_transfer == "response") != c.response.has_value())
    (cam.Has("response") ? cam.Child("response") : cam.Child("frames_transfer"))
        .Fail("frames_transfer \"response\" and a response file go together");
  if (cam.Has("exposure")) c.exposure = cam.Child("exposure").Number(1e-12, 1e12);
  c.gains_scale = "render";
  if (cam.Has("gains_scale")) c.gains_scale = cam.Child("gains_scale").OneOf({"render", "room"});
  if (cam.Has("shutter")) c.shutter = cam.Child("shutter").Number(0, 1);
  if (cam.Has("lens")) {
    const Node lens = cam.Child("lens");
    lens.RequireObject({"aperture_radius", "focus_distance"});
    c.aperture_radius = lens.Required("aperture_radius").Number(0, 10);
    c.focus_distance = lens.Required("focus_distance").Number(1e-3, 1e9);
  }
  if (cam.Has("gains")) {
    // Not checked here: mr-pipeline's scene names the gains its radiometry
    // stage is yet to fit (mr-render's FrameDecoding reads and checks them).
    c.gains = ResolveFile(cam.Child("gains"), base, false, "plate gains");
    if (!cam.Has("frames")) cam.Child("gains").Fail("plate gains need a plate: camera.frames is not given");
    if (c.frames_transfer == "display" && cam.Has("exposure"))
      cam.Child("exposure")
          .Fail("with camera.gains the gains scale the render in \"display\" mode: give one of the two");
  }
  if (cam.Has("poses")) {
    Node p = cam.Child("poses");
    p.RequireObject({"format", "path"});
    std::string fmt_name = p.Required("format").OneOf({"tum", "7scenes", "colmap"});
    c.pose_format = fmt_name == "tum"       ? PoseFormat::kTum
                    : fmt_name == "7scenes" ? PoseFormat::k7Scenes
                                            : PoseFormat::kColmap;
    c.poses = ResolveFile(p.Required("path"), base, check, "poses");
  }
}

// lighting: the environment (a file, a pattern or a video), its scale and
// orientation, the lights.
void ParseLighting(const Node& l, const fs::path& base, bool check, SceneLighting* out) {
  SceneLighting& lighting = *out;
  l.RequireObject({"environment", "environment_scale", "environment_rotation_deg", "environment_up", "lights"});
  // A file, or a printf pattern of one per frame.
  auto file_or_pattern = [&](const char* key, const char* what, std::optional<fs::path>* path, bool* per_frame) {
    if (!l.Has(key)) return;
    const Node n = l.Child(key);
    *per_frame = IsFramePattern(n.String());
    *path = *per_frame ? ResolvePattern(n, base, check) : ResolveFile(n, base, check, what);
  };
  file_or_pattern("environment", "environment map", &lighting.environment, &lighting.environment_per_frame);
  lighting.environment_video =
      lighting.environment && !lighting.environment_per_frame && IsVideoFile(*lighting.environment);
  if (l.Has("environment_scale")) lighting.environment_scale = l.Child("environment_scale").Number(0, kHuge);
  if (l.Has("environment_rotation_deg")) {
    double yaw = l.Child("environment_rotation_deg").Number(-360, 360) * kDegToRad;
    lighting.world_from_env = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  }
  if (l.Has("environment_up")) {
    // The world direction of the map's zenith (+y): for rooms whose frame
    // is not +y up (a reconstruction in its first camera's frame).
    const Eigen::Vector3d up = l.Child("environment_up").Vec3(-kHuge, kHuge);
    if (!(up.norm() > 1e-9)) l.Child("environment_up").Fail("a zero vector has no direction");
    lighting.world_from_env =
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitY(), up.normalized()).toRotationMatrix() *
        lighting.world_from_env;
  }
  file_or_pattern("lights", "lights file", &lighting.lights, &lighting.lights_per_frame);
}

// real: one {mesh, material} or a list of them (a room whose parts differ in material).
void ParseReals(const Node& node, const fs::path& base, bool check, std::vector<SceneReal>* reals) {
  auto parse_real = [&](const Node& r) {
    r.RequireObject({"mesh", "material"});
    SceneReal real;
    real.mesh = ResolveFile(r.Required("mesh"), base, check, "mesh");
    if (r.Has("material")) real.material = ParseMaterial(r.Child("material"), base, check);
    reals->push_back(real);
  };
  if (node.json().is_array()) {
    if (node.json().empty()) node.Fail("expected at least one {mesh, material}");
    for (size_t i = 0; i < node.json().size(); ++i) parse_real(node.Index(i));
  } else {
    parse_real(node);
  }
}

// virtual: objects and virtual lights, their names unique.
void ParseVirtuals(const Node& v, const fs::path& base, bool check, Scene* out) {
  Scene& s = *out;
  if (!v.json().is_array()) v.Fail(fmt::format("expected an array of objects, got {}", v.TypeName()));
  std::set<std::string> names;
  for (size_t i = 0; i < v.json().size(); ++i) {
    Node o = v.Index(i);
    if (o.json().is_object() && o.json().contains("light")) {
      // A virtual light: a lights.json light in its own frame, posed.
      o.RequireObject({"name", "light", "transform", "trajectory"});
      SceneVirtualLight vl;
      vl.light = ParseLight(o.Child("light"), fmt::format("light{}", i));
      vl.light.is_virtual = true;
      vl.name = o.Has("name") ? o.Child("name").String() : vl.light.name;
      vl.light.name = vl.name;
      if (!names.insert(vl.name).second) o.Fail(fmt::format("name \"{}\" is used twice", vl.name));
      if (o.Has("transform") && o.Has("trajectory"))
        o.Child("trajectory").Fail("give either transform or trajectory, not both");
      if (o.Has("transform")) vl.world_from_object = ParseTransform(o.Child("transform"));
      if (o.Has("trajectory")) vl.keyframes = ParseTrajectory(o.Child("trajectory"));
      vl.world_from_object =
          PoseAt(vl.keyframes, vl.world_from_object, vl.keyframes.empty() ? 0 : vl.keyframes.front().frame);
      s.virtual_lights.push_back(vl);
      continue;
    }
    o.RequireObject({"name", "mesh", "transform", "trajectory", "material", "formfactors"});
    SceneVirtual sv;
    sv.name = o.Has("name") ? o.Child("name").String() : fmt::format("object{}", i);
    if (!names.insert(sv.name).second) o.Child("name").Fail(fmt::format("name \"{}\" is used twice", sv.name));
    sv.mesh = ResolveFile(o.Required("mesh"), base, check, "mesh");
    if (o.Has("transform") && o.Has("trajectory"))
      o.Child("trajectory").Fail("give either transform or trajectory, not both");
    if (o.Has("transform")) sv.world_from_object = ParseTransform(o.Child("transform"));
    if (o.Has("trajectory")) {
      sv.keyframes = ParseTrajectory(o.Child("trajectory"));
      sv.world_from_object = sv.WorldFromObjectAt(sv.keyframes.front().frame);
    }
    if (o.Has("material")) sv.material = ParseMaterial(o.Child("material"), base, check);
    if (o.Has("formfactors")) sv.formfactors = ResolveFile(o.Child("formfactors"), base, check, "form factors");
    s.virtuals.push_back(sv);
  }
}

// render: the generic settings; any other key holding an object is a
// method's block (render.vpl, ...), kept as written for the method to parse.
void ParseRender(const Node& r, SceneRender* out) {
  SceneRender& render = *out;
  static const std::initializer_list<const char*> generic = {
      "method",       "spp",           "max_depth",        "seed",
      "frames",       "time_budget_s", "plate_neighbours", "plate_neighbour_step",
      "world_update", "adaptive"};
  if (!r.json().is_object()) r.Fail(fmt::format("expected an object, got {}", r.TypeName()));
  for (auto& [k, v] : r.json().items()) {
    bool known = false;
    for (const char* g : generic) known = known || k == g;
    if (known) continue;
    if (!v.is_object()) {
      std::string list;
      for (const char* g : generic) list += (list.empty() ? "" : ", ") + std::string(g);
      r.Child(k).Fail(fmt::format("unknown key (allowed here: {}, or a method's settings object)", list));
    }
    render.method_settings[k] = v;
  }
  if (r.Has("method")) render.method = r.Child("method").String();
  if (r.Has("spp")) render.spp = static_cast<int>(r.Child("spp").Integer(1, 1 << 24));
  if (r.Has("max_depth")) render.max_depth = static_cast<int>(r.Child("max_depth").Integer(0, 1000));
  if (r.Has("seed")) render.seed = static_cast<uint64_t>(r.Child("seed").Integer(0, INT64_MAX));
  if (r.Has("frames")) {
    const Node f = r.Child("frames");
    const std::string v = f.String();
    std::string why;
    if (!ParseFrameRange(v, &render.frame_begin, &render.frame_end, &why)) f.Fail(why);
  }
  if (r.Has("time_budget_s")) render.time_budget_s = r.Child("time_budget_s").Number(0, 1e9);
  if (r.Has("adaptive")) {
    const Node a = r.Child("adaptive");
    a.RequireObject({"threshold", "min_spp"});
    if (a.Has("threshold")) render.adaptive_threshold = a.Child("threshold").Number(0, 1);
    if (a.Has("min_spp")) render.adaptive_min_spp = static_cast<int>(a.Child("min_spp").Integer(2, 1 << 24));
  }
  if (r.Has("plate_neighbours")) render.plate_neighbours = static_cast<int>(r.Child("plate_neighbours").Integer(0, 16));
  if (r.Has("world_update")) render.world_update = r.Child("world_update").OneOf({"incremental", "rebuild"});
  if (r.Has("plate_neighbour_step"))
    render.plate_neighbour_step = static_cast<int>(r.Child("plate_neighbour_step").Integer(1, 100000));
}

// output: the folder (default `out` beside the scene), formats and layers.
void ParseOutput(const Node& o, const fs::path& base, SceneOutput* out) {
  SceneOutput& output = *out;
  o.RequireObject({"dir", "png", "half", "video", "review", "grain", "layers"});
  if (o.Has("dir")) {
    fs::path d = o.Child("dir").String();
    output.dir = d.is_relative() ? base / d : d;
  } else {
    output.dir = base / "out";
  }
  if (o.Has("png")) output.png = o.Child("png").Bool();
  if (o.Has("half")) output.half = o.Child("half").Bool();
  if (o.Has("video")) output.video = o.Child("video").OneOf({"mp4", "mkv", "none"});
  if (o.Has("review")) output.review = o.Child("review").Bool();
  if (o.Has("grain")) output.grain = o.Child("grain").OneOf({"auto", "on", "off"});
  if (o.Has("layers")) {
    Node l = o.Child("layers");
    if (!l.json().is_array() || l.json().empty()) l.Fail("expected a non-empty array of layer names");
    output.layers.clear();
    for (size_t i = 0; i < l.json().size(); ++i) output.layers.push_back(l.Index(i).OneOf(OutputLayers()));
    if (std::find(output.layers.begin(), output.layers.end(), "composite") == output.layers.end())
      l.Fail("must include \"composite\", the render's result");
  }
}

}  // namespace

Scene ParseScene(const Json& j, const fs::path& base, const std::string& name, bool check) {
  Node root(j, "", &name);
  root.RequireObject({"version", "camera", "lighting", "real", "virtual", "render", "output", "reference", "comment"});
  Scene s;
  s.file = name;
  int64_t version = root.Required("version").Integer(1, 1000);
  if (version != kSceneVersion)
    root.Child("version").Fail(
        fmt::format("this mr reads scene version {}, the file is version {}", kSceneVersion, version));
  if (root.Has("comment")) root.Child("comment").String();

  ParseCamera(root.Required("camera"), base, check, &s.camera);
  if (root.Has("lighting")) ParseLighting(root.Child("lighting"), base, check, &s.lighting);
  if (root.Has("real")) ParseReals(root.Child("real"), base, check, &s.reals);
  if (root.Has("virtual")) ParseVirtuals(root.Child("virtual"), base, check, &s);
  if (root.Has("render")) ParseRender(root.Child("render"), &s.render);
  if (root.Has("output"))
    ParseOutput(root.Child("output"), base, &s.output);
  else
    s.output.dir = base / "out";

  if (root.Has("reference")) {
    Node r = root.Child("reference");
    s.reference =
        IsFramePattern(r.String()) ? ResolvePattern(r, base, check) : ResolveFile(r, base, check, "reference");
  }
  if (s.reals.empty() && s.virtuals.empty()) root.Fail("the scene has neither real nor virtual geometry");
  return s;
}

Scene ReadScene(const fs::path& path, bool check_files) {
  Json j = ReadJsonFile(path);
  fs::path base = path.parent_path();
  if (base.empty()) base = ".";
  return ParseScene(j, base, path.string(), check_files);
}

Eigen::Affine3d SceneVirtual::WorldFromObjectAt(double frame) const {
  return PoseAt(keyframes, world_from_object, frame);
}

Light SceneVirtualLight::At(double frame) const {
  const Eigen::Affine3d t = PoseAt(keyframes, world_from_object, frame);
  Light l = light;
  l.position = t * light.position;
  const Eigen::Vector3d d = t.rotation() * light.direction;
  if (d.norm() > 0) l.direction = d.normalized();
  return l;
}

Eigen::Affine3d PoseAt(const std::vector<ObjectKeyframe>& keyframes, const Eigen::Affine3d& fixed, double frame) {
  if (keyframes.empty()) return fixed;
  auto make = [](const Eigen::Vector3d& t, const Eigen::Quaterniond& r, const Eigen::Vector3d& s) {
    Eigen::Affine3d a = Eigen::Affine3d::Identity();
    a.translate(t);
    a.rotate(r.normalized());
    a.scale(s);
    return a;
  };
  const ObjectKeyframe* a = &keyframes.front();
  if (frame <= a->frame) return make(a->translation, a->rotation, a->scale);
  for (size_t i = 1; i < keyframes.size(); ++i) {
    const ObjectKeyframe& b = keyframes[i];
    if (frame < b.frame) {
      const double t = (frame - a->frame) / (b.frame - a->frame);
      return make((1 - t) * a->translation + t * b.translation, a->rotation.slerp(t, b.rotation),
                  (1 - t) * a->scale + t * b.scale);
    }
    a = &b;
  }
  return make(a->translation, a->rotation, a->scale);
}

}  // namespace mr
