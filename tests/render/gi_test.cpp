// The fast differential GI methods (ic, vpl) together: against pt on purpose-built
// scenes, and what no virtual object changes.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>

#include "core/image_metrics.h"
#include "core/math.h"
#include "geometry/primitives.h"
#include "light/lights_file.h"
#include "render/gi_scenes.h"
#include "render/irradiance_cache.h"
#include "render/pt.h"
#include "render/vct.h"
#include "render/vpl.h"

namespace mr {
namespace {

using namespace gi_test;

// With nothing virtual, I_m and I_r are the same numbers: no noise, no bias
// in the difference.
TEST(Gi, NothingVirtualMeansExactlyNoDifference) {
  RenderScene s;
  OpenCorner(&s, 1e3, /*with_object=*/false);
  const CameraModel cam = Pinhole(24, 18, 20);
  VplSettings vs;
  vs.paths = 64;
  VplFrameRenderer v(s, VplSet::Build(s, vs), cam, kCornerCamera, 0, 0);
  v.RenderPass(1);
  IcSettings is;
  is.rays = 32;
  IrradianceCache cache(s, is);
  IcFrameRenderer c(s, &cache, cam, kCornerCamera, 0, 0);
  c.RenderPass(1);
  for (const FrameMethod* r : {static_cast<const FrameMethod*>(&v), static_cast<const FrameMethod*>(&c)}) {
    const Image d = Difference(*r);
    for (float x : d.values()) ASSERT_EQ(x, 0.0f);
    EXPECT_GT(Mean(r->Mixed()), 0);
  }
}

// Shadow, contact shadow and bounce light of a sphere resting on the floor
// under a sun 1e3 x the sky, against a converged pt (1024 spp): the
// composite (photograph = pt's I_r) no worse than twice pt's own at the same
// camera samples per pixel (another seed), and the light the object takes
// from the floor (the sum of I_m - I_r over its shadow) within 20%: the
// sum's spread over seeds, measured, is ~8% for pt at 16-64 spp and ~10% for
// ic, whose records' noise is shared by many pixels.  The
// shadow region comes from a third, independent pt render: chosen from the
// reference's own noise, it would favour the reference.
TEST(Gi, IcAndVplMatchPathTracerAroundAnObjectOnTheFloor) {
  RenderScene s;
  OpenCorner(&s, 1e3);
  const CameraModel cam = Pinhole(40, 30, 34);
  PathTracerSettings ps;
  ps.max_depth = 5;  // as IcSettings and VplSettings
  PtFrameRenderer pt(s, cam, kCornerCamera, ps);
  pt.RenderPass(1024);
  const Image photo = pt.Real(), truth = pt.Mixed();
  auto composite = [&](const FrameMethod& r) {
    Image out = photo;
    const Image m = r.Mixed(), re = r.Real(), a = r.Mask();
    for (int y = 0; y < out.height(); ++y)
      for (int x = 0; x < out.width(); ++x)
        for (int c = 0; c < 3; ++c) {
          const float k = a.at(x, y, 0);
          out.at(x, y, c) = k * m.at(x, y, c) + (1 - k) * (photo.at(x, y, c) + m.at(x, y, c) - re.at(x, y, c));
        }
    return out;
  };
  ps.seed = 2;
  PtFrameRenderer pt_region(s, cam, kCornerCamera, ps);
  pt_region.RenderPass(256);
  const Image pt_diff = Difference(pt_region), mask = pt.Mask();
  auto shadow = [&](const Image& d) {
    double sum = 0;
    for (int y = 0; y < d.height(); ++y)
      for (int x = 0; x < d.width(); ++x)
        if (mask.at(x, y, 0) == 0 && pt_diff.at(x, y, 1) < -0.05f) sum += d.at(x, y, 1);
    return sum;
  };
  const double pt_shadow = shadow(Difference(pt));
  ASSERT_LT(pt_shadow, -1.0);
  ps.seed = 1;
  PtFrameRenderer pt16(s, cam, kCornerCamera, ps);
  pt16.RenderPass(16);
  const double pt16_error = CompareImages(composite(pt16), truth).relmse;
  EXPECT_GT(CompareImages(photo, truth).relmse, 3 * pt16_error);  // leaving the object out is far worse

  IcSettings is;
  is.rays = 256;
  IrradianceCache cache(s, is);
  IcFrameRenderer ic(s, &cache, cam, kCornerCamera, 0, 0);
  ic.RenderPass(16);
  VplSettings vs;
  vs.paths = 512;
  vs.directions = 256;
  VplFrameRenderer vpl(s, VplSet::Build(s, vs), cam, kCornerCamera, 0, 0);
  vpl.RenderPass(16);
  for (const FrameMethod* r : {static_cast<const FrameMethod*>(&ic), static_cast<const FrameMethod*>(&vpl)}) {
    const char* name = r == &ic ? "ic" : "vpl";
    EXPECT_LT(CompareImages(composite(*r), truth).relmse, 2 * pt16_error) << name;
    EXPECT_NEAR(shadow(Difference(*r)), pt_shadow, 0.2 * std::abs(pt_shadow)) << name;
  }
}

// A virtual spot light over the real floor: all of its light is a
// difference.  The total of I_m - I_r over the image within 10% of pt's
// (vpl: the spot's direct light is exact, its bounce light comes from ~100
// light paths).
TEST(Gi, VirtualSpotLightRelightsTheRealRoom) {
  RenderScene s;
  s.AddReal(Quad({-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}), Diffuse(0.6));
  s.AddReal(Quad({-2, 0, 1}, {2, 0, 1}, {2, 2, 1}, {-2, 2, 1}), Diffuse(0.7));
  Light spot;
  spot.type = LightType::kSpot;
  spot.is_virtual = true;
  spot.position = Eigen::Vector3d(0, 1.5, 0);
  spot.direction = Eigen::Vector3d(0, -1, 0.3).normalized();
  spot.intensity = Eigen::Vector3d::Constant(2.0);
  spot.cone_deg = 30;
  spot.falloff_start_deg = 20;
  s.AddLight(spot);
  s.SetEnvironment(Sky(1));
  s.Commit();
  const CameraModel cam = Pinhole(32, 24, 28);
  PathTracerSettings ps;
  ps.max_depth = 5;  // as IcSettings and VplSettings
  PtFrameRenderer pt(s, cam, kCornerCamera, ps);
  pt.RenderPass(256);
  const double expected = Mean(Difference(pt));
  ASSERT_GT(expected, 0.01);
  IcSettings is;
  is.rays = 128;
  IrradianceCache cache(s, is);
  IcFrameRenderer ic(s, &cache, cam, kCornerCamera, 0, 0);
  ic.RenderPass(4);
  VplSettings vs;
  vs.paths = 256;
  VplFrameRenderer vpl(s, VplSet::Build(s, vs), cam, kCornerCamera, 0, 0);
  vpl.RenderPass(2);
  EXPECT_NEAR(Mean(Difference(ic)), expected, 0.1 * expected);
  EXPECT_NEAR(Mean(Difference(vpl)), expected, 0.1 * expected);
}

// A virtual lamp panel (lights.json "area", 0.6 x 0.4 m, 1.5 m up, facing
// down and a little towards the wall) over the real floor: every method
// renders it.  The total of I_m - I_r within 10% of pt's for ic and vpl
// (both sample it by next-event estimation, vpl's paths leave it by
// cosine), 25% for vct (its cones inject it as a cosine point at its
// centre, its bias floor as measured in docs/benchmarks.md).
TEST(Gi, VirtualAreaLightRelightsTheRealRoomInEveryMethod) {
  RenderScene s;
  s.AddReal(Quad({-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}), Diffuse(0.6));
  s.AddReal(Quad({-2, 0, 1}, {2, 0, 1}, {2, 2, 1}, {-2, 2, 1}), Diffuse(0.7));
  Light panel;
  panel.type = LightType::kArea;
  panel.is_virtual = true;
  panel.position = Eigen::Vector3d(0, 1.5, 0);
  panel.direction = Eigen::Vector3d(0, -1, 0.3).normalized();
  panel.axis = Eigen::Vector3d(1, 0, 0);
  panel.width = 0.6;
  panel.height = 0.4;
  panel.radiance = Eigen::Vector3d::Constant(2.0);
  s.AddLight(panel);
  s.SetEnvironment(Sky(1));
  s.Commit();
  const CameraModel cam = Pinhole(32, 24, 28);
  PathTracerSettings ps;
  ps.max_depth = 5;
  PtFrameRenderer pt(s, cam, kCornerCamera, ps);
  pt.RenderPass(256);
  const double expected = Mean(Difference(pt));
  ASSERT_GT(expected, 0.01);
  IcSettings is;
  is.rays = 128;
  IrradianceCache cache(s, is);
  IcFrameRenderer ic(s, &cache, cam, kCornerCamera, 0, 0);
  ic.RenderPass(4);
  VplSettings vs;
  vs.paths = 256;
  VplFrameRenderer vpl(s, VplSet::Build(s, vs), cam, kCornerCamera, 0, 0);
  vpl.RenderPass(2);
  VctSettings ts;
  ts.resolution = 32;
  VctFrameRenderer vct(s, VctVolumes::Build(s, ts), cam, kCornerCamera, 0, 0);
  vct.RenderPass(4);
  std::printf("area light: I_m - I_r mean pt %.4f, ic %.4f, vpl %.4f, vct %.4f\n", expected, Mean(Difference(ic)),
              Mean(Difference(vpl)), Mean(Difference(vct)));
  EXPECT_NEAR(Mean(Difference(ic)), expected, 0.1 * expected);
  EXPECT_NEAR(Mean(Difference(vpl)), expected, 0.1 * expected);
  EXPECT_NEAR(Mean(Difference(vct)), expected, 0.25 * expected);
}

}  // namespace
}  // namespace mr
