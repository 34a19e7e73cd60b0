#include "geometry/planes.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/sampling.h"

namespace mr {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

// A room's sparse points as SfM gives them: a floor (3 x 3 m), a table top
// 0.75 m over it (1.0 x 0.6 m), a wall at the back (3 m wide, 2 m high),
// 4 mm of noise, and a tenth as many points scattered through the room.
// The room is turned by `world_from_room` so that nothing is axis-aligned.
struct SparseRoom {
  std::vector<Eigen::Vector3d> points;
  Eigen::Matrix3d world_from_room;
};

SparseRoom MakeRoom(uint64_t seed) {
  SparseRoom r;
  r.world_from_room =
      (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  Pcg32 rng(seed);
  auto noise = [&] { return 0.004 * (rng.NextDouble() + rng.NextDouble() + rng.NextDouble() - 1.5) * 2; };
  auto add = [&](const Eigen::Vector3d& p) { r.points.push_back(r.world_from_room * p); };
  for (int i = 0; i < 1500; ++i) add({-1.5 + 3 * rng.NextDouble(), noise(), -1.5 + 3 * rng.NextDouble()});
  for (int i = 0; i < 600; ++i) add({-0.5 + rng.NextDouble(), 0.75 + noise(), -0.3 + 0.6 * rng.NextDouble()});
  for (int i = 0; i < 900; ++i) add({-1.5 + 3 * rng.NextDouble(), 2 * rng.NextDouble(), -1.5 + noise()});
  for (int i = 0; i < 300; ++i)
    add({-1.5 + 3 * rng.NextDouble(), 0.05 + 1.9 * rng.NextDouble(), -1.4 + 2.9 * rng.NextDouble()});
  return r;
}

TEST(Planes, FloorTableAndWallFoundAndTurnedToGravity) {
  const SparseRoom room = MakeRoom(3);
  const Eigen::Vector3d up = room.world_from_room.col(1);
  PlaneOptions o;
  // A hand-held camera's mean up: 12 degrees off.
  o.up_hint = Eigen::AngleAxisd(12 * kDeg, room.world_from_room.col(0)) * up;
  const Eigen::Vector3d eye = room.world_from_room * Eigen::Vector3d(0, 1.6, 1.2);
  const PlaneSet set = DetectPlanes(room.points, {eye}, o);
  EXPECT_EQ(set.up_from, "plane");
  // The floor's fit fixes up: 1500 points with 4 mm of noise over 3 m.
  EXPECT_LT(std::acos(std::min(1.0, set.up.dot(up))) / kDeg, 0.1);
  ASSERT_EQ(set.planes.size(), 3u);
  EXPECT_EQ(set.planes[0].kind, "horizontal");  // the floor, most points
  EXPECT_NEAR(set.planes[0].offset, 0, 0.002);
  EXPECT_EQ(set.planes[1].kind, "vertical");  // the wall
  EXPECT_LT(std::acos(std::min(1.0, set.planes[1].normal.dot(room.world_from_room.col(2)))) / kDeg, 0.5);
  EXPECT_NEAR(set.planes[1].offset, -1.5, 0.003);
  EXPECT_EQ(set.planes[2].kind, "horizontal");  // the table, normal up (towards the eye)
  EXPECT_GT(set.planes[2].normal.dot(up), 0.9999);
  EXPECT_NEAR(set.planes[2].offset, 0.75, 0.002);
  // Inliers: the noise is within the 2 cm gate, the scattered points mostly not.
  EXPECT_GE(set.planes[2].inliers.size(), 600u);
  EXPECT_LT(set.planes[2].inliers.size(), 640u);
  EXPECT_LT(set.planes[2].rms, 0.0045);  // the noise's standard deviation is 4 mm

  // The table's surface: its 1.0 x 0.6 m grown by 0.15 m, up to a cell (2 cm)
  // and a disc of whole cells (8 cells, 16 cm) more, no holes.
  PlaneMeshOptions mo;
  std::vector<int> kept;
  const Mesh mesh = MeshPlanes(room.points, set, mo, &kept);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_GE(kept[2], 600);  // every table point; scattered points in the slab elsewhere are not
  Mesh table;
  std::vector<int> index(mesh.vertex_count(), -1);
  for (const Eigen::Vector3i& t : mesh.triangles)
    if (mesh.scalars[0].values[static_cast<size_t>(t[0])] == 2) {
      table.positions.push_back(mesh.positions[static_cast<size_t>(t[0])]);
      table.positions.push_back(mesh.positions[static_cast<size_t>(t[1])]);
      table.positions.push_back(mesh.positions[static_cast<size_t>(t[2])]);
      const int n = static_cast<int>(table.positions.size());
      table.triangles.emplace_back(n - 3, n - 2, n - 1);
    }
  EXPECT_GT(table.SurfaceArea(), 0.6 * 1.2);
  EXPECT_LT(table.SurfaceArea(), 1.36 * 0.96);
  for (const Eigen::Vector3f& p : table.positions) EXPECT_NEAR(up.dot(p.cast<double>()), 0.75, 0.002);
  // Faces front the normal (counter-clockwise seen from above).
  const Eigen::Vector3f a = table.positions[0], b = table.positions[1], c = table.positions[2];
  EXPECT_GT((b - a).cross(c - a).cast<double>().dot(up), 0);
}

TEST(Planes, DeterministicForASeed) {
  const SparseRoom room = MakeRoom(5);
  PlaneOptions o;
  o.up_hint = room.world_from_room.col(1);
  const PlaneSet a = DetectPlanes(room.points, {}, o), b = DetectPlanes(room.points, {}, o);
  ASSERT_EQ(a.planes.size(), b.planes.size());
  for (size_t i = 0; i < a.planes.size(); ++i) {
    EXPECT_EQ(a.planes[i].inliers, b.planes[i].inliers);
    EXPECT_EQ(a.planes[i].offset, b.planes[i].offset);
  }
}

TEST(Planes, PointsThatSupportNoPlaneAreAClearError) {
  // A cloud of scattered points (a video of foliage): no 2 cm slab holds
  // 60 of them.
  Pcg32 rng(1);
  std::vector<Eigen::Vector3d> cloud;
  for (int i = 0; i < 400; ++i) cloud.emplace_back(3 * rng.NextDouble(), 3 * rng.NextDouble(), 3 * rng.NextDouble());
  try {
    DetectPlanes(cloud, {}, PlaneOptions{});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("support no plane"), std::string::npos) << e.what();
  }
  std::vector<Eigen::Vector3d> bad = cloud;
  bad[7].x() = std::nan("");
  EXPECT_THROW(DetectPlanes(bad, {}, PlaneOptions{}), Error);
}

TEST(Planes, WithoutAHintNothingIsTurned) {
  const SparseRoom room = MakeRoom(7);
  const PlaneSet set = DetectPlanes(room.points, {}, PlaneOptions{});
  EXPECT_EQ(set.up_from, "none");
  for (const Plane& p : set.planes) {
    EXPECT_EQ(p.kind, "slanted");
    EXPECT_LT(p.tilt_deg, 0.1);  // the points' own fit, after the last refit took its inliers again
  }
}

}  // namespace
}  // namespace mr

namespace mr {
namespace {

// A ramp tilted 50 degrees among the level and upright planes: left out by
// default (listed as dropped), kept when asked.  (No level or upright 4 cm
// slab through it holds 60 of its points.)
TEST(Planes, SlantedPlanesAreDroppedUnlessKept) {
  SparseRoom room = MakeRoom(9);
  Pcg32 rng(4);
  const double t = 50 * kDeg;
  for (int i = 0; i < 400; ++i) {
    const double u = rng.NextDouble(), v = rng.NextDouble();
    room.points.push_back(room.world_from_room *
                          Eigen::Vector3d(0.6 + 0.6 * u, 0.1 + 0.6 * v * std::sin(t), 0.5 + 0.6 * v * std::cos(t)));
  }
  PlaneOptions o;
  o.up_hint = room.world_from_room.col(1);
  const PlaneSet dropped = DetectPlanes(room.points, {}, o);
  ASSERT_EQ(dropped.dropped.size(), 1u);
  EXPECT_EQ(dropped.dropped[0].kind, "slanted");
  EXPECT_EQ(dropped.planes.size(), 3u);
  o.keep_slanted = true;
  const PlaneSet kept = DetectPlanes(room.points, {}, o);
  EXPECT_TRUE(kept.dropped.empty());
  ASSERT_EQ(kept.planes.size(), 4u);
  int slanted = 0;
  for (const Plane& p : kept.planes) slanted += p.kind == "slanted";
  EXPECT_EQ(slanted, 1);
}

}  // namespace
}  // namespace mr

namespace mr {
namespace {

// One table top whose SfM points RANSAC splits into two slabs 4.5 cm apart
// (more than its 2 cm gate spans; the points' scatter along the rays) is
// merged back into one plane at their mean; a counter beside it, within the
// merge distance in height (10 cm here) but not overlapping it, stays apart.
TEST(Planes, SlabsOfOneSurfaceAreMergedNeighboursAreNot) {
  Pcg32 rng(6);
  std::vector<Eigen::Vector3d> pts;
  auto noise = [&] { return 0.004 * (2 * rng.NextDouble() - 1); };
  for (int i = 0; i < 1500; ++i) pts.emplace_back(-1.5 + 3 * rng.NextDouble(), noise(), -1.5 + 3 * rng.NextDouble());
  for (int i = 0; i < 400; ++i)  // table, upper slab
    pts.emplace_back(-0.5 + rng.NextDouble(), 0.795 + noise(), -0.3 + 0.6 * rng.NextDouble());
  for (int i = 0; i < 300; ++i)  // table, lower slab
    pts.emplace_back(-0.5 + rng.NextDouble(), 0.75 + noise(), -0.3 + 0.6 * rng.NextDouble());
  for (int i = 0; i < 200; ++i)  // the counter beside it
    pts.emplace_back(1.0 + 0.4 * rng.NextDouble(), 0.86 + noise(), -0.3 + 0.6 * rng.NextDouble());
  PlaneOptions o;
  o.up_hint = Eigen::Vector3d::UnitY();
  o.merge_distance = 0.1;
  const PlaneSet set = DetectPlanes(pts, {}, o);
  EXPECT_EQ(set.merged, 1);
  ASSERT_EQ(set.planes.size(), 3u);
  EXPECT_EQ(set.planes[1].inliers.size(), 700u);
  EXPECT_NEAR(set.planes[1].offset, (400 * 0.795 + 300 * 0.75) / 700, 0.001);
  EXPECT_NEAR(set.planes[2].offset, 0.86, 0.002);
  o.merge_distance = 0;
  EXPECT_EQ(DetectPlanes(pts, {}, o).planes.size(), 4u);
}

}  // namespace
}  // namespace mr
