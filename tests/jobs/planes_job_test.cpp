#include "jobs/planes_job.h"

#include <cmath>

#include <gtest/gtest.h>

#include "camera/camera_model.h"
#include "camera/trajectory.h"
#include "core/error.h"
#include "core/image.h"
#include "core/sampling.h"
#include "geometry/mesh.h"
#include "test_util.h"

namespace mr {
namespace {

// A room a video without depth sees: a floor (grey 0.2) at y = 0, a table
// top (0.6) 0.75 m over it, x in [-0.5, 0.5], z in [-0.3, 0.3], a wall
// (0.4) at z = -1.5; y up.  Three cameras 1.6 m over the floor at z = 1.2,
// looking down at the table.  The frames are the room ray cast (sRGB PNG);
// the sparse points are samples of the three surfaces with 3 mm of noise.
double Radiance(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  double best = INFINITY, value = 0;
  auto plane = [&](int axis, double at, double v, auto inside) {
    if (std::abs(d[axis]) < 1e-12) return;
    const double t = (at - o[axis]) / d[axis];
    if (t > 0 && t < best && inside(o + t * d)) best = t, value = v;
  };
  plane(1, 0.0, 0.2, [](const Eigen::Vector3d&) { return true; });
  plane(1, 0.75, 0.6, [](const Eigen::Vector3d& p) { return std::abs(p.x()) <= 0.5 && std::abs(p.z()) <= 0.3; });
  plane(2, -1.5, 0.4, [](const Eigen::Vector3d&) { return true; });
  return value;
}

class PlanesJob : public ::testing::Test {
 protected:
  void SetUp() override {
    const CameraModel camera("LENSMODEL_PINHOLE", {300, 300, 159.5, 119.5}, 320, 240);
    camera.Write(dir_ / "cam.cameramodel");
    Trajectory poses;
    for (int f = 0; f < 3; ++f) {
      const Eigen::Vector3d eye(-0.3 + 0.3 * f, 1.6, 1.2), target(0, 0.75, 0);
      const Eigen::Vector3d z = (target - eye).normalized();
      const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized() * -1;  // right
      const Eigen::Vector3d y = z.cross(x);                                           // down
      Eigen::Matrix3d r;
      r << x, y, z;
      poses.poses.push_back({static_cast<double>(f), Rigid3(Eigen::Quaterniond(r), eye)});
      Image img = Image::Rgb(320, 240);
      for (int py = 0; py < 240; ++py)
        for (int px = 0; px < 320; ++px) {
          Eigen::Vector3d dir;
          ASSERT_TRUE(camera.Unproject(Eigen::Vector2d(px, py), &dir));
          const float v = static_cast<float>(Radiance(eye, r * dir.normalized()));
          for (int c = 0; c < 3; ++c) img.at(px, py, c) = v;
        }
      WriteImage(dir_ / fmt::format("{:05d}.png", f), img);
    }
    WriteTum(dir_ / "poses.tum", poses);
    Pcg32 rng(2);
    Mesh cloud;
    auto noise = [&] { return 0.003 * (2 * rng.NextDouble() - 1); };
    for (int i = 0; i < 1200; ++i)
      cloud.positions.emplace_back(-1.5 + 3 * rng.NextDouble(), noise(), -1.5 + 3 * rng.NextDouble());
    for (int i = 0; i < 500; ++i)
      cloud.positions.emplace_back(-0.5 + rng.NextDouble(), 0.75 + noise(), -0.3 + 0.6 * rng.NextDouble());
    for (int i = 0; i < 700; ++i)
      cloud.positions.emplace_back(-1.5 + 3 * rng.NextDouble(), 2 * rng.NextDouble(), -1.5 + noise());
    WritePly(dir_ / "points.ply", cloud);
    options_.points = (dir_ / "points.ply").string();
    options_.poses = (dir_ / "poses.tum").string();
    options_.camera = (dir_ / "cam.cameramodel").string();
    options_.frames = (dir_ / "%05d.png").string();
    options_.out = (dir_ / "room.ply").string();
  }
  test::TempDir dir_;
  PlanesJobOptions options_;
};

// The three planes found from the points, up from the floor (the cameras
// look down 28 degrees: their mean up is that far off), and each vertex's
// albedo the colour the frames saw there: within one 8-bit step of sRGB
// (0.6 is code 203, whose neighbours decode 0.0035 away).
TEST_F(PlanesJob, PlanesAndTheirColoursFromTheFrames) {
  Report report;
  RunPlanes(options_, &report);
  const nlohmann::json& m = report.metrics();
  EXPECT_EQ(m["up"]["from"], "plane");
  EXPECT_GT(m["up"]["from_hint_deg"].get<double>(), 20);
  ASSERT_EQ(m["planes"].size(), 3u);
  const Mesh room = ReadMesh(dir_ / "room.ply");
  ASSERT_EQ(room.colors.size(), room.vertex_count());
  int table = 0, floor = 0;
  for (size_t i = 0; i < room.vertex_count(); ++i) {
    const Eigen::Vector3f p = room.positions[i];
    // Well inside a surface, away from the table's edge and its shadow in the views.
    if (std::abs(p.y() - 0.75f) < 0.01f && std::abs(p.x()) < 0.4f && std::abs(p.z()) < 0.2f) {
      EXPECT_NEAR(room.colors[i].x(), 0.6, 0.004) << p.transpose();
      ++table;
    }
    // The floor beside the table, in view (the cameras see 13 to 57 degrees below level).
    if (std::abs(p.y()) < 0.01f && p.z() > -0.8f && p.z() < -0.2f && std::abs(p.x()) > 0.7f &&
        std::abs(p.x()) < 0.95f) {
      EXPECT_NEAR(room.colors[i].x(), 0.2, 0.004) << p.transpose();
      ++floor;
    }
  }
  EXPECT_GT(table, 100);
  EXPECT_GT(floor, 100);
  EXPECT_GT(m["albedo"]["vertices_observed"].get<int64_t>(), 0);
  EXPECT_TRUE(report.warnings().empty());
}

// A floor seen only at grazing angles (cameras 0.1 m over it, looking level
// at the wall): its plane is still found from its points, but the frames see
// only a strip of it within 80 degrees of its normal (0.25 to 0.57 m ahead),
// so most of its vertices take their neighbours' colour and the report
// warns.  (The frames' content does not matter here, only which vertices
// the views reach.)
TEST_F(PlanesJob, APlaneSeenAtGrazingAnglesIsFoundAndItsColourReportedUnseen) {
  Trajectory poses;
  for (int f = 0; f < 3; ++f)  // looking along -z, level: x right, y down
    poses.poses.push_back(
        {static_cast<double>(f), Rigid3(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX())),
                                        Eigen::Vector3d(-0.3 + 0.3 * f, 0.1, 1.2))});
  WriteTum(dir_ / "level.tum", poses);
  PlanesJobOptions o = options_;
  o.poses = (dir_ / "level.tum").string();
  o.up = {0, 1, 0};
  Report report;
  RunPlanes(o, &report);
  const nlohmann::json& m = report.metrics();
  ASSERT_GE(m["planes"].size(), 2u);
  EXPECT_EQ(m["planes"][0]["kind"], "horizontal");  // the floor, most points
  EXPECT_NEAR(m["planes"][0]["offset"].get<double>(), 0, 0.002);
  ASSERT_EQ(report.warnings().size(), 1u);
  EXPECT_NE(report.warnings()[0].find("plane 0 is in view mostly at grazing angles"), std::string::npos)
      << report.warnings()[0];
}

// A model in COLMAP's units (0.37 of a metre, turned, moved): --height 1.6
// (the cameras over the floor) brings it back to metres, --world
// first-camera into the first camera's frame, where the table lies 0.85 m
// below the camera along up.
TEST_F(PlanesJob, HeightScalesAModelWithoutUnits) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Vector3d t(4, -2, 1);
  const double s = 0.37;
  MeshReadOptions read;
  read.points = true;
  Mesh cloud = ReadMesh(dir_ / "points.ply", read);
  for (Eigen::Vector3f& p : cloud.positions) p = (s * (q * p.cast<double>()) + t).cast<float>();
  WritePly(dir_ / "points-colmap.ply", cloud);
  Trajectory poses = ReadTum(dir_ / "poses.tum");
  for (TimedPose& p : poses.poses)
    p.world_from_cam = Rigid3(q * p.world_from_cam.rotation, s * (q * p.world_from_cam.translation) + t);
  WriteTum(dir_ / "poses-colmap.tum", poses);
  PlanesJobOptions o = options_;
  o.points = (dir_ / "points-colmap.ply").string();
  o.poses = (dir_ / "poses-colmap.tum").string();
  o.height = 1.6;
  o.world = "first-camera";
  o.poses_out = (dir_ / "poses-out.tum").string();
  Report report;
  RunPlanes(o, &report);
  const nlohmann::json& m = report.metrics();
  EXPECT_NEAR(m["scale"]["factor"].get<double>(), 1 / s, 0.01 / s);
  const Trajectory out = ReadTum(dir_ / "poses-out.tum");
  EXPECT_LT(out.poses[0].world_from_cam.translation.norm(), 1e-9);
  EXPECT_NEAR((out.poses[2].world_from_cam.translation - out.poses[0].world_from_cam.translation).norm(), 0.6, 0.01);
  bool found_table = false;
  for (const auto& p : m["planes"])
    if (p["kind"] == "horizontal" && std::abs(p["offset"].get<double>() + 0.85) < 0.01) found_table = true;
  EXPECT_TRUE(found_table) << m["planes"].dump();
  // --world gravity: the same, turned so that up is +y (the floor's normal
  // exactly), the first camera's right level.
  o.world = "gravity";
  Report turned;
  RunPlanes(o, &turned);
  const nlohmann::json& g = turned.metrics();
  EXPECT_EQ(g["up"]["direction"], nlohmann::json({0.0, 1.0, 0.0}));
  found_table = false;
  for (const auto& p : g["planes"])
    if (p["kind"] == "horizontal" && std::abs(p["offset"].get<double>() + 0.85) < 0.01 &&
        std::abs(p["normal"][1].get<double>() - 1) < 1e-9)
      found_table = true;
  EXPECT_TRUE(found_table) << g["planes"].dump();
  const Trajectory level = ReadTum(dir_ / "poses-out.tum");
  // The cameras have no roll: the first one's right is level to the floor fit's accuracy (1e-4 rad).
  EXPECT_NEAR((level.poses[0].world_from_cam.rotation * Eigen::Vector3d::UnitX()).y(), 0, 1e-4);
  // Bad options name their flag.
  o.poses_out.clear();
  EXPECT_THROW(RunPlanes(o, &report), UsageError);
}

}  // namespace
}  // namespace mr
