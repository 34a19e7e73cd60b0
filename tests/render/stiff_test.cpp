// Issue 22's and 41's stiff cases, for every sampled method through the registry
// (pt, ic, vpl, vct): a sun 1e6 x the sky straight behind the object, a
// near-mirror object (GGX roughness 0.01) and an object that fills the
// whole view.  Each method's image must be finite with no sample dropped,
// and agree with pt's converged render where the case lets it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "core/json_node.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/spherical.h"
#include "geometry/primitives.h"
#include "render/gi_scenes.h"
#include "render/method.h"
#include "render/pixel_loop.h"
#include "render/render_scene.h"
#include "render/vct.h"
#include "render/vpl.h"

namespace mr {
namespace {

using namespace gi_test;

struct Rendered {
  std::unique_ptr<RenderMethod> method;  // owns what the frame may point to (ic's cache)
  std::unique_ptr<FrameMethod> frame;
};

Rendered Render(const std::string& name, const Json& block, const RenderScene& rs, const CameraModel& cam,
                const Rigid3& pose, int spp) {
  Json render = {{"method", name}};
  if (!block.empty()) render[name] = block;
  const Json j = {{"version", 1},
                  {"camera", {{"model", "cam.cameramodel"}}},
                  {"virtual", Json::array({{{"mesh", "object.ply"}}})},
                  {"render", render}};
  const Scene scene = ParseScene(j, ".", "scene.json", false);
  const std::string file = "scene.json";
  Rendered r;
  r.method = CreateRenderMethod(FindRenderMethod(name), JsonNode(block, "render." + name, &file), scene);
  Report report("mr-render", "test");
  r.method->Prepare(JobContext{scene, rs, cam, spp, 0, false, &report});
  r.frame = r.method->NewFrame(FrameContext{rs, cam, pose, 0, 0, nullptr});
  r.frame->RenderPass(spp);
  return r;
}

// The fast methods at settings that take a few seconds here.
const std::vector<std::pair<std::string, Json>> kFast = {
    {"ic", {{"rays", 64}}}, {"vpl", {{"paths", 256}}}, {"vct", {{"resolution", 32}}}};

bool AllFinite(const Image& img) {
  for (float v : img.values())
    if (!std::isfinite(v)) return false;
  return true;
}

// Mean of channel 1 of `img` over the pixels where `mask` is exactly
// `value` (1: the object covers the pixel entirely; 0: not at all).
double MeanWhere(const Image& img, const Image& mask, float value, int* count = nullptr) {
  double s = 0;
  int n = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      if (mask.at(x, y, 0) == value) {
        s += img.at(x, y, 1);
        ++n;
      }
  if (count) *count = n;
  return n > 0 ? s / n : 0;
}

// Largest value of channel 1 of `img` where `mask` is 1.
double MaxWhereCovered(const Image& img, const Image& mask) {
  double m = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      if (mask.at(x, y, 0) == 1.0f) m = std::max(m, static_cast<double>(img.at(x, y, 1)));
  return m;
}

// A sky of 0.5 with a sun 1e6 x brighter 8.4 degrees above the horizon, an
// 8 m floor of `floor` and a virtual diffuse sphere (r 0.3, albedo 0.8)
// resting on it at the origin; returns the direction towards the sun.
Eigen::Vector3d SunnyFloorWithSphere(const Material& floor, RenderScene* rs) {
  Image sky = Image::Rgb(64, 32);
  for (float& v : sky.values()) v = 0.5f;
  const int sx = 20, sy = 14;  // row 14 of 32: 8.4 degrees above the horizon
  for (int c = 0; c < 3; ++c) sky.at(sx, sy, c) = 0.5e6f;
  rs->AddReal(Quad({-4, 0, -4}, {4, 0, -4}, {4, 0, 4}, {-4, 0, 4}), floor);
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.translate(Eigen::Vector3d(0, 0.3, 0));
  rs->AddVirtual(UvSphere(0.3f, 32), t, Diffuse(0.8));
  rs->SetEnvironment(EnvironmentMap(sky, "sun"));
  rs->Commit();
  return LatLongPixelToDirection(Eigen::Vector2d(sx + 0.5, sy + 0.5), 64, 32);
}

// A sun 1e6 x the sky, low (8 degrees up), exactly behind a virtual sphere
// resting on the floor as the camera sees it: the camera looks into the
// sun, the sphere hides it, and its shadow runs towards the camera.  The
// sphere's side facing the camera is lit by the sky and the floor's bounce
// of the sun; its rim is next to pixels that see the sun itself (their
// I_m - I_r must stay 0: a camera ray that meets nothing is the plate).
TEST(Stiff, SunBehindTheObject) {
  RenderScene rs;
  const Eigen::Vector3d sun = SunnyFloorWithSphere(Diffuse(0.6), &rs);
  ASSERT_GT(sun.y(), 0.1);
  const Eigen::Vector3d centre(0, 0.3, 0);
  const Rigid3 pose = LookAt(centre - 1.6 * sun, centre);
  const CameraModel cam = Pinhole(40, 30, 50);
  Rendered pt = Render("pt", Json::object(), rs, cam, pose, 1024);
  const Image mask = pt.frame->Mask();
  int covered = 0;
  const double truth = MeanWhere(pt.frame->Mixed(), mask, 1.0f, &covered);
  ASSERT_GT(covered, 100);
  ASSERT_GT(truth, 0);
  for (const auto& [name, block] : kFast) {
    Rendered r = Render(name, block, rs, cam, pose, 8);
    const Image m = r.frame->Mixed(), re = r.frame->Real();
    EXPECT_TRUE(AllFinite(m) && AllFinite(re)) << name;
    EXPECT_EQ(r.frame->nonfinite_samples(), 0) << name;
    // The sphere's face towards the camera: sky and the floor's bounce of
    // the sun, no sun.  Bound: 10%, a few times the methods' error on this
    // face at these settings (printed).
    const double face = MeanWhere(m, mask, 1.0f);
    std::printf("sun behind the object: %s %.3f, pt %.3f\n", name.c_str(), face, truth);
    EXPECT_NEAR(face, truth, 0.1 * truth) << name;
    // Pixels whose camera rays see only the sky and sun: no difference.
    for (int y = 0; y < m.height(); ++y)
      for (int x = 0; x < m.width(); ++x)
        if (mask.at(x, y, 0) == 0 && r.frame->Mask().at(x, y, 0) == 0)
          for (int c = 0; c < 3; ++c)
            if (!std::isfinite(m.at(x, y, c) - re.at(x, y, c))) ADD_FAILURE() << name << " " << x << "," << y;
  }
}

// A near-mirror sphere (GGX roughness 0.01, specular 0.9, no diffuse) in a
// sky of 0.5 with no sun: each pixel sees 0.9 x 0.5 x the lobe's
// directional albedo, which at this roughness is 1 but for the shadowing
// at grazing angles (the sphere's rim): the mean over the sphere's pixels
// lies within 0.43 and 0.45 (0.45 measured for every method: the rim's
// pixels are mostly partly covered and left out).
TEST(Stiff, NearMirrorObject) {
  RenderScene rs;
  Material mirror;
  mirror.albedo = Eigen::Vector3d::Zero();
  mirror.specular = Eigen::Vector3d::Constant(0.9);
  mirror.roughness = 0.01;
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  rs.AddVirtual(UvSphere(0.5f, 64), t, mirror);
  Image sky = Image::Rgb(64, 32);
  for (float& v : sky.values()) v = 0.5f;
  rs.SetEnvironment(EnvironmentMap(sky, "sky"));
  rs.Commit();
  const CameraModel cam = Pinhole(32, 24, 40);
  const Rigid3 pose = LookAt({0, 0.2, -2.0}, {0, 0, 0});
  for (const auto& [name, block] :
       std::vector<std::pair<std::string, Json>>{{"pt", Json::object()}, kFast[0], kFast[1], kFast[2]}) {
    Rendered r = Render(name, block, rs, cam, pose, 16);
    const Image m = r.frame->Mixed();
    EXPECT_TRUE(AllFinite(m)) << name;
    EXPECT_EQ(r.frame->nonfinite_samples(), 0) << name;
    int n = 0;
    const double mean = MeanWhere(m, r.frame->Mask(), 1.0f, &n);
    EXPECT_GT(n, 50) << name;
    std::printf("near-mirror object: %s %.4f\n", name.c_str(), mean);
    EXPECT_NEAR(mean, 0.44, 0.011) << name;
  }
}

// Issue 41: a sun 1e6 x the sky, low (8 degrees up), grazing a glossy
// table (GGX 0.1, specular 0.5) beside a diffuse sphere, the camera on the
// sun's side.  The table reflects the sun onto the sphere's lower half: a
// caustic (camera -> diffuse sphere -> glossy table -> sun) that a final
// gather ray from the sphere meets only by chance; vpl once sampled the sun
// through the table's glossy lobe at the point the gather ray met, and at a
// sample or a few a pixel made fireflies of it (the main job's dynamic
// capture: region relMSE 0.32 at 1 spp); then it left that path out, and
// the sphere's mean was 29% below pt's (1015 against 1433).  Now photons
// from the sun reflected by the table into the sphere carry it
// (render/caustics.h).  At 4 spp no pixel of the sphere may exceed 3 x the
// brightest of pt's converged render (the firefly was 50 641 against
// pt's 2 576, 20 x), and the mean is within 8% of pt's (the photons' gather
// radius blurs the caustic; measured 0.2%); without the photons it falls
// below 80% of it, so the test fails if they stop carrying the caustic.
TEST(Stiff, SunGrazingAGlossyTableBesideTheObject) {
  Material table = Diffuse(0.3);
  table.specular = Eigen::Vector3d::Constant(0.5);
  table.roughness = 0.1;
  RenderScene rs;
  const Eigen::Vector3d sun = SunnyFloorWithSphere(table, &rs);
  const Eigen::Vector3d centre(0, 0.3, 0), level = Eigen::Vector3d(sun.x(), 0, sun.z()).normalized();
  const Rigid3 pose = LookAt(centre + 1.4 * level + Eigen::Vector3d(0, 0.5, 0), centre);
  const CameraModel cam = Pinhole(40, 30, 50);
  Rendered pt = Render("pt", Json::object(), rs, cam, pose, 2048);
  const Image mask = pt.frame->Mask();
  int covered = 0;
  const double truth = MeanWhere(pt.frame->Mixed(), mask, 1.0f, &covered);
  ASSERT_GT(covered, 100);
  const double brightest = MaxWhereCovered(pt.frame->Mixed(), mask);
  Rendered vpl = Render("vpl", {{"paths", 256}}, rs, cam, pose, 4);
  const Image m = vpl.frame->Mixed();
  const double worst = MaxWhereCovered(m, mask);
  const double mean = MeanWhere(m, mask, 1.0f);
  std::printf("sun grazing a glossy table: vpl mean %.3f, brightest %.3f; pt %.3f, %.3f\n", mean, worst, truth,
              brightest);
  EXPECT_LT(worst, 3 * brightest);
  EXPECT_NEAR(mean, truth, 0.08 * truth);
  Rendered without = Render("vpl", {{"paths", 256}, {"caustic_photons", 0}}, rs, cam, pose, 4);
  const double mean_without = MeanWhere(without.frame->Mixed(), mask, 1.0f);
  std::printf("  without the photons: mean %.3f\n", mean_without);
  EXPECT_LT(mean_without, 0.8 * truth);
}

// A virtual sphere that fills the whole view, resting on the real floor
// under a sky with a sun 1e3 x brighter: every camera sample's first hit is
// virtual (mask 1 everywhere), no real point is seen directly, so the
// composite is I_m alone; each fast method must agree with pt there.
TEST(Stiff, ObjectCoveringTheWholeView) {
  RenderScene rs;
  SphereOnFloor(&rs, 4, 0.45f, 48, 1e3);
  // Outside the sphere, close enough that it fills the frame.
  const CameraModel cam = Pinhole(32, 24, 60);
  const Rigid3 pose = LookAt({0, 0.45, -0.6}, {0, 0.45, 0});
  Rendered pt = Render("pt", Json::object(), rs, cam, pose, 256);
  const Image mask = pt.frame->Mask();
  for (float v : mask.values()) ASSERT_EQ(v, 1.0f);
  const double truth = Mean(pt.frame->Mixed());
  for (const auto& [name, block] : kFast) {
    Rendered r = Render(name, block, rs, cam, pose, 8);
    EXPECT_TRUE(AllFinite(r.frame->Mixed())) << name;
    EXPECT_EQ(r.frame->nonfinite_samples(), 0) << name;
    const Image covered = r.frame->Mask();
    for (float v : covered.values()) ASSERT_EQ(v, 1.0f) << name;
    std::printf("object covering the view: %s %.4f, pt %.4f\n", name.c_str(), Mean(r.frame->Mixed()), truth);
    EXPECT_NEAR(Mean(r.frame->Mixed()), truth, 0.1 * truth) << name;
  }
}

// Issue 41's stiff cases.

// The same bytes whatever the thread count: every method's I_m and I_r at
// 1 and 2 threads (each pixel, record, VPL and voxel seeds its own numbers
// from its index; sums run over fixed chunks).
TEST(Stiff, SameBytesWithOneAndTwoThreads) {
  RenderScene rs;
  OpenCorner(&rs, 1e3);
  const CameraModel cam = Pinhole(24, 18, 20);
  const Rigid3 pose = LookAt({0, 0.8, -1.6}, {0, 0.3, 0.2});
  std::vector<std::pair<std::string, Json>> methods = kFast;
  methods.insert(methods.begin(), {"pt", Json::object()});
  for (const auto& [name, block] : methods) {
    SetThreadCount(1);
    Rendered one = Render(name, block, rs, cam, pose, 2);
    SetThreadCount(2);
    Rendered two = Render(name, block, rs, cam, pose, 2);
    SetThreadCount(0);
    EXPECT_TRUE(one.frame->Mixed().values() == two.frame->Mixed().values()) << name;
    EXPECT_TRUE(one.frame->Real().values() == two.frame->Real().values()) << name;
  }
}

// A virtual sphere inside a closed real box (a crate) on a floor under a
// sun 1e6 x the sky: it is in the box's shadow from every direction and
// hidden from the camera, so it can change nothing.  pt, ic and vpl test
// the real blockers before the virtual ones on every path they share, and
// the shared direct light meets the box behind the sphere: their I_m - I_r
// is exactly zero in every pixel.  vct's volumes see the sphere through the
// walls' partly filled voxels: its mean bounded by 1e-3 of I_r's (measured
// 2e-5).
TEST(Stiff, ObjectEntirelyInAnotherObjectsShadow) {
  Image sky = Image::Rgb(64, 32);
  for (float& v : sky.values()) v = 0.5f;
  for (int c = 0; c < 3; ++c) sky.at(20, 10, c) = 0.5e6f;
  RenderScene rs;
  rs.AddReal(Quad({-4, 0, -4}, {4, 0, -4}, {4, 0, 4}, {-4, 0, 4}), Diffuse(0.6));
  rs.AddReal(Box({-0.5f, 0.0f, -0.5f}, {0.5f, 1.0f, 0.5f}), Diffuse(0.7));
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.translate(Eigen::Vector3d(0, 0.4, 0));
  rs.AddVirtual(UvSphere(0.3f, 24), t, Diffuse(0.8));
  rs.SetEnvironment(EnvironmentMap(sky, "sun"));
  rs.Commit();
  const CameraModel cam = Pinhole(32, 24, 26);
  const Rigid3 pose = LookAt({0.3, 1.8, -2.5}, {0, 0.4, 0});
  std::vector<std::pair<std::string, Json>> methods = kFast;
  methods.insert(methods.begin(), {"pt", Json::object()});
  for (const auto& [name, block] : methods) {
    Rendered r = Render(name, block, rs, cam, pose, 4);
    const Image m = r.frame->Mixed(), real = r.frame->Real();
    const Image mask = r.frame->Mask();
    for (float v : mask.values()) ASSERT_EQ(v, 0.0f) << name;
    double worst = 0, diff = 0;
    for (size_t i = 0; i < m.values().size(); ++i) {
      worst = std::max(worst, static_cast<double>(std::abs(m.values()[i] - real.values()[i])));
      diff += m.values()[i] - real.values()[i];
    }
    diff /= static_cast<double>(m.values().size());
    std::printf("object in a closed box: %s worst |I_m - I_r| %.3g, mean %.3g, I_r mean %.3g\n", name.c_str(), worst,
                diff, Mean(real));
    if (name == "vct")
      EXPECT_LT(std::abs(diff), 1e-3 * Mean(real));
    else
      EXPECT_EQ(worst, 0.0) << name;
  }
}

// No light source and no sun: a sky of constant radiance only, so every
// direct light is the environment's, and the difference the object makes
// is its sky shadow and its bounce.  Each fast method's mean I_m - I_r
// where the object does not cover the pixel within 15% of pt's at 1024 spp
// (their noise; measured: ic 3.5%, vpl 3.5%), at settings that resolve a
// 30 cm sphere (ic's records at most 4 px apart; at 32 px, the default, one
// record spans this image and the bounce is lost).  vct's within 150%
// (measured 119% too dark: its cones carry about 5% of the sphere's bounce
// onto the floor, not yet traced; docs/benchmarks.md, issue 41's second
// part).
TEST(Stiff, NoDirectLightOnlyTheEnvironment) {
  RenderScene rs;
  rs.AddReal(Quad({-1.5, 0, -1.5}, {1.5, 0, -1.5}, {1.5, 0, 1.5}, {-1.5, 0, 1.5}), Diffuse(0.6));
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.translate(Eigen::Vector3d(0, 0.3, 0));
  rs.AddVirtual(UvSphere(0.3f, 32), t, Diffuse(0.8));
  rs.SetEnvironment(EnvironmentMap::Constant(Eigen::Vector3d::Constant(0.5)));
  rs.Commit();
  const CameraModel cam = Pinhole(48, 36, 40);
  const Rigid3 pose = LookAt({0, 1.2, -1.6}, {0, 0.2, 0});
  // Where the object does not cover the pixel: its shadow and bounce on the floor.
  auto shadow = [](const FrameMethod& f) { return MeanWhere(Difference(f), f.Mask(), 0.0f); };
  Rendered pt = Render("pt", Json::object(), rs, cam, pose, 1024);
  const double truth = shadow(*pt.frame);
  ASSERT_LT(truth, -1e-3);
  const std::vector<std::pair<std::string, Json>> fine = {
      {"ic", {{"rays", 64}, {"max_spacing_px", 4}}}, {"vpl", {{"paths", 1024}}}, {"vct", {{"resolution", 64}}}};
  for (const auto& [name, block] : fine) {
    Rendered r = Render(name, block, rs, cam, pose, 16);
    EXPECT_TRUE(AllFinite(r.frame->Mixed())) << name;
    const double d = shadow(*r.frame);
    std::printf("only the environment: %s shadow %.5f, pt %.5f\n", name.c_str(), d, truth);
    EXPECT_NEAR(d, truth, (name == "vct" ? 1.5 : 0.15) * std::abs(truth)) << name;
  }
}

// The same 1 m x 1 m ceiling panel (radiance 5) as one area light and as
// 10,000 lights of 1 cm x 1 cm: the same light, so each method's image
// agrees between the two within its noise.  On a diffuse floor: the means
// over the image within 3% (measured within 0.8%), the objects' difference
// within 10% for pt and ic (measured 4% and 1.2%) and 15% for vpl (9% at
// 4096 paths, the VPLs' own noise being 35% at 256); vct's within 25%
// (measured 15%): its volumes take each light as a fan of rays from its
// centre, and the tiles' fans differ from the panel's.  With more than 16
// local lights next-event estimation picks one per estimate by power,
// vpl's light paths draw their emitters, vct's fans shrink with the
// light's share, and the lights a ray meets are found through a BVH of
// their shapes.  On a glossy floor too (every method's glossy next-event
// samples; vct's take an area light's centre, so the panel's and the
// tiles' differ: the difference is not compared there), no method traces
// more than 1.5 x the rays with 10,000 lights (measured 1.0 x; each light
// tested would be thousands of times more) and the means agree within 3%.
TEST(Stiff, OneAndTenThousandAreaLights) {
  auto scene = [](int tiles, bool glossy, RenderScene* rs) {
    Material floor = Diffuse(0.6);
    if (glossy) {
      floor.albedo = Eigen::Vector3d::Constant(0.5);
      floor.specular = Eigen::Vector3d::Constant(0.2);
      floor.roughness = 0.4;
    }
    rs->AddReal(Quad({-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}), floor);
    Eigen::Affine3d t = Eigen::Affine3d::Identity();
    t.translate(Eigen::Vector3d(0, 0.3, 0));
    rs->AddVirtual(UvSphere(0.3f, 24), t, Diffuse(0.8));
    const double side = 1.0 / tiles;
    for (int i = 0; i < tiles; ++i)
      for (int j = 0; j < tiles; ++j) {
        Light l;
        l.type = LightType::kArea;
        l.position = Eigen::Vector3d(-0.5 + (i + 0.5) * side, 1.8, -0.5 + (j + 0.5) * side);
        l.direction = Eigen::Vector3d(0, -1, 0);
        l.axis = Eigen::Vector3d(1, 0, 0);
        l.width = l.height = side;
        l.radiance = Eigen::Vector3d::Constant(5.0);
        rs->AddLight(l);
      }
    rs->Commit();
  };
  const CameraModel cam = Pinhole(16, 12, 14);
  const Rigid3 pose = LookAt({0, 1.2, -1.6}, {0, 0.2, 0});
  const std::vector<std::pair<std::string, Json>> methods = {
      {"pt", Json::object()}, {"ic", {{"rays", 64}}}, {"vpl", {{"paths", 4096}}}, {"vct", {{"resolution", 32}}}};
  for (const bool glossy : {false, true}) {
    RenderScene one, many;
    scene(1, glossy, &one);
    scene(100, glossy, &many);
    ASSERT_FALSE(one.picks_local_light());
    ASSERT_TRUE(many.picks_local_light());
    for (const auto& [name, block] : methods) {
      const int spp = name == "pt" ? 64 : 16;
      Rendered a = Render(name, block, one, cam, pose, spp);
      Rendered b = Render(name, block, many, cam, pose, spp);
      EXPECT_TRUE(AllFinite(b.frame->Mixed())) << name;
      const double ma = Mean(a.frame->Mixed()), mb = Mean(b.frame->Mixed());
      const double da = Mean(Difference(*a.frame)), db = Mean(Difference(*b.frame));
      const auto rays = [&](const Rendered& r) -> int64_t {  // vpl and vct count theirs in their report
        if (name == "pt" || name == "ic") return static_cast<const PixelLoopMethod&>(*r.frame).rays_traced();
        Report report("test", "");
        if (name == "vpl") {
          static_cast<const VplFrameRenderer&>(*r.frame).Describe(&report, 0);
          return report.metrics()["vpl"]["frames"]["0"]["rays"].get<int64_t>();
        }
        static_cast<const VctFrameRenderer&>(*r.frame).Describe(&report, 0);
        return report.metrics()["vct"]["frames"]["0"]["rays"].get<int64_t>();
      };
      std::printf("1 and 10,000 area lights%s: %s mean %.4f vs %.4f, difference %.5f vs %.5f, rays %lld vs %lld\n",
                  glossy ? " (glossy floor)" : "", name.c_str(), ma, mb, da, db, static_cast<long long>(rays(a)),
                  static_cast<long long>(rays(b)));
      EXPECT_NEAR(mb, ma, 0.03 * ma) << name;
      EXPECT_LT(rays(b), 1.5 * rays(a)) << name;
      if (!glossy) {
        EXPECT_NEAR(db, da, (name == "vct" ? 0.25 : name == "vpl" ? 0.15 : 0.1) * std::abs(da)) << name;
      }
    }
  }
}

// The assets issue's materials in the fast methods: a smooth glass slab
// (a glTF transmissive material, ior 1.5, 0.2 m thick) before a sky of
// radiance 1 in the +z half, seen along +z.  pt shows the sky through it at
// (1 - R)^2 / (1 - R^2) = 0.923 (tests/render/glass_test.cpp).  ic, vpl
// and vct follow a transmissive asset's whole BSDF by sampled rays, as pt:
// within 3% of pt (measured at 16 spp: ic +0.6%, vpl -0.4%, vct 0.0%, the
// slab being smooth, so that vct's paths through it are pt's own).  They
// once took the scene's lobes for the geometry, the asset's mean material,
// which knows no transmission, and the glass was opaque (ic 0.0, vpl 0.0);
// vct's glossy lobe was a cone along the mirror direction (0.0 too).
TEST(Stiff, FastMethodsSeeThroughAGlassAsset) {
  Image sky = Image::Rgb(256, 128);
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 256; ++x)
      for (int c = 0; c < 3; ++c)
        sky.at(x, y, c) = LatLongPixelToDirection(Eigen::Vector2d(x, y), 256, 128).z() > 0 ? 1.0f : 0.0f;
  RenderScene rs;
  AddGlassAsset(&rs, Box(Eigen::Vector3f(-2, -2, -0.1f), Eigen::Vector3f(2, 2, 0.1f)), 1.5f, 0.2f);
  rs.SetEnvironment(EnvironmentMap(sky, "half sky"));
  rs.Commit();
  const CameraModel cam("LENSMODEL_PINHOLE", {400, 400, 7.5, 7.5}, 16, 16);
  Rigid3 pose;
  pose.translation = Eigen::Vector3d(0, 0, -3);
  auto centre = [](const Image& img) {
    double sum = 0;
    for (int y = 6; y < 10; ++y)
      for (int x = 6; x < 10; ++x) sum += img.at(x, y, 1);
    return sum / 16;
  };
  const double truth = centre(Render("pt", Json::object(), rs, cam, pose, 16).frame->Mixed());
  EXPECT_NEAR(truth, 0.923, 0.02);  // 16 spp, Russian roulette
  for (const auto& [name, block] : kFast) {
    const double through = centre(Render(name, block, rs, cam, pose, 16).frame->Mixed());
    std::printf("through a glass asset: %s %.4f, pt %.4f\n", name.c_str(), through, truth);
    EXPECT_NEAR(through, truth, 0.03 * truth) << name;
  }
}

// The fast methods' object_direct_samples: at camera points on the virtual
// objects, n samples of the direct light, each weighted 1/n.  The objects'
// pixels keep their mean (the same estimator, averaged) and lose noise: on
// the open corner under a sun 1e3 x the sky at 1 spp, against pt at 1024
// spp over the pixels the sphere covers entirely (vpl with direct_samples
// 1, which object_direct_samples cannot go below).  Bounds: the mean with
// 16 samples within 3% of pt's and two of its standard errors (measured
// 0.2-2.6% off), with one within four of its standard errors; the rms at 16
// below 0.7 of that at one (measured ic 0.24, vpl 0.39, vct 0.43).
TEST(FastMethods, ObjectDirectSamplesLowerTheObjectsNoise) {
  RenderScene rs;
  OpenCorner(&rs, 1e3);
  const CameraModel cam = Pinhole(64, 48, 52);
  Rendered pt = Render("pt", Json::object(), rs, cam, kCornerCamera, 1024);
  const Image truth = pt.frame->Mixed(), mask = pt.frame->Mask();
  auto rms = [&](const Image& img, int* n) {
    double sq = 0;
    *n = 0;
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x)
        if (mask.at(x, y, 0) == 1.0f)
          for (int c = 0; c < 3; ++c, ++*n) sq += std::pow(img.at(x, y, c) - truth.at(x, y, c), 2);
    return std::sqrt(sq / std::max(1, *n));
  };
  for (const auto& [name, block] : kFast) {
    double mean[2], err[2];
    int n = 0;
    for (int k = 0; k < 2; ++k) {
      Json b = block;
      b["object_direct_samples"] = k == 0 ? 1 : 16;
      if (name == "vpl") b["direct_samples"] = 1;
      Rendered r = Render(name, b, rs, cam, kCornerCamera, 1);
      err[k] = rms(r.frame->Mixed(), &n);
      ASSERT_GT(n, 3 * 60) << name;
      mean[k] = MeanWhere(r.frame->Mixed(), mask, 1.0f);
    }
    std::printf("object direct samples: %s rms %.4f with 1, %.4f with 16; means %.4f %.4f, pt %.4f\n", name.c_str(),
                err[0], err[1], mean[0], mean[1], MeanWhere(truth, mask, 1.0f));
    const double want = MeanWhere(truth, mask, 1.0f);
    const double pixels = n / 3.0;
    EXPECT_NEAR(mean[1], want, 0.03 * want + 2 * err[1] / std::sqrt(pixels)) << name;
    EXPECT_NEAR(mean[0], want, 4 * err[0] / std::sqrt(pixels)) << name;
    EXPECT_LT(err[1], 0.7 * err[0]) << name;
  }
}

}  // namespace
}  // namespace mr
