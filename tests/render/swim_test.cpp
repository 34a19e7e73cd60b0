// The objects' swim against the plate (render/swim.h): a cube standing on
// a textured floor, the plate ray-cast through a camera that moves; with
// the poses the plate was made with the cube does not swim, with one pose
// turned by 0.5 degree it swims by what that turn moves its contact point.
#include "render/swim.h"

#include <gtest/gtest.h>

#include "ray_cast_image.h"

#include <cmath>

#include "core/file.h"
#include "geometry/primitives.h"
#include "render/render_scene.h"
#include "test_util.h"

namespace mr {
namespace {

TEST(Swim, AnObjectOnTheFloorMovesAsTheFloorDoes) {
  test::TempDir dir;
  WriteTextFile(dir / "cube.obj",
                "v -0.1 0 -0.1\nv 0.1 0 -0.1\nv 0.1 0 0.1\nv -0.1 0 0.1\nv -0.1 0.2 -0.1\nv 0.1 0.2 -0.1\n"
                "v 0.1 0.2 0.1\nv -0.1 0.2 0.1\nf 1 2 3\nf 1 3 4\nf 5 7 6\nf 5 8 7\n");
  Scene scene;
  SceneVirtual cube;
  cube.name = "cube";
  cube.mesh = dir / "cube.obj";
  cube.world_from_object.translate(Eigen::Vector3d(0.1, 0, 2.0));
  scene.virtuals.push_back(cube);
  const CameraModel camera("LENSMODEL_PINHOLE", {400, 400, 159.5, 119.5}, 320, 240);
  RenderScene floor;
  floor.AddReal(Box({-5, -1, -5}, {5, 0, 8}), Material{});
  floor.Commit();
  // The floor's texture: waves in random directions, 8 to 25 cm.
  auto shade = [](const Eigen::Vector3d& p) {
    double v = 0;
    for (int i = 0; i < 20; ++i) {
      const double a = 2.4 * i, k = 6.2831853 / (0.08 + 0.0085 * i);
      v += std::sin(k * (std::cos(a) * p.x() + std::sin(a) * p.z()) + 1.7 * i);
    }
    return 1 + 0.08 * v;
  };
  auto plate = [&](const Rigid3& pose) { return test::RayCastImage(floor, camera, pose, shade); };
  // A camera 1.2 m up, looking down 35 degrees at the cube, moving 3 cm
  // sideways a frame (camera frame: x right, y down, z forward).
  auto pose_at = [](int f) {
    const double t = 35 * 3.14159265358979 / 180;
    const Eigen::Vector3d forward(0, -std::sin(t), std::cos(t)), right(-1, 0, 0);
    Eigen::Matrix3d r;
    r << right, forward.cross(right), forward;
    return Rigid3(Eigen::Quaterniond(r), Eigen::Vector3d(0.03 * f, 1.2, 0.3));
  };
  SwimMeter exact(scene, camera), off(scene, camera);
  EXPECT_TRUE(exact.Frame(0, pose_at(0), plate(pose_at(0))).is_null());  // no motion yet
  const Json a = exact.Frame(1, pose_at(1), plate(pose_at(1)));
  ASSERT_TRUE(a.contains("cube")) << a.dump();
  off.Frame(0, pose_at(0), plate(pose_at(0)));
  const Rigid3 turned =
      pose_at(1) * Rigid3(Eigen::Quaterniond(Eigen::AngleAxisd(0.5 * 3.14159265358979 / 180, Eigen::Vector3d::UnitY())),
                          Eigen::Vector3d::Zero());
  const Json b = off.Frame(1, turned, plate(pose_at(1)));
  ASSERT_TRUE(b.contains("cube")) << b.dump();
  const double expected = 400 * std::tan(0.5 * 3.14159265358979 / 180);  // 3.5 px near the image centre
  std::printf("swim with the plate's poses %.3f px, with one turned 0.5 degree %.3f px (about %.2f expected)\n",
              a["cube"].get<double>(), b["cube"].get<double>(), expected);
  EXPECT_LT(a["cube"].get<double>(), 0.2);
  EXPECT_NEAR(b["cube"].get<double>(), expected, 0.5);
  EXPECT_EQ(exact.Summary()["cube"]["frames"], 1);
}

}  // namespace
}  // namespace mr
