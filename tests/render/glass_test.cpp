// Glass (render/glass_bsdf.h) against Fresnel's equations and energy
// conservation, and through the path tracer: a slab's transmittance, total
// internal reflection, absorption, and an invisible ior-1 glass.
#include "render/glass_bsdf.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/math.h"
#include "core/sampling.h"
#include "core/spherical.h"
#include "geometry/asset.h"
#include "geometry/primitives.h"
#include "render/gi_scenes.h"
#include "render/pbr_bsdf.h"
#include "render/pt.h"
#include "render/render_scene.h"

namespace mr {
namespace {

Eigen::Vector3d Dir(double theta) { return {std::sin(theta), 0, std::cos(theta)}; }

// Reflected and transmitted energy of a lobe by its own sampling: the means
// of f |cos| / pdf over stratified samples, apart.
struct Split {
  double r = 0, t = 0;
};
Split Energy(const GlassBsdf& g, const Eigen::Vector3d& wo, int n = 256) {
  Split e;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      BsdfSample s;
      const double ul = std::fmod((i * n + j) * 0.6180339887498949, 1.0);
      if (!g.Sample(wo, ul, (i + 0.5) / n, (j + 0.5) / n, &s)) continue;
      const double w = s.f[1] * std::abs(s.wi.z()) / s.pdf / (n * n);
      (s.wi.z() > 0 ? e.r : e.t) += w;
    }
  return e;
}

// A smooth interface: the reflected share is Fresnel's reflectance
// (checked at normal incidence against ((n - 1) / (n + 1))^2 and at
// Brewster's angle, where the p-polarised part vanishes), and reflected
// plus transmitted energy (radiance transport: the transmitted radiance
// times eta^2) is 1, entering and leaving, at ior 1.5 and 2.4.
TEST(Glass, SmoothInterfaceFollowsFresnel) {
  for (double ior : {1.5, 2.4}) {
    const GlassBsdf enter(GlassParams{.alpha = 1e-4, .eta = ior});
    const Split n0 = Energy(enter, Dir(0));
    EXPECT_NEAR(n0.r, Square((ior - 1) / (ior + 1)), 2e-3) << ior;
    EXPECT_NEAR(n0.r + Square(ior) * n0.t, 1.0, 2e-3) << ior;
    const double brewster = std::atan(ior);
    const double ct = std::sqrt(1 - Square(std::sin(brewster) / ior));
    const double rs = Square((std::cos(brewster) - ior * ct) / (std::cos(brewster) + ior * ct));
    const Split b = Energy(enter, Dir(brewster));
    EXPECT_NEAR(b.r, rs / 2, 3e-3) << ior;
    const GlassBsdf leave(GlassParams{.alpha = 1e-4, .eta = 1 / ior});
    const Split l = Energy(leave, Dir(0.3));
    EXPECT_NEAR(l.r + l.t / Square(ior), 1.0, 3e-3) << ior;
  }
}

// Inside a glass beyond the critical angle (41.8 degrees at ior 1.5)
// everything is reflected: nothing transmits, and the reflection keeps all
// the energy.
TEST(Glass, TotalInternalReflection) {
  const GlassBsdf leave(GlassParams{.alpha = 1e-4, .eta = 1 / 1.5});
  const Split e = Energy(leave, Dir(60 * kPi / 180));
  EXPECT_EQ(e.t, 0);
  EXPECT_NEAR(e.r, 1.0, 2e-3);
  for (double th : {0.0, 0.5, 1.0, 2.0, 3.0})  // alpha 1e-4: D's tail that far out is < 1e-9
    EXPECT_LT(
        leave.Eval(Dir(60 * kPi / 180), Eigen::Vector3d(std::sin(th), 0, -std::cos(th) * 0.9).normalized()).maxCoeff(),
        1e-6);
}

// Rough glass: the sampled estimate of f |cos| agrees with a quadrature
// of Eval over the sphere (so Sample, Eval and Pdf agree), energy never
// exceeds 1, and a single-scattering lobe keeps what GGX's masking keeps:
// a thin sheet's reflected plus transmitted energy is the GGX directional
// albedo E(mu, alpha) (every microfacet reflects F and passes 1 - F;
// PbrTables: 0.82 at roughness 0.6, 0.32 at 1), a solid interface's more
// (0.98, 0.87: a refracted direction is rarely masked).  That loss is the
// open part: no multiple-scattering compensation for glass
// (docs/methods.md, "Glass").
TEST(Glass, RoughGlassConservesAndAgreesWithItsPdf) {
  const Eigen::Vector3d wo = Dir(0.4);
  for (double rough : {0.3, 0.6, 1.0})
    for (bool thin : {false, true}) {
      const GlassBsdf g(GlassParams{.alpha = rough * rough, .eta = 1.5, .thin = thin});
      const Split e = Energy(g, wo);
      const double scale = thin ? 1.0 : 2.25;  // radiance entering: x 1/eta^2
      const double total = e.r + scale * e.t;
      const double albedo = GetPbrTables().E(wo.z(), rough * rough);
      EXPECT_LE(total, 1.0 + 3e-3) << rough << " thin " << thin;
      if (thin)
        EXPECT_NEAR(total, albedo, 0.01) << rough;
      else  // refraction loses less than reflection (measured 0.98 at roughness 0.6, 0.87 at 1)
        EXPECT_GE(total, std::max(albedo, 0.85)) << rough;
      CompensatedSum<double> quad;
      const int n = 600;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          const double z = 1 - 2 * (i + 0.5) / n, phi = 2 * kPi * (j + 0.5) / n, r = std::sqrt(1 - z * z);
          const Eigen::Vector3d wi(r * std::cos(phi), r * std::sin(phi), z);
          quad += g.Eval(wo, wi)[1] * std::abs(z) * 4 * kPi / (Square(n));
        }
      EXPECT_NEAR(quad.Value(), e.r + e.t, 0.01) << rough << " thin " << thin;
    }
}

// An asset of one part: `mesh` with one transmissive material.
struct GlassAsset {
  Asset asset;
  Mesh mesh;
  std::vector<int> triangle_material;
};
GlassAsset MakeGlass(const Mesh& mesh, float ior, float thickness, float attenuation_distance = 0,
                     const Eigen::Vector3f& attenuation_color = Eigen::Vector3f::Ones()) {
  GlassAsset g;
  g.asset.parts.push_back({.name = "glass", .mesh = mesh, .material = 0});
  AssetMaterial m = gi_test::GlassMaterial(ior, thickness);
  m.attenuation_distance = attenuation_distance;
  m.attenuation_color = attenuation_color;
  g.asset.materials.push_back(m);
  g.mesh = MergeParts(g.asset, &g.triangle_material);
  return g;
}

// A sky of radiance 1 in the +z half, 0 in the -z half.
EnvironmentMap HalfSky() {
  Image img = Image::Rgb(256, 128);
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 256; ++x) {
      const double z = LatLongPixelToDirection(Eigen::Vector2d(x, y), 256, 128).z();
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = z > 0 ? 1.0f : 0.0f;
    }
  return EnvironmentMap(img, "half sky");
}

// pt's image of `g` from z = -3 looking along +z before `env` (16 x 16
// pixels of focal length f, every path to `depth` bounces, no roulette).
Image RenderGlass(const GlassAsset& g, EnvironmentMap env, double f, int depth, int spp) {
  RenderScene scene;
  const uint32_t id = scene.AddVirtual(g.mesh, Eigen::Affine3d::Identity(), Material());
  scene.SetAssetMaterials(id, g.asset, g.triangle_material, g.mesh, "glass.glb");
  scene.SetEnvironment(std::move(env));
  scene.Commit();
  PathTracerSettings st;
  st.max_depth = depth;
  st.rr_depth = depth;
  Rigid3 world_from_cam;
  world_from_cam.translation = Eigen::Vector3d(0, 0, -3);
  PtFrameRenderer r(scene, CameraModel("LENSMODEL_PINHOLE", {f, f, 7.5, 7.5}, 16, 16), world_from_cam, st);
  r.RenderPass(spp);
  EXPECT_EQ(r.nonfinite_samples(), 0);
  return r.Mixed();
}

// The mean of the central 4 x 4 pixels looking through `mesh` at a half
// sky, the camera's rays within a degree of +z.
double ThroughGlass(const GlassAsset& g) {
  const Image img = RenderGlass(g, HalfSky(), 400, 64, 64);
  double sum = 0;
  for (int y = 6; y < 10; ++y)
    for (int x = 6; x < 10; ++x) sum += img.at(x, y, 1);
  return sum / 16;
}

// A smooth slab 0.2 m thick at normal incidence: the sky behind it comes
// through (1 - R)^2 / (1 - R^2) = 0.9231 at ior 1.5 (R = 0.04, every
// internal reflection summed; the camera side is black), and with
// absorption (attenuation colour 0.5 at 0.2 m: e^(-sigma d) = 0.5)
// (1 - R)^2 a / (1 - R^2 a^2) = 0.4604.  Within 1 % (the rays spread over
// +-1 degree and the lobe's alpha is 1e-4).
TEST(Glass, SlabTransmitsWhatFresnelAndBeerLambertLeave) {
  const Mesh slab = Box(Eigen::Vector3f(-2, -2, -0.1f), Eigen::Vector3f(2, 2, 0.1f));
  EXPECT_NEAR(ThroughGlass(MakeGlass(slab, 1.5f, 0.2f)), 0.9231, 0.01);
  EXPECT_NEAR(ThroughGlass(MakeGlass(slab, 1.5f, 0.2f, 0.2f, Eigen::Vector3f::Constant(0.5f))), 0.4604, 0.01);
  // Thin-walled (no volume): each of the box's faces a sheet, nothing
  // bends: the same two interfaces.
  EXPECT_NEAR(ThroughGlass(MakeGlass(slab, 1.5f, 0.0f)), 0.9231, 0.01);
  // One thin sheet: 1 - R = 0.96.
  const Mesh sheet =
      Quad(Eigen::Vector3f(-2, -2, 0), Eigen::Vector3f(2, -2, 0), Eigen::Vector3f(2, 2, 0), Eigen::Vector3f(-2, 2, 0));
  EXPECT_NEAR(ThroughGlass(MakeGlass(sheet, 1.5f, 0.0f)), 0.96, 0.01);
}

// ior 1: an invisible glass sphere (no reflection, no bending) shows the sky
// behind it exactly.
TEST(Glass, IorOneIsInvisible) {
  Mesh sphere = UvSphere(0.5f, 48);
  for (const Eigen::Vector3f& p : sphere.positions) sphere.normals.push_back(p.normalized());
  EXPECT_NEAR(ThroughGlass(MakeGlass(sphere, 1.0f, 1.0f)), 1.0, 1e-3);
}

// A smooth glass sphere at ior 1.5 in a uniform sky of radiance 1 shows
// the sky, radiance 1 everywhere: energy is conserved through every
// bounce, total internal reflections inside included, and the radiance
// scaling entering (1/eta^2) and leaving (eta^2) cancels.  Within 2 %
// (16 samples; the shading normals' guard loses a little at the rim).
TEST(Glass, GlassSphereInAWhiteSkyIsInvisible) {
  Mesh sphere = UvSphere(0.5f, 64);
  for (const Eigen::Vector3f& p : sphere.positions) sphere.normals.push_back(p.normalized());
  const Image img =
      RenderGlass(MakeGlass(sphere, 1.5f, 1.0f), EnvironmentMap::Constant(Eigen::Vector3d::Ones()), 40, 256, 16);
  for (int y = 3; y < 13; ++y)
    for (int x = 3; x < 13; ++x) EXPECT_NEAR(img.at(x, y, 1), 1.0, 0.02) << x << "," << y;
}

}  // namespace
}  // namespace mr
