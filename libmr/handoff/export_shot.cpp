#include "handoff/export_shot.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <tuple>
#include <utility>

#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/error.h"
#include "core/file.h"
#include "core/image.h"
#include "core/math.h"
#include "geometry/asset.h"
#include "geometry/mesh.h"
#include "handoff/gltf_builder.h"
#include "handoff/stmap.h"
#include "light/lights_file.h"
#include "scene/frames.h"
#include "scene/scene.h"

namespace mr {

namespace {

Json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
Json Quat(const Eigen::Quaterniond& q) { return {q.x(), q.y(), q.z(), q.w()}; }  // glTF's order

// A path as the glTF file names it: relative to the folder it is written in.
std::string Relative(const fs::path& p, const fs::path& out) {
  const fs::path base = fs::absolute(out).parent_path();
  return fs::absolute(p).lexically_relative(base).generic_string();
}

// T * R * S of an affine map without shear (a scene's world_from_object);
// a mirror goes into the scale's sign.
void Decompose(const Eigen::Affine3d& a, Eigen::Vector3d* t, Eigen::Quaterniond* r, Eigen::Vector3d* s) {
  const Eigen::Matrix3d m = a.linear();
  *t = a.translation();
  for (int k = 0; k < 3; ++k) (*s)[k] = m.col(k).norm();
  if (m.determinant() < 0) (*s)[0] = -(*s)[0];
  Eigen::Matrix3d rot = m;
  for (int k = 0; k < 3; ++k) rot.col(k) = (*s)[k] != 0 ? Eigen::Vector3d(m.col(k) / (*s)[k]) : Eigen::Vector3d::Zero();
  if ((s->array() == 0).any()) rot.setIdentity();  // a collapsed object: its rotation does not matter
  *r = Eigen::Quaterniond(rot).normalized();
}

// The PBR material glTF readers understand, and mr's own in extras.
Json PbrMaterial(const std::string& name, const Material& m, bool vertex_colors) {
  const Eigen::Vector3d base = vertex_colors ? Eigen::Vector3d::Ones() : m.albedo;
  Json pbr = {{"baseColorFactor", {base.x(), base.y(), base.z(), 1.0}},
              {"metallicFactor", 0.0},
              {"roughnessFactor", m.IsGlossy() ? m.roughness : 1.0}};  // GGX alpha = roughness^2 in both
  Json j = {{"name", name},
            {"pbrMetallicRoughness", pbr},
            {"extras",
             {{"mr",
               {{"albedo", Vec(m.albedo)},
                {"specular", Vec(m.specular)},
                {"roughness", m.roughness},
                {"emission", Vec(m.emission)},
                {"albedo_from_vertex_colors", m.albedo_from_vertex_colors}}}}}};
  if (m.IsEmissive()) {
    const double strength = std::max(1.0, m.emission.maxCoeff());
    j["emissiveFactor"] = Vec(m.emission / strength);
    if (strength > 1) j["extensions"]["KHR_materials_emissive_strength"] = {{"emissiveStrength", strength}};
  }
  return j;
}

// A mesh in glTF coordinates (gltf_from_world applied), one primitive.
int AddMesh(GltfBuilder& b, const std::string& name, const Mesh& m, const Eigen::Matrix3f& rot, int material,
            bool colors) {
  std::vector<float> pos, nrm, col, uv;
  std::vector<uint32_t> idx;
  pos.reserve(3 * m.vertex_count());
  for (const auto& p : m.positions) {
    const Eigen::Vector3f q = rot * p;
    pos.insert(pos.end(), {q.x(), q.y(), q.z()});
  }
  bool normals = m.normals.size() == m.positions.size();
  for (size_t i = 0; normals && i < m.normals.size(); ++i) {
    const Eigen::Vector3f n = rot * m.normals[i];
    if (!(n.norm() > 1e-12f) || !n.allFinite()) normals = false;  // glTF normals are unit: none rather than bad
    const Eigen::Vector3f u = n.normalized();
    nrm.insert(nrm.end(), {u.x(), u.y(), u.z()});
  }
  if (colors)
    for (const auto& c : m.colors) col.insert(col.end(), {c.x(), c.y(), c.z()});
  for (const auto& t : m.uvs) uv.insert(uv.end(), {t.x(), 1 - t.y()});  // glTF's v runs down the image
  for (const auto& t : m.triangles)
    idx.insert(idx.end(), {static_cast<uint32_t>(t.x()), static_cast<uint32_t>(t.y()), static_cast<uint32_t>(t.z())});
  Json attributes = {{"POSITION", b.AddFloats(pos, 3, true)}};
  if (normals) attributes["NORMAL"] = b.AddFloats(nrm, 3, false);
  if (colors && !col.empty()) attributes["COLOR_0"] = b.AddFloats(col, 3, false);
  if (!uv.empty()) attributes["TEXCOORD_0"] = b.AddFloats(uv, 2, false);
  Json prim = {{"attributes", attributes}, {"indices", b.AddIndices(idx)}, {"mode", 4}};
  if (material >= 0) prim["material"] = material;
  return b.Push("meshes", {{"name", name}, {"primitives", Json::array({prim})}});
}

// glTF lights shine along their node's -z; `towards` is where the light goes.
Eigen::Quaterniond ShiningAlong(const Eigen::Vector3d& towards, const Eigen::Vector3d& axis_x) {
  const Eigen::Vector3d z = -towards.normalized();
  Eigen::Vector3d x = axis_x - axis_x.dot(z) * z;
  if (!(x.norm() > 1e-9)) x = std::abs(z.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  x = (x - x.dot(z) * z).normalized();
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = z.cross(x);
  r.col(2) = z;
  return Eigen::Quaterniond(r).normalized();
}

// One lights.json light as a node (KHR_lights_punctual where it has a
// punctual form; an area light or a distant disc in extras for the Blender
// script).  Its exact radiometric values are in extras: glTF's candela and
// lux are photometric, mr's units are the scene's radiance scale.
int AddLight(GltfBuilder& b, const Light& l, const Eigen::Matrix3d& R, bool is_virtual) {
  Json mr = {{"virtual", is_virtual}, {"name", l.name}};
  Json node = {{"name", l.name.empty() ? "light" : l.name}};
  Json khr;
  auto colour = [](const Eigen::Vector3d& v, double* peak) {
    *peak = v.maxCoeff();
    return *peak > 0 ? Vec(v / *peak) : Vec(Eigen::Vector3d::Ones());
  };
  double peak = 0;
  switch (l.type) {
    case LightType::kPoint:
    case LightType::kSpot: {
      node["translation"] = Vec(R * l.position);
      khr = {{"type", l.type == LightType::kPoint ? "point" : "spot"}, {"color", colour(l.intensity, &peak)}};
      khr["intensity"] = peak;
      mr["type"] = l.type == LightType::kPoint ? "point" : "spot";
      mr["intensity_w_sr"] = Vec(l.intensity);
      if (l.type == LightType::kSpot) {
        const double outer = l.cone_deg * kDegToRad, inner = std::min(l.falloff_start_deg, l.cone_deg) * kDegToRad;
        khr["spot"] = {{"innerConeAngle", inner}, {"outerConeAngle", outer}};
        node["rotation"] = Quat(ShiningAlong(R * l.direction, R * Eigen::Vector3d::UnitX()));
        mr["cone_deg"] = l.cone_deg;
        mr["falloff_start_deg"] = l.falloff_start_deg;
      }
      break;
    }
    case LightType::kDistant:
      node["rotation"] = Quat(ShiningAlong(-(R * l.direction), R * Eigen::Vector3d::UnitX()));
      khr = {{"type", "directional"}, {"color", colour(l.irradiance, &peak)}};
      khr["intensity"] = peak;
      mr["type"] = "distant";
      mr["irradiance_w_m2"] = Vec(l.irradiance);
      mr["angular_radius_deg"] = l.angular_radius_deg;
      break;
    case LightType::kArea:
      node["translation"] = Vec(R * l.position);
      node["rotation"] = Quat(ShiningAlong(R * l.direction, R * l.axis));
      mr["type"] = "area";
      mr["shape"] = l.shape == AreaShape::kRect ? "rect" : "disc";
      mr["width"] = l.width;
      mr["height"] = l.height;
      mr["radiance"] = Vec(l.radiance);
      break;
  }
  if (!khr.is_null()) {
    khr["name"] = l.name;
    Json& ext = b.json()["extensions"]["KHR_lights_punctual"]["lights"];
    if (ext.is_null()) ext = Json::array();
    ext.push_back(khr);
    node["extensions"]["KHR_lights_punctual"] = {{"light", ext.size() - 1}};
  }
  node["extras"]["mr"] = mr;
  return b.Push("nodes", node);
}

// An animation channel pair (translation, rotation[, scale]) over `times`.
void Animate(GltfBuilder& b, Json* animation, int node, const std::vector<float>& times,
             const std::vector<float>& translations, const std::vector<float>& rotations,
             const std::vector<float>* scales) {
  const int input = b.AddFloats(times, 1, true, 0);
  auto channel = [&](const std::vector<float>& values, int components, const char* path) {
    const int output = b.AddFloats(values, components, false, 0);
    const int sampler = static_cast<int>((*animation)["samplers"].size());
    (*animation)["samplers"].push_back({{"input", input}, {"output", output}, {"interpolation", "LINEAR"}});
    (*animation)["channels"].push_back({{"sampler", sampler}, {"target", {{"node", node}, {"path", path}}}});
  };
  channel(translations, 3, "translation");
  channel(rotations, 4, "rotation");
  if (scales) channel(*scales, 3, "scale");
}

// Blender's lens shift (sensor fit horizontal) for a pinhole's principal
// point: in units of the image's width, +y up, a pixel's height being
// fx / fy of its width.
Json BlenderShift(const CameraModel& pinhole) {
  const Eigen::Vector4d k = pinhole.Core();
  const double w = pinhole.width(), h = pinhole.height();
  return {-(k[2] - (w - 1) / 2) / w, (k[3] - (h - 1) / 2) * (k[0] / k[1]) / w};
}

// The camera: a perspective camera of `pinhole` (the lens's core, or the
// ST-maps' grown pinhole) where the lens cannot see 90 degrees or more from
// its axis; the principal point's offset is Blender's lens shift in extras.
Json CameraExtras(const CameraModel& lens, const CameraModel& pinhole, ShotExportResult* r) {
  const auto& in = pinhole.intrinsics();
  const double fx = in[0], fy = in[1], cx = in[2], cy = in[3];
  Json j = {{"lensmodel", lens.lensmodel()},
            {"intrinsics", lens.intrinsics()},
            {"lens_width", lens.width()},
            {"lens_height", lens.height()},
            {"width", pinhole.width()},
            {"height", pinhole.height()},
            {"fx", fx},
            {"fy", fy},
            {"cx", cx},
            {"cy", cy},
            {"pixel_centre", "mrcal: (0, 0) is the centre of the top-left pixel"},
            {"distorted", lens.lensmodel() != "LENSMODEL_PINHOLE"}};
  // The widest angle from the axis at which the lens's image border sees.
  const double lw = lens.width(), lh = lens.height();
  double widest = 0;
  bool border_ok = true;
  auto look = [&](double x, double y) {
    Eigen::Vector3d d;
    if (!lens.Unproject(Eigen::Vector2d(x, y), &d) || !d.allFinite()) {
      border_ok = false;
      return;
    }
    widest = std::max(widest, std::acos(std::clamp(d.z() / d.norm(), -1.0, 1.0)) / kDegToRad);
  };
  for (double x = -0.5; x <= lw - 0.5; x += std::max(1.0, lw / 64)) look(x, -0.5), look(x, lh - 0.5);
  for (double y = -0.5; y <= lh - 0.5; y += std::max(1.0, lh / 64)) look(-0.5, y), look(lw - 0.5, y);
  look(lw - 0.5, lh - 0.5);
  j["widest_angle_from_axis_deg"] = widest;
  if (!border_ok || widest >= 89.5) {
    r->no_perspective = border_ok
                            ? fmt::format(
                                  "{} sees {:.1f} degrees from its axis, {:.1f} across: no perspective camera holds "
                                  "its view; the camera node carries the pose alone",
                                  lens.lensmodel(), widest, 2 * widest)
                            : fmt::format(
                                  "{}: part of the image's border has no ray (outside the model's domain): no "
                                  "perspective camera; the camera node carries the pose alone",
                                  lens.lensmodel());
  } else {
    r->perspective = true;
    j["blender_shift"] = BlenderShift(pinhole);
  }
  j["perspective"] = r->perspective;
  if (!r->perspective) j["no_perspective"] = r->no_perspective;
  return j;
}

}  // namespace

namespace {

// The ST-maps beside `out` (its stem + "-undistort.exr", "-redistort.exr").
std::pair<fs::path, fs::path> WriteStMaps(const StMaps& maps, const fs::path& out, Report* report) {
  const fs::path undistort = out.parent_path() / (out.stem().string() + "-undistort.exr");
  const fs::path redistort = out.parent_path() / (out.stem().string() + "-redistort.exr");
  WriteImage(undistort, maps.undistort);
  WriteImage(redistort, maps.redistort);
  report->AddOutput(undistort.string());
  report->AddOutput(redistort.string());
  if (maps.unmapped > 0)
    report->Warn(fmt::format("{} of the lens's pixels see beyond {} degrees from its axis: not in the ST-maps",
                             maps.unmapped, maps.max_angle_deg));
  return {undistort, redistort};
}

// ExportShot's steps over one document: each adds its part of the shot;
// Write puts every file down at the end, after everything that can fail on
// the inputs.
class ShotWriter {
 public:
  ShotWriter(const ShotExportOptions& o, Report* report)
      : o_(o),
        report_(report),
        scene_(ReadScene(o.scene)),
        cam_(CameraModel::Read(scene_.camera.model)),
        poses_(LoadScenePoses(scene_)) {
    const int n = static_cast<int>(poses_.size());
    begin_ = o.frame_begin;
    end_ = o.frame_end < 0 ? n : o.frame_end;
    if (begin_ < 0 || begin_ >= end_ || end_ > n)
      throw Error(fmt::format("{}: frames [{}, {}) are outside the {} poses of {}", o.scene.string(), begin_, end_, n,
                              ScenePoseSource(scene_)));
    // glTF is +y up: the world turned so that its up (the environment's
    // zenith) is +y; identity for a world that is +y up already.
    const Eigen::Vector3d up = (scene_.lighting.world_from_env * Eigen::Vector3d::UnitY()).normalized();
    R_ = Eigen::Quaterniond::FromTwoVectors(up, Eigen::Vector3d::UnitY()).toRotationMatrix();
    extras_ = {{"units", "metres; light in the scene's radiometric units (extras), not glTF's photometric ones"},
               {"gltf_from_world", Rows(R_)}};
    for (int f = begin_; f < end_; ++f) times_.push_back(static_cast<float>((f - begin_) / o.fps));
  }
  void AddRoom();
  void AddObjects();
  void AddCamera();
  void AddLights();
  void AddPlate();
  ShotExportResult Write();

 private:
  static Json Rows(const Eigen::Matrix3d& m) {
    Json j = Json::array();
    for (int i = 0; i < 3; ++i) j.push_back({m(i, 0), m(i, 1), m(i, 2)});
    return j;
  }
  const ShotExportOptions& o_;
  Report* report_;
  const Scene scene_;
  const CameraModel cam_;
  const std::vector<Rigid3> poses_;
  int begin_ = 0, end_ = 0;
  Eigen::Matrix3d R_;
  GltfBuilder b_;
  Json roots_ = Json::array(), extras_;
  Json animation_ = {{"name", "shot"}, {"samplers", Json::array()}, {"channels", Json::array()}};
  std::vector<float> times_;
  std::optional<StMaps> maps_;
  CameraModel pinhole_;
  int camera_node_ = 0;
  ShotExportResult r_;
};

// The room: each real mesh, marked so that a user makes it a shadow catcher.
void ShotWriter::AddRoom() {
  for (size_t i = 0; i < scene_.reals.size(); ++i) {
    const SceneReal& real = scene_.reals[i];
    const Mesh m = ReadMesh(real.mesh);
    const bool colors = real.material.albedo_from_vertex_colors && !m.colors.empty();
    const std::string name = scene_.reals.size() == 1 ? "room" : fmt::format("room.{}", i);
    const int mat = b_.Push("materials", PbrMaterial(name, real.material, colors));
    const int mesh = AddMesh(b_, name, m, R_.cast<float>(), mat, colors);
    roots_.push_back(b_.Push(
        "nodes",
        {{"name", name},
         {"mesh", mesh},
         {"extras", {{"mr", {{"role", "room"}, {"shadow_catcher", true}, {"source", Relative(real.mesh, o_.out)}}}}}}));
    ++r_.room_meshes;
  }
}

// The virtual objects: a mesh with mr's material; a glTF asset merged in
// with its own materials and textures; an OBJ with its MTL referenced for
// the Blender script to import.  Trajectories become per-frame keys.
void ShotWriter::AddObjects() {
  for (const SceneVirtual& v : scene_.virtuals) {
    Json node = {{"name", v.name}};
    Json mr = {{"role", "object"}, {"source", Relative(v.mesh, o_.out)}};
    const std::string ext = LowerExtension(v.mesh);
    const bool gltf_asset = v.file_materials && (ext == ".glb" || ext == ".gltf");
    if (v.file_materials && !gltf_asset) {
      mr["asset"] = Relative(v.mesh, o_.out);  // an OBJ's MTL: imported by the Blender script onto this node
      ++r_.assets;
    } else if (gltf_asset) {
      mr["asset_embedded"] = true;  // merged below, its own materials and textures with it
      ++r_.assets;
    } else {
      const Mesh m = ReadMesh(v.mesh);
      const int mat = b_.Push("materials", PbrMaterial(v.name, v.material, false));
      node["mesh"] = AddMesh(b_, v.name, m, Eigen::Matrix3f::Identity(), mat, false);
    }
    auto trs = [&](double frame, Eigen::Vector3d* t, Eigen::Quaterniond* q, Eigen::Vector3d* s) {
      Eigen::Affine3d a = v.WorldFromObjectAt(frame);
      a.linear() = R_ * a.linear();
      a.translation() = R_ * a.translation();
      Decompose(a, t, q, s);
    };
    Eigen::Vector3d t, s;
    Eigen::Quaterniond q;
    trs(begin_, &t, &q, &s);
    node["translation"] = Vec(t);
    node["rotation"] = Quat(q);
    node["scale"] = Vec(s);
    node["extras"]["mr"] = mr;
    const int id = b_.Push("nodes", node);
    roots_.push_back(id);
    if (gltf_asset) {
      const std::string note = b_.MergeAsset(v.mesh, id);
      if (!note.empty()) report_->Warn(fmt::format("{}: {}", v.mesh.string(), note));
    }
    if (!v.keyframes.empty()) {
      std::vector<float> tr, ro, sc;
      for (int f = begin_; f < end_; ++f) {
        trs(f, &t, &q, &s);
        for (int k = 0; k < 3; ++k) tr.push_back(static_cast<float>(t[k])), sc.push_back(static_cast<float>(s[k]));
        for (double c : {q.x(), q.y(), q.z(), q.w()}) ro.push_back(static_cast<float>(c));
      }
      Animate(b_, &animation_, id, times_, tr, ro, &sc);
    }
    ++r_.objects;
  }
}

// The camera, a key per frame with a pose, through the lens's pinhole core
// or the ST-maps' grown pinhole.  glTF's camera looks along its -z with +y
// up; mr's along +z with +y down: a half turn about x.
void ShotWriter::AddCamera() {
  const Eigen::Vector4d core = cam_.Core();
  pinhole_ = CameraModel("LENSMODEL_PINHOLE", {core[0], core[1], core[2], core[3]}, cam_.width(), cam_.height());
  if (o_.stmaps) {
    maps_ = MakeStMaps(cam_, o_.stmap_max_angle_deg);
    pinhole_ = maps_->pinhole;
  }
  Json cam_extras = CameraExtras(cam_, pinhole_, &r_);
  if (maps_ && !r_.perspective) {  // the maps' pinhole holds the part within the widest angle
    r_.perspective = true;
    cam_extras["perspective"] = true;
    cam_extras["blender_shift"] = BlenderShift(pinhole_);
    cam_extras["no_perspective"] =
        r_.no_perspective +
        fmt::format("; with the ST-maps, the part within {} degrees of its axis is rendered", o_.stmap_max_angle_deg);
  }
  Json node = {{"name", "camera"}};
  if (r_.perspective) {
    const Eigen::Vector4d k = pinhole_.Core();
    const double w = pinhole_.width(), h = pinhole_.height();
    node["camera"] = b_.Push(
        "cameras",
        {{"name", "camera"},
         {"type", "perspective"},
         {"perspective",
          {{"yfov", 2 * std::atan(h / (2 * k[1]))}, {"aspectRatio", (w * k[1]) / (h * k[0])}, {"znear", 0.01}}}});
  }
  const Eigen::Quaterniond Rq(R_), flip(0, 1, 0, 0);  // flip (w, x, y, z): a half turn about x
  std::vector<float> times, tr, ro;
  for (int f = begin_; f < end_; ++f) {
    const Rigid3& p = poses_[static_cast<size_t>(f)];
    if (!p.translation.allFinite() || !p.rotation.coeffs().allFinite()) {
      ++r_.frames_without_pose;
      continue;
    }
    const Eigen::Vector3d t = R_ * p.translation;
    const Eigen::Quaterniond q = (Rq * p.rotation * flip).normalized();
    if (times.empty()) node["translation"] = Vec(t), node["rotation"] = Quat(q);
    times.push_back(static_cast<float>((f - begin_) / o_.fps));
    for (int k = 0; k < 3; ++k) tr.push_back(static_cast<float>(t[k]));
    for (double c : {q.x(), q.y(), q.z(), q.w()}) ro.push_back(static_cast<float>(c));
  }
  if (times.empty())
    throw Error(fmt::format("{}: no frame in [{}, {}) has a finite pose", ScenePoseSource(scene_), begin_, end_));
  r_.frames = static_cast<int>(times.size());
  node["extras"]["mr"] = cam_extras;
  const int id = camera_node_ = b_.Push("nodes", node);
  roots_.push_back(id);
  if (times.size() > 1) Animate(b_, &animation_, id, times, tr, ro, nullptr);
}

// lights.json's lights (frame `begin`'s where they change per frame), the
// virtual lights, and the environment map for the Blender script.
void ShotWriter::AddLights() {
  const SceneLighting& lighting = scene_.lighting;
  std::vector<Light> lights;
  if (lighting.lights) {
    int from = 0;
    const auto file = lighting.lights_per_frame ? PerFrameFile(*lighting.lights, begin_, &from)
                                                : std::optional<fs::path>(*lighting.lights);
    if (file) lights = ReadLights(*file);
    if (lighting.lights_per_frame) report_->Warn(fmt::format("lights change per frame: frame {}'s written", from));
  }
  // Distant lights are directions of the map they came from (mr-lights): they
  // turn with it, as mr-render's LoadLights turns them; the rest stand in the world.
  for (Light l : lights) {
    if (l.type == LightType::kDistant) l.direction = lighting.world_from_env * l.direction;
    roots_.push_back(AddLight(b_, l, R_, l.is_virtual));
    ++r_.lights;
  }
  for (const SceneVirtualLight& vl : scene_.virtual_lights)
    roots_.push_back(AddLight(b_, vl.At(begin_), R_, true)), ++r_.lights;
  if (b_.json().contains("extensions")) b_.json()["extensionsUsed"] = {"KHR_lights_punctual"};
  if (lighting.environment)
    extras_["environment"] = {{"file", Relative(*lighting.environment, o_.out)},
                              {"per_frame", lighting.environment_per_frame},
                              {"scale", lighting.environment_scale},
                              {"gltf_from_map", Rows(R_ * lighting.world_from_env)},
                              {"map", "lat-long, OpenEXR's envmap: +y up, the image centre along +z"}};
}

// The plate, and its render-to-plate gains (mr-eval plate's gains.json) per
// channel and frame of the range: the Blender script scales the render by
// them before it goes over the plate, as mr-render does.
void ShotWriter::AddPlate() {
  const SceneCamera& c = scene_.camera;
  if (!c.frames) return;
  extras_["plate"] = {
      {"frames", Relative(*c.frames, o_.out)}, {"transfer", c.frames_transfer}, {"first_frame", begin_}};
  if (!c.gains || !fs::exists(*c.gains)) return;
  const Json g = Json::parse(ReadTextFile(*c.gains));
  Json frames = Json::array(), gains = Json::array();
  for (const Json& e : g.value("frames", Json::array())) {
    const int f = e.value("frame", -1);
    if (f < begin_ || f >= end_ || !e.contains("gain")) continue;
    frames.push_back(f - begin_);
    gains.push_back(e["gain"]);
  }
  extras_["plate"]["gains"] = {{"frame", frames}, {"gain", gains}, {"scale", c.gains_scale}};
  report_->AddInput(c.gains->string());
}

ShotExportResult ShotWriter::Write() {
  if (maps_) {
    std::tie(r_.undistort, r_.redistort) = WriteStMaps(*maps_, o_.out, report_);
    r_.stmap_unmapped = maps_->unmapped;
    b_.json()["nodes"][static_cast<size_t>(camera_node_)]["extras"]["mr"]["stmaps"] = {
        {"undistort", Relative(r_.undistort, o_.out)}, {"redistort", Relative(r_.redistort, o_.out)},
        {"overscan_left", maps_->overscan_left},       {"overscan_top", maps_->overscan_top},
        {"max_angle_deg", maps_->max_angle_deg},       {"unmapped_lens_pixels", maps_->unmapped}};
  }
  extras_["render"] = {{"width", pinhole_.width()},
                       {"height", pinhole_.height()},
                       {"frame_begin", begin_},
                       {"frame_end", end_},
                       {"fps", o_.fps},
                       {"frames_without_pose", r_.frames_without_pose}};
  if (!animation_["channels"].empty()) b_.Push("animations", animation_);
  b_.Push("scenes", {{"name", scene_.file.stem().string()}, {"nodes", roots_}, {"extras", {{"mr", extras_}}}});
  b_.json()["scene"] = 0;
  b_.Write(o_.out);
  report_->AddOutput(o_.out.string());
  if (o_.blender_script) {
    r_.blender_script = o_.out.parent_path() / (o_.out.stem().string() + "-blender.py");
    WriteTextFile(r_.blender_script, BlenderShotScript());
    report_->AddOutput(r_.blender_script.string());
  }
  if (!r_.perspective) report_->Warn(r_.no_perspective);
  // What the shot leaves out, and why.
  if (!maps_ && cam_.lensmodel() != "LENSMODEL_PINHOLE")
    report_->Skip("ST-maps", fmt::format("not asked (--stmaps): the camera is {}'s pinhole core, its distortion "
                                         "left to the plate",
                                         cam_.lensmodel()));
  if (!scene_.camera.frames) report_->Skip("plate", "the scene names no camera frames");
  if (!scene_.lighting.environment) report_->Skip("world", "the scene names no environment map");
  if (r_.frames_without_pose > 0)
    report_->Warn(fmt::format("{} frames have no finite pose: no camera key there", r_.frames_without_pose));
  for (const auto& [key, value] : {std::pair<const char*, int64_t>{"frames", r_.frames},
                                   {"frames_without_pose", r_.frames_without_pose},
                                   {"room_meshes", r_.room_meshes},
                                   {"objects", r_.objects},
                                   {"assets", r_.assets},
                                   {"lights", r_.lights}})
    report_->SetMetric(std::string("export.") + key, value);
  report_->SetMetric("export.perspective", r_.perspective);
  return r_;
}

}  // namespace

ShotExportResult ExportShot(const ShotExportOptions& o, Report* report) {
  if (!(o.fps > 0) || !std::isfinite(o.fps)) throw UsageError(fmt::format("--fps must be positive, not {}", o.fps));
  if (const std::string ext = LowerExtension(o.out); ext != ".glb" && ext != ".gltf")
    throw Error(fmt::format("{}: a glTF scene is written as .glb or .gltf, not '{}'", o.out.string(), ext));
  ShotWriter w(o, report);
  w.AddRoom();
  w.AddObjects();
  w.AddCamera();
  w.AddLights();
  w.AddPlate();
  return w.Write();
}

int64_t ExportLens(const fs::path& model, const fs::path& out, double max_angle_deg, Report* report) {
  if (LowerExtension(out) != ".cameramodel")
    throw Error(fmt::format("{}: a lens's pinhole is written as a .cameramodel", out.string()));
  const CameraModel lens = CameraModel::Read(model);
  const StMaps maps = MakeStMaps(lens, max_angle_deg);
  const fs::path redistort = WriteStMaps(maps, out, report).second;
  maps.pinhole.Write(out, fmt::format("the distortion-free pinhole of {} (mr-export): render through it, redistort "
                                      "with {}; overscan {} px left, {} px top",
                                      model.filename().string(), redistort.filename().string(), maps.overscan_left,
                                      maps.overscan_top));
  report->AddOutput(out.string());
  report->SetMetric("stmaps.lens", lens.Describe());
  report->SetMetric("stmaps.pinhole", maps.pinhole.Describe());
  report->SetMetric("stmaps.overscan", Json::array({maps.overscan_left, maps.overscan_top,
                                                    maps.pinhole.width() - lens.width() - maps.overscan_left,
                                                    maps.pinhole.height() - lens.height() - maps.overscan_top}));
  report->SetMetric("stmaps.unmapped_lens_pixels", maps.unmapped);
  return maps.unmapped;
}

}  // namespace mr
