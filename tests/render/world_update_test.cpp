// What the methods keep when the world changes between frames, and that
// what they keep is what they would have made again.
#include <gtest/gtest.h>

#include <cmath>

#include "gi_scenes.h"
#include "render/irradiance_cache.h"
#include "render/vct.h"
#include "render/world.h"

namespace mr {
namespace {

using namespace gi_test;

// The largest difference between two volumes' voxels, every level and field.
double MaxVoxelDifference(const VctVolumes& a, const VctVolumes& b) {
  EXPECT_EQ(a.levels().size(), b.levels().size());
  double d = 0;
  for (size_t l = 0; l < std::min(a.levels().size(), b.levels().size()); ++l) {
    const auto& va = a.levels()[l].v;
    const auto& vb = b.levels()[l].v;
    EXPECT_EQ(va.size(), vb.size());
    for (size_t i = 0; i < std::min(va.size(), vb.size()); ++i) {
      d = std::max({d, static_cast<double>(std::abs(va[i].occ_r - vb[i].occ_r)),
                    static_cast<double>(std::abs(va[i].occ_v - vb[i].occ_v)),
                    static_cast<double>((va[i].n_r - vb[i].n_r).cwiseAbs().maxCoeff()),
                    static_cast<double>((va[i].n_v - vb[i].n_v).cwiseAbs().maxCoeff()),
                    static_cast<double>((va[i].l_m - vb[i].l_m).cwiseAbs().maxCoeff()),
                    static_cast<double>((va[i].l_r - vb[i].l_r).cwiseAbs().maxCoeff())});
    }
  }
  return d;
}

Eigen::Affine3d At(double x) {
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.translate(Eigen::Vector3d(x, 0.3, 0));
  return t;
}

// vct keeps the real surfaces' voxelisation when the object moves within
// the grid, and all of it when only the light changes; either way the
// volumes are exactly those a full build on the same grid makes.  (A
// virtual lamp makes the grid the scene's bounds, which the sphere's move
// does not change, so a fresh build has the same grid.)  Without it the
// grid is twice the object's box: a small move keeps it, a move out of
// it voxelises everything again.
TEST(WorldUpdate, VctVoxelisesOnlyWhatMoved) {
  VctSettings st;
  st.resolution = 16;
  st.directions = 16;
  st.far_field_width = 16;
  st.far_field_samples = 2;
  {
    RenderScene s;
    OpenCorner(&s, 100);
    Light lamp;
    lamp.type = LightType::kPoint;
    lamp.is_virtual = true;
    lamp.position = Eigen::Vector3d(0.5, 1.5, -0.5);
    lamp.intensity = Eigen::Vector3d::Constant(2);
    s.AddLight(lamp);
    s.Commit();
    const auto before = VctVolumes::Build(s, st);
    s.SetVirtualTransform(0, At(0.4));
    s.Commit();
    const auto moved = VctVolumes::Build(s, st, before.get(), true);
    EXPECT_EQ(moved->voxelised(), "virtual surfaces only");
    const auto fresh = VctVolumes::Build(s, st);
    EXPECT_EQ(fresh->voxelised(), "full");
    EXPECT_EQ(MaxVoxelDifference(*moved, *fresh), 0.0);
    s.SetEnvironment(Sky(300));
    s.Commit();
    const auto relit = VctVolumes::Build(s, st, fresh.get(), false);
    EXPECT_EQ(relit->voxelised(), "kept");
    EXPECT_EQ(MaxVoxelDifference(*relit, *VctVolumes::Build(s, st)), 0.0);
    EXPECT_GT(MaxVoxelDifference(*relit, *fresh), 0.0);  // the light did change
  }
  RenderScene s;
  OpenCorner(&s, 100);
  const auto before = VctVolumes::Build(s, st);
  s.SetVirtualTransform(0, At(0.05));
  s.Commit();
  EXPECT_EQ(VctVolumes::Build(s, st, before.get(), true)->voxelised(), "virtual surfaces only");
  s.SetVirtualTransform(0, At(1.5));
  s.Commit();
  EXPECT_EQ(VctVolumes::Build(s, st, before.get(), true)->voxelised(), "full");
}

// ic on a 60 m floor under a sky with a sun: a sphere at the centre and
// a second one 28 m away; the sphere moves 1.2 m.  Records on virtual
// surfaces go; real records that can see the moved sphere (where it was or
// is: form factor bound above influence_threshold, 1e-3, within 16 m) are
// re-evaluated; the others, made for the far object, are kept.  Each kept
// record, evaluated again in the new world with its own stream, gives its
// kept value to 1%: the bound that ic already applies when it makes no
// record below the threshold (measured: exactly equal, no ray of theirs
// meets the sphere).
TEST(WorldUpdate, IcKeepsTheRecordsTheObjectCannotReach) {
  RenderScene s;
  s.AddReal(Quad({-30, 0, -30}, {30, 0, -30}, {30, 0, 30}, {-30, 0, 30}), Diffuse(0.6));
  s.AddVirtual(UvSphere(0.3f, 16), At(0), Diffuse(0.8));
  Eigen::Affine3d far = Eigen::Affine3d::Identity();
  far.translate(Eigen::Vector3d(-20, 0.3, -20));
  s.AddVirtual(UvSphere(0.3f, 16), far, Diffuse(0.8));
  s.SetEnvironment(Sky(100));
  s.Commit();
  IcSettings st;
  st.rays = 64;
  IrradianceCache cache(s, st);
  const CameraModel cam = Pinhole(96, 72, 96);
  {
    IcFrameRenderer r(s, &cache, cam, LookAt({-10, 40, -10.5}, {-10, 0, -10}), 0, 0);
    r.RenderPass(1);
  }
  const size_t before = cache.records().size();
  size_t on_virtual = 0;
  for (const IcRecord& r : cache.records()) on_virtual += r.on_virtual;
  s.SetVirtualTransform(0, At(1.2));
  s.Commit();
  WorldChange c;
  c.moved = {"sphere"};
  const std::string what = cache.WorldChanged(c);
  EXPECT_EQ(cache.records().size(), before - on_virtual) << what;
  int kept = 0, stale = 0;
  for (const IcRecord& r : cache.records()) {
    EXPECT_FALSE(r.on_virtual);
    if (r.stale) {
      ++stale;
      continue;
    }
    ++kept;
    IcRecord again = r;
    cache.Evaluate(&again, 1);
    const double scale = std::max(1e-9, r.e_mixed.maxCoeff());
    EXPECT_LT((again.e_mixed - r.e_mixed).cwiseAbs().maxCoeff() / scale, 0.01) << r.p.transpose();
    EXPECT_EQ(again.e_real, r.e_real);  // the real solution does not see the objects at all
  }
  EXPECT_GT(kept, 0) << what << " of " << before;
  EXPECT_GT(stale, 0) << what << " of " << before;
  // New light re-evaluates everything.
  WorldChange light;
  light.environment = true;
  cache.WorldChanged(light);
  for (const IcRecord& r : cache.records()) EXPECT_TRUE(r.stale);
}

// ic evicts the records no frame has used for evict_after frames: the
// camera turns from the room to the open sky, and after 2 frames the
// records are gone; turned back, they are made again.
TEST(WorldUpdate, IcEvictsRecordsNoFrameUses) {
  RenderScene s;
  OpenCorner(&s, 100);
  IcSettings st;
  st.rays = 16;
  st.evict_after = 2;
  IrradianceCache cache(s, st);
  const CameraModel cam = Pinhole(24, 18, 20);
  const Rigid3 room = kCornerCamera, sky = LookAt({0, 3, 0}, {0, 10, 0.1});
  auto frame = [&](const Rigid3& pose, int f) {
    IcFrameRenderer r(s, &cache, cam, pose, 0, f);
    r.RenderPass(1);
  };
  frame(room, 0);
  const size_t made = cache.records().size();
  ASSERT_GT(made, 0u);
  frame(sky, 1);
  frame(sky, 2);
  EXPECT_EQ(cache.records().size(), made);  // 2 frames unused: kept
  frame(sky, 3);
  EXPECT_EQ(cache.records().size(), 0u);  // 3: evicted
  frame(room, 4);
  EXPECT_GT(cache.records().size(), 0u);
}

}  // namespace
}  // namespace mr
