// The room's own albedo in every method (issue "real plates", section 2): a
// floor whose two halves differ in albedo (0.1 and 0.9), given as one mesh
// with vertex colours (albedo_from_vertex_colors, what mr-fuse writes), as
// one mesh with an albedo texture, and as two meshes with one albedo each.  Every method renders the
// two alike (the same random numbers meet the same albedos), and the
// object's shadow and bounce light on each half match pt's.
#include <gtest/gtest.h>

#include "core/error.h"
#include "core/file.h"
#include "core/image_metrics.h"
#include "render/gi_scenes.h"
#include "render/irradiance_cache.h"
#include "render/vct.h"
#include "render/vpl.h"
#include "test_util.h"

namespace mr {
namespace {

using namespace gi_test;

constexpr double kDark = 0.1, kBright = 0.9;

enum class Albedo { kMeshes, kVertexColours, kTexture };

// A 256x4 texture, the left half kDark and the right kBright, as an EXR.
fs::path SplitTexture(const fs::path& dir) {
  Image t = Image::Rgb(256, 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 256; ++x)
      for (int c = 0; c < 3; ++c) t.at(x, y, c) = static_cast<float>(x < 128 ? kDark : kBright);
  const fs::path p = dir / "split.exr";
  WriteImage(p, t);
  return p;
}

// The floor, x < 0 dark and x > 0 bright; a back wall; a virtual sphere on
// the seam; a sky with a sun.
void SplitFloor(RenderScene* s, Albedo how, const fs::path& texture = {}) {
  const Mesh dark = Quad({-2, 0, -2}, {0, 0, -2}, {0, 0, 2}, {-2, 0, 2});
  const Mesh bright = Quad({0, 0, -2}, {2, 0, -2}, {2, 0, 2}, {0, 0, 2});
  if (how == Albedo::kTexture) {
    Mesh floor = Quad({-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2});
    for (const auto& p : floor.positions) floor.uvs.emplace_back((p.x() + 2) / 4, (p.z() + 2) / 4);
    Material m = Diffuse(0.5);  // not used: the texture is
    m.albedo_texture = texture;
    s->AddReal(floor, m);
  } else if (how == Albedo::kVertexColours) {
    Mesh floor = dark;  // the seam's vertices twice, so that each half is uniform
    floor.colors.assign(dark.positions.size(), Eigen::Vector3f::Constant(kDark));
    const int n = static_cast<int>(floor.positions.size());
    for (const auto& p : bright.positions) floor.positions.push_back(p);
    floor.colors.resize(floor.positions.size(), Eigen::Vector3f::Constant(kBright));
    for (const auto& t : bright.triangles) floor.triangles.push_back(t + Eigen::Vector3i::Constant(n));
    floor.normals.clear();
    Material m = Diffuse(0.5);  // not used: the vertex colours are
    m.albedo_from_vertex_colors = true;
    s->AddReal(floor, m);
  } else {
    s->AddReal(dark, Diffuse(kDark));
    s->AddReal(bright, Diffuse(kBright));
  }
  s->AddReal(Quad({-2, 0, 1}, {2, 0, 1}, {2, 2, 1}, {-2, 2, 1}), Diffuse(0.7));
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.translate(Eigen::Vector3d(0, 0.3, 0));
  s->AddVirtual(UvSphere(0.3f, 24), t, Diffuse(0.8));
  s->SetEnvironment(Sky(1e3));
  s->Commit();
}

const Rigid3 kCamera = LookAt({0, 1.6, -2.0}, {0, 0.2, 0.2});
const CameraModel kCam = Pinhole(40, 30, 30);

// Which half of the floor each pixel's centre sees (-1 dark, +1 bright, 0
// neither or the object).
std::vector<int> Halves(const RenderScene& s) {
  std::vector<int> h(static_cast<size_t>(kCam.width() * kCam.height()), 0);
  for (int y = 0; y < kCam.height(); ++y)
    for (int x = 0; x < kCam.width(); ++x) {
      Eigen::Vector3d d;
      if (!kCam.Unproject({x, y}, &d)) continue;
      Ray r;
      r.origin = kCamera.translation.cast<float>();
      r.direction = (kCamera.rotation * d).normalized().cast<float>();
      Hit hit;
      if (!s.embree().Intersect(r, &hit) || hit.is_virtual) continue;
      const Eigen::Vector3f p = r.origin + hit.t * r.direction;
      if (std::abs(p.y()) > 1e-3f || std::abs(p.x()) < 0.02f) continue;  // the wall; the seam
      h[static_cast<size_t>(y * kCam.width() + x)] = p.x() < 0 ? -1 : 1;
    }
  return h;
}

struct Renders {
  std::unique_ptr<FrameMethod> pt, ic, vpl, vct;
  std::unique_ptr<IrradianceCache> cache;
};

Renders RenderAll(const RenderScene& s, int spp) {
  Renders r;
  PathTracerSettings ps;
  ps.max_depth = 5;
  r.pt = std::make_unique<PtFrameRenderer>(s, kCam, kCamera, ps);
  r.pt->RenderPass(spp);
  IcSettings is;
  is.rays = 128;
  r.cache = std::make_unique<IrradianceCache>(s, is);
  r.ic = std::make_unique<IcFrameRenderer>(s, r.cache.get(), kCam, kCamera, 0, 0);
  r.ic->RenderPass(8);
  VplSettings vs;
  vs.paths = 256;
  vs.directions = 128;
  r.vpl = std::make_unique<VplFrameRenderer>(s, VplSet::Build(s, vs), kCam, kCamera, 0, 0);
  r.vpl->RenderPass(8);
  VctSettings cs;
  cs.resolution = 32;
  cs.far_field_samples = 4;
  r.vct = std::make_unique<VctFrameRenderer>(s, VctVolumes::Build(s, cs), kCam, kCamera, 0, 0);
  r.vct->RenderPass(8);
  return r;
}

TEST(VertexAlbedo, EveryMethodUsesTheRoomsPerVertexAlbedo) {
  test::TempDir dir;
  RenderScene per_vertex, per_mesh, textured;
  SplitFloor(&per_vertex, Albedo::kVertexColours);
  SplitFloor(&per_mesh, Albedo::kMeshes);
  SplitFloor(&textured, Albedo::kTexture, SplitTexture(dir.path()));
  const Renders a = RenderAll(per_vertex, 64), b = RenderAll(per_mesh, 64), c = RenderAll(textured, 64);
  const std::vector<int> halves = Halves(per_mesh);
  int dark = 0, bright = 0;
  for (int h : halves) (h < 0 ? dark : bright) += h != 0;
  ASSERT_GT(dark, 100);
  ASSERT_GT(bright, 100);
  const std::pair<const char*, const FrameMethod*> methods[] = {
      {"pt", a.pt.get()}, {"ic", a.ic.get()}, {"vpl", a.vpl.get()}, {"vct", a.vct.get()}};
  const FrameMethod* same[] = {b.pt.get(), b.ic.get(), b.vpl.get(), b.vct.get()};
  const FrameMethod* tex[] = {c.pt.get(), c.ic.get(), c.vpl.get(), c.vct.get()};
  // 1. The vertex colours give what one albedo per half gives: the same
  // paths meet the same albedos, to rounding of the barycentric
  // interpolation (which can flip a rare Russian-roulette decision).
  for (size_t k = 0; k < 4; ++k) {
    SCOPED_TRACE(methods[k].first);
    EXPECT_LT(CompareImages(methods[k].second->Mixed(), same[k]->Mixed()).relmse, 1e-4);
    EXPECT_LT(CompareImages(methods[k].second->Real(), same[k]->Real()).relmse, 1e-4);
    // The texture: the same but within a texel of the seam (1.6 cm of a
    // 4 m floor, where bilinear filtering blends the halves), and for the
    // floor's triangulation differing (two quads against one; ic places its
    // records by it: measured 1.1e-3 for ic, below 1e-3 for the others).
    EXPECT_LT(CompareImages(tex[k]->Mixed(), same[k]->Mixed()).relmse, 2e-3);
    EXPECT_LT(CompareImages(tex[k]->Real(), same[k]->Real()).relmse, 2e-3);
  }
  // 2. The room reflects by its albedo: the bright half of I_r is about 9x
  // the dark half's (the same sky and sun; the wall's bounce adds to both).
  const Image real = a.pt->Real();
  double sum_dark = 0, sum_bright = 0;
  for (int y = 0; y < real.height(); ++y)
    for (int x = 0; x < real.width(); ++x) {
      const int h = halves[static_cast<size_t>(y * real.width() + x)];
      (h < 0 ? sum_dark : sum_bright) += h != 0 ? real.at(x, y, 1) : 0.0f;
    }
  const double ratio = (sum_bright / bright) / (sum_dark / dark);
  EXPECT_GT(ratio, 6.0);
  EXPECT_LT(ratio, 10.0);
  // 3. The object's shadow and bounce light on each half against pt's:
  // sums of I_m - I_r (green) over the pixels where a converged pt
  // (1024 spp) darkens (shadow) or brightens (bounce) the floor by more
  // than 0.05, off the object.
  PathTracerSettings ps;
  ps.max_depth = 5;
  ps.seed = 7;
  PtFrameRenderer converged(per_vertex, kCam, kCamera, ps);
  converged.RenderPass(1024);
  const Image truth = Difference(converged), mask = converged.Mask();
  auto sum = [&](const FrameMethod& r, int half, bool shadow) {
    const Image d = Difference(r);
    double total = 0;
    for (int y = 0; y < d.height(); ++y)
      for (int x = 0; x < d.width(); ++x) {
        const float t = truth.at(x, y, 1);
        if (halves[static_cast<size_t>(y * d.width() + x)] == half && mask.at(x, y, 0) == 0 &&
            (shadow ? t < -0.05f : t > 0.05f))
          total += d.at(x, y, 1);
      }
    return total;
  };
  // The sun's shadow falls on the dark half; the sunlit sphere's bounce
  // light on the bright half.  Tolerances as gi_test and vct_test bound
  // these methods on a uniform floor: 20% (vct 25%) for the shadow; the
  // bounce is a faint sum over a few pixels: pt's at 64 spp over five seeds
  // measured 0.74-1.21 (sd 0.19, 17% of its mean) and the reference's own at
  // 1024 spp 1.07-1.23, so it is held to 40% (two of those spreads).
  const double shadow_dark = sum(converged, -1, true), bounce_bright = sum(converged, 1, false);
  ASSERT_LT(shadow_dark, -1.0);
  ASSERT_GT(bounce_bright, 0.5);
  for (size_t k = 0; k < 4; ++k) {
    SCOPED_TRACE(methods[k].first);
    const double tol = k == 3 ? 0.25 : 0.2;
    const double s_dark = sum(*methods[k].second, -1, true), b_bright = sum(*methods[k].second, 1, false);
    RecordProperty(std::string(methods[k].first) + "_shadow_dark", std::to_string(s_dark));
    RecordProperty(std::string(methods[k].first) + "_bounce_bright", std::to_string(b_bright));
    EXPECT_NEAR(s_dark, shadow_dark, tol * std::abs(shadow_dark));
    // vpl and vct miss the sphere's bounce light near its contact with the
    // floor (measured -0.55 and -1.1 against pt's +1.28; the same with one
    // albedo per half, part 1, so not a vertex-albedo matter; see
    // docs/benchmarks.md, "Vertex albedo"); pt and ic are held to it.
    if (k < 2) {
      EXPECT_NEAR(b_bright, bounce_bright, 0.4 * bounce_bright);
    }
  }
}

// Bilinear between texel centres, repeating, v = 0 at the bottom row.
TEST(VertexAlbedo, TextureSampling) {
  Image t = Image::Rgb(2, 2);
  t.at(0, 1, 0) = 1;  // bottom left, red
  t.at(1, 0, 1) = 1;  // top right, green
  EXPECT_NEAR(RenderScene::SampleTexture(t, {0.25, 0.25})[0], 1.0, 1e-12);
  EXPECT_NEAR(RenderScene::SampleTexture(t, {0.75, 0.75})[1], 1.0, 1e-12);
  EXPECT_NEAR(RenderScene::SampleTexture(t, {0.5, 0.25})[0], 0.5, 1e-12);    // halfway along the bottom row
  EXPECT_NEAR(RenderScene::SampleTexture(t, {1.25, -0.75})[0], 1.0, 1e-12);  // repeats
  EXPECT_EQ(RenderScene::SampleTexture(t, {NAN, 0.5}), Eigen::Vector3d::Zero());
}

TEST(VertexAlbedo, MeshWithoutColoursIsRefused) {
  RenderScene s;
  Material m;
  m.albedo_from_vertex_colors = true;
  EXPECT_THROW(s.AddReal(Quad({-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}), m), Error);
  Material t;
  t.albedo_texture = "/nonexistent.exr";
  EXPECT_THROW(s.AddReal(Quad({-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}), t), Error);  // no uvs
}

// Vertex colours above 1 - specular (a fused albedo's noise) are clamped so
// that the surface cannot reflect more than it receives.
TEST(VertexAlbedo, ClampedToEnergyConservation) {
  RenderScene s;
  Mesh q = Quad({-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1});
  q.colors.assign(q.positions.size(), Eigen::Vector3f(1.5f, -0.2f, 0.5f));
  Material m;
  m.specular = Eigen::Vector3d::Constant(0.2);
  m.albedo_from_vertex_colors = true;
  const uint32_t id = s.AddReal(q, m);
  s.Commit();
  Hit hit;
  hit.geometry_id = id;
  hit.primitive_id = 0;
  hit.uv = {0.25f, 0.25f};
  const Eigen::Vector3d a = s.AlbedoAt(hit);
  EXPECT_NEAR(a[0], 0.8, 1e-12);
  EXPECT_EQ(a[1], 0.0);
  EXPECT_NEAR(a[2], 0.5, 1e-6);
}

}  // namespace
}  // namespace mr
