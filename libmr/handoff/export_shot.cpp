#include "handoff/export_shot.h"

#include <algorithm>
#include <cmath>

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

// The camera: a perspective camera of `pinhole` (the lens's core, or the
// ST-maps' grown pinhole) where the lens cannot see 90 degrees or more from
// its axis; the principal point's offset is Blender's lens shift in extras.
Json CameraExtras(const CameraModel& lens, const CameraModel& pinhole, ShotExportResult* r) {
  const auto& in = pinhole.intrinsics();
  const double fx = in[0], fy = in[1], cx = in[2], cy = in[3];
  const double w = pinhole.width(), h = pinhole.height();
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
    // Blender's lens shift (sensor fit horizontal): in units of the
    // image's width, +y up, a pixel's height being fx / fy of its width.
    j["blender_shift"] = {-(cx - (w - 1) / 2) / w, (cy - (h - 1) / 2) * (fx / fy) / w};
  }
  j["perspective"] = r->perspective;
  if (!r->perspective) j["no_perspective"] = r->no_perspective;
  return j;
}

}  // namespace

ShotExportResult ExportShot(const ShotExportOptions& o, Report* report) {
  if (!(o.fps > 0) || !std::isfinite(o.fps)) throw UsageError(fmt::format("--fps must be positive, not {}", o.fps));
  // Refused before anything is written (the ST-maps come first).
  if (const std::string ext = LowerExtension(o.out); ext != ".glb" && ext != ".gltf")
    throw Error(fmt::format("{}: a glTF scene is written as .glb or .gltf, not '{}'", o.out.string(), ext));
  const Scene scene = ReadScene(o.scene);
  const CameraModel cam = CameraModel::Read(scene.camera.model);
  const std::vector<Rigid3> poses = LoadScenePoses(scene);
  const int n = static_cast<int>(poses.size());
  const int begin = o.frame_begin, end = o.frame_end < 0 ? n : o.frame_end;
  if (begin < 0 || begin >= end || end > n)
    throw Error(fmt::format("{}: frames [{}, {}) are outside the {} poses of {}", o.scene.string(), begin, end, n,
                            ScenePoseSource(scene)));
  ShotExportResult r;
  GltfBuilder b;
  // glTF is +y up: the world turned so that its up (the environment's
  // zenith) is +y; identity for a world that is +y up already.
  const Eigen::Vector3d up = (scene.lighting.world_from_env * Eigen::Vector3d::UnitY()).normalized();
  const Eigen::Matrix3d R = Eigen::Quaterniond::FromTwoVectors(up, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Quaterniond Rq(R);
  Json roots = Json::array();
  Json extras = {{"units", "metres; light in the scene's radiometric units (extras), not glTF's photometric ones"}};
  Json gw = Json::array();
  for (int i = 0; i < 3; ++i) gw.push_back({R(i, 0), R(i, 1), R(i, 2)});
  extras["gltf_from_world"] = gw;

  // The room: each real mesh, marked so that a user makes it a shadow catcher.
  for (size_t i = 0; i < scene.reals.size(); ++i) {
    const SceneReal& real = scene.reals[i];
    const Mesh m = ReadMesh(real.mesh);
    const bool colors = real.material.albedo_from_vertex_colors && !m.colors.empty();
    const std::string name = scene.reals.size() == 1 ? "room" : fmt::format("room.{}", i);
    const int mat = b.Push("materials", PbrMaterial(name, real.material, colors));
    const int mesh = AddMesh(b, name, m, R.cast<float>(), mat, colors);
    roots.push_back(b.Push(
        "nodes",
        {{"name", name},
         {"mesh", mesh},
         {"extras", {{"mr", {{"role", "room"}, {"shadow_catcher", true}, {"source", Relative(real.mesh, o.out)}}}}}}));
    ++r.room_meshes;
  }

  // The virtual objects: a mesh with mr's material, or an asset's own file
  // (glTF, OBJ with MTL) referenced for the Blender script to import.
  Json animation = {{"name", "shot"}, {"samplers", Json::array()}, {"channels", Json::array()}};
  std::vector<float> times;
  for (int f = begin; f < end; ++f) times.push_back(static_cast<float>((f - begin) / o.fps));
  for (const SceneVirtual& v : scene.virtuals) {
    Json node = {{"name", v.name}};
    Json mr = {{"role", "object"}, {"source", Relative(v.mesh, o.out)}};
    const std::string ext = LowerExtension(v.mesh);
    const bool gltf_asset = v.file_materials && (ext == ".glb" || ext == ".gltf");
    if (v.file_materials && !gltf_asset) {
      mr["asset"] = Relative(v.mesh, o.out);  // an OBJ's MTL: imported by the Blender script onto this node
      ++r.assets;
    } else if (gltf_asset) {
      mr["asset_embedded"] = true;  // merged below, its own materials and textures with it
      ++r.assets;
    } else {
      const Mesh m = ReadMesh(v.mesh);
      const int mat = b.Push("materials", PbrMaterial(v.name, v.material, false));
      node["mesh"] = AddMesh(b, v.name, m, Eigen::Matrix3f::Identity(), mat, false);
    }
    auto trs = [&](double frame, Eigen::Vector3d* t, Eigen::Quaterniond* q, Eigen::Vector3d* s) {
      Eigen::Affine3d a = v.WorldFromObjectAt(frame);
      a.linear() = R * a.linear();
      a.translation() = R * a.translation();
      Decompose(a, t, q, s);
    };
    Eigen::Vector3d t, s;
    Eigen::Quaterniond q;
    trs(begin, &t, &q, &s);
    node["translation"] = Vec(t);
    node["rotation"] = Quat(q);
    node["scale"] = Vec(s);
    node["extras"]["mr"] = mr;
    const int id = b.Push("nodes", node);
    roots.push_back(id);
    if (gltf_asset) {
      const std::string note = b.MergeAsset(v.mesh, id);
      if (!note.empty()) report->Warn(fmt::format("{}: {}", v.mesh.string(), note));
    }
    if (!v.keyframes.empty()) {
      std::vector<float> tr, ro, sc;
      for (int f = begin; f < end; ++f) {
        trs(f, &t, &q, &s);
        for (int k = 0; k < 3; ++k) tr.push_back(static_cast<float>(t[k])), sc.push_back(static_cast<float>(s[k]));
        for (double c : {q.x(), q.y(), q.z(), q.w()}) ro.push_back(static_cast<float>(c));
      }
      Animate(b, &animation, id, times, tr, ro, &sc);
    }
    ++r.objects;
  }

  // The lens as ST-maps, and the pinhole they render through.
  CameraModel pinhole("LENSMODEL_PINHOLE", {cam.Core()[0], cam.Core()[1], cam.Core()[2], cam.Core()[3]}, cam.width(),
                      cam.height());
  Json stmaps;
  if (o.stmaps) {
    const StMaps maps = MakeStMaps(cam, o.stmap_max_angle_deg);
    pinhole = maps.pinhole;
    r.undistort = o.out.parent_path() / (o.out.stem().string() + "-undistort.exr");
    r.redistort = o.out.parent_path() / (o.out.stem().string() + "-redistort.exr");
    WriteImage(r.undistort, maps.undistort);
    WriteImage(r.redistort, maps.redistort);
    report->AddOutput(r.undistort.string());
    report->AddOutput(r.redistort.string());
    r.stmap_unmapped = maps.unmapped;
    stmaps = {{"undistort", Relative(r.undistort, o.out)}, {"redistort", Relative(r.redistort, o.out)},
              {"overscan_left", maps.overscan_left},       {"overscan_top", maps.overscan_top},
              {"max_angle_deg", maps.max_angle_deg},       {"unmapped_lens_pixels", maps.unmapped}};
    if (maps.unmapped > 0)
      report->Warn(fmt::format("{} of the lens's pixels see beyond {} degrees from its axis: not in the ST-maps",
                               maps.unmapped, maps.max_angle_deg));
  }

  // The camera, a key per frame with a pose.  glTF's camera looks along
  // its -z with +y up; mr's along +z with +y down: a half turn about x.
  Json cam_extras = CameraExtras(cam, pinhole, &r);
  if (!stmaps.is_null()) {
    cam_extras["stmaps"] = stmaps;
    if (!r.perspective) {  // the maps' pinhole holds the part within the widest angle
      r.perspective = true;
      cam_extras["perspective"] = true;
      const double fx = pinhole.Core()[0], fy = pinhole.Core()[1];
      const double w = pinhole.width(), h = pinhole.height();
      cam_extras["blender_shift"] = {-(pinhole.Core()[2] - (w - 1) / 2) / w,
                                     (pinhole.Core()[3] - (h - 1) / 2) * (fx / fy) / w};
      cam_extras["no_perspective"] =
          r.no_perspective +
          fmt::format("; with the ST-maps, the part within {} degrees of its axis is rendered", o.stmap_max_angle_deg);
    }
  }
  Json cam_node = {{"name", "camera"}};
  if (r.perspective) {
    const double fx = pinhole.Core()[0], fy = pinhole.Core()[1];
    const double w = pinhole.width(), h = pinhole.height();
    cam_node["camera"] = b.Push(
        "cameras", {{"name", "camera"},
                    {"type", "perspective"},
                    {"perspective",
                     {{"yfov", 2 * std::atan(h / (2 * fy))}, {"aspectRatio", (w * fy) / (h * fx)}, {"znear", 0.01}}}});
  }
  const Eigen::Quaterniond flip(0, 1, 0, 0);  // w, x, y, z: a half turn about x
  std::vector<float> ctimes, ctr, cro;
  for (int f = begin; f < end; ++f) {
    const Rigid3& p = poses[static_cast<size_t>(f)];
    if (!p.translation.allFinite() || !p.rotation.coeffs().allFinite()) {
      ++r.frames_without_pose;
      continue;
    }
    const Eigen::Vector3d t = R * p.translation;
    const Eigen::Quaterniond q = (Rq * p.rotation * flip).normalized();
    if (ctimes.empty()) cam_node["translation"] = Vec(t), cam_node["rotation"] = Quat(q);
    ctimes.push_back(static_cast<float>((f - begin) / o.fps));
    for (int k = 0; k < 3; ++k) ctr.push_back(static_cast<float>(t[k]));
    for (double c : {q.x(), q.y(), q.z(), q.w()}) cro.push_back(static_cast<float>(c));
  }
  if (ctimes.empty())
    throw Error(fmt::format("{}: no frame in [{}, {}) has a finite pose", ScenePoseSource(scene), begin, end));
  r.frames = static_cast<int>(ctimes.size());
  cam_node["extras"]["mr"] = cam_extras;
  const int cam_id = b.Push("nodes", cam_node);
  roots.push_back(cam_id);
  if (ctimes.size() > 1) Animate(b, &animation, cam_id, ctimes, ctr, cro, nullptr);

  // The light: lights.json's (frame `begin`'s where they change per frame),
  // the virtual lights, and the environment map for the Blender script.
  std::vector<Light> lights;
  if (scene.lighting.lights) {
    int from = 0;
    const auto file = scene.lighting.lights_per_frame ? PerFrameFile(*scene.lighting.lights, begin, &from)
                                                      : std::optional<fs::path>(*scene.lighting.lights);
    if (file) lights = ReadLights(*file);
    if (scene.lighting.lights_per_frame) report->Warn(fmt::format("lights change per frame: frame {}'s written", from));
  }
  // Distant lights are directions of the map they came from (mr-lights): they
  // turn with it, as mr-render's LoadLights turns them; the rest stand in the world.
  for (Light l : lights) {
    if (l.type == LightType::kDistant) l.direction = scene.lighting.world_from_env * l.direction;
    roots.push_back(AddLight(b, l, R, l.is_virtual));
    ++r.lights;
  }
  for (const SceneVirtualLight& vl : scene.virtual_lights)
    roots.push_back(AddLight(b, vl.At(begin), R, true)), ++r.lights;
  if (b.json().contains("extensions")) b.json()["extensionsUsed"] = {"KHR_lights_punctual"};
  if (scene.lighting.environment) {
    const Eigen::Matrix3d gm = R * scene.lighting.world_from_env;
    Json m = Json::array();
    for (int i = 0; i < 3; ++i) m.push_back({gm(i, 0), gm(i, 1), gm(i, 2)});
    extras["environment"] = {{"file", Relative(*scene.lighting.environment, o.out)},
                             {"per_frame", scene.lighting.environment_per_frame},
                             {"scale", scene.lighting.environment_scale},
                             {"gltf_from_map", m},
                             {"map", "lat-long, OpenEXR's envmap: +y up, the image centre along +z"}};
  }
  if (scene.camera.frames) {
    extras["plate"] = {{"frames", Relative(*scene.camera.frames, o.out)},
                       {"transfer", scene.camera.frames_transfer},
                       {"first_frame", begin}};
    // The render-to-plate gains (mr-eval plate's gains.json), per channel
    // and frame of the range: the Blender script scales the render by them
    // before it goes over the plate, as mr-render does.
    if (scene.camera.gains && fs::exists(*scene.camera.gains)) {
      const Json g = Json::parse(ReadTextFile(*scene.camera.gains));
      Json frames = Json::array(), gains = Json::array();
      for (const Json& e : g.value("frames", Json::array())) {
        const int f = e.value("frame", -1);
        if (f < begin || f >= end || !e.contains("gain")) continue;
        frames.push_back(f - begin);
        gains.push_back(e["gain"]);
      }
      extras["plate"]["gains"] = {{"frame", frames}, {"gain", gains}, {"scale", scene.camera.gains_scale}};
      report->AddInput(scene.camera.gains->string());
    }
  }
  extras["render"] = {{"width", cam.width()}, {"height", cam.height()}, {"frame_begin", begin},
                      {"frame_end", end},     {"fps", o.fps},           {"frames_without_pose", r.frames_without_pose}};
  if (!animation["channels"].empty()) b.Push("animations", animation);
  b.Push("scenes", {{"name", scene.file.stem().string()}, {"nodes", roots}, {"extras", {{"mr", extras}}}});
  b.json()["scene"] = 0;
  b.Write(o.out);
  report->AddOutput(o.out.string());
  if (o.blender_script) {
    r.blender_script = o.out.parent_path() / (o.out.stem().string() + "-blender.py");
    WriteTextFile(r.blender_script, BlenderShotScript());
    report->AddOutput(r.blender_script.string());
  }
  if (!r.perspective) report->Warn(r.no_perspective);
  if (r.frames_without_pose > 0)
    report->Warn(fmt::format("{} frames have no finite pose: no camera key there", r.frames_without_pose));
  report->SetMetric("export.frames", r.frames);
  report->SetMetric("export.frames_without_pose", r.frames_without_pose);
  report->SetMetric("export.perspective", r.perspective);
  report->SetMetric("export.room_meshes", r.room_meshes);
  report->SetMetric("export.objects", r.objects);
  report->SetMetric("export.assets", r.assets);
  report->SetMetric("export.lights", r.lights);
  return r;
}

int64_t ExportLens(const fs::path& model, const fs::path& out, double max_angle_deg, Report* report) {
  if (LowerExtension(out) != ".cameramodel")
    throw Error(fmt::format("{}: a lens's pinhole is written as a .cameramodel", out.string()));
  const CameraModel lens = CameraModel::Read(model);
  const StMaps maps = MakeStMaps(lens, max_angle_deg);
  const fs::path undistort = out.parent_path() / (out.stem().string() + "-undistort.exr");
  const fs::path redistort = out.parent_path() / (out.stem().string() + "-redistort.exr");
  WriteImage(undistort, maps.undistort);
  WriteImage(redistort, maps.redistort);
  maps.pinhole.Write(out, fmt::format("the distortion-free pinhole of {} (mr-export): render through it, redistort "
                                      "with {}; overscan {} px left, {} px top",
                                      model.filename().string(), redistort.filename().string(), maps.overscan_left,
                                      maps.overscan_top));
  for (const auto& f : {out, undistort, redistort}) report->AddOutput(f.string());
  report->SetMetric("stmaps.lens", lens.Describe());
  report->SetMetric("stmaps.pinhole", maps.pinhole.Describe());
  report->SetMetric("stmaps.overscan", Json::array({maps.overscan_left, maps.overscan_top,
                                                    maps.pinhole.width() - lens.width() - maps.overscan_left,
                                                    maps.pinhole.height() - lens.height() - maps.overscan_top}));
  report->SetMetric("stmaps.unmapped_lens_pixels", maps.unmapped);
  if (maps.unmapped > 0)
    report->Warn(fmt::format("{} of the lens's pixels see beyond {} degrees from its axis: not in the ST-maps",
                             maps.unmapped, max_angle_deg));
  return maps.unmapped;
}

}  // namespace mr
