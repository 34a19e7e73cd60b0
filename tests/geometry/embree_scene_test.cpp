#include "geometry/embree_scene.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/sampling.h"

namespace mr {
namespace {

// An axis-aligned square in the plane z = z0, facing -z.
Mesh Square(float z0, float half = 1.0f) {
  Mesh m;
  m.positions = {{-half, -half, z0}, {half, -half, z0}, {half, half, z0}, {-half, half, z0}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}};
  return m;
}

Ray RayAlongZ(float x, float y, uint32_t mask) {
  Ray r;
  r.origin = {x, y, 0};
  r.direction = {0, 0, 1};
  r.mask = mask;
  return r;
}

TEST(EmbreeScene, RealRaysIgnoreVirtualGeometry) {
  EmbreeScene s;
  uint32_t wall = s.AddMesh(Square(5), /*is_virtual=*/false);
  uint32_t object = s.AddMesh(Square(2, 0.5f), /*is_virtual=*/true);
  s.Commit();
  Hit h;
  ASSERT_TRUE(s.Intersect(RayAlongZ(0.1f, 0.1f, kMaskAll), &h));
  EXPECT_EQ(h.geometry_id, object);
  EXPECT_TRUE(h.is_virtual);
  EXPECT_FLOAT_EQ(h.t, 2);
  ASSERT_TRUE(s.Intersect(RayAlongZ(0.1f, 0.1f, kMaskReal), &h));
  EXPECT_EQ(h.geometry_id, wall);
  EXPECT_FALSE(h.is_virtual);
  EXPECT_FLOAT_EQ(h.t, 5);
  // Virtual-only rays (for the virtual object's own shadows).
  ASSERT_TRUE(s.Intersect(RayAlongZ(0.9f, 0.9f, kMaskVirtual), &h) == false);
  // Occlusion: st_r and st_v of Differential Instant Radiosity.
  Ray shadow = RayAlongZ(0.1f, 0.1f, kMaskVirtual);
  shadow.tfar = 3;
  EXPECT_TRUE(s.Occluded(shadow));
  shadow.mask = kMaskReal;
  EXPECT_FALSE(s.Occluded(shadow));
  EXPECT_FALSE(s.Intersect(RayAlongZ(3, 3, kMaskAll), &h));
  EXPECT_FALSE(h.valid());
}

TEST(EmbreeScene, InstancesArePlacedByTheirTransform) {
  EmbreeScene s;
  uint32_t proto = s.AddPrototype(Square(0, 0.5f));
  Eigen::Affine3f a = Eigen::Affine3f::Identity();
  a.translate(Eigen::Vector3f(0, 0, 4));
  a.scale(2.0f);
  uint32_t inst = s.AddInstance(proto, a);
  s.Commit();
  Hit h;
  ASSERT_TRUE(s.Intersect(RayAlongZ(0.9f, 0, kMaskAll), &h));  // inside the scaled square
  EXPECT_EQ(h.geometry_id, inst);
  EXPECT_TRUE(h.is_virtual);
  EXPECT_NEAR(h.t, 4, 1e-5);
  EXPECT_FALSE(s.Intersect(RayAlongZ(0.9f, 0, kMaskReal), &h));
  EXPECT_FALSE(s.Intersect(RayAlongZ(1.1f, 0, kMaskAll), &h));
  Eigen::Affine3f singular = Eigen::Affine3f::Identity();
  singular.scale(Eigen::Vector3f(1, 0, 1));
  EmbreeScene s2;
  uint32_t p2 = s2.AddPrototype(Square(0));
  EXPECT_THROW(s2.AddInstance(p2, singular), Error);
}

TEST(EmbreeScene, StreamsAndPacketsMatchSingleRays) {
  EmbreeScene s;
  s.AddMesh(Square(5, 2), false);
  s.AddMesh(Square(3, 0.7f), true);
  s.Commit();
  std::vector<Ray> rays;
  Pcg32 rng(9, 9);
  for (int i = 0; i < 37; ++i) {
    Ray r;
    r.origin = {0, 0, 0};
    r.direction = Eigen::Vector3f(rng.NextFloat() - 0.5f, rng.NextFloat() - 0.5f, 1.0f);
    r.mask = i % 3 == 0 ? kMaskAll : i % 3 == 1 ? kMaskReal : kMaskVirtual;  // a stream of every kind
    rays.push_back(r);
  }
  std::vector<Hit> stream(rays.size());
  s.Intersect(rays, stream);
  std::vector<char> occ(rays.size());
  s.Occluded(rays, occ);
  for (size_t i = 0; i < rays.size(); ++i) {
    Hit one;
    bool hit = s.Intersect(rays[i], &one);
    EXPECT_EQ(stream[i].geometry_id, one.geometry_id) << i;
    EXPECT_EQ(stream[i].t, one.t) << i;
    EXPECT_EQ(static_cast<bool>(occ[i]), hit) << i;
  }
  for (size_t i0 = 0; i0 < rays.size(); i0 += 8) {
    size_t n = std::min<size_t>(8, rays.size() - i0);
    std::vector<Hit> packet(n);
    s.IntersectPacket8(std::span<const Ray>(rays).subspan(i0, n), packet);
    for (size_t k = 0; k < n; ++k) {
      EXPECT_EQ(packet[k].geometry_id, stream[i0 + k].geometry_id);
      if (std::isinf(stream[i0 + k].t)) {
        EXPECT_TRUE(std::isinf(packet[k].t));
      } else {
        EXPECT_NEAR(packet[k].t, stream[i0 + k].t, 1e-5f * stream[i0 + k].t);  // same kernel family; ulps
      }
    }
  }
  auto b = s.Bounds();
  EXPECT_NEAR(b.max().z(), 5, 1e-6);
}

// A wall at z = 5 over [-1, 1]^2 as an n x n grid (2 n^2 triangles).
Mesh GridWall(int n) {
  Mesh m;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) m.positions.emplace_back(2.0f * x / n - 1, 2.0f * y / n - 1, 5.0f);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int i = y * (n + 1) + x;
      m.triangles.push_back({i, i + n + 2, i + 1});
      m.triangles.push_back({i, i + n + 1, i + n + 2});
    }
  return m;
}

// Each kind of ray is served by its kind's own tree and a ray of both kinds
// by a tree of both, or, once an object has moved in a room past 100 000
// triangles, by the objects' tree and then the room's (embree_scene.cpp).
// The hits must be those of one scene of everything under the ray's mask:
// a real ray passes a virtual instance wherever it is moved, a virtual ray
// meets only the instance, a disabled instance nothing, one by one and in
// streams; with no virtual geometry a virtual ray meets nothing at all.
void CheckKindsAsTheObjectMoves(const Mesh& wall_mesh) {
  EmbreeScene s;
  const uint32_t wall = s.AddMesh(wall_mesh, false);
  const uint32_t proto = s.AddPrototype(Square(0, 0.5f));
  Eigen::Affine3f at2 = Eigen::Affine3f::Identity();
  at2.translate(Eigen::Vector3f(0, 0, 2));
  const uint32_t object = s.AddInstance(proto, Eigen::Affine3f::Identity());
  s.SetInstanceTransform(object, at2);  // placed before the first commit, as RenderScene does: no move
  s.Commit();
  EXPECT_EQ(s.last_commit(), "the room's tree and the objects' tree and the tree of both rebuilt");
  for (int step = 0; step < 3; ++step) {
    Hit h;
    const float z = step == 0 ? 2.0f : 3.0f;
    const bool present = step < 2;
    ASSERT_TRUE(s.Intersect(RayAlongZ(0.1f, 0.1f, kMaskReal), &h)) << step;
    EXPECT_EQ(h.geometry_id, wall) << step;
    EXPECT_FLOAT_EQ(h.t, 5);
    EXPECT_EQ(s.Intersect(RayAlongZ(0.1f, 0.1f, kMaskVirtual), &h), present) << step;
    if (present) {
      EXPECT_EQ(h.geometry_id, object);
      EXPECT_NEAR(h.t, z, 1e-5);
    }
    ASSERT_TRUE(s.Intersect(RayAlongZ(0.1f, 0.1f, kMaskAll), &h)) << step;
    EXPECT_EQ(h.geometry_id, present ? object : wall) << step;
    EXPECT_NEAR(h.t, present ? z : 5.0f, 1e-5) << step;
    Ray shadow = RayAlongZ(0.1f, 0.1f, kMaskVirtual);
    shadow.tfar = 4;
    EXPECT_EQ(s.Occluded(shadow), present) << step;
    shadow.mask = kMaskReal;
    EXPECT_FALSE(s.Occluded(shadow)) << step;
    // The same in streams of every kind, beside the object (x = 0.8) and on it.
    std::vector<Ray> rays;
    for (const uint32_t mask : {kMaskAll, kMaskReal, kMaskVirtual})
      for (const float x : {0.1f, 0.8f}) rays.push_back(RayAlongZ(x, 0.1f, mask));
    std::vector<Hit> hits(rays.size());
    s.Intersect(rays, hits);
    std::vector<char> occ(rays.size());
    s.Occluded(rays, occ);
    for (size_t i = 0; i < rays.size(); ++i) {
      Hit one;
      const bool met = s.Intersect(rays[i], &one);
      EXPECT_EQ(hits[i].geometry_id, one.geometry_id) << step << " " << i;
      EXPECT_EQ(hits[i].t, one.t) << step << " " << i;
      EXPECT_EQ(static_cast<bool>(occ[i]), met) << step << " " << i;
      EXPECT_EQ(met, rays[i].mask != kMaskVirtual || (present && i % 2 == 0)) << step << " " << i;
    }
    // The next step: the object moved to z = 3, then scaled to nothing.
    Eigen::Affine3f next = Eigen::Affine3f::Identity();
    next.translate(Eigen::Vector3f(0, 0, 3));
    if (step == 1) next.scale(Eigen::Vector3f(1, 0, 1));
    s.SetInstanceTransform(object, next);
    s.Commit();
    // The report's line: the room's tree kept; a large room's tree of both dropped.
    const bool large = wall_mesh.triangles.size() > 100000;
    EXPECT_EQ(s.last_commit().rfind(large && step == 0
                                        ? "the objects' tree rebuilt; the room's tree kept; the tree of both dropped"
                                    : large ? "the objects' tree rebuilt; the room's tree kept"
                                            : "the objects' tree and the tree of both rebuilt; the room's tree kept",
                                    0),
              0u)
        << s.last_commit();
    if (large && step > 0) EXPECT_EQ(s.last_commit().find("dropped"), std::string::npos) << s.last_commit();
  }
}

TEST(EmbreeScene, EachKindOfRayMeetsItsKindOnlyAsTheObjectMoves) {
  CheckKindsAsTheObjectMoves(Square(5));
  CheckKindsAsTheObjectMoves(GridWall(230));  // 105 800 triangles: the tree of both dropped at the first move
  EmbreeScene room;
  room.AddMesh(Square(5), false);
  room.Commit();
  Hit h;
  EXPECT_FALSE(room.Intersect(RayAlongZ(0.1f, 0.1f, kMaskVirtual), &h));
  EXPECT_TRUE(room.Intersect(RayAlongZ(0.1f, 0.1f, kMaskReal), &h));
  std::vector<Ray> rays = {RayAlongZ(0.1f, 0.1f, kMaskVirtual), RayAlongZ(0.1f, 0.1f, kMaskReal)};
  std::vector<char> occ(2);
  room.Occluded(rays, occ);
  EXPECT_FALSE(occ[0]);
  EXPECT_TRUE(occ[1]);
}

TEST(EmbreeScene, RefusesBadMeshes) {
  EmbreeScene s;
  Mesh m = Square(1);
  m.triangles.push_back({0, 1, 7});
  EXPECT_THROW(s.AddMesh(m, false), Error);
  Mesh n = Square(1);
  n.positions[0].x() = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(s.AddMesh(n, false), Error);
}

}  // namespace
}  // namespace mr
