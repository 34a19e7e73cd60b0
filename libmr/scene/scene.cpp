#include "scene/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <set>

#include "camera/camera_model.h"
#include "core/error.h"
#include "core/json_node.h"
#include "core/json_settings.h"
#include "core/math.h"
#include "core/video.h"
#include "geometry/mesh.h"
#include "scene/frames.h"

namespace mr {

const std::vector<std::string>& OutputLayers() {
  static const std::vector<std::string> l = {"composite", "mixed",   "real",  "mask",   "difference",
                                             "variance",  "samples", "photo", "objects"};
  return l;
}

namespace {

// A glTF asset (geometry/asset.h; scene's layer does not read it).
bool IsAssetPath(const fs::path& p) {
  const std::string e = LowerExtension(p);
  return e == ".gltf" || e == ".glb";
}

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
  JsonSettings s(n);
  Material m;
  if (const auto v = s.Take("albedo")) m.albedo = v->Vec3(0, 1);
  if (const auto v = s.Take("specular")) m.specular = v->Vec3(0, 1);
  s.Number("roughness", &m.roughness, 1e-3, 1);
  if (const auto v = s.Take("emission")) m.emission = v->Vec3(0, kHuge);
  s.Bool("albedo_from_vertex_colors", &m.albedo_from_vertex_colors);
  s.Choice("normals", &m.normals,
           {{"geometric", Material::Normals::kGeometric}, {"vertex", Material::Normals::kVertex}});
  const auto texture = s.Take("albedo_texture");
  s.Done();
  if (texture) {
    m.albedo_texture = ResolveFile(*texture, base, check, "albedo texture");
    if (m.albedo_from_vertex_colors) texture->Fail("give albedo_from_vertex_colors or albedo_texture, not both");
  }
  for (int c = 0; c < 3; ++c)
    if (m.albedo[c] + m.specular[c] > 1.0)
      n.Fail(fmt::format("albedo + specular is {:.4g} in channel {}: a surface cannot reflect more than it receives",
                         m.albedo[c] + m.specular[c], c));
  return m;
}

// A scale: one number (uniform) or three.
Eigen::Vector3d ParseScale(const Node& n, double lo) {
  if (n.json().is_number()) return Eigen::Vector3d::Constant(n.Number(lo, kHuge));
  if (!n.json().is_array())
    n.Fail(fmt::format("expected a number (a uniform scale) or 3 numbers [sx, sy, sz], got {}", n.TypeName()));
  return n.Vec3(lo, kHuge);
}

// `rest_on` and `at_pixel`, when the block has one, receive its node (the
// placement is resolved against the real meshes by RestOnTheRoom).
Eigen::Affine3d ParseTransform(const Node& n, std::optional<Node>* rest_on = nullptr,
                               std::optional<Node>* at_pixel = nullptr) {
  JsonSettings s(n);
  const auto matrix = s.Take("matrix");
  const auto translation = s.Take("translation");
  const auto rotation = s.Take("rotation_deg");
  const auto scale = s.Take("scale");
  const auto rest = rest_on ? s.Take("rest_on") : std::nullopt;
  const auto pixel = at_pixel ? s.Take("at_pixel") : std::nullopt;
  s.Done();
  if (rest && pixel) pixel->Fail("give either rest_on or at_pixel, not both");
  if (rest) {
    if (matrix || translation) rest->Fail("give either rest_on or translation/matrix, not both");
    rest->Vec3(-kHuge, kHuge);
    *rest_on = *rest;
  }
  if (pixel) {
    if (matrix || translation) pixel->Fail("give either at_pixel or translation/matrix, not both");
    *at_pixel = *pixel;
  }
  if (matrix) {
    if (translation || rotation || scale) n.Fail("give either matrix or translation/rotation_deg/scale, not both");
    auto v = matrix->Numbers(16, -kHuge, kHuge);
    Eigen::Matrix4d mat = Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(v.data());
    if ((mat.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-12)
      matrix->Fail("last row of a 4x4 affine matrix must be 0 0 0 1");
    if (std::abs(mat.topLeftCorner<3, 3>().determinant()) < 1e-12) matrix->Fail("matrix is singular");
    Eigen::Affine3d a;
    a.matrix() = mat;
    return a;
  }
  Eigen::Affine3d a = Eigen::Affine3d::Identity();
  if (translation) a.translate(translation->Vec3(-kHuge, kHuge));
  if (rotation) {
    // Rotations about the world x, then y, then z axes: R = Rz * Ry * Rx.
    Eigen::Vector3d r = rotation->Vec3(-360, 360) * kDegToRad;
    a.rotate(Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
             Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()));
  }
  if (scale) a.scale(ParseScale(*scale, 1e-9));
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
    JsonSettings ks(k);
    const JsonNode frame = ks.Require("frame");
    const auto translation = ks.Take("translation");
    const auto rotation = ks.Take("rotation_deg");
    const auto scale = ks.Take("scale");
    ks.Done();
    ObjectKeyframe f;
    f.frame = frame.Number(0, 1e9);
    if (!out.empty() && !(f.frame > out.back().frame))
      frame.Fail(fmt::format("keyframes must be in increasing frame order: {} after {}", f.frame, out.back().frame));
    if (translation) f.translation = translation->Vec3(-kHuge, kHuge);
    if (rotation) {
      const Eigen::Vector3d r = rotation->Vec3(-360, 360) * kDegToRad;
      f.rotation = Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX());
    }
    if (scale) f.scale = ParseScale(*scale, 0);
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
void ParseCamera(const Node& node, const fs::path& base, bool check, SceneCamera* out) {
  SceneCamera& c = *out;
  JsonSettings cam(node);
  const JsonNode model = cam.Require("model");
  const auto frames = cam.Take("frames");
  const bool transfer_given = node.json().contains("frames_transfer");
  cam.OneOf("frames_transfer", &c.frames_transfer, {"srgb", "linear", "display", "response"});
  const auto colorspace = cam.Take("frames_colorspace");
  const auto ocio_config = cam.Take("ocio_config");
  const auto ocio_working = cam.Take("ocio_working");
  const auto exposure = cam.Take("exposure");
  const auto response = cam.Take("response");
  const auto gains = cam.Take("gains");
  cam.OneOf("gains_scale", &c.gains_scale, {"render", "room"});
  const auto poses = cam.Take("poses");
  cam.Number("shutter", &c.shutter, 0, 1);
  const auto lens = cam.Take("lens");
  cam.Done();
  c.model = ResolveFile(model, base, check, "camera model");
  if (frames) {
    if (IsFramePattern(frames->String())) {
      c.frames = ResolvePattern(*frames, base, check);
    } else {
      c.frames = ResolveFile(*frames, base, check, "video");
      c.frames_are_video = true;
    }
  }
  if (colorspace) {
    c.frames_colorspace = colorspace->String();
    if (c.frames_colorspace.empty()) colorspace->Fail("names no colour space");
    if (transfer_given) colorspace->Fail("replaces frames_transfer: give one of the two");
    if (!frames) colorspace->Fail("decodes the plate: camera.frames is not given");
  }
  if (ocio_config) c.ocio_config = ResolveFile(*ocio_config, base, check, "OpenColorIO config");
  if (ocio_working) c.ocio_working = ocio_working->String();
  if ((ocio_config || ocio_working) && !colorspace)
    (ocio_config ? *ocio_config : *ocio_working).Fail("is used with camera.frames_colorspace, which is not given");
  if (response) c.response = ResolveFile(*response, base, check, "camera response");
  if ((c.frames_transfer == "response") != c.response.has_value())
    (response ? *response : cam.Node("frames_transfer"))
        .Fail("frames_transfer \"response\" and a response file go together");
  if (exposure) c.exposure = exposure->Number(1e-12, 1e12);
  if (lens) {
    JsonSettings l(*lens);
    const JsonNode aperture = l.Require("aperture_radius");
    const JsonNode focus = l.Require("focus_distance");
    l.Done();
    c.aperture_radius = aperture.Number(0, 10);
    c.focus_distance = focus.Number(1e-3, 1e9);
  }
  if (gains) {
    // Not checked here: mr-pipeline's scene names the gains its radiometry
    // stage is yet to fit (mr-render's FrameDecoding reads and checks them).
    c.gains = ResolveFile(*gains, base, false, "plate gains");
    if (!frames) gains->Fail("plate gains need a plate: camera.frames is not given");
    if (c.frames_transfer == "display" && exposure)
      exposure->Fail("with camera.gains the gains scale the render in \"display\" mode: give one of the two");
  }
  if (poses) {
    JsonSettings p(*poses);
    const JsonNode format = p.Require("format");
    const JsonNode path = p.Require("path");
    std::string of = "camera";
    p.OneOf("of", &of, {"camera", "rig"});
    p.Done();
    c.poses_of_rig = of == "rig";
    const std::string fmt_name = format.OneOf({"tum", "7scenes", "colmap"});
    c.pose_format = fmt_name == "tum"       ? PoseFormat::kTum
                    : fmt_name == "7scenes" ? PoseFormat::k7Scenes
                                            : PoseFormat::kColmap;
    c.poses = ResolveFile(path, base, check, "poses");
  }
}

// lighting: the environment (a file, a pattern or a video), its scale and
// orientation, the lights.
void ParseLighting(const Node& node, const fs::path& base, bool check, SceneLighting* out) {
  SceneLighting& lighting = *out;
  JsonSettings l(node);
  const auto environment = l.Take("environment");
  l.Number("environment_scale", &lighting.environment_scale, 0, kHuge);
  const auto rotation = l.Take("environment_rotation_deg");
  const auto up = l.Take("environment_up");
  const auto lights = l.Take("lights");
  const auto probes = l.Take("probes");
  l.Done();
  // A file, or a printf pattern of one per frame.
  auto file_or_pattern = [&](const std::optional<JsonNode>& n, const char* what, std::optional<fs::path>* path,
                             bool* per_frame) {
    if (!n) return;
    *per_frame = IsFramePattern(n->String());
    *path = *per_frame ? ResolvePattern(*n, base, check) : ResolveFile(*n, base, check, what);
  };
  file_or_pattern(environment, "environment map", &lighting.environment, &lighting.environment_per_frame);
  lighting.environment_video =
      lighting.environment && !lighting.environment_per_frame && IsVideoFile(*lighting.environment);
  if (rotation) {
    double yaw = rotation->Number(-360, 360) * kDegToRad;
    lighting.world_from_env = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  }
  if (up) {
    // The world direction of the map's zenith (+y): for rooms whose frame
    // is not +y up (a reconstruction in its first camera's frame).
    const Eigen::Vector3d u = up->Vec3(-kHuge, kHuge);
    if (!(u.norm() > 1e-9)) up->Fail("a zero vector has no direction");
    lighting.world_from_env =
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitY(), u.normalized()).toRotationMatrix() *
        lighting.world_from_env;
  }
  file_or_pattern(lights, "lights file", &lighting.lights, &lighting.lights_per_frame);
  if (probes) {
    if (!probes->json().is_array() || probes->json().empty() || probes->json().size() > 16)
      probes->Fail("expected a list of 1 to 16 probes {at: [x, y, z], map}");
    for (size_t i = 0; i < probes->json().size(); ++i) {
      JsonSettings ps(probes->Index(i));
      SceneLighting::Probe probe;
      probe.at = ps.Require("at").Vec3(-kHuge, kHuge);
      file_or_pattern(ps.Take("map"), "probe map", &probe.map, &probe.map_per_frame);
      ps.Done();
      if (!probe.map && !lighting.environment)
        probes->Index(i).Fail("a probe without a map takes the environment's, and the scene names none");
      lighting.probes.push_back(probe);
    }
  }
}

// real: one {mesh, material} or a list of them (a room whose parts differ in material).
void ParseReals(const Node& node, const fs::path& base, bool check, std::vector<SceneReal>* reals) {
  auto parse_real = [&](const Node& r) {
    JsonSettings rs(r);
    const JsonNode mesh = rs.Require("mesh");
    const auto material = rs.Take("material");
    rs.Done();
    SceneReal real;
    real.mesh = ResolveFile(mesh, base, check, "mesh");
    if (material) real.material = ParseMaterial(*material, base, check);
    reals->push_back(real);
  };
  if (node.json().is_array()) {
    if (node.json().empty()) node.Fail("expected at least one {mesh, material}");
    for (size_t i = 0; i < node.json().size(); ++i) parse_real(node.Index(i));
  } else {
    parse_real(node);
  }
}

// A virtual light: a lights.json light in its own frame, posed.
SceneVirtualLight ParseVirtualLight(const Node& o, size_t i) {
  JsonSettings os(o);
  const auto name = os.Take("name");
  const JsonNode light = os.Require("light");
  const auto transform = os.Take("transform");
  const auto trajectory = os.Take("trajectory");
  os.Done();
  SceneVirtualLight vl;
  vl.light = ParseLight(light, fmt::format("light{}", i));
  vl.light.is_virtual = true;
  vl.name = name ? name->String() : vl.light.name;
  vl.light.name = vl.name;
  if (transform && trajectory) trajectory->Fail("give either transform or trajectory, not both");
  if (transform) vl.world_from_object = ParseTransform(*transform);
  if (trajectory) vl.keyframes = ParseTrajectory(*trajectory);
  vl.world_from_object =
      PoseAt(vl.keyframes, vl.world_from_object, vl.keyframes.empty() ? 0 : vl.keyframes.front().frame);
  return vl;
}

// The nearest hit of the ray o + t d (t > 0) on the scene's real meshes:
// its distance t and the hit triangle's unit normal; t infinite on none.
struct RealHit {
  double t = std::numeric_limits<double>::infinity();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
};
RealHit FirstRealHit(const Scene& scene, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  RealHit best;
  for (const SceneReal& r : scene.reals) {
    const Mesh m = ReadMesh(r.mesh);
    for (const Eigen::Vector3i& t : m.triangles) {
      const Eigen::Vector3d a = m.positions[static_cast<size_t>(t[0])].cast<double>();
      const Eigen::Vector3d e1 = m.positions[static_cast<size_t>(t[1])].cast<double>() - a;
      const Eigen::Vector3d e2 = m.positions[static_cast<size_t>(t[2])].cast<double>() - a;
      const Eigen::Vector3d q = d.cross(e2);
      const double det = e1.dot(q);
      if (std::abs(det) < 1e-18) continue;
      const Eigen::Vector3d s = o - a;
      const double u = s.dot(q) / det;
      const Eigen::Vector3d r2 = s.cross(e1);
      const double v = d.dot(r2) / det;
      const double dist = e2.dot(r2) / det;
      if (u >= 0 && v >= 0 && u + v <= 1 && dist > 0 && dist < best.t) {
        best.t = dist;
        best.normal = e1.cross(e2).normalized();
      }
    }
  }
  return best;
}

// transform.rest_on: the object (its rotation and scale applied) moved so
// that its lowest point along the world's up (lighting.up, default +y) rests
// on the first real surface below the given point, its bounding box
// centred on the point across up.  Needs the files (skipped unchecked).
Eigen::Vector3d WorldUp(const Scene& scene) {
  return (scene.lighting.world_from_env * Eigen::Vector3d::UnitY()).normalized();
}

void RestOnTheRoom(const Node& rest_on, const Eigen::Vector3d& p, const Eigen::Vector3d& up, const Scene& scene,
                   bool check, SceneVirtual* sv) {
  if (!check) return;
  if (scene.reals.empty()) rest_on.Fail("there is no real mesh to rest the object on");
  const double best = FirstRealHit(scene, p, -up).t;
  if (!std::isfinite(best))
    rest_on.Fail(
        fmt::format("no real surface below [{:.4g}, {:.4g}, {:.4g}] (along -up, up = [{:.3g}, {:.3g}, {:.3g}])", p.x(),
                    p.y(), p.z(), up.x(), up.y(), up.z()));
  const Eigen::Vector3d hit = p - best * up;
  const Mesh object = ReadMesh(sv->mesh);
  if (object.positions.empty()) rest_on.Fail(fmt::format("{} has no vertices", sv->mesh.string()));
  const Eigen::Matrix3d linear = sv->world_from_object.linear();
  double lowest = std::numeric_limits<double>::infinity();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(kHuge), hi = Eigen::Vector3d::Constant(-kHuge);
  for (const Eigen::Vector3f& v : object.positions) {
    const Eigen::Vector3d w = linear * v.cast<double>();
    lowest = std::min(lowest, up.dot(w));
    lo = lo.cwiseMin(w);
    hi = hi.cwiseMax(w);
  }
  const Eigen::Vector3d centre = (lo + hi) / 2;
  const Eigen::Vector3d across = (p - centre) - up.dot(p - centre) * up;
  sv->world_from_object.translation() = across + (up.dot(hit) - lowest) * up;
  sv->rests_on = hit;
}

// transform.at_pixel {frame, pixel: [x, y], up}: the object stood upright
// (along `up`, default the world's) on the real surface seen at that pixel
// of that frame (the ray through it by the scene's camera model and the
// frame's pose), as rest_on stands it on the point; a surface steeper than
// kMaxStandDeg from level is refused.
constexpr double kMaxStandDeg = 30;
void StandAtPixel(const Node& at_pixel, const Scene& scene, bool check, SceneVirtual* sv) {
  JsonSettings s(at_pixel);
  const JsonNode frame_node = s.Require("frame");
  const JsonNode pixel_node = s.Require("pixel");
  const auto up_node = s.Take("up");
  s.Done();
  const auto frame = static_cast<size_t>(frame_node.Integer(0, 10000000));
  const std::vector<double> q = pixel_node.Numbers(2, -kHuge, kHuge);
  Eigen::Vector3d up = WorldUp(scene);
  if (up_node) {
    up = up_node->Vec3(-kHuge, kHuge);
    if (!(up.norm() > 0)) up_node->Fail("up must not be zero");
    up.normalize();
  }
  if (!check) return;
  const CameraModel camera = CameraModel::Read(scene.camera.model);
  if (q[0] < -0.5 || q[1] < -0.5 || q[0] > camera.width() - 0.5 || q[1] > camera.height() - 0.5)
    pixel_node.Fail(
        fmt::format("({}, {}) is outside the camera's {}x{} image", q[0], q[1], camera.width(), camera.height()));
  const std::vector<Rigid3> poses = LoadScenePoses(scene);
  if (frame >= poses.size())
    frame_node.Fail(fmt::format("frame {} has no pose (the camera has {})", frame, poses.size()));
  Eigen::Vector3d dir;
  if (!camera.Unproject(Eigen::Vector2d(q[0], q[1]), &dir))
    pixel_node.Fail("the camera model cannot unproject this pixel");
  const Rigid3& world_from_cam = poses[frame];
  const Eigen::Vector3d o = world_from_cam.translation, d = (world_from_cam.rotation * dir).normalized();
  if (scene.reals.empty()) at_pixel.Fail("there is no real mesh to stand the object on");
  const RealHit hit = FirstRealHit(scene, o, d);
  if (!std::isfinite(hit.t)) pixel_node.Fail("the ray through this pixel meets no real surface");
  const double tilt = std::acos(std::min(1.0, std::abs(hit.normal.dot(up)))) * 180 / 3.14159265358979323846;
  if (tilt > kMaxStandDeg)
    pixel_node.Fail(
        fmt::format("the surface seen here is {:.0f} degrees from level (a wall?): an object cannot stand "
                    "on it (at most {:.0f})",
                    tilt, kMaxStandDeg));
  // A point just above the surface, so that rest_on's ray down finds it.
  const Eigen::Vector3d p = o + hit.t * d;
  RestOnTheRoom(at_pixel, p + 1e-4 * std::max(1.0, p.norm()) * up, up, scene, check, sv);
}

// A virtual object: a mesh placed by a transform or a trajectory; `names`
// holds the names taken so far.
SceneVirtual ParseVirtualObject(const Node& o, size_t i, const fs::path& base, bool check, std::set<std::string>* names,
                                const Scene& scene) {
  JsonSettings os(o);
  const auto name = os.Take("name");
  const JsonNode mesh = os.Require("mesh");
  const auto transform = os.Take("transform");
  const auto trajectory = os.Take("trajectory");
  const auto material = os.Take("material");
  const auto formfactors = os.Take("formfactors");
  os.Done("or light, which makes the entry a virtual light");
  SceneVirtual sv;
  sv.name = name ? name->String() : fmt::format("object{}", i);
  if (!names->insert(sv.name).second) (name ? *name : o).Fail(fmt::format("name \"{}\" is used twice", sv.name));
  sv.mesh = ResolveFile(mesh, base, check, "mesh");
  if (transform && trajectory) trajectory->Fail("give either transform or trajectory, not both");
  std::optional<Node> rest_on, at_pixel;
  if (transform) sv.world_from_object = ParseTransform(*transform, &rest_on, &at_pixel);
  if (rest_on) RestOnTheRoom(*rest_on, rest_on->Vec3(-kHuge, kHuge), WorldUp(scene), scene, check, &sv);
  if (at_pixel) StandAtPixel(*at_pixel, scene, check, &sv);
  if (trajectory) {
    sv.keyframes = ParseTrajectory(*trajectory);
    sv.world_from_object = sv.WorldFromObjectAt(sv.keyframes.front().frame);
  }
  sv.file_materials = IsAssetPath(sv.mesh);
  if (material && sv.file_materials)
    material->Fail("the mesh is an asset, whose materials are its own: remove \"material\"");
  if (material && material->json().is_string()) {  // "mtl": the OBJ's own materials
    if (material->String() != "mtl" || LowerExtension(sv.mesh) != ".obj")
      material->Fail("expected a material block, or \"mtl\" for an OBJ's own MTL materials");
    sv.file_materials = true;
  } else if (material) {
    sv.material = ParseMaterial(*material, base, check);
  }
  if (formfactors) sv.formfactors = ResolveFile(*formfactors, base, check, "form factors");
  return sv;
}

// virtual: objects and virtual lights, their names unique.
void ParseVirtuals(const Node& v, const fs::path& base, bool check, Scene* out) {
  Scene& s = *out;
  if (!v.json().is_array()) v.Fail(fmt::format("expected an array of objects, got {}", v.TypeName()));
  std::set<std::string> names;
  for (size_t i = 0; i < v.json().size(); ++i) {
    const Node o = v.Index(i);
    if (o.json().is_object() && o.json().contains("light")) {
      SceneVirtualLight vl = ParseVirtualLight(o, i);
      if (!names.insert(vl.name).second) o.Fail(fmt::format("name \"{}\" is used twice", vl.name));
      s.virtual_lights.push_back(std::move(vl));
    } else {
      s.virtuals.push_back(ParseVirtualObject(o, i, base, check, &names, s));
    }
  }
}

// render: the generic settings; any other key holding an object is a
// method's block (render.vpl, ...), kept as written for the method to parse.
void ParseRender(const Node& node, SceneRender* out) {
  SceneRender& render = *out;
  JsonSettings r(node);
  const auto method = r.Take("method");
  r.Integer("spp", &render.spp, 1, 1 << 24);
  r.Integer("max_depth", &render.max_depth, 0, 1000);
  const auto seed = r.Take("seed");
  const auto frames = r.Take("frames");
  r.Number("time_budget_s", &render.time_budget_s, 0, 1e9);
  r.Integer("plate_neighbours", &render.plate_neighbours, 0, 16);
  r.Integer("plate_neighbour_step", &render.plate_neighbour_step, 1, 100000);
  r.OneOf("world_update", &render.world_update, {"incremental", "rebuild"});
  const auto adaptive = r.Take("adaptive");
  for (const std::string& k : r.Unread()) {
    const Json& v = node.json().at(k);
    if (!v.is_object()) {
      std::string list;
      for (const SettingDecl& d : r.declared()) list += (list.empty() ? "" : ", ") + d.key;
      node.Child(k).Fail(fmt::format("unknown key (allowed here: {}, or a method's settings object)", list));
    }
    render.method_settings[k] = v;
  }
  if (method) render.method = method->String();
  if (seed) render.seed = static_cast<uint64_t>(seed->Integer(0, INT64_MAX));
  if (frames) {
    std::string why;
    if (!ParseFrameRange(frames->String(), &render.frame_begin, &render.frame_end, &why)) frames->Fail(why);
  }
  if (adaptive) {
    JsonSettings a(*adaptive);
    a.Number("threshold", &render.adaptive_threshold, 0, 1);
    a.Integer("min_spp", &render.adaptive_min_spp, 2, 1 << 24);
    a.Done();
  }
}

// output: the folder (default `out` beside the scene), formats and layers.
void ParseOutput(const Node& node, const fs::path& base, SceneOutput* out) {
  SceneOutput& output = *out;
  JsonSettings o(node);
  const auto dir = o.Take("dir");
  o.Bool("png", &output.png);
  o.Bool("half", &output.half);
  o.OneOf("video", &output.video, {"mp4", "mkv", "none"});
  o.Bool("review", &output.review);
  o.OneOf("grain", &output.grain, {"auto", "on", "off"});
  const auto layers = o.Take("layers");
  o.Done();
  if (dir) {
    const fs::path d = dir->String();
    output.dir = d.is_relative() ? base / d : d;
  } else {
    output.dir = base / "out";
  }
  if (layers) {
    if (!layers->json().is_array() || layers->json().empty()) layers->Fail("expected a non-empty array of layer names");
    output.layers.clear();
    for (size_t i = 0; i < layers->json().size(); ++i) output.layers.push_back(layers->Index(i).OneOf(OutputLayers()));
    if (std::find(output.layers.begin(), output.layers.end(), "composite") == output.layers.end())
      layers->Fail("must include \"composite\", the render's result");
  }
}

}  // namespace

Scene ParseScene(const Json& j, const fs::path& base, const std::string& name, bool check) {
  const Node root_node(j, "", &name);
  JsonSettings root(root_node);
  const JsonNode version = root.Require("version");
  const JsonNode camera = root.Require("camera");
  const auto lighting = root.Take("lighting");
  const auto real = root.Take("real");
  const auto virtuals = root.Take("virtual");
  const auto render = root.Take("render");
  const auto output = root.Take("output");
  const auto reference = root.Take("reference");
  const auto comment = root.Take("comment");
  root.Done();
  Scene s;
  s.file = name;
  if (const int64_t v = version.Integer(1, 1000); v != kSceneVersion)
    version.Fail(fmt::format("this mr reads scene version {}, the file is version {}", kSceneVersion, v));
  if (comment) comment->String();
  ParseCamera(camera, base, check, &s.camera);
  if (lighting) ParseLighting(*lighting, base, check, &s.lighting);
  if (real) ParseReals(*real, base, check, &s.reals);
  if (virtuals) ParseVirtuals(*virtuals, base, check, &s);
  if (render) ParseRender(*render, &s.render);
  if (output)
    ParseOutput(*output, base, &s.output);
  else
    s.output.dir = base / "out";
  if (reference)
    s.reference = IsFramePattern(reference->String()) ? ResolvePattern(*reference, base, check)
                                                      : ResolveFile(*reference, base, check, "reference");
  if (s.reals.empty() && s.virtuals.empty()) root_node.Fail("the scene has neither real nor virtual geometry");
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
  l.axis = t.rotation() * light.axis;
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
