// The room's own light from a probe (render/plate_view.h, PlateView::probe;
// docs/methods.md, "The room's own light"): a ray from a virtual object that
// meets the real room takes the radiance the probe saw there, so that an
// object is lit by the room as it was, not as mr renders it from a wrong
// albedo.
#include <gtest/gtest.h>

#include "core/image_metrics.h"
#include "geometry/primitives.h"
#include "gi_scenes.h"
#include "render/irradiance_cache.h"
#include "render/path_tracer.h"
#include "render/pt.h"

namespace mr {
namespace {

using gi_test::LookAt;
using gi_test::Pinhole;

// A closed 4 x 2.5 x 4 m room of albedo `albedo` lit by a point light under
// its ceiling; with `sphere`, a white diffuse sphere (virtual) on its floor.
void Room(RenderScene* s, double albedo, bool sphere) {
  s->AddReal(Box({-2, 0, -2}, {2, 2.5f, 2}), gi_test::Diffuse(albedo));
  Light l;
  l.type = LightType::kPoint;
  l.position = Eigen::Vector3d(0.3, 2.2, -0.2);
  l.intensity = Eigen::Vector3d::Constant(20);
  s->AddLight(l);
  if (sphere) {
    Eigen::Affine3d t = Eigen::Affine3d::Identity();
    t.translate(Eigen::Vector3d(0.4, 0.3, 0.3));
    s->AddVirtual(UvSphere(0.3f, 32), t, gi_test::Diffuse(0.8));
  }
  s->Commit();
}

struct Shot {
  Image mixed, mask;
  int64_t from_probe = 0, rendered = 0;
};

Shot Render(const RenderScene& s, const PlateViews& views, int spp) {
  PathTracerSettings st;  // max_depth 64: the closed room's light is long paths
  st.seed = 3;
  st.plates = views;
  PtFrameRenderer r(s, Pinhole(32, 24, 30), LookAt({-0.5, 0.9, -1.5}, {0.4, 0.3, 0.3}), st);
  r.RenderPass(spp);
  Shot out{r.Mixed(), r.Mask(), r.plate_counters().from_probe.load(), r.plate_counters().rendered.load()};
  for (float& m : out.mask.values()) m = m > 0.99f ? 1.0f : 0.0f;
  return out;
}

double MeanOver(const Image& img, const Image& mask) {
  double v = 0, n = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      if (mask.at(x, y, 0) > 0) v += img.at(x, y, 0) + img.at(x, y, 1) + img.at(x, y, 2), n += 3;
  return v / n;
}

// The room's albedo is 0.7; mr believes it 0.3.  Rendered from that
// belief the sphere's light is 33% too dark (measured: the room's bounce
// light is most of it in a closed room of albedo 0.7: 64% too dark); with
// the probe's map of the true room, taken 0.9 m from the sphere, the wrong
// albedo no longer matters: within 2.5% of the truth (measured -0.0%; +2.2%
// at a quarter of the samples everywhere, +0.5% at twice: the bound is the
// noise of a 512-spp truth and a 32-spp probe map), and the reflected points
// come from the probe.  A probe outside the room sees none of them: the
// room is rendered.
TEST(RoomLight, ProbeGivesTheRoomAsItWas) {
  RenderScene truth_scene, wrong_scene, empty_room;
  Room(&truth_scene, 0.7, true);
  Room(&wrong_scene, 0.3, true);
  Room(&empty_room, 0.7, false);
  const Eigen::Vector3d probe_at(-0.4, 0.8, -0.3);
  const PathTracerSettings ps;
  const EnvironmentMap probe(RenderProbeMap(empty_room, probe_at, 256, 32, ps, 11), "probe");
  PlateView view;
  view.probe = &probe;
  view.probe_centre = probe_at;
  const Shot truth = Render(truth_scene, {}, 512);
  const Shot wrong = Render(wrong_scene, {}, 64);
  const Shot from_probe = Render(wrong_scene, {view}, 128);
  const double t = MeanOver(truth.mixed, truth.mask);
  const double w = MeanOver(wrong.mixed, truth.mask) / t - 1;
  const double p = MeanOver(from_probe.mixed, truth.mask) / t - 1;
  std::printf(
      "sphere mean %.4f; wrong albedo rendered %+.3f, from the probe %+.3f; %lld from the probe, %lld rendered\n", t, w,
      p, static_cast<long long>(from_probe.from_probe), static_cast<long long>(from_probe.rendered));
  EXPECT_LT(w, -0.15);  // the test means something: the belief is far off
  EXPECT_LT(std::abs(p), 0.025);
  EXPECT_GT(from_probe.from_probe, 4 * from_probe.rendered);
  // ic: its records on the sphere gather through the probe too (their
  // diffuse light was the rendered room's: as far off as the wrong render).
  // Its interpolation's bias and 256 rays a record: within 5%.
  for (const bool with_probe : {false, true}) {
    IcSettings is;
    is.seed = 3;
    IrradianceCache cache(wrong_scene, is);
    IcFrameRenderer ic(wrong_scene, &cache, Pinhole(32, 24, 30), LookAt({-0.5, 0.9, -1.5}, {0.4, 0.3, 0.3}), 3, 0, {},
                       with_probe ? PlateViews{view} : PlateViews{});
    ic.RenderPass(16);
    const double e = MeanOver(ic.Mixed(), truth.mask) / t - 1;
    std::printf("ic %s the probe: %+.3f\n", with_probe ? "with" : "without", e);
    if (with_probe)
      EXPECT_LT(std::abs(e), 0.05);
    else
      EXPECT_LT(e, -0.15);
  }
  view.probe_centre = Eigen::Vector3d(0, 1, 3);  // behind the wall
  const Shot outside = Render(wrong_scene, {view}, 16);
  EXPECT_EQ(outside.from_probe, 0);
  EXPECT_GT(outside.rendered, 0);
}

}  // namespace
}  // namespace mr
