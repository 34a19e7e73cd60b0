// mr-export's glTF scene read back as JSON: the camera against the
// calibrated model and the poses, the room, the objects, the lights, the
// world's up, and issue 42's stiff cases (a fish-eye past 180 degrees, a
// shot without a room, 10,000 frames of camera animation, bad outputs).
// Blender's reading of the same file: tests/crosscheck/shot_roundtrip.py.
#include "handoff/export_shot.h"
#include "handoff/gltf_builder.h"
#include "handoff/stmap.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "camera/camera_model.h"
#include "camera/trajectory.h"
#include "core/error.h"
#include "core/file.h"
#include "core/image.h"
#include "core/math.h"
#include "geometry/asset.h"
#include "geometry/mesh.h"
#include "geometry/primitives.h"
#include "test_util.h"

namespace mr {
namespace {

// A shot on disk: a room (floor quad), a box object, `frames` poses
// turning about y, a pinhole of non-square pixels (or `lens`), lights.
struct Shot {
  test::TempDir dir;
  Json scene;
  std::vector<Rigid3> poses;
  explicit Shot(int frames, const CameraModel& cam = CameraModel("LENSMODEL_PINHOLE", {150, 170, 84.3, 46.1}, 160, 100),
                bool room = true) {
    cam.Write(dir / "cam.cameramodel");
    WritePly(dir / "room.ply", Quad({-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}));
    WritePly(dir / "box.ply", Box(Eigen::Vector3f(-0.1f, 0, -0.1f), Eigen::Vector3f(0.1f, 0.2f, 0.1f)));
    Trajectory t;
    for (int k = 0; k < frames; ++k) {
      const Eigen::Quaterniond q(Eigen::AngleAxisd(0.01 * k, Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()));
      poses.emplace_back(q, Eigen::Vector3d(0.001 * k, 1.2, -1.5));
      t.poses.push_back({static_cast<double>(k), poses.back()});
    }
    WriteTum(dir / "traj.txt", t);
    WriteTextFile(dir / "lights.json", R"({"version": 1, "lights": [
      {"name": "lamp", "type": "point", "position": [0.5, 1.6, 0.5], "intensity": [2, 1.5, 1]},
      {"name": "sun", "type": "distant", "direction": [0, 1, 0], "irradiance": [5, 5, 5]}]})");
    scene = {{"version", 1},
             {"camera", {{"model", "cam.cameramodel"}, {"poses", {{"format", "tum"}, {"path", "traj.txt"}}}}},
             {"virtual", Json::array({{{"name", "box"},
                                       {"mesh", "box.ply"},
                                       {"transform", {{"translation", {0.1, 0.0, 0.2}}, {"scale", 2}}}}})},
             {"lighting", {{"lights", "lights.json"}}}};
    if (room) scene["real"] = {{"mesh", "room.ply"}, {"material", {{"albedo", {0.6, 0.5, 0.4}}}}};
  }
  ShotExportResult Export(const std::string& name = "shot.gltf", int begin = 0, int end = -1) {
    WriteTextFile(dir / "scene.json", scene.dump());
    ShotExportOptions o;
    o.scene = dir / "scene.json";
    o.out = dir / name;
    o.frame_begin = begin;
    o.frame_end = end;
    Report report("mr-export", "test");
    return ExportShot(o, &report);
  }
  Json Read(const std::string& name = "shot.gltf") { return Json::parse(ReadTextFile(dir / name)); }
};

const Json* NodeNamed(const Json& doc, const std::string& name) {
  for (const Json& n : doc["nodes"])
    if (n.value("name", "") == name) return &n;
  return nullptr;
}

TEST(Export, TheCameraIsTheModelsPinholeAndThePosesTurnedToGltfs) {
  Shot s(5);
  const ShotExportResult r = s.Export();
  EXPECT_TRUE(r.perspective);
  EXPECT_EQ(r.frames, 5);
  const Json doc = s.Read();
  ASSERT_EQ(doc["cameras"].size(), 1u);
  const Json& p = doc["cameras"][0]["perspective"];
  // The glTF projection of a pinhole of fx, fy and a centred principal
  // point: yfov = 2 atan(h / 2 fy), aspect = w fy / (h fx).
  EXPECT_NEAR(p["yfov"].get<double>(), 2 * std::atan(100 / (2 * 170.0)), 1e-12);
  EXPECT_NEAR(p["aspectRatio"].get<double>(), 160 * 170.0 / (100 * 150.0), 1e-12);
  const Json* cam = NodeNamed(doc, "camera");
  ASSERT_NE(cam, nullptr);
  const Json& mr = (*cam)["extras"]["mr"];
  EXPECT_NEAR(mr["blender_shift"][0].get<double>(), -(84.3 - 79.5) / 160, 1e-12);
  EXPECT_NEAR(mr["blender_shift"][1].get<double>(), (46.1 - 49.5) * (150.0 / 170) / 160, 1e-12);
  // The first key: mr's pose times a half turn about x (glTF's camera
  // looks along -z, +y up).
  const Eigen::Quaterniond q = s.poses[0].rotation * Eigen::Quaterniond(0, 1, 0, 0);
  const Json& rot = (*cam)["rotation"];
  const double sign = q.w() * rot[3].get<double>() >= 0 ? 1 : -1;
  EXPECT_NEAR(rot[0].get<double>(), sign * q.x(), 1e-12);
  EXPECT_NEAR(rot[3].get<double>(), sign * q.w(), 1e-12);
  EXPECT_NEAR((*cam)["translation"][1].get<double>(), 1.2, 1e-12);
  // One key per frame at k / fps.
  ASSERT_EQ(doc["animations"].size(), 1u);
  bool found = false;
  for (const Json& c : doc["animations"][0]["channels"]) {
    if (c["target"]["node"].get<size_t>() >= doc["nodes"].size()) continue;
    if (doc["nodes"][c["target"]["node"].get<size_t>()]["name"] != "camera") continue;
    const Json& sampler = doc["animations"][0]["samplers"][c["sampler"].get<size_t>()];
    const Json& input = doc["accessors"][sampler["input"].get<size_t>()];
    EXPECT_EQ(input["count"], 5);
    EXPECT_NEAR(input["max"][0].get<double>(), 4 / 30.0, 1e-6);
    found = true;
  }
  EXPECT_TRUE(found);
}

TEST(Export, TheRoomIsAShadowCatcherAndTheObjectsAndLightsAreThere) {
  Shot s(2);
  const ShotExportResult r = s.Export();
  EXPECT_EQ(r.room_meshes, 1);
  EXPECT_EQ(r.objects, 1);
  EXPECT_EQ(r.lights, 2);
  const Json doc = s.Read();
  const Json* room = NodeNamed(doc, "room");
  ASSERT_NE(room, nullptr);
  EXPECT_EQ((*room)["extras"]["mr"]["shadow_catcher"], true);
  const Json& prim = doc["meshes"][(*room)["mesh"].get<size_t>()]["primitives"][0];
  const Json& pos = doc["accessors"][prim["attributes"]["POSITION"].get<size_t>()];
  EXPECT_EQ(pos["count"], 4);
  EXPECT_EQ(pos["max"][0], 2.0);
  const Json& mat = doc["materials"][prim["material"].get<size_t>()];
  EXPECT_NEAR(mat["pbrMetallicRoughness"]["baseColorFactor"][0].get<double>(), 0.6, 1e-12);
  const Json* box = NodeNamed(doc, "box");
  ASSERT_NE(box, nullptr);
  EXPECT_EQ((*box)["scale"][0], 2.0);
  EXPECT_NEAR((*box)["translation"][2].get<double>(), 0.2, 1e-12);
  // KHR_lights_punctual, mr's radiometric values in extras.
  const Json& lights = doc["extensions"]["KHR_lights_punctual"]["lights"];
  ASSERT_EQ(lights.size(), 2u);
  EXPECT_EQ(lights[0]["type"], "point");
  EXPECT_EQ(lights[1]["type"], "directional");
  const Json* lamp = NodeNamed(doc, "lamp");
  ASSERT_NE(lamp, nullptr);
  EXPECT_EQ((*lamp)["extras"]["mr"]["intensity_w_sr"][0], 2.0);
  // The sun shines down: its node's -z is -y.
  const Json* sun = NodeNamed(doc, "sun");
  ASSERT_NE(sun, nullptr);
  const Json& sq = (*sun)["rotation"];
  const Eigen::Quaterniond q(sq[3].get<double>(), sq[0].get<double>(), sq[1].get<double>(), sq[2].get<double>());
  EXPECT_NEAR((q * -Eigen::Vector3d::UnitZ()).y(), -1.0, 1e-9);
}

// A world whose up is +z (a room in its first camera's frame, turned by
// lighting.environment_up): glTF's +y is that up.
TEST(Export, TheWorldsUpBecomesGltfsY) {
  Shot s(1);
  s.scene["lighting"]["environment_up"] = {0, 0, 1};
  s.Export();
  const Json doc = s.Read();
  const Json& gw = doc["scenes"][0]["extras"]["mr"]["gltf_from_world"];
  EXPECT_NEAR(gw[1][2].get<double>(), 1.0, 1e-12);  // world +z -> glTF +y
  const Json* room = NodeNamed(doc, "room");
  const Json& pos =
      doc["accessors"]
         [doc["meshes"][(*room)["mesh"].get<size_t>()]["primitives"][0]["attributes"]["POSITION"].get<size_t>()];
  EXPECT_NEAR(pos["max"][1].get<double>(), 2.0, 1e-6);  // the floor's z extent is glTF's y now
  // The sun of lights.json is a direction of the map (its zenith, +y there):
  // it turns with the map to the world's up, glTF's +y, and shines down.
  const Json& sq = (*NodeNamed(doc, "sun"))["rotation"];
  const Eigen::Quaterniond q(sq[3].get<double>(), sq[0].get<double>(), sq[1].get<double>(), sq[2].get<double>());
  EXPECT_NEAR((q * -Eigen::Vector3d::UnitZ()).y(), -1.0, 1e-9);
}

// Issue 42's stiff cases.

// A stereographic fish-eye whose corners see 109 degrees from its axis: no
// perspective camera can hold its view.  The export says so, in the node's
// extras and in the result, and keeps the camera's path.
TEST(Export, AFishEyePast180DegreesHasNoPerspectiveCamera) {
  Shot s(3, CameraModel("LENSMODEL_STEREOGRAPHIC", {100, 100, 199.5, 199.5}, 400, 400));
  const ShotExportResult r = s.Export();
  EXPECT_FALSE(r.perspective);
  EXPECT_NE(r.no_perspective.find("degrees from its axis"), std::string::npos) << r.no_perspective;
  const Json doc = s.Read();
  EXPECT_FALSE(doc.contains("cameras"));
  const Json* cam = NodeNamed(doc, "camera");
  ASSERT_NE(cam, nullptr);
  EXPECT_EQ((*cam)["extras"]["mr"]["perspective"], false);
  EXPECT_GT((*cam)["extras"]["mr"]["widest_angle_from_axis_deg"].get<double>(), 100.0);
  EXPECT_FALSE(cam->contains("camera"));
  // A narrower stereographic lens (70 degrees from its axis) keeps one.
  Shot narrow(1, CameraModel("LENSMODEL_STEREOGRAPHIC", {300, 300, 199.5, 199.5}, 400, 400));
  EXPECT_TRUE(narrow.Export().perspective);
}

TEST(Export, AShotWithoutARoom) {
  Shot s(2, CameraModel("LENSMODEL_PINHOLE", {150, 150, 79.5, 49.5}, 160, 100), false);
  const ShotExportResult r = s.Export("shot.glb");
  EXPECT_EQ(r.room_meshes, 0);
  EXPECT_EQ(r.objects, 1);
  // A .glb: the header, then the JSON chunk, then the binary one.
  const std::string glb = ReadTextFile(s.dir / "shot.glb");
  ASSERT_GT(glb.size(), 20u);
  uint32_t magic = 0, length = 0, json_length = 0;
  std::memcpy(&magic, glb.data(), 4);
  std::memcpy(&length, glb.data() + 8, 4);
  std::memcpy(&json_length, glb.data() + 12, 4);
  EXPECT_EQ(magic, 0x46546C67u);
  EXPECT_EQ(length, glb.size());
  const Json doc = Json::parse(glb.substr(20, json_length));
  EXPECT_EQ(NodeNamed(doc, "room"), nullptr);
  EXPECT_NE(NodeNamed(doc, "box"), nullptr);
  EXPECT_NE(NodeNamed(doc, "camera"), nullptr);
}

TEST(Export, TenThousandFramesOfCameraAnimation) {
  Shot s(10000);
  const ShotExportResult r = s.Export("shot.glb");
  EXPECT_EQ(r.frames, 10000);
  const std::string glb = ReadTextFile(s.dir / "shot.glb");
  uint32_t json_length = 0;
  std::memcpy(&json_length, glb.data() + 12, 4);
  const Json doc = Json::parse(glb.substr(20, json_length));
  const Json& sampler = doc["animations"][0]["samplers"][0];
  EXPECT_EQ(doc["accessors"][sampler["input"].get<size_t>()]["count"], 10000);
  EXPECT_NEAR(doc["accessors"][sampler["input"].get<size_t>()]["max"][0].get<double>(), 9999 / 30.0, 1e-3);
}

TEST(Export, BadOutputsAndRangesAreRefusedAndWriteNothing) {
  Shot s(3);
  const size_t before = (WriteTextFile(s.dir / "scene.json", s.scene.dump()), s.dir.FileCount());
  try {
    s.Export("shot.obj");
    FAIL() << "a .obj output was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("shot.obj"), std::string::npos) << e.what();
  }
  try {
    s.Export("shot.gltf", 2, 7);
    FAIL() << "frames past the poses were accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("outside the 3 poses"), std::string::npos) << e.what();
  }
  EXPECT_EQ(s.dir.FileCount(), before);
}

// ST-maps (handoff/stmap.h).  A pinhole lens maps to itself: s = (x + 0.5)
// / w exactly, no overscan.  A barrel lens grows the pinhole, and its two
// maps are each other's inverse: a lens pixel through the redistort map and
// back through the undistort map (bilinear) lands within 0.01 px of itself.
TEST(StMaps, APinholeIsTheIdentityAndABarrelLensRoundTrips) {
  const StMaps id = MakeStMaps(CameraModel("LENSMODEL_PINHOLE", {100, 100, 31.5, 23.5}, 64, 48));
  EXPECT_EQ(id.pinhole.width(), 64);
  EXPECT_EQ(id.overscan_left, 0);
  for (int y : {0, 23, 47})
    for (int x : {0, 40, 63}) {
      EXPECT_NEAR(id.undistort.at(x, y, 0), (x + 0.5) / 64, 1e-6);
      EXPECT_NEAR(id.undistort.at(x, y, 1), 1 - (y + 0.5) / 48, 1e-6);
      EXPECT_EQ(id.redistort.at(x, y, 3), 1.0f);
    }
  const CameraModel barrel("LENSMODEL_OPENCV4", {200, 205, 80.3, 60.2, -0.3, 0.08, 0.001, -0.001}, 160, 120);
  const StMaps m = MakeStMaps(barrel);
  EXPECT_GT(m.overscan_left, 0);
  EXPECT_GT(m.pinhole.width(), 160);
  EXPECT_EQ(m.unmapped, 0);
  const int W = m.pinhole.width(), H = m.pinhole.height();
  auto bilinear = [&](double px, double py, int c) {
    const int x0 = std::clamp(static_cast<int>(std::floor(px)), 0, W - 2);
    const int y0 = std::clamp(static_cast<int>(std::floor(py)), 0, H - 2);
    const double fx = px - x0, fy = py - y0;
    return (1 - fy) * ((1 - fx) * m.undistort.at(x0, y0, c) + fx * m.undistort.at(x0 + 1, y0, c)) +
           fy * ((1 - fx) * m.undistort.at(x0, y0 + 1, c) + fx * m.undistort.at(x0 + 1, y0 + 1, c));
  };
  double worst = 0;
  for (int y = 2; y < 118; y += 7)
    for (int x = 2; x < 158; x += 7) {
      const double px = m.redistort.at(x, y, 0) * W - 0.5, py = (1 - m.redistort.at(x, y, 1)) * H - 0.5;
      const double bx = bilinear(px, py, 0) * 160 - 0.5, by = (1 - bilinear(px, py, 1)) * 120 - 0.5;
      worst = std::max({worst, std::abs(bx - x), std::abs(by - y)});
    }
  EXPECT_LT(worst, 0.01);
}

// A fish-eye past 180 degrees: the maps hold what lies within the widest
// angle, the rest of the lens is unmapped (alpha 0), and with --stmaps the
// shot's camera is that pinhole.
TEST(StMaps, AFishEyePast180DegreesMapsThePartWithinTheWidestAngle) {
  const CameraModel fish("LENSMODEL_STEREOGRAPHIC", {100, 100, 199.5, 199.5}, 400, 400);
  const StMaps m = MakeStMaps(fish, 60);
  EXPECT_GT(m.unmapped, 0);
  EXPECT_EQ(m.redistort.at(0, 0, 3), 0.0f);      // a corner: 109 degrees from the axis
  EXPECT_EQ(m.redistort.at(200, 200, 3), 1.0f);  // the centre
  // 2 x 60 degrees, and the half lens pixel round the last ray within it.
  EXPECT_GT(m.pinhole.HorizontalFovDeg(), 120.0);
  EXPECT_LT(m.pinhole.HorizontalFovDeg(), 130.0);
  Shot s(2, fish);
  WriteTextFile(s.dir / "scene.json", s.scene.dump());
  ShotExportOptions o;
  o.scene = s.dir / "scene.json";
  o.out = s.dir / "shot.gltf";
  o.stmaps = true;
  o.stmap_max_angle_deg = 60;
  Report report("mr-export", "test");
  const ShotExportResult r = ExportShot(o, &report);
  EXPECT_TRUE(r.perspective);
  EXPECT_GT(r.stmap_unmapped, 0);
  EXPECT_TRUE(fs::exists(r.undistort) && fs::exists(r.redistort));
  const Json cam = *NodeNamed(s.Read(), "camera");
  EXPECT_EQ(cam["extras"]["mr"]["width"], m.pinhole.width());
  EXPECT_EQ(cam["extras"]["mr"]["stmaps"]["unmapped_lens_pixels"], m.unmapped);
}

// A glTF asset placed in the shot is merged into it, its meshes, materials
// and textures with it (images from files and from the .glb's buffer
// embedded), under the object's node: mr's own asset reader, which checks
// every accessor against its buffer, reads the exported shot's parts and
// finds the assets' triangles and images in it.
TEST(Export, GltfAssetsAreMergedIntoTheShot) {
  const fs::path assets = fs::path(MR_SOURCE_DIR) / "tests" / "data" / "assets";
  for (const char* name : {"khronos/BoxTextured.gltf", "blender/blender.glb"}) {
    Shot s(1, CameraModel("LENSMODEL_PINHOLE", {150, 150, 79.5, 49.5}, 160, 100), false);
    fs::copy(assets / name, s.dir / fs::path(name).filename());
    if (fs::path(name).extension() == ".gltf")
      for (const char* extra : {"BoxTextured0.bin", "CesiumLogoFlat.png"})
        if (fs::exists(assets / "khronos" / extra)) fs::copy(assets / "khronos" / extra, s.dir / extra);
    s.scene["virtual"][0]["mesh"] = fs::path(name).filename().string();
    const ShotExportResult r = s.Export("shot.glb");
    EXPECT_EQ(r.assets, 1) << name;
    const Asset original = ReadAsset(s.dir / fs::path(name).filename());
    const Asset exported = ReadAsset(s.dir / "shot.glb");
    EXPECT_EQ(exported.triangle_count(), original.triangle_count()) << name;
    EXPECT_EQ(exported.images.size(), original.images.size()) << name;
    EXPECT_EQ(exported.materials.size(), original.materials.size()) << name;
  }
}

// A plate with radiometric gains (mr-eval plate's gains.json): the export
// carries the plate's frames and the gains of the frames in its range, keyed
// from the range's start, for the Blender script's compositor.
TEST(Export, ThePlateAndItsGainsAreCarried) {
  Shot s(4);
  for (int f = 0; f < 4; ++f) WriteImage(s.dir / fmt::format("plate{:05d}.png", f), Image::Rgb(160, 100, 0.5f));
  WriteTextFile(s.dir / "gains.json", R"({"frames": [{"frame": 0, "gain": [0.7, 0.9, 1.1]},
    {"frame": 1, "gain": [0.8, 0.9, 1.0]}, {"frame": 2, "gain": [0.9, 0.9, 0.9]}, {"frame": 3, "gain": [1, 1, 1]}]})");
  s.scene["camera"]["frames"] = "plate%05d.png";
  s.scene["camera"]["gains"] = "gains.json";
  s.Export("shot.gltf", 1, 3);
  const Json plate = s.Read()["scenes"][0]["extras"]["mr"]["plate"];
  EXPECT_EQ(plate["frames"], "plate%05d.png");
  EXPECT_EQ(plate["first_frame"], 1);
  EXPECT_EQ(plate["gains"]["frame"], Json::array({0, 1}));
  EXPECT_EQ(plate["gains"]["gain"][0][0], 0.8);
}

TEST(Export, Base64MatchesTheRfcVectors) {
  EXPECT_EQ(Base64Decode("Zm9vYmFy"), "foobar");
  EXPECT_EQ(Base64Decode("Zm8="), "fo");
  EXPECT_EQ(Base64Encode(""), "");
  EXPECT_EQ(Base64Encode("f"), "Zg==");
  EXPECT_EQ(Base64Encode("fo"), "Zm8=");
  EXPECT_EQ(Base64Encode("foo"), "Zm9v");
  EXPECT_EQ(Base64Encode("foobar"), "Zm9vYmFy");
}

}  // namespace
}  // namespace mr
