#include "geometry/enclosure.h"
#include "geometry/primitives.h"

#include <gtest/gtest.h>

namespace mr {
namespace {

Eigen::AlignedBox3d PointBox(double x, double y, double z) {
  Eigen::AlignedBox3d b;
  b.extend(Eigen::Vector3d(x, y, z));
  return b;
}

TEST(ClosedSurfaces, ABoxSeparatesInsideFromOutside) {
  ClosedSurfaces c;
  c.Add(Box({-1, -1, -1}, {1, 1, 1}));
  c.Build();
  ASSERT_EQ(c.count(), 1);
  const Eigen::Vector3d inside(0.1, 0.2, 0.3);
  EXPECT_TRUE(c.Separates(inside, PointBox(3, 0, 0)));
  EXPECT_TRUE(c.Separates(inside, Eigen::AlignedBox3d()));  // a distant light, at infinity
  Eigen::AlignedBox3d far(Eigen::Vector3d(2, 2, 2), Eigen::Vector3d(3, 3, 3));
  EXPECT_TRUE(c.Separates(inside, far));
  EXPECT_FALSE(c.Separates(inside, PointBox(0.5, 0.5, 0.5)));  // same side
  EXPECT_FALSE(c.Separates(Eigen::Vector3d(5, 0, 0), PointBox(3, 0, 0)));
  // A box that straddles the wall is on neither side.
  EXPECT_FALSE(c.Separates(inside, Eigen::AlignedBox3d(Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d(1.5, 0.1, 0.1))));
  // A camera on the surface itself is not decided.
  EXPECT_FALSE(c.Separates(Eigen::Vector3d(1, 0, 0), PointBox(3, 0, 0)));
  // Rays through edges and corners of the box: the test retries or declines, never guesses.
  EXPECT_TRUE(c.Separates(Eigen::Vector3d(0, 0, 0), PointBox(3, 3, 3)));
}

TEST(ClosedSurfaces, AnOpeningMeansNothingIsProven) {
  Mesh open = Box({-1, -1, -1}, {1, 1, 1});
  open.triangles.pop_back();  // one missing triangle: light gets in
  ClosedSurfaces c;
  c.Add(open);
  c.Build();
  EXPECT_EQ(c.count(), 0);
  EXPECT_FALSE(c.Separates(Eigen::Vector3d::Zero(), PointBox(3, 0, 0)));
}

// A room made of separate meshes (walls, floor, ceiling) that share edges
// is closed as a whole: vertices are welded across meshes.
TEST(ClosedSurfaces, PartsThatShareEdgesCloseTogether) {
  Mesh box = Box({0, 0, 0}, {4, 3, 5});
  ClosedSurfaces c;
  for (size_t f = 0; f < box.triangles.size(); f += 2) {
    Mesh part;
    part.positions = box.positions;
    part.triangles = {box.triangles[f], box.triangles[f + 1]};
    c.Add(part);
  }
  c.Build();
  EXPECT_EQ(c.count(), 1);
  EXPECT_TRUE(c.Separates(Eigen::Vector3d(2, 1.5, 2.5), PointBox(10, 1, 1)));
  // A closed cupboard inside the room: the camera in the room, the object in the cupboard.
  c.Add(Box({1, 0.5, 1}, {2, 1.5, 2}));
  c.Build();
  EXPECT_TRUE(c.Separates(Eigen::Vector3d(3, 1.5, 4), PointBox(1.5, 1, 1.5)));
  EXPECT_FALSE(c.Separates(Eigen::Vector3d(3, 1.5, 4), PointBox(3.5, 1, 1.5)));
}

}  // namespace
}  // namespace mr
