#include "scene/scene.h"

#include <gtest/gtest.h>

#include <cmath>

#include "camera/camera_model.h"
#include "core/error.h"
#include "scene/frames.h"
#include "test_util.h"

namespace mr {
namespace {

class SceneFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteTextFile(dir_ / "cam.cameramodel", "x");
    WriteTextFile(dir_ / "room.ply", "x");
    WriteTextFile(dir_ / "bunny.ply", "x");
    WriteTextFile(dir_ / "env.exr", "x");
    WriteTextFile(dir_ / "traj.txt", "x");
    fs::create_directories(dir_ / "frames");
  }
  Json Valid() const {
    return ParseJsonStrict(R"({
      "version": 1,
      "camera": {"model": "cam.cameramodel", "frames": "frames/%05d.png",
                 "poses": {"format": "tum", "path": "traj.txt"}},
      "lighting": {"environment": "env.exr", "environment_scale": 2.0},
      "real": {"mesh": "room.ply", "material": {"albedo": [0.8, 0.8, 0.8]}},
      "virtual": [
        {"name": "a", "mesh": "bunny.ply", "transform": {"translation": [0, 0, 1], "scale": 2},
         "material": {"albedo": [0.5, 0.4, 0.3], "specular": [0.2, 0.2, 0.2], "roughness": 0.3}},
        {"name": "b", "mesh": "bunny.ply", "material": {"albedo": [0.9, 0.9, 0.9]}}
      ],
      "render": {"method": "pt", "spp": 16, "frames": "0:3", "seed": 7},
      "output": {"dir": "out", "layers": ["composite", "mask"]}
    })",
                           "scene.json");
  }
  std::string ErrorOf(const Json& j) const {
    try {
      ParseScene(j, dir_.path(), "scene.json", true);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  }
  test::TempDir dir_;
};

TEST_F(SceneFiles, ValidSceneParses) {
  Scene s = ParseScene(Valid(), dir_.path(), "scene.json", true);
  EXPECT_EQ(s.camera.model, dir_ / "cam.cameramodel");  // relative to the scene's folder
  EXPECT_EQ(s.virtuals.size(), 2u);
  EXPECT_TRUE(s.virtuals[0].material.IsGlossy());
  EXPECT_FALSE(s.virtuals[1].material.IsGlossy());
  EXPECT_EQ(s.virtuals[0].world_from_object * Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(2, 0, 1));
  EXPECT_EQ(s.render.frame_begin, 0);
  EXPECT_EQ(s.render.frame_end, 3);
  EXPECT_EQ(s.render.seed, 7u);
  EXPECT_EQ(s.lighting.environment_scale, 2.0);
  EXPECT_EQ(s.output.layers.size(), 2u);
}

TEST_F(SceneFiles, EnvironmentUpTurnsTheMap) {
  Json j = Valid();
  // A room in its first camera's frame (y down, tilted): the map's zenith
  // goes where gravity's opposite is (7-Scenes kitchen's gravity direction).
  const Eigen::Vector3d up = -Eigen::Vector3d(-0.0088746, 0.9044256, 0.4265392).normalized();
  j["lighting"]["environment_up"] = {up.x(), up.y(), up.z()};
  j["lighting"]["environment_rotation_deg"] = 30;
  const Scene s = ParseScene(j, dir_.path(), "scene.json", true);
  // Exact up to round-off of a 3x3 rotation (1e-12).
  EXPECT_LT((s.lighting.world_from_env * Eigen::Vector3d::UnitY() - up).norm(), 1e-12);
  EXPECT_LT((s.lighting.world_from_env.transpose() * s.lighting.world_from_env - Eigen::Matrix3d::Identity()).norm(),
            1e-12);
  j["lighting"]["environment_up"] = {0, -1, 0};  // upside down: the antiparallel case
  EXPECT_LT((ParseScene(j, dir_.path(), "scene.json", true).lighting.world_from_env * Eigen::Vector3d::UnitY() -
             Eigen::Vector3d(0, -1, 0))
                .norm(),
            1e-12);
  j["lighting"]["environment_up"] = {0, 0, 0};
  EXPECT_NE(ErrorOf(j).find("lighting.environment_up: a zero vector"), std::string::npos) << ErrorOf(j);
}

// A virtual object's mesh may be a glTF asset, whose materials are its own.
TEST_F(SceneFiles, AssetMeshesBringTheirMaterials) {
  Json j = Valid();
  const std::string glb = std::string(MR_SOURCE_DIR) + "/tests/data/assets/blender/blender.glb";
  j["virtual"][0]["mesh"] = glb;
  j["virtual"][0].erase("material");
  EXPECT_EQ(ErrorOf(j), "");
  j["virtual"][0]["material"] = {{"albedo", {0.5, 0.5, 0.5}}};
  EXPECT_EQ(ErrorOf(j),
            "scene.json: virtual[0].material: the mesh is an asset, whose materials are its own: remove \"material\"");
  // An OBJ takes its own MTL materials with "material": "mtl" (its renders
  // with a material block, or none, are unchanged).
  j = Valid();
  j["virtual"][0]["mesh"] = std::string(MR_SOURCE_DIR) + "/tests/data/assets/blender/blender.obj";
  j["virtual"][0]["material"] = "mtl";
  EXPECT_EQ(ErrorOf(j), "");
  EXPECT_TRUE(ParseScene(j, dir_.path(), "scene.json", true).virtuals[0].file_materials);
  j["virtual"][0]["material"] = "gltf";
  EXPECT_EQ(ErrorOf(j),
            "scene.json: virtual[0].material: expected a material block, or \"mtl\" for an OBJ's own MTL materials");
  j["virtual"][0].erase("material");
  EXPECT_FALSE(ParseScene(j, dir_.path(), "scene.json", true).virtuals[0].file_materials);
}

// lighting.probes: where the light was captured; a probe without its own
// map takes the environment's.
TEST_F(SceneFiles, ProbesNameWhereTheLightWasCaptured) {
  Json j = Valid();
  j["lighting"]["probes"] = Json::array({{{"at", {0.5, 1.0, -0.2}}}, {{"at", {1, 1, 1}}, {"map", "env.exr"}}});
  const Scene s = ParseScene(j, dir_.path(), "scene.json", true);
  ASSERT_EQ(s.lighting.probes.size(), 2u);
  EXPECT_EQ(s.lighting.probes[0].at, Eigen::Vector3d(0.5, 1.0, -0.2));
  EXPECT_FALSE(s.lighting.probes[0].map);
  EXPECT_EQ(*s.lighting.probes[1].map, dir_ / "env.exr");
  j["lighting"]["probes"] = Json::array({{{"at", {0, 1}}}});
  EXPECT_EQ(ErrorOf(j), "scene.json: lighting.probes[0].at: expected 3 numbers in [-1e+30,1e+30], got 2");
  j["lighting"]["probes"] = Json::object();
  EXPECT_EQ(ErrorOf(j), "scene.json: lighting.probes: expected a list of 1 to 16 probes {at: [x, y, z], map}");
  j["lighting"]["probes"] = Json::array({{{"at", {0, 1, 0}}}});
  j["lighting"].erase("environment");
  EXPECT_EQ(ErrorOf(j),
            "scene.json: lighting.probes[0]: a probe without a map takes the environment's, and the scene names none");
}

TEST_F(SceneFiles, ErrorsNameTheKeyPath) {
  Json j = Valid();
  j["virtual"][1]["material"]["albedo"] = {0.1, 0.2, 0.3, 0.4};
  EXPECT_EQ(ErrorOf(j), "scene.json: virtual[1].material.albedo: expected 3 numbers in [0,1], got 4");
  j = Valid();
  j["virtual"][0]["material"]["albedo"] = {0.1, 1.5, 0.3};
  EXPECT_EQ(ErrorOf(j), "scene.json: virtual[0].material.albedo: expected 3 numbers in [0,1], got 1.5");
  j = Valid();
  j["virtual"][0]["colour"] = "red";
  EXPECT_EQ(ErrorOf(j),
            "scene.json: virtual[0].colour: unknown key (allowed here: name, mesh, transform, "
            "trajectory, material, formfactors; or light, which makes the entry a virtual light)");
  j = Valid();  // one number or three
  j["virtual"][0]["transform"]["scale"] = "0.5";
  EXPECT_EQ(ErrorOf(j),
            "scene.json: virtual[0].transform.scale: expected a number (a uniform scale) or 3 numbers "
            "[sx, sy, sz], got string");
  j = Valid();
  j["render"]["spp"] = "many";
  EXPECT_EQ(ErrorOf(j), "scene.json: render.spp: expected an integer in [1, 16777216], got string");
  j = Valid();
  j["render"]["method"] = 3;
  EXPECT_EQ(ErrorOf(j), "scene.json: render.method: expected a string, got number");
  j = Valid();  // a method's block is kept for its method to check (tests/render/method_test.cpp)
  j["render"]["vpl"] = {{"paths", 16}};
  EXPECT_EQ(ParseScene(j, dir_.path(), "scene.json", true).render.method_settings.at("vpl")["paths"], 16);
  j = Valid();
  j["render"]["vpl"] = 16;
  EXPECT_EQ(ErrorOf(j).rfind("scene.json: render.vpl: unknown key (allowed here: method, spp", 0), 0u) << ErrorOf(j);
  j = Valid();
  j["output"]["layers"] = {"mask"};
  EXPECT_EQ(ErrorOf(j), "scene.json: output.layers: must include \"composite\", the render's result");
  j = Valid();
  j["real"]["mesh"] = "nowhere.ply";
  EXPECT_EQ(ErrorOf(j), "scene.json: real.mesh: mesh " + (dir_ / "nowhere.ply").string() + " does not exist");
  j = Valid();
  j.erase("camera");
  EXPECT_EQ(ErrorOf(j), "scene.json: camera: missing required key");
  j = Valid();
  j["version"] = 2;
  EXPECT_EQ(ErrorOf(j), "scene.json: version: this mr reads scene version 1, the file is version 2");
  j = Valid();
  j["virtual"][0]["material"]["specular"] = {0.6, 0.6, 0.6};
  EXPECT_NE(ErrorOf(j).find("albedo + specular"), std::string::npos);
  j = Valid();
  j["virtual"][1]["name"] = "a";
  EXPECT_EQ(ErrorOf(j), "scene.json: virtual[1].name: name \"a\" is used twice");
  j = Valid();
  j["render"]["frames"] = "5:2";
  EXPECT_EQ(ErrorOf(j), "scene.json: render.frames: \"5:2\": the range is empty");
  j = Valid();
  j["camera"]["frames"] = "frames/%s.png";
  EXPECT_NE(ErrorOf(j).find("camera.frames: frame pattern"), std::string::npos);
  j = Valid();
  j["virtual"][0]["transform"] = {{"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 2}}};
  EXPECT_NE(ErrorOf(j).find("last row"), std::string::npos);
}

// transform.rest_on: the object's lowest point (after its rotation and
// scale) on the first real surface below the point, centred on it across
// up; with lighting.up, "below" follows it.  A point over nothing, or
// rest_on beside a translation, is an error naming the key.
TEST_F(SceneFiles, RestOnPutsTheObjectOnTheSurfaceBelow) {
  // A floor at y = 0 and a table top at y = 0.7 over x, z in [0, 1].
  WriteTextFile(dir_ / "room.obj",
                "v -5 0 -5\nv 5 0 -5\nv 5 0 5\nv -5 0 5\nv 0 0.7 0\nv 1 0.7 0\nv 1 0.7 1\nv 0 0.7 1\n"
                "f 1 3 2\nf 1 4 3\nf 5 7 6\nf 5 8 7\n");
  // A box from (-1, -2, -1) to (1, 0, 3): lowest y -2, centre (0, -1, 1).
  WriteTextFile(dir_ / "box.obj", "v -1 -2 -1\nv 1 -2 -1\nv 1 0 3\nv -1 0 3\nf 1 2 3\nf 1 3 4\n");
  Json j = Valid();
  j["real"]["mesh"] = "room.obj";
  j["virtual"][0]["mesh"] = "box.obj";
  j["virtual"][0]["transform"] = {{"rest_on", {0.5, 2.0, 0.5}}, {"scale", 0.1}};
  Scene s = ParseScene(j, dir_.path(), "scene.json", true);
  const Eigen::Affine3d& m = s.virtuals[0].world_from_object;
  // The mesh's float positions: 0.7f is 0.7 to 1.2e-8.
  EXPECT_TRUE((m * Eigen::Vector3d(0, -2, 1)).isApprox(Eigen::Vector3d(0.5, 0.7, 0.5), 1e-7))  // bottom centre
      << (m * Eigen::Vector3d(0, -2, 1)).transpose();
  ASSERT_TRUE(s.virtuals[0].rests_on);
  EXPECT_TRUE(s.virtuals[0].rests_on->isApprox(Eigen::Vector3d(0.5, 0.7, 0.5), 1e-7));
  j["virtual"][0]["transform"]["rest_on"] = {3.0, 2.0, 3.0};  // beside the table: the floor
  s = ParseScene(j, dir_.path(), "scene.json", true);
  EXPECT_NEAR((s.virtuals[0].world_from_object * Eigen::Vector3d(0, -2, 1)).y(), 0, 1e-7);
  j["virtual"][0]["transform"]["rest_on"] = {3.0, -1.0, 3.0};  // under the floor: nothing below
  EXPECT_EQ(ErrorOf(j).rfind("scene.json: virtual[0].transform.rest_on: no real surface below [3, -1, 3]", 0), 0u)
      << ErrorOf(j);
  j["virtual"][0]["transform"]["rest_on"] = {0.5, 2.0, 0.5};
  j["virtual"][0]["transform"]["translation"] = {0, 0, 0};
  EXPECT_EQ(ErrorOf(j),
            "scene.json: virtual[0].transform.rest_on: give either rest_on or translation/matrix, not both");
  // Up along +z (a room in its first camera's frame): "below" is -z, which
  // both planes contain, so nothing is below.
  j["virtual"][0]["transform"].erase("translation");
  j["lighting"]["environment_up"] = {0, 0, 1};
  EXPECT_NE(ErrorOf(j).find("no real surface below"), std::string::npos) << ErrorOf(j);
}

// transform.at_pixel: the object stood on the real surface seen at a pixel
// of a frame, through the camera model and that frame's pose.  A camera
// 1.5 m over a table top at y = 0.7 (frame 1 of two: the first pose is
// elsewhere), looking straight down: the pixel 100 px right of the centre
// sees x = 0.5 + 100 / 500 * 0.8 = 0.66 on the table.  A pixel that sees the
// wall, or nothing, is an error naming the key.
TEST_F(SceneFiles, AtPixelStandsTheObjectOnTheSurfaceSeenThere) {
  WriteTextFile(dir_ / "room.obj",
                "v -5 0 -5\nv 5 0 -5\nv 5 0 5\nv -5 0 5\nv 0 0.7 0\nv 1 0.7 0\nv 1 0.7 1\nv 0 0.7 1\n"
                "v 0.9 0 -5\nv 0.9 0 5\nv 0.9 3 5\nv 0.9 3 -5\n"
                "f 1 3 2\nf 1 4 3\nf 5 7 6\nf 5 8 7\nf 9 10 11\nf 9 11 12\n");
  WriteTextFile(dir_ / "box.obj", "v -1 -2 -1\nv 1 -2 -1\nv 1 0 3\nv -1 0 3\nf 1 2 3\nf 1 3 4\n");
  CameraModel("LENSMODEL_PINHOLE", {500, 500, 319.5, 239.5}, 640, 480).Write(dir_ / "cam.cameramodel");
  // Looking down -y: camera x = world x, camera y = world z, z forward = -y.
  const double h = 0.5 * std::sqrt(0.5);
  WriteTextFile(dir_ / "traj.txt", fmt::format("0 5 5 5 0 0 0 1\n1 0.5 2.2 0.5 {} 0 0 {}\n", h * 2, h * 2));
  Json j = Valid();
  j["real"]["mesh"] = "room.obj";
  j["virtual"][0]["mesh"] = "box.obj";
  j["virtual"][0]["transform"] = {{"at_pixel", {{"frame", 1}, {"pixel", {419.5, 239.5}}}}, {"scale", 0.1}};
  Scene s = ParseScene(j, dir_.path(), "scene.json", true);
  ASSERT_TRUE(s.virtuals[0].rests_on);
  EXPECT_LT((*s.virtuals[0].rests_on - Eigen::Vector3d(0.5 + 0.2 * 1.5, 0.7, 0.5)).norm(), 1e-4)
      << s.virtuals[0].rests_on->transpose();
  // The box's bottom centre (0, -2, 1) at that point.
  EXPECT_LT((s.virtuals[0].world_from_object * Eigen::Vector3d(0, -2, 1) - *s.virtuals[0].rests_on).norm(), 1e-3);
  // Stood along another up: the wall is then the floor (up = -x, towards the camera's side).
  j["virtual"][0]["transform"]["at_pixel"]["pixel"] = {619.5, 239.5};  // x = 1.1: the wall at x = 0.9
  j["virtual"][0]["transform"]["at_pixel"]["up"] = {-1, 0, 0};
  s = ParseScene(j, dir_.path(), "scene.json", true);
  ASSERT_TRUE(s.virtuals[0].rests_on);
  EXPECT_NEAR(s.virtuals[0].rests_on->x(), 0.9, 1e-6);
  j["virtual"][0]["transform"]["at_pixel"].erase("up");
  EXPECT_NE(ErrorOf(j).find("at_pixel.pixel: the surface seen here is 90 degrees from level"), std::string::npos)
      << ErrorOf(j);
  j["virtual"][0]["transform"]["at_pixel"]["pixel"] = {700, 239.5};
  EXPECT_NE(ErrorOf(j).find("outside the camera's 640x480 image"), std::string::npos) << ErrorOf(j);
  j["virtual"][0]["transform"]["at_pixel"] = {{"frame", 0}, {"pixel", {319.5, 239.5}}};  // looks along +z, at nothing
  EXPECT_NE(ErrorOf(j).find("meets no real surface"), std::string::npos) << ErrorOf(j);
  j["virtual"][0]["transform"]["at_pixel"] = {{"frame", 2}, {"pixel", {319.5, 239.5}}};
  EXPECT_NE(ErrorOf(j).find("frame 2 has no pose (the camera has 2)"), std::string::npos) << ErrorOf(j);
  j["virtual"][0]["transform"]["rest_on"] = {0.5, 2.0, 0.5};
  EXPECT_NE(ErrorOf(j).find("give either rest_on or at_pixel"), std::string::npos) << ErrorOf(j);
}

// A trajectory (docs/conventions.md, "Object trajectories"): keyframes by
// frame, translation and scale linear between them, rotation slerp the
// shorter way (350 degrees after 0 is 10 degrees back), held before the first
// and after the last; a scale of 0 is allowed (the object collapses).  The
// ambiguous is refused: a transform and a trajectory together, frames out of
// order or repeated, a matrix (which cannot be interpolated).
// A virtual light in the `virtual` list: a lights.json light in its own
// frame, posed by a transform or a trajectory; always virtual; its
// position follows the pose (scale included), its direction the rotation.
// A mesh beside the light is refused.
TEST_F(SceneFiles, VirtualLightsTakeTrajectories) {
  Json j = Valid();
  j["virtual"].push_back(Json::parse(R"({"name": "torch",
    "light": {"type": "spot", "position": [0, 0, 0], "direction": [0, 0, 1], "intensity": [5, 5, 5],
              "cone_deg": 20},
    "trajectory": [{"frame": 0, "translation": [1, 1, 0]},
                   {"frame": 4, "translation": [1, 1, 4], "rotation_deg": [0, 90, 0], "scale": 3}]})"));
  const Scene s = ParseScene(j, dir_.path(), "scene.json", true);
  ASSERT_EQ(s.virtual_lights.size(), 1u);
  EXPECT_EQ(s.virtuals.size(), 2u);
  const Light l0 = s.virtual_lights[0].At(0), l4 = s.virtual_lights[0].At(4);
  EXPECT_TRUE(l0.is_virtual);
  EXPECT_EQ(l0.name, "torch");
  EXPECT_LT((l0.position - Eigen::Vector3d(1, 1, 0)).norm(), 1e-12);
  EXPECT_LT((l4.position - Eigen::Vector3d(1, 1, 4)).norm(), 1e-12);
  EXPECT_LT((l4.direction - Eigen::Vector3d(1, 0, 0)).norm(), 1e-9);  // +z turned 90 degrees about +y
  EXPECT_LT((s.virtual_lights[0].At(2).position - Eigen::Vector3d(1, 1, 2)).norm(), 1e-12);
  j["virtual"][2]["mesh"] = "bunny.ply";
  EXPECT_NE(ErrorOf(j).find("virtual[2].mesh: unknown key"), std::string::npos) << ErrorOf(j);
}

TEST_F(SceneFiles, TrajectoriesInterpolateAndRefuseTheAmbiguous) {
  Json j = Valid();
  j["virtual"][0].erase("transform");
  j["virtual"][0]["trajectory"] = Json::parse(R"([
    {"frame": 2, "translation": [0, 0, 1]},
    {"frame": 6, "translation": [4, 0, 1], "rotation_deg": [0, 350, 0], "scale": 2},
    {"frame": 8, "scale": 0}])");
  const Scene s = ParseScene(j, dir_.path(), "scene.json", true);
  const SceneVirtual& v = s.virtuals[0];
  ASSERT_EQ(v.keyframes.size(), 3u);
  auto at = [&](double f, const Eigen::Vector3d& p) { return v.WorldFromObjectAt(f) * p; };
  EXPECT_LT((at(0, {0, 0, 0}) - Eigen::Vector3d(0, 0, 1)).norm(), 1e-12);  // held before the first
  EXPECT_LT((at(4, {0, 0, 0}) - Eigen::Vector3d(2, 0, 1)).norm(), 1e-12);  // half way
  // Half way the rotation is 5 degrees back about y (the shorter way), the scale 1.5.
  const Eigen::Vector3d x = at(4, {1, 0, 0}) - at(4, {0, 0, 0});
  const double a = -5 * M_PI / 180;
  EXPECT_LT((x - 1.5 * Eigen::Vector3d(std::cos(a), 0, -std::sin(a))).norm(), 1e-12) << x.transpose();
  EXPECT_LT(std::abs(v.WorldFromObjectAt(7).linear().norm() - std::sqrt(3.0)), 1e-12);  // scale 1 half way to 0
  EXPECT_EQ(v.WorldFromObjectAt(9).linear().norm(), 0.0);                               // collapsed
  EXPECT_EQ(v.world_from_object.matrix(), v.WorldFromObjectAt(2).matrix());             // the first keyframe's

  Json k = j;
  k["virtual"][0]["transform"] = {{"translation", {0, 0, 1}}};
  EXPECT_NE(ErrorOf(k).find("virtual[0].trajectory: give either transform or trajectory"), std::string::npos)
      << ErrorOf(k);
  k = j;
  k["virtual"][0]["trajectory"][2]["frame"] = 6;
  EXPECT_NE(ErrorOf(k).find("virtual[0].trajectory[2].frame: keyframes must be in increasing frame order"),
            std::string::npos)
      << ErrorOf(k);
  k = j;
  k["virtual"][0]["trajectory"][1]["matrix"] = Json::array();
  EXPECT_NE(ErrorOf(k).find("a matrix cannot be interpolated"), std::string::npos) << ErrorOf(k);
  k = j;
  k["virtual"][0]["trajectory"][1]["scale"] = -1;
  EXPECT_NE(ErrorOf(k).find("virtual[0].trajectory[1].scale"), std::string::npos) << ErrorOf(k);
  k = j;
  k["virtual"][0]["trajectory"] = Json::array();
  EXPECT_NE(ErrorOf(k).find("expected an array of keyframes"), std::string::npos) << ErrorOf(k);
  // Light per frame: a pattern, like camera.frames.
  k = j;
  k["lighting"]["environment"] = "frames/env%05d.exr";
  k["lighting"]["lights"] = "frames/lights%05d.json";
  const Scene d = ParseScene(k, dir_.path(), "scene.json", true);
  EXPECT_TRUE(d.lighting.environment_per_frame);
  EXPECT_TRUE(d.lighting.lights_per_frame);
  EXPECT_FALSE(s.lighting.environment_per_frame);
}

// A model's extrinsics place the camera one way in every case (the reported
// failure: without poses mr-render put the camera at the identity while
// mr-probe used the extrinsics): without poses, world_from_cam is
// ref_from_cam; with the camera's poses, the poses; with the rig's poses,
// each composed with ref_from_cam.
TEST_F(SceneFiles, ModelExtrinsicsPlaceTheCameraOneWay) {
  Rigid3 cam_from_ref;
  cam_from_ref.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(2.5, Eigen::Vector3d(1, 2, 3).normalized()));
  cam_from_ref.translation = Eigen::Vector3d(0.1, -0.2, 0.3);
  CameraModel("LENSMODEL_PINHOLE", {100, 100, 63.5, 47.5}, 128, 96, cam_from_ref)
      .Write(dir_ / "cam.cameramodel", "test");
  Rigid3 world_from_x;
  world_from_x.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()));
  world_from_x.translation = Eigen::Vector3d(1, 2, 3);
  const Eigen::Quaterniond& q = world_from_x.rotation;
  WriteTextFile(dir_ / "traj.txt",
                fmt::format("0 1 2 3 {:.17g} {:.17g} {:.17g} {:.17g}\n", q.x(), q.y(), q.z(), q.w()));
  auto near = [](const Rigid3& a, const Rigid3& b) {
    return (a.translation - b.translation).norm() < 1e-12 && a.rotation.angularDistance(b.rotation) < 1e-12;
  };
  Json j = Valid();
  j["camera"].erase("poses");
  Scene s = ParseScene(j, dir_.path(), "scene.json", true);
  ASSERT_EQ(LoadScenePoses(s).size(), 1u);
  EXPECT_TRUE(near(LoadScenePoses(s)[0], cam_from_ref.Inverse()));
  EXPECT_NE(ScenePoseSource(s).find("extrinsics"), std::string::npos);
  s = ParseScene(Valid(), dir_.path(), "scene.json", true);
  ASSERT_EQ(LoadScenePoses(s).size(), 1u);
  EXPECT_TRUE(near(LoadScenePoses(s)[0], world_from_x));
  j = Valid();
  j["camera"]["poses"]["of"] = "rig";
  s = ParseScene(j, dir_.path(), "scene.json", true);
  EXPECT_TRUE(near(LoadScenePoses(s)[0], world_from_x * cam_from_ref.Inverse()));
  j["camera"]["poses"]["of"] = "sensor";
  EXPECT_NE(ErrorOf(j).find("camera.poses.of"), std::string::npos) << ErrorOf(j);
}

TEST_F(SceneFiles, ReadSceneReportsSyntaxErrorsWithLine) {
  WriteTextFile(dir_ / "bad.json", "{\n \"version\": 1,\n \"camera\": {\n}\n");
  try {
    ReadScene(dir_ / "bad.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind((dir_ / "bad.json").string() + ":5:1: invalid JSON", 0), 0u) << e.what();
  }
}

}  // namespace
}  // namespace mr
