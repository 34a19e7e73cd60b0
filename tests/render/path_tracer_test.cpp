#include "render/path_tracer.h"
#include "render/pt.h"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <optional>

#include "core/math.h"
#include "core/parallel.h"
#include "core/spherical.h"
#include "geometry/asset.h"
#include "geometry/primitives.h"
#include "light/lights_file.h"

namespace mr {
namespace {

// A closed axis-aligned box [-h, h]^3 (two-sided shading, so the winding does not matter).
Mesh Box(double h) {
  Mesh m;
  const float f = static_cast<float>(h);
  m.positions = {{-f, -f, -f}, {f, -f, -f}, {f, f, -f}, {-f, f, -f}, {-f, -f, f}, {f, -f, f}, {f, f, f}, {-f, f, f}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                 {2, 3, 7}, {2, 7, 6}, {1, 2, 6}, {1, 6, 5}, {0, 4, 7}, {0, 7, 3}};
  return m;
}

Mesh Quad(double half, double y) {
  Mesh m;
  const float h = static_cast<float>(half), fy = static_cast<float>(y);
  m.positions = {{-h, fy, -h}, {h, fy, -h}, {h, fy, h}, {-h, fy, h}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}};
  return m;
}

CameraModel Pinhole(int w, int h, double f) {
  return CameraModel("LENSMODEL_PINHOLE", {f, f, (w - 1) / 2.0, (h - 1) / 2.0}, w, h);
}

double MeanOf(const Image& img, int channel) {
  CompensatedSum<double> s;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) s += img.at(x, y, channel);
  return s.Value() / static_cast<double>(img.pixel_count());
}

// Furnace: inside a closed box of albedo a whose walls all emit Le, every
// point sees L = Le / (1 - a) (the Neumann series of a constant).  Pixel
// means are independent, so the image mean's standard error comes from their
// spread; the test allows 5 standard errors (a false alarm ~1 in 2 million)
// and requires that error to be small enough (< 2%) for the test to mean something.
void Furnace(double albedo, int spp) {
  RenderScene scene;
  Material m;
  m.albedo = Eigen::Vector3d::Constant(albedo);
  m.emission = Eigen::Vector3d(1.0, 0.5, 0.25);
  scene.AddReal(Box(1.0), m);
  scene.Commit();
  PathTracerSettings st;
  st.max_depth = 100000;  // Russian roulette ends the paths; no truncation bias
  PtFrameRenderer r(scene, Pinhole(32, 24, 20), Rigid3(), st);
  r.RenderPass(spp);
  Image img = r.Mixed();
  EXPECT_EQ(r.nonfinite_samples(), 0);
  EXPECT_EQ(CountNonFinite(img), 0);
  for (int c = 0; c < 3; ++c) {
    const double expected = m.emission[c] / (1 - albedo);
    const double mean = MeanOf(img, c);
    CompensatedSum<double> sq;
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x) sq += (img.at(x, y, c) - mean) * (img.at(x, y, c) - mean);
    const double n = static_cast<double>(img.pixel_count());
    const double std_error = std::sqrt(sq.Value() / (n - 1) / n);
    EXPECT_LT(std_error, 0.02 * expected) << "albedo " << albedo;
    EXPECT_NEAR(mean, expected, 5 * std_error) << "albedo " << albedo << " channel " << c;
  }
}

TEST(PathTracer, FurnaceMatchesClosedForm) { Furnace(0.5, 32); }
TEST(PathTracer, FurnaceWithAlbedoNearOneStaysBoundedAndCorrect) { Furnace(0.99, 16); }

// An open ground plane under a sky with a sun 1e6 times brighter: the
// plane's radiance is albedo / pi times the cosine-weighted integral of the
// piecewise-constant map over the upper hemisphere, in closed form.
TEST(PathTracer, SunAndSkyOverAGroundPlaneMatchTheClosedForm) {
  const int W = 64, H = 33;
  Image img = Image::Rgb(W, H, 1.0f);
  const int sx = 20, sy = 6;  // the sun, about 57 degrees up
  for (int c = 0; c < 3; ++c) img.at(sx, sy, c) = 1e6f;
  double expected_e = 0;  // irradiance: sum of L * integral of sin(lat) over the cell's upper part
  const double dlat = kPi / (H - 1), dlon = kTwoPi / (W - 1);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double lat = kPi / 2 - y * dlat;
      const double hi = std::min(kPi / 2, lat + dlat / 2), lo = std::max(0.0, lat - dlat / 2);
      if (hi <= lo) continue;
      const double w = (x == 0 || x == W - 1) ? dlon / 2 : dlon;
      expected_e += img.at(x, y, 0) * w * (std::sin(hi) * std::sin(hi) - std::sin(lo) * std::sin(lo)) / 2;
    }
  RenderScene scene;
  Material m;
  m.albedo = Eigen::Vector3d::Constant(0.5);
  scene.AddReal(Quad(1e4, 0.0), m);  // blocks the lower hemisphere as seen from near the origin
  scene.SetEnvironment(EnvironmentMap(img, "sun.exr"));
  scene.Commit();
  PathTracerSettings st;
  st.max_depth = 1;  // direct light only: the closed form has no interreflection (the plane sees no plane)
  // Camera 1 m up, looking straight down (camera z = world -y).
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, -1, 0, 1, 0;  // columns: cam x -> world x, cam y -> world -z, cam z -> world -y
  PtFrameRenderer r(scene, Pinhole(8, 8, 20), Rigid3(Eigen::Quaterniond(R), Eigen::Vector3d(0, 1, 0)), st);
  r.RenderPass(64);
  const double expected_l = 0.5 / kPi * expected_e;
  // Environment sampling puts nearly all samples on the sun, whose
  // contribution is then nearly constant: 1% is many standard errors.
  EXPECT_NEAR(MeanOf(r.Mixed(), 1), expected_l, 0.01 * expected_l);
  EXPECT_EQ(r.nonfinite_samples(), 0);
}

struct TwoObjects {
  RenderScene scene;
  TwoObjects(bool with_virtual) {
    Material wall;
    wall.albedo = Eigen::Vector3d(0.6, 0.5, 0.4);
    scene.AddReal(Quad(10, 0.0), wall);
    if (with_virtual) {
      Material red;
      red.albedo = Eigen::Vector3d(0.8, 0.1, 0.1);
      red.specular = Eigen::Vector3d::Constant(0.1);
      red.roughness = 0.3;
      Eigen::Affine3d t = Eigen::Affine3d::Identity();
      t.translate(Eigen::Vector3d(0, 0.3, 0));
      scene.AddVirtual(Box(0.25), t, red);
    }
    Image sky = Image::Rgb(32, 17, 0.5f);
    for (int c = 0; c < 3; ++c) sky.at(12, 4, c) = 2000.0f;
    scene.SetEnvironment(EnvironmentMap(sky, "sky"));
    scene.Commit();
  }
};

Rigid3 LookDownFrom(double height) {
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  return Rigid3(Eigen::Quaterniond(R), Eigen::Vector3d(0, height, 0));
}

TEST(PathTracer, WithoutVirtualObjectsMixedEqualsRealExactly) {
  TwoObjects s(false);
  PtFrameRenderer r(s.scene, Pinhole(24, 16, 12), LookDownFrom(2), PathTracerSettings());
  r.RenderPass(8);
  EXPECT_EQ(r.Mixed().values(), r.Real().values());
  EXPECT_EQ(MeanOf(r.Mask(), 0), 0.0);
  EXPECT_EQ(MeanOf(r.DifferenceVariance(), 0), 0.0);
}

// The real paths of a scene with virtual objects are the paths of the scene
// without them, sample for sample: I_r is exactly the photograph of the real
// scene alone (what mr-synth relies on for its photographs).
TEST(PathTracer, RealPathsIgnoreVirtualObjectsExactly) {
  TwoObjects with(true), without(false);
  PtFrameRenderer a(with.scene, Pinhole(24, 16, 12), LookDownFrom(2), PathTracerSettings());
  PtFrameRenderer b(without.scene, Pinhole(24, 16, 12), LookDownFrom(2), PathTracerSettings());
  a.RenderPass(8);
  b.RenderPass(8);
  EXPECT_TRUE(a.Real().values() == b.Mixed().values());
  EXPECT_FALSE(a.Mixed().values() == b.Mixed().values());
}

TEST(PathTracer, VirtualObjectCoversPixelsAndShadowsTheRealPlane) {
  TwoObjects s(true);
  PtFrameRenderer r(s.scene, Pinhole(24, 16, 12), LookDownFrom(2), PathTracerSettings());
  r.RenderPass(16);
  Image m = r.Mixed(), rl = r.Real(), mask = r.Mask();
  EXPECT_EQ(mask.at(12, 8, 0), 1.0f);  // the box is below the camera's centre
  EXPECT_EQ(mask.at(0, 0, 0), 0.0f);
  // The real image sees the plane through the object; the mixed image sees the red box.
  EXPECT_GT(m.at(12, 8, 0), 1.5 * m.at(12, 8, 2));
  EXPECT_NEAR(rl.at(12, 8, 0) / rl.at(12, 8, 2), 0.6 / 0.4, 0.2);
  // Relighting of the real plane: less light reaches it with the box there.
  double diff = 0;  // sum over pixels outside the object of luminance(I_m - I_r)
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 24; ++x)
      if (mask.at(x, y, 0) == 0) {
        Eigen::Vector3d d(m.at(x, y, 0) - rl.at(x, y, 0), m.at(x, y, 1) - rl.at(x, y, 1),
                          m.at(x, y, 2) - rl.at(x, y, 2));
        diff += Luminance(d);
      }
  EXPECT_LT(diff, 0.0);
}

TEST(PathTracer, ResultsDoNotDependOnThreadsOrPassSplits) {
  TwoObjects s(true);
  auto render = [&](int threads, std::vector<int> passes) {
    SetThreadCount(threads);
    PtFrameRenderer r(s.scene, Pinhole(20, 12, 10), LookDownFrom(2), PathTracerSettings());
    for (int p : passes) r.RenderPass(p);
    SetThreadCount(0);
    return std::make_pair(r.Mixed().values(), r.Real().values());
  };
  auto a = render(1, {8});
  auto b = render(2, {8});
  auto c = render(2, {3, 5});
  EXPECT_EQ(a, b);
  EXPECT_EQ(a, c);
}

// The virtual shadow tests left out where the shadow segment meets no
// virtual object's bounding box change nothing: the same bytes as tracing
// every test, with fewer rays.
TEST(PathTracer, CulledVirtualShadowTestsChangeNothing) {
  TwoObjects s(true);
  auto render = [&](bool cull) {
    PathTracerSettings st;
    st.cull_virtual_shadow_tests = cull;
    auto r = std::make_unique<PtFrameRenderer>(s.scene, Pinhole(24, 16, 12), LookDownFrom(2), st);
    r->RenderPass(8);
    return r;
  };
  const auto culled = render(true), all = render(false);
  EXPECT_TRUE(culled->Mixed().values() == all->Mixed().values());
  EXPECT_TRUE(culled->Real().values() == all->Real().values());
  EXPECT_EQ(all->virtual_tests_skipped(), 0);
  EXPECT_GT(culled->virtual_tests_skipped(), 0);
  EXPECT_EQ(culled->rays_traced() + culled->virtual_tests_skipped(), all->rays_traced());
}

// pt's camera paths traced in batches (TraceBatch: each bounce's rays and
// shadow rays as Embree streams) give the bytes of tracing them one by one,
// whatever the batch size: one ray (issue 41's stiff case: every batch of
// a frame a single ray), 7 (a row's last batch short) and 256.  The scene
// has what the shared path handles: virtual geometry parting the paths, a
// glossy virtual box, an emissive real panel, a real area light and a
// virtual point light, a sky with a sun, culled virtual tests, Russian
// roulette, and two passes (the second continuing each pixel's sequence);
// then the same with 20 more lamps, one picked per estimate.  The batches'
// draws, environment samples, lights' points and directions (a rectangle,
// a disc, a sun of 2 degrees) and the BSDF's cosine directions are
// computed in lanes (core/lanes.h), the one-by-one paths' by the scalar
// calls; the real wall is glossy, so that both lobes are sampled.
void CheckBatchesGiveTheSameBytes(bool many_lamps) {
  SCOPED_TRACE(many_lamps ? "many lamps" : "two lights");
  RenderScene scene;
  Material wall;
  wall.albedo = Eigen::Vector3d(0.6, 0.5, 0.4);
  wall.specular = Eigen::Vector3d::Constant(0.2);
  wall.roughness = 0.35;
  scene.AddReal(Quad(10, 0.0), wall);
  Material red;
  red.albedo = Eigen::Vector3d(0.8, 0.1, 0.1);
  red.specular = Eigen::Vector3d::Constant(0.1);
  red.roughness = 0.3;
  scene.AddVirtual(Box(0.25), Eigen::Affine3d(Eigen::Translation3d(0, 0.3, 0)), red);
  Image sky = Image::Rgb(32, 17, 0.5f);
  for (int c = 0; c < 3; ++c) sky.at(12, 4, c) = 2000.0f;
  scene.SetEnvironment(EnvironmentMap(sky, "sky"));
  Material panel;
  panel.albedo = Eigen::Vector3d::Constant(0.3);
  panel.emission = Eigen::Vector3d(0.5, 0.4, 0.2);
  Mesh cube = Box(0.1);
  for (auto& q : cube.positions) q += Eigen::Vector3f(-0.7f, 0.1f, 0.4f);
  scene.AddReal(cube, panel);
  Light area;
  area.type = LightType::kArea;
  area.position = Eigen::Vector3d(0.5, 1.5, 0);
  area.direction = Eigen::Vector3d(0, -1, 0);
  area.axis = Eigen::Vector3d(1, 0, 0);
  area.width = area.height = 0.4;
  area.radiance = Eigen::Vector3d::Constant(8.0);
  scene.AddLight(area);
  Light disc = area;  // a disc lamp and a sun of 2 degrees: their points and directions in lanes
  disc.shape = AreaShape::kDisc;
  disc.position = Eigen::Vector3d(-0.6, 1.2, 0.2);
  scene.AddLight(disc);
  Light sun;
  sun.type = LightType::kDistant;
  sun.direction = Eigen::Vector3d(0.3, 1, 0.2).normalized();
  sun.angular_radius_deg = 2;
  sun.irradiance = Eigen::Vector3d::Constant(3.0);
  scene.AddLight(sun);
  Light lamp;
  lamp.type = LightType::kPoint;
  lamp.position = Eigen::Vector3d(-0.4, 0.9, -0.3);
  lamp.intensity = Eigen::Vector3d::Constant(0.5);
  lamp.is_virtual = true;
  scene.AddLight(lamp);
  for (int i = 0; many_lamps && i < 20; ++i) {
    Light l = lamp;
    l.is_virtual = i % 3 == 0;
    l.position += Eigen::Vector3d(0.05 * i - 0.5, 0.02 * i, 0.3 - 0.03 * i);
    l.intensity *= 0.1 + 0.05 * i;
    scene.AddLight(l);
  }
  scene.Commit();
  ASSERT_EQ(scene.picks_local_light(), many_lamps);
  auto render = [&](int batch) {
    PathTracerSettings st;
    st.batch = batch;
    auto r = std::make_unique<PtFrameRenderer>(scene, Pinhole(23, 16, 12), LookDownFrom(2), st);
    r->RenderPass(3);
    r->RenderPass(2);
    return r;
  };
  const auto one_by_one = render(0);
  EXPECT_NE(MeanOf(one_by_one->Mixed(), 0), MeanOf(one_by_one->Real(), 0));  // the objects do act
  for (const int batch : {1, 7, 256}) {
    const auto b = render(batch);
    EXPECT_TRUE(b->Mixed().values() == one_by_one->Mixed().values()) << batch;
    EXPECT_TRUE(b->Real().values() == one_by_one->Real().values()) << batch;
    EXPECT_TRUE(b->Mask().values() == one_by_one->Mask().values()) << batch;
    EXPECT_EQ(b->rays_traced(), one_by_one->rays_traced()) << batch;
    EXPECT_EQ(b->virtual_tests_skipped(), one_by_one->virtual_tests_skipped()) << batch;
  }
}

TEST(PathTracer, BatchesGiveTheSameBytes) {
  ASSERT_NO_FATAL_FAILURE(CheckBatchesGiveTheSameBytes(false));
  ASSERT_NO_FATAL_FAILURE(CheckBatchesGiveTheSameBytes(true));
}

TEST(PathTracer, VirtualObjectOutOfViewChangesOnlyLighting) {
  TwoObjects s(true);
  // Camera far to the side looking away from the box: the mask is empty.
  PtFrameRenderer r(s.scene, Pinhole(16, 12, 10), Rigid3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 1, 5)),
                    PathTracerSettings());
  r.RenderPass(4);
  EXPECT_EQ(MeanOf(r.Mask(), 0), 0.0);
  EXPECT_EQ(CountNonFinite(r.Mixed()), 0);
}

// A closed room lit by a lamp inside, a virtual object and a virtual lamp
// outside: the enclosure test proves them unable to act, and the renders
// agree (I_m = I_r bit for bit), so the frame skip changes nothing.  With
// one wall triangle missing, nothing is proven and the virtual lamp's light
// does get in.
TEST(PathTracer, ObjectsOutsideAClosedRoomCannotChangeIt) {
  for (bool closed : {true, false}) {
    RenderScene scene;
    Material wall;
    wall.albedo = Eigen::Vector3d::Constant(0.7);
    Mesh room = Box(2.0);
    if (!closed) room.triangles.erase(room.triangles.begin() + 8);  // a hole in the +x wall
    scene.AddReal(room, wall);
    Eigen::Affine3d t = Eigen::Affine3d::Identity();
    t.translate(Eigen::Vector3d(4, 0, 0));
    scene.AddVirtual(Box(0.5), t, wall);
    Light inside, outside;
    inside.position = Eigen::Vector3d(0, 1.5, 0);
    inside.intensity = Eigen::Vector3d::Constant(10);
    outside.name = "virtual lamp";
    outside.position = Eigen::Vector3d(3, 0, 0);
    outside.intensity = Eigen::Vector3d::Constant(1000);
    outside.is_virtual = true;
    scene.AddLight(inside);
    scene.AddLight(outside);
    scene.Commit();
    const Eigen::Vector3d eye(-1, 0, 0);
    std::string why;
    EXPECT_EQ(scene.VirtualEnclosedAwayFrom(eye, &why), closed);
    if (closed) {
      EXPECT_NE(why.find("closed real surface"), std::string::npos) << why;
    }
    // Looking at the +x wall (camera z = world +x).
    Eigen::Matrix3d R;
    R << 0, 0, 1, 0, 1, 0, -1, 0, 0;
    PtFrameRenderer r(scene, Pinhole(16, 12, 10), Rigid3(Eigen::Quaterniond(R), eye), PathTracerSettings());
    r.RenderPass(4);
    if (closed) {
      EXPECT_EQ(r.Mixed().values(), r.Real().values());
    } else {
      EXPECT_NE(r.Mixed().values(), r.Real().values());
    }
  }
}

// An open scene (a ground plane under the sky) seen towards the horizon:
// pixels whose camera rays provably miss all geometry are sampled once, and
// the difference I_m - I_r, hence the composite, is bit-identical to a render
// that samples them all.
TEST(PathTracer, EnvironmentPixelsAreSampledOnceAndChangeNothing) {
  TwoObjects s(true);
  Eigen::Matrix3d R;  // camera z = world +z, camera y = world -y, slightly tilted down
  R = Eigen::AngleAxisd(0.15, Eigen::Vector3d::UnitX()) * Eigen::Matrix3d(Eigen::Vector3d(1, -1, 1).asDiagonal());
  const Rigid3 pose(Eigen::Quaterniond(R), Eigen::Vector3d(0, 1, -4));
  auto render = [&](bool skip) {
    PathTracerSettings st;
    st.skip_environment_pixels = skip;
    auto r = std::make_unique<PtFrameRenderer>(s.scene, Pinhole(32, 24, 20), pose, st);
    for (int p : {1, 1, 2, 4}) r->RenderPass(p);
    return r;
  };
  auto on = render(true), off = render(false);
  EXPECT_GT(on->skipped_pixels(), 32 * 4);   // the upper rows see only sky
  EXPECT_LT(on->skipped_pixels(), 32 * 20);  // the plane fills the lower rows
  EXPECT_EQ(off->skipped_pixels(), 0);
  auto difference = [](const PtFrameRenderer& r) {
    Image m = r.Mixed(), re = r.Real();
    std::vector<float> d(m.values().size());
    for (size_t i = 0; i < d.size(); ++i) d[i] = m.values()[i] - re.values()[i];
    return d;
  };
  EXPECT_EQ(difference(*on), difference(*off));
  const Image count = on->SampleCount();
  int ones = 0;
  for (float c : count.values()) {
    EXPECT_TRUE(c == 1 || c == 8) << c;
    ones += c == 1;
  }
  EXPECT_EQ(ones, on->skipped_pixels());
  EXPECT_LT(on->rays_traced(), off->rays_traced());
}

}  // namespace
}  // namespace mr

namespace mr {
namespace {

// An OBJ with "material": "mtl" is added with its MTL materials, its mesh
// as ReadVirtualMesh reads it (prt's and the renderer's agree).
TEST(PathTracer, ObjWithMtlMaterialsLoads) {
  SceneVirtual v;
  v.name = "blender";
  v.mesh = fs::path(MR_SOURCE_DIR) / "tests/data/assets/blender/blender.obj";
  v.file_materials = true;
  const Mesh mesh = ReadVirtualMesh(v);
  EXPECT_EQ(mesh.triangle_count(), 248u);
  EXPECT_EQ(mesh.vertex_count(), 199u);  // split at seams, unlike ReadMesh's 130
  Scene scene;
  scene.virtuals.push_back(v);
  RenderScene rs;
  LoadRenderScene(scene, &rs);
  const uint32_t id = rs.virtual_ids().at(0);
  EXPECT_TRUE(rs.has_asset_material(id));
  EXPECT_EQ(rs.asset_textures(id), 2);  // checker.png and normal.png
}

// prt's per-vertex albedo of an asset (AssetVertexAlbedo) on Blender's
// export: the gold sphere (metallic 1) and the glass slab (transmission 1)
// have no diffuse albedo; the painted cube (metallic factor 1, its texture's
// B channel 0) takes its checker's two colours (sRGB codes 204, 51, 26 and
// 26, 77, 204, decoded: 0.604, 0.033, 0.010 and 0.010, 0.074, 0.604) or a
// bilinear mix of them at each vertex's uv.
TEST(PathTracer, AssetVertexAlbedoForPrt) {
  const fs::path glb = fs::path(MR_SOURCE_DIR) / "tests/data/assets/blender/blender.glb";
  const Asset asset = ReadAsset(glb);
  const std::vector<Eigen::Vector3f> albedo = AssetVertexAlbedo(asset, glb.string());
  ASSERT_EQ(albedo.size(), MergeParts(asset).vertex_count());
  size_t i = 0;
  for (const AssetPart& p : asset.parts) {
    const std::string& mat = asset.materials[static_cast<size_t>(p.material)].name;
    for (size_t k = 0; k < p.mesh.positions.size(); ++k, ++i) {
      const Eigen::Vector3f& a = albedo[i];
      if (mat != "painted") {
        EXPECT_EQ(a.maxCoeff(), 0) << mat;
        continue;
      }
      const Eigen::Vector3f red(0.604f, 0.033f, 0.010f), blue(0.010f, 0.074f, 0.604f);
      const float t = (a.x() - blue.x()) / (red.x() - blue.x());  // the mix, from R
      EXPECT_GE(t, -0.01f);
      EXPECT_LE(t, 1.01f);
      EXPECT_LT((a - (t * red + (1 - t) * blue)).norm(), 0.01f) << a.transpose();
    }
  }
}

// An asset's materials through the path tracer: a convex sphere in a
// uniform sky of radiance 1 reflects radiance 1 wherever its BSDF conserves
// energy (render/pbr_bsdf.h): a white metal, and a white base under the
// dielectric coat, at roughness 1.  The mean over the sphere's
// pixels within 5 standard errors; the lobes' white furnace itself is
// measured in pbr_bsdf_test (0.998 to 1.001).
TEST(PathTracer, AssetMaterialsConserveEnergyInAWhiteSky) {
  for (double metallic : {1.0, 0.0}) {
    Asset asset;
    asset.parts.push_back({.name = "sphere", .mesh = UvSphere(0.5f, 48), .material = 0});
    AssetMaterial m;
    m.metallic = static_cast<float>(metallic);
    m.roughness = 1.0f;  // where single scattering alone loses the most
    asset.materials.push_back(m);
    std::vector<int> triangle_material;
    const Mesh mesh = MergeParts(asset, &triangle_material);
    RenderScene scene;
    const uint32_t id = scene.AddVirtual(mesh, Eigen::Affine3d::Identity(), Material());
    scene.SetAssetMaterials(id, asset, triangle_material, mesh, "sphere.glb");
    scene.SetEnvironment(EnvironmentMap::Constant(Eigen::Vector3d::Ones()));
    scene.Commit();
    PathTracerSettings st;
    st.max_depth = 64;
    Rigid3 world_from_cam;
    world_from_cam.translation = Eigen::Vector3d(0, 0, -3);
    PtFrameRenderer r(scene, Pinhole(32, 32, 60), world_from_cam, st);
    r.RenderPass(32);
    const Image img = r.Mixed();
    CompensatedSum<double> sum, sq;
    int n = 0;
    for (int y = 12; y < 20; ++y)  // the sphere's middle: 0.5 m at 3 m is +-10 pixels
      for (int x = 12; x < 20; ++x) {
        sum += img.at(x, y, 1);
        ++n;
      }
    const double mean = sum.Value() / n;
    for (int y = 12; y < 20; ++y)
      for (int x = 12; x < 20; ++x) sq += (img.at(x, y, 1) - mean) * (img.at(x, y, 1) - mean);
    const double se = std::sqrt(sq.Value() / (n - 1) / n);
    EXPECT_NEAR(mean, 1.0, 5 * se + 0.01) << "metallic " << metallic;
  }
}

// A 2 m square in z = 0 (u along +x, glTF's v down the image along -y)
// as an asset of one part with material `m` and `images`.
Asset QuadAsset(const AssetMaterial& m, std::vector<AssetImage> images = {}) {
  Asset asset;
  Mesh quad;
  quad.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  quad.uvs = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
  quad.triangles = {{0, 1, 2}, {0, 2, 3}};
  asset.parts.push_back({.name = "quad", .mesh = quad, .material = 0});
  asset.materials.push_back(m);
  asset.images = std::move(images);
  return asset;
}

// `asset` at the origin of a scene with environment `env` (none: black),
// seen by pt from z = -3 along +z through a size x size pinhole of focal
// length f: the renderer after `spp` samples.
std::unique_ptr<PtFrameRenderer> RenderAssetFromFront(const Asset& asset, std::optional<EnvironmentMap> env, int size,
                                                      double f, int spp, std::unique_ptr<RenderScene>* keep) {
  std::vector<int> triangle_material;
  const Mesh mesh = MergeParts(asset, &triangle_material);
  *keep = std::make_unique<RenderScene>();
  RenderScene& scene = **keep;
  const uint32_t id = scene.AddVirtual(mesh, Eigen::Affine3d::Identity(), Material());
  scene.SetAssetMaterials(id, asset, triangle_material, mesh, "quad.glb");
  if (env) scene.SetEnvironment(std::move(*env));
  scene.Commit();
  Rigid3 world_from_cam;
  world_from_cam.translation = Eigen::Vector3d(0, 0, -3);
  auto r = std::make_unique<PtFrameRenderer>(scene, Pinhole(size, size, f), world_from_cam, PathTracerSettings());
  r->RenderPass(spp);
  return r;
}

// An emissive asset material seen directly: emissiveFactor x
// KHR_materials_emissive_strength (glTF: radiance, linear), the black base
// reflecting nothing of the black sky: exactly e x strength.
TEST(PathTracer, AssetEmissionIsItsFactorTimesItsStrength) {
  AssetMaterial m;
  m.base_color = Eigen::Vector4f(0, 0, 0, 1);
  m.metallic = 0;
  m.emissive = Eigen::Vector3f(1.0f, 0.5f, 0.25f);
  m.emissive_strength = 40;
  std::unique_ptr<RenderScene> scene;
  const auto r = RenderAssetFromFront(QuadAsset(m), std::nullopt, 8, 20, 1, &scene);
  const Image img = r->Mixed();
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(img.at(4, 4, c), 40.0 * m.emissive[c], 1e-3) << c;
  EXPECT_EQ(r->Real().at(4, 4, 0), 0);  // a virtual emitter: in I_m only
}

// Alpha (glTF 3.9.4) in Embree's filters: a quad before a white sky whose
// base colour texture is opaque on its right half and clear on its left.
// MASK: the left half shows the sky (1), the right half the black quad (its
// coat's reflection of the sky, ~0.014), for camera rays and shadow rays
// alike (a ray through each half); BLEND at alpha 0.25 lets 3/4 of the rays
// through (within 3 %, 1024 rays a pixel).
TEST(PathTracer, AssetAlphaCutsAndBlends) {
  const fs::path dir = fs::temp_directory_path() / "mr_alpha_test";
  fs::create_directories(dir);
  Image rgba(2, 1, {"R", "G", "B", "A"});
  rgba.values() = {0, 0, 0, 0, 0, 0, 0, 1};  // left texel clear, right opaque
  WriteImage(dir / "alpha.png", rgba, {.ldr_transfer = Transfer::kLinear});
  for (AlphaMode mode : {AlphaMode::kMask, AlphaMode::kBlend}) {
    AssetMaterial m;
    m.base_color = Eigen::Vector4f(0, 0, 0, mode == AlphaMode::kBlend ? 0.25f : 1.0f);
    m.metallic = 0;
    m.alpha_mode = mode;
    if (mode == AlphaMode::kMask) m.base_color_texture.image = 0;
    std::unique_ptr<RenderScene> scene;
    const auto r = RenderAssetFromFront(QuadAsset(m, {{.name = "alpha.png", .file = dir / "alpha.png"}}),
                                        EnvironmentMap::Constant(Eigen::Vector3d::Ones()), 16, 40,
                                        mode == AlphaMode::kBlend ? 1024 : 4, &scene);
    const Image img = r->Mixed();
    if (mode == AlphaMode::kMask) {
      EXPECT_NEAR(img.at(4, 8, 1), 1.0, 1e-6);  // x < 0: the clear texel
      EXPECT_LT(img.at(11, 8, 1), 0.05);        // the black base's dielectric coat reflects a little sky
      Ray through;
      through.origin = Eigen::Vector3f(-0.5f, 0, -1);
      through.direction = Eigen::Vector3f(0, 0, 1);
      EXPECT_FALSE(scene->embree().Occluded(through));
      through.origin.x() = 0.5f;
      EXPECT_TRUE(scene->embree().Occluded(through));
    } else {
      EXPECT_NEAR(img.at(8, 8, 1), 0.75, 0.03);
    }
  }
}

// Texture footprints from the pixel cone: a quad emitting a checker of
// single texels (256 x 256, black and white) seen from so far that a pixel
// covers about 19 texels across reads the mip level that averages them:
// every pixel within 0.05 of the mean 0.5 at one sample, where mip level 0
// (a thin ray) gives 0 or 1.
TEST(PathTracer, TextureFootprintsFollowThePixelCone) {
  const fs::path dir = fs::temp_directory_path() / "mr_footprint_test";
  fs::create_directories(dir);
  Image checker = Image::Rgb(256, 256);
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x)
      for (int c = 0; c < 3; ++c) checker.at(x, y, c) = static_cast<float>((x + y) % 2);
  WriteImage(dir / "checker.png", checker);
  AssetMaterial m;
  m.base_color = Eigen::Vector4f(0, 0, 0, 1);
  m.metallic = 0;
  m.emissive = Eigen::Vector3f::Ones();
  m.emissive_texture.image = 0;
  std::unique_ptr<RenderScene> scene;
  const auto r = RenderAssetFromFront(QuadAsset(m, {{.name = "checker.png", .file = dir / "checker.png"}}),
                                      std::nullopt, 16, 20, 1, &scene);
  const Image img = r->Mixed();
  for (int y = 5; y < 11; ++y)
    for (int x = 5; x < 11; ++x) EXPECT_NEAR(img.at(x, y, 1), 0.5, 0.05) << x << "," << y;
}

// A material both half metal and half transmissive: glTF's weights (metal
// m, transmission T (1 - m), diffuse base (1 - m)(1 - T)) give a diffuse
// albedo of a quarter of the base colour, the same per hit (pt, ic, vpl,
// vct) as per vertex (prt).
TEST(PathTracer, MetalAndTransmissionWeighAsGltfSays) {
  AssetMaterial m;
  m.base_color = Eigen::Vector4f(0.8f, 0.6f, 0.4f, 1);
  m.metallic = 0.5f;
  m.transmission = 0.5f;
  const Asset asset = QuadAsset(m);
  std::vector<int> triangle_material;
  const Mesh mesh = MergeParts(asset, &triangle_material);
  RenderScene scene;
  const uint32_t id = scene.AddVirtual(mesh, Eigen::Affine3d::Identity(), Material());
  scene.SetAssetMaterials(id, asset, triangle_material, mesh, "quad.glb");
  scene.Commit();
  Hit hit;
  hit.t = 1;
  hit.geometry_id = id;
  hit.primitive_id = 0;
  hit.uv = Eigen::Vector2f(0.3f, 0.3f);
  hit.geometric_normal = Eigen::Vector3f::UnitZ();
  Eigen::Vector3d diffuse;
  const Bsdf b = scene.AssetBsdfAt(hit, false, 0, &diffuse);
  EXPECT_TRUE(b.Transmits());
  EXPECT_LT((diffuse - 0.25 * Eigen::Vector3d(0.8, 0.6, 0.4)).norm(), 1e-6) << diffuse.transpose();
  for (const Eigen::Vector3f& a : AssetVertexAlbedo(asset, "quad.glb"))
    EXPECT_LT((a.cast<double>() - diffuse).norm(), 1e-6);
}

}  // namespace
}  // namespace mr

namespace mr {
namespace {

// An object resting on a surface touches it without crossing it, also where
// the surface's stored height is rougher (5e-7 m: an OBJ's 6 decimals) than
// the edges near the contact of a fine sphere (its pole's ring 1.5e-5 m
// above the pole); sunk by a millimetre it crosses.
TEST(RealCrossings, RestingIsNotCrossingSinkingIs) {
  for (const double sink : {0.0, 1e-3}) {
    RenderScene scene;
    Mesh floor = Quad(2.0, 5e-7);  // a hair above y = 0, where the pole rests
    scene.AddReal(floor, Material());
    const Mesh ball = UvSphere(0.05f, 128);
    Eigen::Affine3d t = Eigen::Affine3d::Identity();
    t.translation() = Eigen::Vector3d(0, 0.05 - sink, 0);  // the lower pole at y = -sink
    scene.AddVirtual(ball, t, Material());
    scene.Commit();
    if (sink == 0)
      EXPECT_EQ(scene.RealCrossings(0), 0);
    else
      EXPECT_GT(scene.RealCrossings(0), 0);
  }
}

}  // namespace
}  // namespace mr
