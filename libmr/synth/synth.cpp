#include "synth/synth.h"
#include "core/check.h"
#include "synth/bracket.h"
#include "synth/rgbd_view.h"
#include "synth/sphere_view.h"

#include <spdlog/spdlog.h>

#include "camera/camera_model.h"
#include "camera/trajectory.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "core/spherical.h"
#include "core/video.h"
#include "geometry/mesh.h"
#include "geometry/primitives.h"
#include "hdr/exposures_file.h"
#include "light/light_source.h"
#include "light/lights_file.h"
#include "render/error_curve.h"
#include "render/path_tracer.h"
#include "render/pt.h"
#include "render/render_scene.h"
#include "render/world.h"
#include "scene/scene.h"

namespace mr {

SynthPreset GetSynthPreset(const std::string& name) {
  if (name == "small") return {64, 48, 2, 256, 16, 1e4};
  if (name == "medium") return {320, 240, 2, 256, 16, 1e4};
  if (name == "room") return {640, 480, 4, 1024, 64, 1e6};
  throw UsageError(fmt::format("unknown preset \"{}\" (small, medium, room)", name));
}

namespace {

Mesh Sphere(float r, int n) {
  Mesh m;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= 2 * n; ++j) {
      const double th = kPi * i / n, ph = kPi * j / n;
      m.positions.emplace_back(static_cast<float>(r * std::sin(th) * std::cos(ph)),
                               static_cast<float>(r * std::cos(th)),
                               static_cast<float>(r * std::sin(th) * std::sin(ph)));
    }
  const int row = 2 * n + 1;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < 2 * n; ++j) {
      int a = i * row + j, b = a + row;
      if (i > 0) m.triangles.push_back({a, a + 1, b});
      if (i < n - 1) m.triangles.push_back({a + 1, b + 1, b});
    }
  return m;
}

// The sky: a vertical gradient, a dim ground below the horizon and a sun of
// one pixel `sun_to_sky` times brighter than the sky at the zenith.
Image SkyMap(int w, int h, double sun_to_sky, int* sun_x, int* sun_y, int sun_shift = 0) {
  Image img = Image::Rgb(w, h);
  for (int y = 0; y < h; ++y) {
    const double lat = kPi / 2 - y * kPi / (h - 1);
    for (int x = 0; x < w; ++x) {
      Eigen::Vector3d c;
      if (lat >= 0)
        c = Eigen::Vector3d(0.35, 0.5, 0.9) * (0.6 + 0.4 * std::sin(lat));
      else
        c = Eigen::Vector3d(0.25, 0.22, 0.2);
      for (int k = 0; k < 3; ++k) img.at(x, y, k) = static_cast<float>(c[k]);
    }
  }
  *sun_x = w / 3 + sun_shift;
  *sun_y = h / 5;  // ~54 degrees up
  const double zenith_sky = 0.9;
  for (int k = 0; k < 3; ++k)
    img.at(*sun_x, *sun_y, k) = static_cast<float>(sun_to_sky * zenith_sky * (k == 2 ? 0.9 : 1.0));
  return img;
}

Json MaterialJson(const Material& m) {
  Json j = {{"albedo", {m.albedo.x(), m.albedo.y(), m.albedo.z()}}};
  if (m.IsGlossy()) {
    j["specular"] = {m.specular.x(), m.specular.y(), m.specular.z()};
    j["roughness"] = m.roughness;
  }
  return j;
}

Material Diffuse(double r, double g, double b) {
  Material m;
  m.albedo = Eigen::Vector3d(r, g, b);
  return m;
}

}  // namespace

namespace {

// The light camera's bracket: exposure times and what mr-hdr needs to know.
// The sun reflected in the sphere (about 600 x the sky after the lens blur)
// saturates even the shortest: mr-hdr must bound it from the ring.
const std::vector<double> kProbeTimes = {1, 0.25, 0.0625, 0.015625};

void WriteBracket(const fs::path& dir, const std::string& prefix, const Image& radiance, uint64_t seed,
                  const ImageWriteOptions& wo, Report* report) {
  BracketOptions bo;
  bo.times = kProbeTimes;
  bo.blur_px = 1.0;
  bo.seed = seed;
  const std::vector<Exposure> bracket = SynthesiseBracket(radiance, bo);
  fs::create_directories(dir);
  std::vector<std::pair<std::string, double>> times;
  ImageWriteOptions raw = wo;
  raw.ldr_transfer = Transfer::kLinear;  // the values are already the camera's codes
  for (size_t k = 0; k < bracket.size(); ++k) {
    const std::string name = fmt::format("{}-{}.png", prefix, k);
    WriteImage(dir / name, bracket[k].codes, raw);
    times.emplace_back(name, bracket[k].time_s);
    report->AddOutput((dir / name).string());
  }
  WriteExposures(dir / "exposures.txt", times, "exposure times (s) of the bracket, for mr-hdr --exposures");
}

}  // namespace

std::vector<SynthPart> SynthRoom(bool glossy_table) {
  // The room: floor, back and left walls (open to the sky above, in front and to the right),
  // a table with a glossy top, two boxes of known albedo.
  Material glossy = Diffuse(0.15, 0.15, 0.18);
  glossy.specular = Eigen::Vector3d::Constant(glossy_table ? 0.6 : 0.0);
  glossy.roughness = 0.25;
  std::vector<SynthPart> parts = {
      {"floor", Quad({-3, 0, -3}, {-3, 0, 3}, {3, 0, 3}, {3, 0, -3}), Diffuse(0.55, 0.5, 0.45)},
      {"wall_back", Quad({-3, 0, 3}, {-3, 2.5f, 3}, {3, 2.5f, 3}, {3, 0, 3}), Diffuse(0.7, 0.7, 0.65)},
      {"wall_left", Quad({-3, 0, -3}, {-3, 2.5f, -3}, {-3, 2.5f, 3}, {-3, 0, 3}), Diffuse(0.6, 0.25, 0.2)},
      {"table_top", Box({-0.6f, 0.70f, -0.4f}, {0.6f, 0.75f, 0.4f}), glossy},
      {"table_legs", Box({-0.55f, 0, -0.35f}, {-0.5f, 0.7f, -0.3f}), Diffuse(0.3, 0.2, 0.1)},
      {"box_green", Box({1.2f, 0, 0.8f}, {1.7f, 0.5f, 1.3f}), Diffuse(0.2, 0.6, 0.25)},
      {"box_blue", Box({-2.0f, 0, 1.0f}, {-1.5f, 0.35f, 1.5f}), Diffuse(0.15, 0.25, 0.7)},
  };
  for (int leg = 1; leg < 4; ++leg) {  // the other three legs
    const float sx = leg & 1 ? 1.0f : -1.0f, sz = leg & 2 ? 1.0f : -1.0f;
    Mesh l = Box({sx * 0.5f - 0.025f, 0, sz * 0.325f - 0.025f}, {sx * 0.5f + 0.025f, 0.7f, sz * 0.325f + 0.025f});
    const int base = static_cast<int>(parts[4].mesh.positions.size());
    for (auto& v : l.positions) parts[4].mesh.positions.push_back(v);
    for (auto t : l.triangles) parts[4].mesh.triangles.push_back(t + Eigen::Vector3i::Constant(base));
  }

  return parts;
}

Mesh MergeParts(const std::vector<SynthPart>& parts) {
  Mesh room;
  for (const auto& part : parts) {
    const int base = static_cast<int>(room.positions.size());
    room.positions.insert(room.positions.end(), part.mesh.positions.begin(), part.mesh.positions.end());
    for (const auto& t : part.mesh.triangles) room.triangles.push_back(t + Eigen::Vector3i::Constant(base));
  }
  return room;
}

void WriteProbe(const SynthOptions& o, const Image& sky, Report* report) {
  ImageWriteOptions wo;
  wo.tool = o.tool;
  wo.command_line = o.command_line;
  const std::string note =
      fmt::format("written by {} ({}); preset {}, seed {}", o.tool, o.command_line, o.preset, o.seed);
  const Eigen::Matrix3d world_from_light = Eigen::Vector3d(1, -1, -1).asDiagonal();
  CameraModel light("LENSMODEL_STEREOGRAPHIC", {134, 134, 319.5, 319.5}, 640, 640);
  light.set_cam_from_ref(Rigid3(Eigen::Quaterniond(world_from_light.transpose()), Eigen::Vector3d::Zero()));
  const Eigen::Vector3d centre(0.04, -0.02, 0.12);
  const double radius = 0.0254, reflectance = 0.6, body = 0.02;
  const EnvironmentMap env(sky, "sky");
  SphereViewOptions so;
  so.supersample = 3;
  so.world_from_cam = world_from_light;
  so.reflectance = reflectance;
  so.camera_body_radius = body;
  so.seed = o.seed;
  fs::create_directories(o.out / "probe");
  light.Write(o.out / "probe" / "light.cameramodel", note);
  // One render: the bracket adds the sensor's noise, sphere.exr 1% of its own.
  const Image sphere = RenderSphereView(env, light, centre, radius, so);
  WriteBracket(o.out / "probe" / "bracket", "sphere", sphere, o.seed, wo, report);
  Image noisy = sphere;
  AddRelativeNoise(&noisy, 0.01, o.seed);
  WriteImage(o.out / "probe" / "sphere.exr", noisy, wo);
  // The fish-eye at the zenith: camera z along world +y, camera y along -z.
  CameraModel up = light;
  Eigen::Matrix3d world_from_up;
  world_from_up << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  up.set_cam_from_ref(Rigid3(Eigen::Quaterniond(world_from_up.transpose()), Eigen::Vector3d::Zero()));
  up.Write(o.out / "probe" / "fisheye.cameramodel", note);
  so.world_from_cam = world_from_up;
  so.camera_body_radius = 0;
  so.supersample = 2;  // no silhouette to resolve
  WriteBracket(o.out / "probe" / "fisheye", "sky", RenderEnvironmentView(env, up, so), HashCombine(o.seed, 99), wo,
               report);
  Json times = Json::array();
  for (double t : kProbeTimes) times.push_back(t);
  WriteTextFile(
      o.out / "probe" / "truth.json",
      Json({{"radius_m", radius},
            {"centre_cam_m", {centre.x(), centre.y(), centre.z()}},
            {"reflectance", reflectance},
            {"camera_body_radius_m", body},
            {"environment", "../env.exr"},
            {"bracket",
             {{"times_s", times}, {"response", "sRGB curve, saturating at exposure 1"}, {"blur_px", 1.0}, {"bits", 8}}},
            {"comment", note}})
              .dump(2) +
          "\n");
  for (const char* f2 :
       {"probe/light.cameramodel", "probe/sphere.exr", "probe/truth.json", "probe/fisheye.cameramodel"})
    report->AddOutput((o.out / f2).string());
}

SynthCapture MakeSynthCapture(const SynthOptions& o) {
  SynthCapture c;
  SynthPreset& p = c.preset;
  p = GetSynthPreset(o.preset);
  if (o.frames > 0) p.frames = o.frames;
  c.truth_spp = o.truth_spp > 0 ? o.truth_spp : p.truth_spp;
  o.Check();
  c.parts = SynthRoom(o.table_top == "glossy");
  if (o.plate_sphere) {
    // Facets of 1.9 degrees: a pixel of the medium preset's plate spans
    // about 4 degrees of the sphere's normals at its centre, more towards
    // the rim, so the (flat-shaded) facets stay below what the plate resolves.
    const SynthPlateSphere sp;
    c.plate_sphere = sp;
    Mesh m = Sphere(static_cast<float>(sp.radius), 96);
    for (auto& v : m.positions) v += sp.centre.cast<float>();
    Material mirror = Diffuse(0, 0, 0);
    mirror.specular = Eigen::Vector3d::Constant(sp.reflectance);
    mirror.roughness = sp.roughness;
    c.parts.push_back({"plate_sphere", m, mirror});
  }
  // The virtual object, resting on the table.
  Mesh& object = c.object;
  fs::path object_file;
  if (o.object == "sphere") {
    object = Sphere(0.15f, 24);
  } else if (o.object == "box") {
    object = Box({-0.12f, -0.12f, -0.12f}, {0.12f, 0.12f, 0.12f});
  } else {
    object_file = o.object;
    object = ReadMesh(object_file);
  }
  const auto ob = object.Bounds();
  const double size = static_cast<double>((ob.max() - ob.min()).maxCoeff());
  const double scale = 0.3 / std::max(size, 1e-9);  // about 30 cm across
  Eigen::Affine3d& world_from_object = c.world_from_object;
  world_from_object = Eigen::Affine3d::Identity();
  c.object_rests_on = Eigen::Vector3d(0.1, 0.75, 0.0);  // on the table top, its footprint centred there
  c.object_scale = scale;
  const Eigen::Vector3d object_at =
      c.object_rests_on + Eigen::Vector3d(0, -scale * static_cast<double>(ob.min().y()), 0);
  // Placed as scene.json's transform.rest_on places an object: turned 0.5
  // rad about y and scaled, its lowest point on the table top, the box
  // around it centred on object_rests_on across y (so that a scene placing
  // the user's mesh with rest_on, the same rotation and scale, matches the
  // truth).
  c.object_rotation_deg = Eigen::Vector3d(0, 0.5 / kDegToRad, 0);
  const Eigen::Matrix3d linear = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()).toRotationMatrix() * scale;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const Eigen::Vector3f& v : object.positions) {
    lo = lo.cwiseMin(linear * v.cast<double>());
    hi = hi.cwiseMax(linear * v.cast<double>());
  }
  world_from_object.linear() = linear;
  world_from_object.translation() =
      c.object_rests_on - Eigen::Vector3d((lo.x() + hi.x()) / 2, lo.y(), (lo.z() + hi.z()) / 2);
  Eigen::Vector3d oc = 0.5 * (ob.min() + ob.max()).cast<double>();
  const Eigen::Vector3d object_centre(oc.x(), 0, oc.z());
  const double object_scale = scale;
  Material& object_material = c.object_material;
  object_material = Diffuse(0.8, 0.75, 0.7);
  if (o.object_material == "glossy") {
    object_material = Diffuse(0.25, 0.22, 0.2);
    object_material.specular = Eigen::Vector3d::Constant(0.6);
    object_material.roughness = 0.3;
  } else if (o.object_material == "mirror") {
    object_material = Diffuse(0.02, 0.02, 0.02);
    object_material.specular = Eigen::Vector3d::Constant(0.9);
    object_material.roughness = 0.05;
  } else if (o.object_material != "diffuse") {
    throw UsageError(fmt::format("unknown object material \"{}\" (diffuse, glossy, mirror)", o.object_material));
  }

  // Lighting, camera and path.
  int sun_x, sun_y;
  c.sky = SkyMap(256, 129, p.sun_to_sky, &sun_x, &sun_y);
  std::vector<Light>& lights = c.lights;
  if (o.spot_light || o.dynamic) {  // a warm lamp up and to the right, aimed at the table
    Light spot;
    spot.name = "spot";
    spot.type = LightType::kSpot;
    spot.position = Eigen::Vector3d(1.6, 2.4, -0.6);
    spot.direction = (Eigen::Vector3d(0.1, 0.75, 0.0) - spot.position).normalized();
    spot.cone_deg = 35;
    spot.falloff_start_deg = 25;
    // About 10x the sky's irradiance on the table top.
    spot.intensity = Eigen::Vector3d(1.0, 0.85, 0.6) * 60.0;
    lights.push_back(spot);
  }
  const double f = 0.9 * p.width;  // ~58 degree horizontal field of view
  const double cx = (p.width - 1) / 2.0, cy = (p.height - 1) / 2.0;
  if (o.lens == "opencv4")
    c.camera = CameraModel("LENSMODEL_OPENCV4", {f, f, cx, cy, -0.02, 0.005, 0, 0}, p.width, p.height);
  else if (o.lens == "pinhole")
    c.camera = CameraModel("LENSMODEL_PINHOLE", {f, f, cx, cy}, p.width, p.height);
  else
    throw UsageError(fmt::format("unknown lens \"{}\" (opencv4, pinhole)", o.lens));
  Trajectory& traj = c.trajectory;
  const Eigen::Vector3d target(0, 0.8, 0.2);
  for (int i = 0; i < p.frames; ++i) {
    const Eigen::Vector3d eye(-0.4 + 0.8 * i / std::max(1, p.frames - 1), 1.5, -2.2);
    const Eigen::Vector3d z = (target - eye).normalized();
    const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized() * -1.0;  // camera x to the right
    const Eigen::Vector3d y = z.cross(x);                                             // camera y down
    Eigen::Matrix3d R;
    R.col(0) = x;
    R.col(1) = y;
    R.col(2) = z;
    traj.poses.push_back({i / 30.0, Rigid3(Eigen::Quaterniond(R), eye)});
  }
  if (o.dynamic) {
    // The sun 2 map pixels (2.8 degrees) west per frame; the lamp on from
    // the middle frame; the object 0.4 m across the table and a quarter turn.
    for (int i = 0; i < p.frames; ++i) {
      c.skies.push_back(SkyMap(256, 129, p.sun_to_sky, &sun_x, &sun_y, 2 * i));
      c.lamp_on.push_back(i >= p.frames / 2);
    }
    // world_from_object = T R S T(-centre): the centring folded into each
    // keyframe's translation (T - R S centre).
    auto key = [&](double frame, const Eigen::Vector3d& t, double yaw) {
      ObjectKeyframe k;
      k.frame = frame;
      k.rotation = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY());
      k.scale = Eigen::Vector3d::Constant(object_scale);
      k.translation = t - k.rotation * (object_scale * object_centre);
      return k;
    };
    c.keyframes = {key(0, object_at - Eigen::Vector3d(0.2, 0, 0), 0.5),
                   key(std::max(1, p.frames - 1), object_at + Eigen::Vector3d(0.2, 0, 0.1), 0.5 + kPi / 2)};
  }

  return c;
}

// The light camera's video of a dynamic capture (docs/formats.md,
// "Synthetic captures"): a 200-degree stereographic fish-eye at the zenith
// (probe/fisheye.cameramodel's orientation), 160x160, seeing each frame's
// sky; 30 fps, 4 ms after the plate; auto-exposure stepping through 1, 0.7
// and 1.4 (exposures.txt; frame 0's is 1, so the maps are in radiance);
// 2% noise; frame 2 dropped by the capture (frames.txt lists the rest).
void WriteLightVideo(const SynthOptions& o, const SynthCapture& c, const std::string& note, Report* report) {
  const fs::path dir = o.out / "lightcam";
  std::error_code ec;
  fs::create_directories(dir, ec);
  CameraModel up("LENSMODEL_STEREOGRAPHIC", {33.5, 33.5, 79.5, 79.5}, 160, 160);
  Eigen::Matrix3d world_from_up;
  world_from_up << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  up.set_cam_from_ref(Rigid3(Eigen::Quaterniond(world_from_up.transpose()), Eigen::Vector3d::Zero()));
  up.Write(dir / "fisheye.cameramodel", note);
  ImageWriteOptions wo;
  wo.tool = o.tool;
  wo.command_line = o.command_line;
  SphereViewOptions so;
  so.world_from_cam = world_from_up;
  so.supersample = 16;  // a pixel integrates the one-pixel sun: 256 samples keep its energy to about 3%
  std::string list = "# timestamp path: the light camera's frames (" + note + ")\n";
  std::vector<std::pair<std::string, double>> times;
  const double steps[] = {1.0, 0.7, 1.4};
  for (size_t i = 0; i < c.skies.size(); ++i) {
    if (i == 2 && c.skies.size() > 3) continue;  // dropped
    so.exposure = steps[i % 3];
    Image view = RenderEnvironmentView(EnvironmentMap(c.skies[i], "sky"), up, so);
    AddRelativeNoise(&view, 0.02, HashCombine(o.seed, 0x6c69676874ULL + i));
    const std::string name = fmt::format("{:05d}.exr", i);
    WriteImage(dir / name, view, wo);
    list += fmt::format("{:.6f} {}\n", static_cast<double>(i) / 30.0 + 0.004, name);
    times.emplace_back(name, so.exposure);
  }
  WriteTextFile(dir / "frames.txt", list);
  WriteExposures(dir / "exposures.txt", times, "the light camera's auto-exposure, relative to frame 0");
  for (const char* f : {"fisheye.cameramodel", "frames.txt", "exposures.txt"}) report->AddOutput((dir / f).string());
}

void WriteSynthInputs(const SynthOptions& o, const SynthCapture& c, const std::string& note, Report* report) {
  ScopedTimer t(report, "write inputs");
  Json reals = Json::array();
  for (const auto& part : c.parts) {
    const fs::path mesh_path = o.out / "meshes" / (part.name + ".ply");
    WritePly(mesh_path, part.mesh, note);
    reals.push_back({{"mesh", "meshes/" + part.name + ".ply"}, {"material", MaterialJson(part.material)}});
    report->AddOutput(mesh_path.string());
  }
  WritePly(o.out / "meshes" / "object.ply", c.object, note);
  c.camera.Write(o.out / "camera.cameramodel", note);
  WriteTum(o.out / "trajectory.txt", c.trajectory);
  ImageWriteOptions wo;
  wo.tool = o.tool;
  wo.command_line = o.command_line;
  WriteImage(o.out / "env.exr", c.sky, wo);
  if (!c.lights.empty()) {
    WriteTextFile(o.out / "lights.json", LightsToJson(c.lights, note).dump(2) + "\n");
    report->AddOutput((o.out / "lights.json").string());
  }
  Json scene = {{"version", 1},
                {"comment", "synthetic capture (" + note + ")"},
                {"camera",
                 {{"model", "camera.cameramodel"},
                  {"frames", "photos/%05d.exr"},
                  {"frames_transfer", "linear"},
                  {"poses", {{"format", "tum"}, {"path", "trajectory.txt"}}}}},
                {"lighting", {{"environment", "env.exr"}}},
                {"real", reals},
                {"virtual", Json::array({{{"name", "object"},
                                          {"mesh", "meshes/object.ply"},
                                          {"transform", {{"matrix", Json::array()}}},
                                          {"material", MaterialJson(c.object_material)}}})},
                {"render", {{"method", "pt"}, {"spp", c.preset.render_spp}, {"max_depth", 8}, {"seed", o.seed}}},
                {"output", {{"dir", "render"}, {"png", true}}},
                {"reference", "truth/%05d.exr"}};
  if (!c.lights.empty()) scene["lighting"]["lights"] = "lights.json";
  Json& mat = scene["virtual"][0]["transform"]["matrix"];
  for (int r = 0; r < 4; ++r)
    for (int k = 0; k < 4; ++k) mat.push_back(c.world_from_object.matrix()(r, k));
  if (!c.skies.empty()) {
    // The world per frame: a map and a lights file for every frame, the
    // object's trajectory.
    std::error_code ec;
    fs::create_directories(o.out / "env", ec);
    fs::create_directories(o.out / "lights", ec);
    for (size_t i = 0; i < c.skies.size(); ++i) {
      WriteImage(o.out / "env" / fmt::format("{:05d}.exr", i), c.skies[i], wo);
      const std::vector<Light> on = c.lamp_on[i] ? c.lights : std::vector<Light>{};
      WriteTextFile(o.out / "lights" / fmt::format("{:05d}.json", i), LightsToJson(on, note).dump(2) + "\n");
    }
    scene["lighting"] = {{"environment", "env/%05d.exr"}, {"lights", "lights/%05d.json"}};
    WriteLightVideo(o, c, note, report);
    Json keys = Json::array();
    for (const ObjectKeyframe& k : c.keyframes) {
      const Eigen::Vector3d r = k.rotation.toRotationMatrix().eulerAngles(2, 1, 0);  // z, y, x
      keys.push_back({{"frame", k.frame},
                      {"translation", {k.translation.x(), k.translation.y(), k.translation.z()}},
                      {"rotation_deg", {r[2] / kDegToRad, r[1] / kDegToRad, r[0] / kDegToRad}},
                      {"scale", k.scale.x()}});
    }
    scene["virtual"][0].erase("transform");
    scene["virtual"][0]["trajectory"] = keys;
  }
  if (c.plate_sphere) {
    const SynthPlateSphere& sp = *c.plate_sphere;
    const Json j = {
        {"comment", "the mirror sphere in the plate (" + note +
                        "): mr-probe --sphere-in-plate scene.json --sphere X,Y,Z,R --reflectance REFLECTANCE"},
        {"centre", {sp.centre.x(), sp.centre.y(), sp.centre.z()}},
        {"radius", sp.radius},
        {"reflectance", sp.reflectance}};
    WriteTextFile(o.out / "plate-sphere.json", j.dump(2) + "\n");
    report->AddOutput((o.out / "plate-sphere.json").string());
  }
  WriteTextFile(o.out / "scene.json", scene.dump(2) + "\n");
  for (const char* f2 : {"scene.json", "camera.cameramodel", "trajectory.txt", "env.exr", "meshes/object.ply"})
    report->AddOutput((o.out / f2).string());
  // The light probe: a 2-inch mirror sphere photographed by a 200-degree
  // stereographic fish-eye (the "light camera", looking along the world's
  // -z, +y up: its extrinsics say so), for mr-calibrate sphere;
  // probe/truth.json holds the answer.  Then the same sphere as a bracket
  // of 8-bit photographs through the sRGB curve (the camera's response),
  // with lens blur, noise and the camera's own body reflected, the sun
  // saturating every exposure (mr-hdr, then mr-probe: the result should
  // be env.exr); and a bracket of the fish-eye pointed at the zenith.
  if (o.probe) WriteProbe(o, c.sky, report);
}

namespace {

// The light arriving at the plate sphere's centre from the real room and
// the sky, as a 256x128 lat-long map (the EXR envmap convention, world
// axes): 64 stratified samples a pixel, each a real-only path from the
// centre that starts past the sphere's own surface.  A point or spot lamp,
// which rays never meet, is put into the pixel of its direction where it
// is in sight, as the radiance that gives its irradiance there (a probe
// sees the lamp's bulb).
Image RenderPlateSphereTruth(const RenderScene& rs, const SynthPlateSphere& sp, const PathTracerSettings& st) {
  const int w = 256, h = 128, spp = 64;
  Image map = Image::Rgb(w, h);
  std::vector<std::pair<Eigen::Vector2i, Eigen::Vector3d>> lamps;
  for (const LightSource& l : rs.lights()) {
    LightSample ls;
    if (l.is_virtual() || !l.Sample(sp.centre, 0.5, 0.5, &ls) || !ls.delta || !std::isfinite(ls.distance)) continue;
    Ray r;
    r.origin = sp.centre.cast<float>();
    r.direction = ls.wi.cast<float>();
    r.tnear = static_cast<float>(sp.radius * 1.01);
    r.tfar = static_cast<float>(ls.distance * (1 - 1e-4));
    r.mask = kMaskReal;
    if (rs.embree().Occluded(r)) continue;
    const Eigen::Vector2d q = DirectionToLatLongPixel(ls.wi, w, h);
    const Eigen::Vector2i px(std::clamp(static_cast<int>(std::lround(q.x())), 0, w - 1),
                             std::clamp(static_cast<int>(std::lround(q.y())), 0, h - 1));
    lamps.emplace_back(px, ls.li / LatLongPixelSolidAngle(px.x(), px.y(), w, h));
  }
  DifferentialPathTracer tracer(rs, st);
  ParallelFor(0, h, [&](int64_t y) {
    for (int x = 0; x < w; ++x) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (int k = 0; k < spp; ++k) {
        Sampler rng = Sampler::Stratified(HashCombine(st.seed, 0x737068ULL + static_cast<uint64_t>(st.frame)),
                                          static_cast<uint32_t>((y * w + x) * spp + k));
        const auto u = rng.Next2D();
        const Eigen::Vector3d d = LatLongPixelToDirection({x - 0.5 + u[0], y - 0.5 + u[1]}, w, h);  // centres at x, y
        Ray r;
        r.origin = sp.centre.cast<float>();
        r.direction = d.cast<float>();
        r.tnear = static_cast<float>(sp.radius * 1.01);
        r.mask = kMaskReal;
        int rays = 0;
        sum += tracer.RealRadiance(r, Eigen::Vector3d::Ones(), 0, 0, rng, &rays);
      }
      for (int ch = 0; ch < 3; ++ch) map.at(x, static_cast<int>(y), ch) = static_cast<float>(sum[ch] / spp);
    }
  });
  for (const auto& [px, radiance] : lamps)
    for (int ch = 0; ch < 3; ++ch) map.at(px.x(), px.y(), ch) += static_cast<float>(radiance[ch]);
  return map;
}

// The pixels where the object changes the image, found by a pilot render of
// its own seed (independent of the truth's samples), grown by 2 pixels: the
// truth's extra samples go there (SynthOptions::truth_region_spp).
std::vector<char> PilotRegion(const RenderScene& rs, const CameraModel& camera, const Rigid3& world_from_cam,
                              PathTracerSettings st) {
  constexpr int kPilotSpp = 32, kGrow = 2;
  st.seed = HashCombine(st.seed, 0x70696c6f74ULL);
  PtFrameRenderer pilot(rs, camera, world_from_cam, st);
  pilot.RenderPass(kPilotSpp);
  const Image changed = ChangedRegion(pilot.Mixed(), pilot.Real());
  const int w = changed.width(), h = changed.height();
  std::vector<char> region(static_cast<size_t>(w) * h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (changed.at(x, y, 0) == 0) continue;
      for (int v = std::max(0, y - kGrow); v <= std::min(h - 1, y + kGrow); ++v)
        for (int u = std::max(0, x - kGrow); u <= std::min(w - 1, x + kGrow); ++u)
          region[static_cast<size_t>(v) * w + u] = 1;
    }
  return region;
}

}  // namespace

namespace {

// The pixels of frame `frame` the plate sphere can cover: its projection's
// box, 2 pixels wider.
std::vector<char> PlateSpherePixels(const SynthCapture& c, int frame) {
  const SynthPreset& p = c.preset;
  const Rigid3& pose = c.trajectory.poses[static_cast<size_t>(frame)].world_from_cam;
  const Eigen::Vector3d centre = pose.Inverse() * c.plate_sphere->centre;
  std::vector<char> only(static_cast<size_t>(p.width) * p.height, 0);
  Eigen::Vector2d q;
  if (centre.z() > c.plate_sphere->radius && c.camera.Project(centre, &q)) {
    const double fx = c.camera.intrinsics()[0];
    const double r = std::min(static_cast<double>(p.width + p.height),
                              fx * c.plate_sphere->radius / (centre.z() - c.plate_sphere->radius) + 2);
    // Clamped as doubles first: a point near the camera plane projects far out.
    auto px = [](double v, int n) { return static_cast<int>(std::clamp(v, 0.0, n - 1.0)); };
    for (int y = px(q.y() - r, p.height); y <= px(q.y() + r, p.height); ++y)
      for (int x = px(q.x() - r, p.width); x <= px(q.x() + r, p.width); ++x)
        only[static_cast<size_t>(y) * p.width + x] = 1;
  }
  MR_CHECK_EQ(only.size(), static_cast<size_t>(p.width) * p.height);
  return only;
}

// Frame `frame`'s 8-bit photograph through the documented camera response:
// one exposure for the sequence (frame 0's 99th percentile maps to 0.9, set
// in *exposure), the sRGB curve, Gaussian noise of sigma 1/255 before
// quantisation (seeded per pixel).
Image EightBitPhotograph(const Image& photo, uint64_t seed, int frame, float* exposure) {
  std::vector<float> lum;
  for (int y = 0; y < photo.height(); ++y)
    for (int x = 0; x < photo.width(); ++x)
      lum.push_back(LuminanceF(photo.at(x, y, 0), photo.at(x, y, 1), photo.at(x, y, 2)));
  std::nth_element(lum.begin(), lum.begin() + static_cast<long>(lum.size() * 99 / 100), lum.end());
  if (frame == 0) *exposure = 0.9f / std::max(1e-6f, lum[lum.size() * 99 / 100]);
  Image ldr = Image::Rgb(photo.width(), photo.height());
  for (int y = 0; y < photo.height(); ++y)
    for (int x = 0; x < photo.width(); ++x) {
      Pcg32 rng(HashCombine(seed, static_cast<uint64_t>(frame)), static_cast<uint64_t>(y) * photo.width() + x);
      for (int ch = 0; ch < 3; ++ch) {
        const double u1 = std::max(1e-12, rng.NextDouble()), u2 = rng.NextDouble();
        const double gauss = std::sqrt(-2 * std::log(u1)) * std::cos(kTwoPi * u2);
        const float v =
            LinearToSrgb(Clamp(photo.at(x, y, ch) * *exposure, 0.0f, 1.0f)) + static_cast<float>(gauss / 255.0);
        ldr.at(x, y, ch) = SrgbToLinear(Clamp(v, 0.0f, 1.0f));  // WriteImage re-encodes sRGB
      }
    }
  return ldr;
}

// The same capture seen through the 8-bit photographs, response unknown:
// mr-render composites it in display space with the capture's exposure.
void WriteLdrScene(const SynthOptions& o, float exposure, Report* report) {
  Json ldr = ReadJsonFile(o.out / "scene.json");
  ldr["camera"]["frames"] = "photos/%05d.png";
  ldr["camera"]["frames_transfer"] = "display";
  ldr["camera"]["exposure"] = exposure;
  ldr["output"]["dir"] = "render-ldr";
  WriteTextFile(o.out / "scene-ldr.json", ldr.dump(2) + "\n");
  report->AddOutput((o.out / "scene-ldr.json").string());
}

}  // namespace

void SynthOptions::Check() const {
  if (out.empty()) throw UsageError("--out is required");
  GetSynthPreset(preset);
  if (table_top != "glossy" && table_top != "diffuse")
    throw UsageError(fmt::format("unknown table top \"{}\" (glossy, diffuse)", table_top));
  if (object_material != "diffuse" && object_material != "glossy" && object_material != "mirror")
    throw UsageError(fmt::format("unknown object material \"{}\" (diffuse, glossy, mirror)", object_material));
  if (lens != "opencv4" && lens != "pinhole")
    throw UsageError(fmt::format("unknown lens \"{}\" (opencv4, pinhole)", lens));
  if (truth_spp < 0 || truth_region_spp < 0 || frames < 0)
    throw UsageError("--truth-spp, --truth-region-spp and --frames must not be negative");
  const int truth = truth_spp > 0 ? truth_spp : GetSynthPreset(preset).truth_spp;
  const int region = truth_region_spp > 0 ? truth_region_spp : truth;
  if (region < truth)
    throw UsageError(fmt::format("--truth-region-spp {} is below the truth's {} samples per pixel", region, truth));
  if (region > truth && (truth % 2 || region % 2))
    throw UsageError(
        fmt::format("--truth-region-spp {} and the truth's {} samples per pixel must both be even "
                    "(the truth's two halves estimate its noise)",
                    region, truth));
}

void RunSynth(const SynthOptions& o, Report* report) {
  o.Check();
  const SynthCapture c = MakeSynthCapture(o);
  const SynthPreset& p = c.preset;
  const int truth_spp = c.truth_spp;
  const int region_spp = o.truth_region_spp > 0 ? o.truth_region_spp : truth_spp;
  int64_t region_pixels = 0;
  std::error_code ec;
  for (const char* sub : {"", "meshes", "photos", "truth"}) fs::create_directories(o.out / sub, ec);
  if (!fs::is_directory(o.out / "truth")) ThrowErrorAt(FileLoc{o.out.string()}, "cannot create the capture folder");
  const std::string note =
      fmt::format("written by {} ({}); preset {}, seed {}", o.tool, o.command_line, o.preset, o.seed);
  WriteSynthInputs(o, c, note, report);

  // Render the truth; its real-only paths are the photographs.  A dynamic
  // capture's world per frame is the scene's as mr-render reads it.
  RenderScene rs;
  std::optional<Scene> dynamic_scene;
  std::optional<WorldTracker> world;
  if (o.dynamic) {
    dynamic_scene = ReadScene(o.out / "scene.json");
    LoadRenderScene(*dynamic_scene, &rs, 0);
    world.emplace(*dynamic_scene, rs, 0);
  } else {
    for (const auto& part : c.parts) rs.AddReal(part.mesh, part.material);
    rs.AddVirtual(c.object, c.world_from_object, c.object_material);
    rs.SetEnvironment(EnvironmentMap(c.sky, (o.out / "env.exr").string()));
    for (const Light& l : c.lights) rs.AddLight(l);
    rs.Commit();
  }
  PathTracerSettings st;
  st.max_depth = 8;
  st.seed = HashCombine(o.seed, 0x7275746875ULL);  // independent of mr-render's seed
  int64_t changed = 0;
  float exposure = 0;  // one for the whole sequence, from frame 0
  TruthNoise noise_sum;
  VideoWriter video(o.out / "photos.mp4", p.width, p.height, 30.0);
  for (int i = 0; i < p.frames; ++i) {
    st.frame = i;
    if (world) world->Advance(i, &rs);
    PtFrameRenderer fr(rs, c.camera, c.trajectory.poses[static_cast<size_t>(i)].world_from_cam, st);
    // In two halves, so that the truth states its own noise.  Every pixel the
    // object can change gets the same samples as in one pass (they do not
    // depend on the split); pixels whose rays provably see only the sky
    // (pt's skip) keep the first half's, so the photograph's sky differs
    // from a one-pass render there, within its noise.
    std::vector<char> region;
    if (region_spp > truth_spp) {
      ScopedTimer t(report, "render the pilot for the object's region");
      region = PilotRegion(rs, c.camera, c.trajectory.poses[static_cast<size_t>(i)].world_from_cam, st);
      region_pixels += std::count(region.begin(), region.end(), 1);
    }
    // The object's region takes its extra samples in both halves alike, so
    // that each half is half of every pixel's samples.
    auto region_pass = [&] {
      if (region.empty()) return;
      fr.RestrictTo(region);
      fr.RenderPass((region_spp - truth_spp) / 2);
      fr.RestrictTo({});
    };
    Image mixed_half, real_half;
    {
      ScopedTimer t(report, "render truth");
      if (truth_spp >= 2) {
        fr.RenderPass(truth_spp / 2);
        region_pass();
        mixed_half = fr.Mixed();
        real_half = fr.Real();
        fr.RenderPass(truth_spp - truth_spp / 2);
        region_pass();
      } else {
        fr.RenderPass(truth_spp);
      }
    }
    if (c.plate_sphere) {
      // The sun reflected in the mirror sphere is a few hundredths of a
      // pixel: at truth_spp a sphere pixel's estimate of it is mostly 0 or
      // many times its mean.  The sphere's pixels (its projection's box,
      // 2 pixels wider) get 16 times the samples, photograph and truth alike
      // (the truth's noise estimate, from its first half, overstates theirs).
      ScopedTimer t(report, "render the plate sphere's pixels");
      fr.RestrictTo(PlateSpherePixels(c, i));
      fr.RenderPass(15 * truth_spp);
    }
    Image photo = fr.Real(), truth = fr.Mixed();
    if (truth_spp >= 2) {
      const TruthNoise n = EstimateTruthNoise(mixed_half, real_half, truth, photo, truth_spp / 2, truth_spp);
      noise_sum.relmse += n.relmse;
      noise_sum.region_relmse += n.region_relmse;
      spdlog::debug("frame {}: the truth's own noise: relMSE {:.3g}, in the object's region {:.3g}", i, n.relmse,
                    n.region_relmse);
    }
    for (size_t k = 0; k < photo.values().size(); ++k) changed += photo.values()[k] != truth.values()[k];
    ImageWriteOptions wo;
    wo.tool = o.tool;
    wo.command_line = o.command_line;
    const fs::path photo_path = o.out / "photos" / fmt::format("{:05d}.exr", i);
    const fs::path truth_path = o.out / "truth" / fmt::format("{:05d}.exr", i);
    WriteImage(photo_path, photo, wo);
    WriteImage(truth_path, truth, wo);
    const Image ldr = EightBitPhotograph(photo, o.seed, i, &exposure);
    WriteImage(o.out / "photos" / fmt::format("{:05d}.png", i), ldr, wo);
    video.Write(ldr);
    if (c.plate_sphere) {
      ScopedTimer t(report, "render the plate sphere's truth");
      const fs::path sp = o.out / "reference" / "sphere" / fmt::format("{:05d}.exr", i);
      fs::create_directories(sp.parent_path(), ec);
      WriteImage(sp, RenderPlateSphereTruth(rs, *c.plate_sphere, st), wo);
      report->AddOutput(sp.string());
    }
    report->AddOutput(photo_path.string());
    report->AddOutput(truth_path.string());
    spdlog::info("frame {}: truth at {} spp", i, truth_spp);
  }
  video.Close();
  WriteLdrScene(o, exposure, report);
  report->AddOutput((o.out / "photos.mp4").string());
  report->SetMetric("frames", p.frames);
  report->SetMetric("truth_spp", truth_spp);
  report->SetMetric("truth_region_spp", region_spp);
  if (region_spp > truth_spp) {
    const double share = static_cast<double>(region_pixels) / (static_cast<double>(p.width) * p.height * p.frames);
    report->SetMetric("truth_region_share", share);
    spdlog::info("the truth took {} samples per pixel in the object's region, {:.1f}% of the pixels", region_spp,
                 100 * share);
  }
  if (truth_spp >= 2) {
    // Means over the frames (render/error_curve.h, EstimateTruthNoise).
    const double region = noise_sum.region_relmse / p.frames;
    report->SetMetric("truth_noise_relmse", noise_sum.relmse / p.frames);
    report->SetMetric("truth_noise_region_relmse", region);
    spdlog::info(
        "the truth's own noise: relMSE {:.3g} in the object's region; errors against it below about {:.3g} "
        "are not resolved",
        region, 3 * region);
  }
  report->SetMetric("size", {p.width, p.height});
  // What --object became: mr-synth sets any mesh about 30 cm across on the
  // table (scene.json's virtual[0].transform places it so in the scene).
  report->SetMetric(
      "object", {{"mesh", o.object},
                 {"scale", c.object_scale},
                 {"rotation_deg", {c.object_rotation_deg.x(), c.object_rotation_deg.y(), c.object_rotation_deg.z()}},
                 {"rests_on", {c.object_rests_on.x(), c.object_rests_on.y(), c.object_rests_on.z()}}});
  report->SetMetric("sun_to_sky", p.sun_to_sky);
  report->SetMetric("changed_values", changed);
  report->SetMetric("dynamic", o.dynamic);
}

}  // namespace mr

namespace mr {

void RunSynthRgbd(const SynthOptions& o, const RgbdSynthSize& size, Report* report) {
  o.Check();
  const SynthPreset p = GetSynthPreset(o.preset);
  const bool small = o.preset == "small";
  const int w = size.width > 0 ? size.width : (small ? 160 : 640);
  const int h = size.height > 0 ? size.height : (small ? 120 : 480);
  const int frames = size.frames > 0 ? size.frames : (small ? 60 : 300);
  const std::vector<SynthPart> parts = SynthRoom();
  int sun_x, sun_y;
  const Image sky = SkyMap(256, 129, p.sun_to_sky, &sun_x, &sun_y);
  RenderScene rs;
  for (const auto& part : parts) rs.AddReal(part.mesh, part.material);
  const Mesh room = MergeParts(parts);
  rs.SetEnvironment(EnvironmentMap(sky, "sky"));
  rs.Commit();
  RgbdSynthOptions ro;
  // 7-Scenes' field of view (fx = 585 at 640 px) at the requested size.
  const double f = 585.0 * w / 640.0;
  ro.K = PinholeIntrinsics{f, f, (w - 1) / 2.0, (h - 1) / 2.0, w, h};
  ro.color_spp = size.color_spp >= 0 ? size.color_spp : (small ? 2 : 1);
  ro.exposure = size.exposure;
  if (size.clean) ro.sensor.noise = ro.sensor.quantise = ro.sensor.holes = false;
  ro.seed = o.seed;
  // Around the table, 2 m out at eye height, sweeping 60 degrees (about
  // 7 mm per frame over 300 frames) with the table, its legs, both boxes
  // and the walls in view: the surfaces are 1 to 4 m away, as in a room scan.
  const Trajectory path = ScanPath(frames, Eigen::Vector3d(0, 0.6, 0.3), 2.0, 1.6, -60.0);
  fs::create_directories(o.out / "reference");
  const std::string note =
      fmt::format("written by {} ({}); preset {}, seed {}", o.tool, o.command_line, o.preset, o.seed);
  WriteRgbdSequence(o.out, rs, path, ro, report);
  WritePly(o.out / "reference" / "room.ply", room, "the synthetic room's real geometry; " + note);
  ImageWriteOptions wo;
  wo.tool = o.tool;
  wo.command_line = o.command_line;
  WriteImage(o.out / "reference" / "env.exr", sky, wo);
  report->AddOutput((o.out / "reference" / "room.ply").string());
  report->AddOutput((o.out / "reference" / "env.exr").string());
  report->SetMetric("frames", frames);
  report->SetMetric("size", {w, h});
  report->SetMetric("path_length_m", path.PathLength());
}

}  // namespace mr
