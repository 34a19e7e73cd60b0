// The plate in reflections (render/path_tracer.h, PlateView): a mirror
// sphere on a chequered floor before a striped wall, all diffuse, under a
// sky with a sun.  The plate is the real room rendered with its true albedo
// (2048 spp), so a mirror that reflects the plate where the plate sees the
// reflected point must show what pt shows reflecting the rendered room.
#include <gtest/gtest.h>

#include "core/image_metrics.h"
#include "gi_scenes.h"
#include "render/irradiance_cache.h"
#include "render/vpl.h"

namespace mr {
namespace {

using gi_test::LookAt;
using gi_test::Pinhole;

// `grey`: every real surface 0.5 grey instead (a room whose albedo the
// render has wrong).
void TexturedRoom(RenderScene* s, bool grey) {
  // The floor in 0.5 m tiles of two colours, the wall in vertical stripes.
  for (int i = 0; i < 8; ++i)
    for (int k = 0; k < 8; ++k) {
      const float x0 = -2 + 0.5f * i, z0 = -2 + 0.5f * k;
      Material m;
      m.albedo = (i + k) % 2 ? Eigen::Vector3d(0.8, 0.3, 0.2) : Eigen::Vector3d(0.2, 0.4, 0.8);
      if (grey) m.albedo = Eigen::Vector3d::Constant(0.5);
      s->AddReal(Quad({x0, 0, z0}, {x0 + 0.5f, 0, z0}, {x0 + 0.5f, 0, z0 + 0.5f}, {x0, 0, z0 + 0.5f}), m);
    }
  for (int i = 0; i < 8; ++i) {
    const float x0 = -2 + 0.5f * i;
    Material m;
    m.albedo = i % 2 ? Eigen::Vector3d(0.9, 0.9, 0.3) : Eigen::Vector3d(0.1, 0.5, 0.2);
    if (grey) m.albedo = Eigen::Vector3d::Constant(0.5);
    s->AddReal(Quad({x0, 0, 2}, {x0 + 0.5f, 0, 2}, {x0 + 0.5f, 2, 2}, {x0, 2, 2}), m);
  }
}

void TexturedRoomWithMirror(RenderScene* s, bool grey = false) {
  TexturedRoom(s, grey);
  Material mirror;
  mirror.albedo = Eigen::Vector3d::Zero();
  mirror.specular = Eigen::Vector3d::Constant(0.9);
  mirror.roughness = 0.02;
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.translate(Eigen::Vector3d(0, 0.4, 0.3));
  s->AddVirtual(UvSphere(0.4f, 48), t, mirror);
  s->SetEnvironment(gi_test::Sky(20));
  s->Commit();
}

// A frame renderer's mixed image (64 spp unless told), its plate counters copied out.
template <class Renderer>
Image RenderCounting(Renderer* r, PlateCounters* counts, int spp = 64) {
  r->RenderPass(spp);
  counts->from_plate = r->plate_counters().from_plate.load();
  counts->from_other_frames = r->plate_counters().from_other_frames.load();
  counts->rendered = r->plate_counters().rendered.load();
  return r->Mixed();
}

// The room of TexturedRoomWithMirror seen from the front: its plate (the
// room alone, true albedo) and the reference (pt with the mirror), both at
// `spp`, and the mask of the mirror's pixels.
struct MirrorShot {
  RenderScene s;
  CameraModel cam = Pinhole(64, 48, 54);
  Rigid3 pose = LookAt({0.3, 1.2, -2.2}, {0, 0.35, 0.3});
  Image plate, ref, mask;
  explicit MirrorShot(int spp) {
    TexturedRoomWithMirror(&s);
    PathTracerSettings st;
    st.max_depth = 8;
    PtFrameRenderer p(s, cam, pose, st);
    p.RenderPass(spp);
    plate = p.Real();
    st.seed = 7;
    PtFrameRenderer r(s, cam, pose, st);
    r.RenderPass(spp);
    ref = r.Mixed();
    mask = r.Mask();
    for (float& m : mask.values()) m = m > 0.99f ? 1.0f : 0.0f;
  }
};

// vpl's glossy rays from the mirror take the plate as pt's paths do (its
// diffuse light is the VPLs'; the mirror has none): over the mirror its
// error against pt's reference is within 1.5x + 0.002 of vpl rendering the
// room (measured: 0.0062 from the plate, 0.0145 rendered at 16 spp against
// a 512-spp reference: the plate carries what vpl's clamped VPLs lose).
TEST(PlateReflections, VplGlossyRaysTakeThePlate) {
  const MirrorShot m(512);
  VplSettings vs;
  vs.max_depth = 8;
  vs.glossy_depth = 8;
  const auto vpls = VplSet::Build(m.s, vs);
  auto vpl_render = [&](const PlateViews& pv, PlateCounters* counts) {
    VplFrameRenderer r(m.s, vpls, m.cam, m.pose, 1, 0, CameraExposure{}, pv);
    return RenderCounting(&r, counts, 16);  // vpl's cost per sample is several of pt's
  };
  PlateCounters vpl_plate, vpl_none;
  const PlateViews views = {PlateView{&m.plate, nullptr, &m.cam, m.pose}};
  const double vpl_err_plate = CompareImages(vpl_render(views, &vpl_plate), m.ref, &m.mask).relmse;
  const double vpl_err_render = CompareImages(vpl_render(PlateViews{}, &vpl_none), m.ref, &m.mask).relmse;
  std::printf("vpl: relMSE over the mirror %.5f from the plate, %.5f rendered\n", vpl_err_plate, vpl_err_render);
  EXPECT_LT(vpl_err_plate, 1.5 * vpl_err_render + 0.002) << vpl_err_plate << " from the plate, " << vpl_err_render;
  EXPECT_GT(vpl_plate.from_plate.load(), 2 * vpl_plate.rendered.load());
  EXPECT_EQ(vpl_none.from_plate.load(), 0);
}

// Over the sphere's pixels, pt reflecting the plate at 64 spp is as close
// to pt reflecting the rendered room at 2048 spp as pt reflecting the
// rendered room at 64 spp is, up to the plate route's bias (within 1.5x +
// 0.003; measured 2026-12-03 with stratified samples 0.0034 against
// 0.0008, so about 0.0026 of bias: the sphere's shadow on the points it
// reflects is added back from their next-event estimate, but its occlusion
// of their indirect light and of the sky's BSDF-sampled share is not); most
// real points the mirror shows come from the plate, and those the camera
// does not see (behind and below it) are rendered.  Without a plate nothing
// changes.
TEST(PlateReflections, MirrorShowsTheTexturedRoomAsPtDoes) {
  const MirrorShot shot(2048);
  const RenderScene& s = shot.s;
  const CameraModel& cam = shot.cam;
  const Rigid3& pose = shot.pose;
  const Image& mask = shot.mask;
  PathTracerSettings st;
  st.max_depth = 8;
  st.seed = 1;
  PtFrameRenderer rendered(s, cam, pose, st);
  rendered.RenderPass(64);
  PathTracerSettings sp = st;
  sp.plates = {PlateView{&shot.plate, nullptr, &cam, pose}};
  PtFrameRenderer from_plate(s, cam, pose, sp);
  from_plate.RenderPass(64);

  int64_t n = 0;
  for (float m : mask.values()) n += m > 0;
  ASSERT_GT(n, 100);
  const double err_plate = CompareImages(from_plate.Mixed(), shot.ref, &mask).relmse;
  const double err_render = CompareImages(rendered.Mixed(), shot.ref, &mask).relmse;
  EXPECT_LT(err_plate, 1.5 * err_render + 0.003) << err_plate << " from the plate, " << err_render << " rendered";
  std::printf("relMSE over the mirror: %.5f from the plate, %.5f rendered\n", err_plate, err_render);
  const PlateCounters& c = from_plate.plate_counters();
  EXPECT_GT(c.from_plate.load(), 2 * c.rendered.load());
  EXPECT_GT(c.rendered.load(), 0);
  EXPECT_EQ(rendered.plate_counters().from_plate.load() + rendered.plate_counters().rendered.load(), 0);
  // The real layer never looks at the plate: bit for bit the same paths.
  EXPECT_EQ(from_plate.Real().values(), rendered.Real().values());

  // ic's glossy paths from the mirror take the plate the same way (its
  // camera-ray part is its own; the bound is the same as pt's).
  IcSettings is;
  is.max_depth = 8;
  is.seed = 1;
  auto ic_render = [&](const PlateViews& pv, PlateCounters* counts) {
    IrradianceCache cache(s, is);
    IcFrameRenderer r(s, &cache, cam, pose, 1, 0, CameraExposure{}, pv);
    return RenderCounting(&r, counts);
  };
  PlateCounters ic_plate, ic_none;
  const double ic_err_plate = CompareImages(ic_render(sp.plates, &ic_plate), shot.ref, &mask).relmse;
  const double ic_err_render = CompareImages(ic_render(PlateViews{}, &ic_none), shot.ref, &mask).relmse;
  EXPECT_LT(ic_err_plate, 1.5 * ic_err_render + 0.003) << ic_err_plate << " from the plate, " << ic_err_render;
  EXPECT_GT(ic_plate.from_plate.load(), 2 * ic_plate.rendered.load());
  EXPECT_EQ(ic_none.from_plate.load(), 0);

  // A plate clipped everywhere (an 8-bit plate's highlights: their value is
  // only a lower bound) gives nothing: every point is rendered, and counted.
  const Image all_clipped = Image::Gray(cam.width(), cam.height(), 1.0f);
  sp.plates[0].clipped = &all_clipped;
  PtFrameRenderer clipped(s, cam, pose, sp);
  clipped.RenderPass(4);
  EXPECT_EQ(clipped.plate_counters().from_plate.load(), 0);
  EXPECT_GT(clipped.plate_counters().clipped.load(), 0);
  EXPECT_LE(clipped.plate_counters().clipped.load(), clipped.plate_counters().rendered.load());
}

// Where the frame's own plate does not see a reflected point (the floor
// below and behind the camera), a neighbouring frame's plate that does is
// taken.  The render's room is grey while the plates show the textured
// truth, so only what comes from a plate is right: over the mirror, adding
// a second view looking back at the floor behind the first camera lowers
// the error against the reference (the true room with the mirror) by more
// than a quarter (measured: see the printout), and the points it supplies
// are counted as from other frames.  A neighbour's plate read through the
// wrong pose would put the wrong texture there and raise it.
TEST(PlateReflections, NeighbouringFramesSeeWhatTheFrameDoesNot) {
  RenderScene truth, grey;
  TexturedRoomWithMirror(&truth);
  TexturedRoomWithMirror(&grey, true);
  const CameraModel cam = Pinhole(64, 48, 54);
  const Rigid3 pose = LookAt({0.3, 1.2, -2.2}, {0, 0.35, 0.3});
  const Rigid3 back = LookAt({0.2, 2.2, 1.0}, {0.1, 0, -1.6});  // over the mirror, looking back
  PathTracerSettings st;
  st.max_depth = 8;
  auto plate_from = [&](const Rigid3& p) {
    PtFrameRenderer r(truth, cam, p, st);
    r.RenderPass(1024);
    return r.Real();
  };
  const Image plate = plate_from(pose), plate_back = plate_from(back);
  st.seed = 7;
  PtFrameRenderer ref(truth, cam, pose, st);
  ref.RenderPass(1024);
  Image mask = ref.Mask();
  for (float& m : mask.values()) m = m > 0.99f ? 1.0f : 0.0f;

  st.seed = 1;
  auto render = [&](const PlateViews& views, PlateCounters* counts) {
    PathTracerSettings sp = st;
    sp.plates = views;
    PtFrameRenderer r(grey, cam, pose, sp);
    return CompareImages(RenderCounting(&r, counts), ref.Mixed(), &mask).relmse;
  };
  PlateCounters own, both, wrong;
  const PlateView own_view{&plate, nullptr, &cam, pose};
  const double err_own = render({own_view}, &own);
  const double err_both = render({own_view, PlateView{&plate_back, nullptr, &cam, back}}, &both);
  Rigid3 shifted = back;  // the view back, read as if taken 0.5 m to the side
  shifted.translation.x() += 0.5;
  const double err_wrong = render({own_view, PlateView{&plate_back, nullptr, &cam, shifted}}, &wrong);
  std::printf(
      "relMSE over the mirror: own plate %.4f, with the view back %.4f (wrong pose %.4f); "
      "from other frames %lld of %lld\n",
      err_own, err_both, err_wrong, static_cast<long long>(both.from_other_frames.load()),
      static_cast<long long>(both.from_plate.load() + both.rendered.load()));
  EXPECT_EQ(own.from_other_frames.load(), 0);
  EXPECT_GT(both.from_other_frames.load(), 0);
  EXPECT_LT(both.rendered.load(), own.rendered.load());
  // The own plate comes first (a path that ends at a neighbour's point
  // would have gone on without it, and might have met more).
  EXPECT_LE(both.from_plate - both.from_other_frames, own.from_plate.load());
  EXPECT_LT(err_both, 0.75 * err_own);
  EXPECT_GT(err_wrong, err_both);
}

// The plate shows the room without the object: where a diffuse object
// stands on the floor, the floor next to it is darker than the plate shows
// (the object hides part of its sky and indirect light) and brighter by
// what the object bounces onto it.  A path leaving the object that meets
// the floor takes the plate's light plus that difference, by the point's
// next-event estimate and one differential path on from it.  A white
// sphere resting on a grey floor before a wall under a sky with a sun, the
// plate pt's real image at 1024 spp: over the sphere's lower half, pt with
// the plate at 256 spp agrees with pt rendering the room (1024 spp, another
// seed) within 1% in the mean (measured -0.36%; rendering at 256 spp:
// -0.45%), and over the sphere within 1.5 x the rendered relMSE plus 2e-4
// (measured 2.2e-4 against 3.0e-4).  With the next-event estimate alone the
// lower half was 3.1% too bright and the relMSE 1.0e-3: near the contact the
// plate lacks the sphere's occlusion of the floor.
TEST(PlateReflections, PlateLightNearContactTakesTheObjectsDifference) {
  RenderScene s;
  s.AddReal(Quad({-3, 0, -3}, {3, 0, -3}, {3, 0, 3}, {-3, 0, 3}), gi_test::Diffuse(0.5));
  s.AddReal(Quad({-3, 0, 1.2f}, {3, 0, 1.2f}, {3, 2, 1.2f}, {-3, 2, 1.2f}), gi_test::Diffuse(0.7));
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.translate(Eigen::Vector3d(0, 0.4, 0.3));
  s.AddVirtual(UvSphere(0.4f, 48), t, gi_test::Diffuse(0.9));
  s.SetEnvironment(gi_test::Sky(20));
  s.Commit();
  const CameraModel cam = Pinhole(48, 36, 40);
  const Rigid3 pose = LookAt({0.2, 0.35, -1.5}, {0, 0.3, 0.3});
  PathTracerSettings st;
  st.max_depth = 8;
  Image plate, ref, mask;
  {
    PtFrameRenderer p(s, cam, pose, st);
    p.RenderPass(1024);
    plate = p.Real();
    st.seed = 7;
    PtFrameRenderer r(s, cam, pose, st);
    r.RenderPass(1024);
    ref = r.Mixed();
    mask = r.Mask();
    for (float& m : mask.values()) m = m > 0.99f ? 1.0f : 0.0f;
  }
  auto render = [&](const PlateViews& views, PlateCounters* counts) {
    PathTracerSettings sp = st;
    sp.seed = 3;
    sp.plates = views;
    PtFrameRenderer r(s, cam, pose, sp);
    return RenderCounting(&r, counts, 256);
  };
  auto mean_over = [&](const Image& img, bool lower_half) {
    double v = 0, n = 0;
    for (int y = lower_half ? img.height() / 2 : 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x)
        if (mask.at(x, y, 0) > 0) v += img.at(x, y, 0) + img.at(x, y, 1) + img.at(x, y, 2), n += 3;
    return v / n;
  };
  PlateCounters with_plate, without;
  const Image a = render({PlateView{&plate, nullptr, &cam, pose}}, &with_plate);
  const Image b = render({}, &without);
  const double err_plate = CompareImages(a, ref, &mask).relmse, err_render = CompareImages(b, ref, &mask).relmse;
  std::printf(
      "sphere: mean %.5f (lower half %.5f) with the plate, %.5f (%.5f) rendered, %.5f (%.5f) reference; "
      "relMSE %.3g and %.3g; %lld from the plate\n",
      mean_over(a, false), mean_over(a, true), mean_over(b, false), mean_over(b, true), mean_over(ref, false),
      mean_over(ref, true), err_plate, err_render, static_cast<long long>(with_plate.from_plate));
  EXPECT_GT(with_plate.from_plate, 1000);
  EXPECT_LT(std::abs(mean_over(a, true) / mean_over(ref, true) - 1), 0.01);
  EXPECT_LT(err_plate, 1.5 * err_render + 2e-4);
}

// The plate through glass: an ior-1 glass sphere (it bends and reflects
// nothing) before the wall, in a render whose room is grey while the plate
// shows the textured truth.  Every real point seen through the glass is one
// the plate sees, so over the sphere the composite's mixed layer is the
// plate's up to the difference the glass makes at those points (next-event
// rays do not pass glass, so the light it lets through onto the wall comes
// from BSDF-sampled paths alone: noisy at 16 spp; measured 0.018 against
// 0.49 rendering the grey room, bound at a tenth of the latter), and the
// report counts those points as through glass, nearly all from the plate.
TEST(PlateReflections, GlassShowsThePlateBehindIt) {
  auto glass_room = [](RenderScene* s, bool grey) {
    TexturedRoom(s, grey);
    Mesh sphere = UvSphere(0.4f, 48);
    for (const Eigen::Vector3f& p : sphere.positions) sphere.normals.push_back(p.normalized());
    Eigen::Affine3d t = Eigen::Affine3d::Identity();
    t.translate(Eigen::Vector3d(0, 0.6, 0.8));
    gi_test::AddGlassAsset(s, sphere, 1, 0.8f, t);
    s->SetEnvironment(gi_test::Sky(20));
    s->Commit();
  };
  RenderScene truth, grey;
  glass_room(&truth, false);
  glass_room(&grey, true);
  const CameraModel cam = Pinhole(64, 48, 54);
  const Rigid3 pose = LookAt({0.3, 1.2, -2.2}, {0, 0.6, 0.8});
  PathTracerSettings st;
  st.max_depth = 8;
  PtFrameRenderer p(truth, cam, pose, st);
  p.RenderPass(256);
  const Image plate = p.Real();
  Image mask = p.Mask();
  for (float& m : mask.values()) m = m > 0.99f ? 1.0f : 0.0f;
  st.seed = 3;
  PtFrameRenderer rendered(grey, cam, pose, st);
  rendered.RenderPass(16);
  st.plates = {PlateView{&plate, nullptr, &cam, pose}};
  PtFrameRenderer through(grey, cam, pose, st);
  through.RenderPass(16);
  int64_t n = 0;
  for (float m : mask.values()) n += m > 0;
  ASSERT_GT(n, 100);
  const double err_plate = CompareImages(through.Mixed(), plate, &mask).relmse;
  const double err_render = CompareImages(rendered.Mixed(), plate, &mask).relmse;
  std::printf("relMSE through the glass: %.5f from the plate, %.5f rendered grey\n", err_plate, err_render);
  EXPECT_LT(err_plate, 0.1 * err_render);
  const PlateCounters& c = through.plate_counters();
  EXPECT_GT(c.through_glass.load(), 0);
  EXPECT_GT(c.through_glass_from_plate.load(), 0.9 * c.through_glass.load());
  EXPECT_EQ(rendered.plate_counters().through_glass_from_plate.load(), 0);
}

}  // namespace
}  // namespace mr
