// Lights of lights.json in the path tracer: point, spot and distant lights
// against closed forms, MIS with a wide disc, and virtual lights lighting
// I_m only.
#include <gtest/gtest.h>

#include "core/error.h"
#include "core/math.h"
#include "core/sampling.h"
#include "core/spherical.h"
#include "geometry/primitives.h"
#include "light/lights_file.h"
#include "render/path_tracer.h"
#include "render/prt.h"
#include "render/pt.h"
#include "render/render_scene.h"
#include "transfer/formfactor.h"

namespace mr {
namespace {

Mesh Plane(double half) {
  Mesh m;
  const float h = static_cast<float>(half);
  m.positions = {{-h, 0, -h}, {h, 0, -h}, {h, 0, h}, {-h, 0, h}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}};
  return m;
}

// A camera 1 m above the origin looking straight down, with a field of view
// of about 0.1 degree: every pixel sees the plane within 1 mm of the origin.
Rigid3 LookDown() {
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  return Rigid3(Eigen::Quaterniond(R), Eigen::Vector3d(0, 1, 0));
}
CameraModel Narrow() { return CameraModel("LENSMODEL_PINHOLE", {4000, 4000, 1.5, 1.5}, 4, 4); }

double Mean(const Image& img, int c) {
  double s = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) s += img.at(x, y, c);
  return s / static_cast<double>(img.pixel_count());
}

// Radiance of the plane (albedo 0.5, direct light only) lit by `lights`.
Image RenderPlane(const std::vector<Light>& lights, int spp, Image* real = nullptr, int max_depth = 1) {
  RenderScene scene;
  Material m;
  m.albedo = Eigen::Vector3d::Constant(0.5);
  scene.AddReal(Plane(100), m);
  for (const Light& l : lights) scene.AddLight(l);
  scene.Commit();
  PathTracerSettings st;
  st.max_depth = max_depth;
  PtFrameRenderer r(scene, Narrow(), LookDown(), st);
  r.RenderPass(spp);
  EXPECT_EQ(r.nonfinite_samples(), 0);
  if (real) *real = r.Real();
  return r.Mixed();
}

// L = albedo / pi * I cos(theta) / d^2 at the origin.  The footprint spans
// 1 mm, so the closed form holds to ~1e-6; the estimate has no noise (a delta
// light, and the plane sees nothing else), so the tolerance is float rounding.
TEST(Lights, PointLightMatchesInverseSquareLaw) {
  Light l;
  l.type = LightType::kPoint;
  l.position = Eigen::Vector3d(1.5, 2.0, 0);
  l.intensity = Eigen::Vector3d(100, 50, 1e6);  // a dynamic range of 1e6 between channels
  const double d2 = l.position.squaredNorm(), cos_t = 2.0 / std::sqrt(d2);
  Image img = RenderPlane({l}, 2);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(Mean(img, c), 0.5 / kPi * l.intensity[c] * cos_t / d2, 1e-4 * Mean(img, c));
}

TEST(Lights, SpotLightConeAndSmoothFalloff) {
  Light l;
  l.type = LightType::kSpot;
  l.intensity = Eigen::Vector3d::Constant(10);
  l.position = Eigen::Vector3d(0, 2, 0);
  l.cone_deg = 30;
  l.falloff_start_deg = 20;
  const double full = 0.5 / kPi * 10 / 4;  // straight below: full intensity
  auto at_angle = [&](double deg) {        // the spot's axis tilted `deg` away from the origin
    l.direction = Eigen::Vector3d(std::sin(deg * kDegToRad), -std::cos(deg * kDegToRad), 0);
    return Mean(RenderPlane({l}, 1), 1);
  };
  EXPECT_NEAR(at_angle(0), full, 1e-4 * full);
  EXPECT_NEAR(at_angle(19), full, 1e-4 * full);
  EXPECT_EQ(at_angle(31), 0.0);
  const double c = std::cos(25 * kDegToRad), c0 = std::cos(30 * kDegToRad), c1 = std::cos(20 * kDegToRad);
  const double x = (c - c0) / (c1 - c0);
  EXPECT_NEAR(at_angle(25), full * x * x * (3 - 2 * x), 1e-3 * full);
}

TEST(Lights, DirectionalLightGivesIrradianceTimesCosine) {
  Light l;
  l.type = LightType::kDistant;
  l.direction = Eigen::Vector3d(std::sin(0.6), std::cos(0.6), 0);
  l.irradiance = Eigen::Vector3d(3, 2, 1);
  Image img = RenderPlane({l}, 1);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(Mean(img, c), 0.5 / kPi * l.irradiance[c] * std::cos(0.6), 1e-5);
}

// A uniform disc wholly above the horizon gives E cos(tilt) exactly (the
// cosine integrates linearly over the cap).  With a 60-degree disc both
// light sampling and BSDF sampling carry much of the MIS weight, so a wrong
// weight or pdf on either side would bias the result.  Tolerance: 5 standard
// errors of the mean over 16 pixels x 256 samples (measured spread).
TEST(Lights, WideDiscLightWithMisMatchesTheClosedForm) {
  Light l;
  l.type = LightType::kDistant;
  const double tilt = 20 * kDegToRad;
  l.direction = Eigen::Vector3d(std::sin(tilt), std::cos(tilt), 0);
  l.irradiance = Eigen::Vector3d::Constant(2);
  l.angular_radius_deg = 60;
  Image img = RenderPlane({l}, 256, nullptr, 2);
  const double expected = 0.5 / kPi * 2 * std::cos(tilt);
  double sq = 0;
  const double mean = Mean(img, 0);
  for (float v : img.values()) sq += (v - mean) * (v - mean);
  const double se = std::sqrt(sq / 3 / (img.values().size() - 1) / 16);
  EXPECT_NEAR(mean, expected, std::max(5 * se, 1e-6 * expected)) << "standard error " << se;
  EXPECT_LT(se, 0.01 * expected);
}

// The sun: 0.27 degrees, 1e5 W/m^2.  Narrow cones are where 1 - cos loses
// its digits; the result must still be E cos.
TEST(Lights, SunSizedDiscIsStable) {
  Light l;
  l.type = LightType::kDistant;
  l.direction = Eigen::Vector3d(0, 1, 0);
  l.irradiance = Eigen::Vector3d::Constant(1e5);
  l.angular_radius_deg = 0.27;
  Image img = RenderPlane({l}, 16);
  EXPECT_NEAR(Mean(img, 0), 0.5 / kPi * 1e5, 1e-3 * 0.5 / kPi * 1e5);
}

// Irradiance at a point from a Lambertian rectangle parallel to its
// surface, one corner straight above it at height h, sides x and y: pi L F
// with F the point-to-rectangle form factor (Howell's catalogue, B-3).
double RectCornerIrradiance(double L, double x, double y, double h) {
  const double a = x / h, b = y / h;
  const double A = std::sqrt(1 + a * a), B = std::sqrt(1 + b * b);
  return 0.5 * L * (a / A * std::atan(b / A) + b / B * std::atan(a / B));
}

// Area lights (lights.json "area") against their closed forms: a lamp panel
// 0.8 x 0.5 m 1.2 m above the point, centred (four corner rectangles), and
// a disc of radius 0.4 m 1 m above it, pi L R^2 / (h^2 + R^2); direct light
// only, sampled by next-event estimation alone (area lights are not
// geometry).  A panel turned away lights nothing.  Tolerance: 5 standard
// errors over 16 pixels x 256 samples.
TEST(Lights, AreaLightsMatchTheClosedForms) {
  Light rect;
  rect.type = LightType::kArea;
  rect.position = Eigen::Vector3d(0, 1.2, 0);
  rect.direction = Eigen::Vector3d(0, -1, 0);
  rect.axis = Eigen::Vector3d(1, 0, 0);
  rect.width = 0.8;
  rect.height = 0.5;
  rect.radiance = Eigen::Vector3d(10, 5, 1e4);
  Light disc = rect;
  disc.shape = AreaShape::kDisc;
  disc.position = Eigen::Vector3d(0, 1.0, 0);
  disc.width = disc.height = 0.8;
  const double e_rect = 4 * RectCornerIrradiance(1, 0.4, 0.25, 1.2);
  const double e_disc = kPi * 0.16 / (1 + 0.16);
  for (const auto& [l, e] : {std::pair{rect, e_rect}, std::pair{disc, e_disc}}) {
    const Image img = RenderPlane({l}, 256);
    for (int c = 0; c < 3; ++c) {
      const double expected = 0.5 / kPi * l.radiance[c] * e, mean = Mean(img, c);
      double sq = 0;
      for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x) sq += Square(img.at(x, y, c) - mean);
      const double se = std::sqrt(sq / 15 / 16);
      EXPECT_NEAR(mean, expected, std::max(5 * se, 1e-6 * expected))
          << (l.shape == AreaShape::kRect ? "rect" : "disc") << " channel " << c << ", standard error " << se;
    }
  }
  rect.direction = Eigen::Vector3d(0, 1, 0);  // facing away
  EXPECT_EQ(Mean(RenderPlane({rect}, 4), 0), 0.0);
}

// prt's lights: what AddLightsSeenFrom adds to a map integrates, over the
// sphere, to each light's irradiance integral at the centre, in closed
// form: a distant light's E, a point light's I / d^2, and a rectangle's L x
// its solid angle seen on its axis, 4 asin(ab / sqrt((a^2+d^2)(b^2+d^2)))
// (a, b half sides).  16 x 16 strata over a rectangle 60 degrees across: the
// midpoint rule's error is below 1e-3.  The map's scale divides what is
// added (the projection multiplies it back).
TEST(Lights, PrtTakesEachLightsPowerIntoTheMap) {
  Light sun;
  sun.type = LightType::kDistant;
  sun.direction = Eigen::Vector3d(0.3, 1, 0.2).normalized();
  sun.irradiance = Eigen::Vector3d(5, 3, 1e5);
  Light point;
  point.position = Eigen::Vector3d(1, 2, -1);
  point.intensity = Eigen::Vector3d(2, 2, 2);
  Light rect;
  rect.type = LightType::kArea;
  rect.position = Eigen::Vector3d(0, 1, 0);
  rect.direction = Eigen::Vector3d(0, -1, 0);
  rect.width = 1.2;
  rect.height = 0.6;
  rect.radiance = Eigen::Vector3d(1, 1, 1);
  const double omega_rect = 4 * std::asin(0.6 * 0.3 / std::sqrt((0.36 + 1) * (0.09 + 1)));
  const double scale = 2.5;
  for (const auto& [l, e] :
       {std::pair{sun, sun.irradiance.z()}, std::pair{point, 2.0 / 6}, std::pair{rect, omega_rect}}) {
    const Image env(64, 32, {"R", "G", "B"}, 0.25f);
    const Image lit =
        AddLightsSeenFrom(env, {LightSource(l)}, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity(), scale);
    double added = 0;
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 64; ++x) added += (lit.at(x, y, 2) - env.at(x, y, 2)) * LatLongPixelSolidAngle(x, y, 64, 32);
    EXPECT_NEAR(added * scale, e, 1e-3 * e) << static_cast<int>(l.type);
  }
  // The map's orientation: the sun lands where world_from_env says.
  Eigen::Matrix3d flip = Eigen::Matrix3d::Identity();
  flip(1, 1) = flip(2, 2) = -1;  // env y = world -y
  const Image lit =
      AddLightsSeenFrom(Image(64, 32, {"R", "G", "B"}), {LightSource(sun)}, Eigen::Vector3d::Zero(), flip, 1);
  const Eigen::Vector2d at = DirectionToLatLongPixel(flip.transpose() * sun.direction, 64, 32);
  EXPECT_GT(lit.at(static_cast<int>(std::lround(at.x())), static_cast<int>(std::lround(at.y())), 0), 0);
}

// ...and shaded through a transfer: a unit sphere under a distant light
// straight above (E = pi, nothing else) has L = albedo E cos / pi at its top
// (0.5) and nothing at its bottom.  The cube basis spreads the light over a
// cell 11 degrees across: 2 % at the top.
TEST(Lights, PrtShadesASphereByALightsFile) {
  const Mesh sphere = UvSphere(1.0f, 24);
  TransferStats ts;
  const VertexTransfer t = ComputeTransfer(sphere, TransferOptions{}, &ts);
  Light sun;
  sun.type = LightType::kDistant;
  sun.direction = Eigen::Vector3d::UnitY();
  sun.irradiance = Eigen::Vector3d::Constant(kPi);
  const Image lit = AddLightsSeenFrom(Image(256, 128, {"R", "G", "B"}), {LightSource(sun)}, Eigen::Vector3d::Zero(),
                                      Eigen::Matrix3d::Identity(), 1);
  const EnvironmentCoefficients ec = ProjectEnvironment(lit, "lit", t.header, Eigen::Matrix3d::Identity());
  int64_t clamped = 0;
  const std::vector<Eigen::Vector3d> L = ShadeVertices(t, ec, Eigen::Vector3d::Constant(0.5), &clamped);
  size_t top = 0, bottom = 0;
  for (size_t i = 0; i < sphere.positions.size(); ++i) {
    if (sphere.positions[i].y() > sphere.positions[top].y()) top = i;
    if (sphere.positions[i].y() < sphere.positions[bottom].y()) bottom = i;
  }
  EXPECT_NEAR(L[top].x(), 0.5, 0.01);
  EXPECT_NEAR(L[bottom].x(), 0.0, 1e-6);
}

// A near-mirror under a lamp panel: the panel's light reaches the camera
// through a lobe 3 degrees wide, which next-event estimation's uniform
// points on the panel rarely hit; with the BSDF-sampled rays counting the
// panel too (MIS, PathTracerSettings::mis_area_lights) the estimate is the
// same (within 5 standard errors of the difference) and its per-pixel
// variance at least 20 times lower (measured: 13.7 with variance 6.1e3
// against 9.03 with 0.069: 1/90000).
TEST(Lights, AGlossyPlaneSeesAnAreaLightThroughItsLobe) {
  Light panel;
  panel.type = LightType::kArea;
  panel.position = Eigen::Vector3d(0, 1.2, 0);
  panel.direction = Eigen::Vector3d(0, -1, 0);
  panel.width = 0.8;
  panel.height = 0.5;
  panel.radiance = Eigen::Vector3d::Constant(10);
  auto render = [&](bool mis, bool virtual_plane, double* mean, double* var) {
    RenderScene scene;
    Material m;
    m.albedo.setZero();
    m.specular = Eigen::Vector3d::Constant(0.9);
    m.roughness = 0.05;
    if (virtual_plane)
      scene.AddVirtual(Plane(100), Eigen::Affine3d::Identity(), m);
    else
      scene.AddReal(Plane(100), m);
    scene.AddLight(panel);
    scene.Commit();
    PathTracerSettings st;
    st.max_depth = 1;
    st.mis_area_lights = mis;
    double s = 0, sq = 0;
    const int passes = 64;
    for (int k = 0; k < passes; ++k) {  // one sample per pixel per pass: the pixels' spread is a sample's
      PtFrameRenderer one(scene, Narrow(), LookDown(), [&] {
        PathTracerSettings t = st;
        t.seed = k;
        return t;
      }());
      one.RenderPass(1);
      const double x = Mean(one.Mixed(), 1);
      s += x;
      sq += x * x;
    }
    *mean = s / passes;
    *var = std::max(0.0, sq / passes - *mean * *mean);
  };
  double m_nee = 0, v_nee = 0, m_mis = 0, v_mis = 0, m_virtual = 0, v_virtual = 0;
  render(false, false, &m_nee, &v_nee);
  render(true, false, &m_mis, &v_mis);
  // A virtual near-mirror (the mixed path's own loop) the same.
  render(true, true, &m_virtual, &v_virtual);
  std::printf("virtual: %.4f (variance %.3g)\n", m_virtual, v_virtual);
  EXPECT_NEAR(m_virtual, m_mis, 5 * std::sqrt((v_virtual + v_mis) / 64));
  std::printf("near-mirror under a panel: next-event only %.4f (variance %.3g), with MIS %.4f (variance %.3g)\n", m_nee,
              v_nee, m_mis, v_mis);
  EXPECT_NEAR(m_mis, m_nee, 5 * std::sqrt((v_nee + v_mis) / 64));
  EXPECT_LT(v_mis * 20, v_nee);
  EXPECT_GT(m_mis, 5.0);  // most of 0.9 x 10 reaches the camera
}

// Beyond 16 area lights the lights a ray meets are found through a BVH of
// their shapes; it finds what testing each light finds: the same light, at
// the same distance, with the same radiance, for 20,000 random rays among
// 300 rects and discs facing every way, some virtual (back sides, disc
// rims and lights behind lights included; 1236 of the rays meet one).
TEST(Lights, AreaLightBvhFindsWhatTestingEachFinds) {
  RenderScene scanned, indexed;
  Pcg32 rng(5, 9);
  auto u = [&] { return rng.NextDouble(); };
  for (int i = 0; i < 300; ++i) {
    Light l;
    l.type = LightType::kArea;
    l.shape = i % 3 == 0 ? AreaShape::kDisc : AreaShape::kRect;
    l.is_virtual = i % 5 == 0;
    l.position = Eigen::Vector3d(4 * u() - 2, 4 * u() - 2, 4 * u() - 2);
    const auto d = SampleUniformSphere(u(), u());
    l.direction = Eigen::Vector3d(d[0], d[1], d[2]);
    l.axis = Eigen::Vector3d(u() - 0.5, u() - 0.5, u() - 0.5);
    l.width = 0.05 + 0.5 * u();
    l.height = 0.05 + 0.5 * u();
    l.radiance = Eigen::Vector3d(1 + i, 2, 3);
    scanned.AddLight(l);
    indexed.AddLight(l);
  }
  indexed.Commit();  // builds the BVH; `scanned` is never committed: each light tested
  int met = 0;
  for (int k = 0; k < 20000; ++k) {
    const Eigen::Vector3d o(6 * u() - 3, 6 * u() - 3, 6 * u() - 3);
    const auto d = SampleUniformSphere(u(), u());
    const Eigen::Vector3d dir(d[0], d[1], d[2]);
    const unsigned which = 1 + k % 3;
    double ta = -1, tb = -1;
    Eigen::Vector3d la = Eigen::Vector3d::Zero(), lb = la;
    const size_t a = scanned.NearestAreaLight(o, dir, 5.0, which, &ta, &la);
    const size_t b = indexed.NearestAreaLight(o, dir, 5.0, which, &tb, &lb);
    ASSERT_EQ(a, b) << "ray " << k;
    if (a < 300) {
      EXPECT_EQ(ta, tb);
      EXPECT_EQ(la, lb);
      ++met;
    }
  }
  EXPECT_GT(met, 1000);  // measured 1236
}

// Seen directly (a camera ray, which next-event estimation never
// samples), an area light is its radiance exactly, and nothing from behind.
TEST(Lights, AreaLightSeenDirectlyIsItsRadiance) {
  Light panel;
  panel.type = LightType::kArea;
  panel.position = Eigen::Vector3d(0, 2, 0);
  panel.direction = Eigen::Vector3d(0, -1, 0);
  panel.width = panel.height = 1;
  panel.radiance = Eigen::Vector3d(3, 2, 1e5);
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, 1, 0, -1, 0;  // looking up: camera z along world +y
  const Rigid3 look_up(Eigen::Quaterniond(R), Eigen::Vector3d(0, 0.5, 0));
  for (const bool facing : {true, false}) {
    RenderScene scene;
    scene.AddReal(Plane(0.01), Material());  // below the camera, out of view
    if (!facing) panel.direction = -panel.direction;
    scene.AddLight(panel);
    scene.Commit();
    PtFrameRenderer r(scene, Narrow(), look_up, PathTracerSettings());
    r.RenderPass(2);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(Mean(r.Mixed(), c), facing ? panel.radiance[c] : 0.0, 1e-6 * panel.radiance[c]);
  }
}

TEST(Lights, VirtualLightLightsMixedOnly) {
  Light sun;
  sun.type = LightType::kDistant;
  sun.irradiance = Eigen::Vector3d::Constant(1);
  Light lamp;
  lamp.type = LightType::kPoint;
  lamp.position = Eigen::Vector3d(0, 1, 0);
  lamp.intensity = Eigen::Vector3d::Constant(5);
  lamp.is_virtual = true;
  Image real;
  Image mixed = RenderPlane({sun, lamp}, 2, &real, 4);
  Image alone = RenderPlane({sun}, 2, nullptr, 4);
  EXPECT_EQ(real.values(), alone.values());  // I_r: the lamp does not exist
  EXPECT_NEAR(Mean(mixed, 0) - Mean(real, 0), 0.5 / kPi * 5, 1e-4);
}

TEST(LightsFile, RoundTripsAndRejectsBadInput) {
  Light spot;
  spot.name = "lamp";
  spot.type = LightType::kSpot;
  spot.position = Eigen::Vector3d(1, 2, 3);
  spot.direction = Eigen::Vector3d(0, -1, 0);
  spot.intensity = Eigen::Vector3d(1, 2, 3);
  spot.is_virtual = true;
  Light sun;
  sun.name = "sun";
  sun.type = LightType::kDistant;
  sun.irradiance = Eigen::Vector3d(1e5, 9e4, 8e4);
  sun.angular_radius_deg = 0.27;
  auto back = ParseLights(LightsToJson({spot, sun}, "test"), "lights.json");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].type, LightType::kSpot);
  EXPECT_TRUE(back[0].is_virtual);
  EXPECT_EQ(back[0].position, spot.position);
  EXPECT_EQ(back[1].irradiance, sun.irradiance);
  EXPECT_EQ(back[1].angular_radius_deg, 0.27);
  Light panel;
  panel.name = "panel";
  panel.type = LightType::kArea;
  panel.position = Eigen::Vector3d(0, 2.4, 1);
  panel.direction = Eigen::Vector3d(0, -1, 0);
  panel.axis = Eigen::Vector3d(0, 0, 1);
  panel.width = 1.2;
  panel.height = 0.6;
  panel.radiance = Eigen::Vector3d(30, 30, 25);
  panel.strength_note = "clipped";
  Light bulb = panel;
  bulb.name = "bulb";
  bulb.shape = AreaShape::kDisc;
  bulb.width = bulb.height = 0.1;
  back = ParseLights(LightsToJson({panel, bulb}), "lights.json");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].type, LightType::kArea);
  EXPECT_EQ(back[0].shape, AreaShape::kRect);
  EXPECT_EQ(back[0].axis, panel.axis);
  EXPECT_EQ(back[0].width * back[0].height, panel.width * panel.height);
  EXPECT_EQ(back[0].radiance, panel.radiance);
  EXPECT_EQ(back[0].strength_note, "clipped");
  EXPECT_EQ(back[1].shape, AreaShape::kDisc);
  EXPECT_EQ(back[1].width, 0.1);

  auto fails_with = [](const char* text, const char* message) {
    try {
      ParseLights(ParseJsonStrict(text, "lights.json"), "lights.json");
      ADD_FAILURE() << "accepted " << text;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  };
  fails_with(R"({"version":1,"lights":[{"type":"point","position":[0,0,0],"intensity":[1,1,1],"colour":1}]})",
             "lights[0].colour: unknown key");
  fails_with(R"({"version":1,"lights":[{"type":"lamp"}]})", "lights[0].type");
  fails_with(R"({"version":1,"lights":[{"type":"area","position":[0,1,0],"direction":[0,-1,0],"radiance":[1,1,1]}]})",
             "lights[0].width");
  fails_with(
      R"({"version":1,"lights":[{"type":"area","position":[0,1,0],"direction":[0,-1,0],"radiance":[1,1,1],"width":1,"height":1,"axis":[0,2,0]}]})",
      "must not be parallel");
  fails_with(
      R"({"version":1,"lights":[{"type":"area","shape":"disc","position":[0,1,0],"direction":[0,-1,0],"radiance":[1,1,1],"radius":0}]})",
      "lights[0].radius");
  fails_with(R"({"version":1,"lights":[{"type":"distant","direction":[0,0,0],"irradiance":[1,1,1]}]})", "non-zero");
  fails_with(
      R"({"version":1,"lights":[{"type":"spot","position":[0,0,0],"intensity":[1,1,1],"direction":[0,-1,0],"cone_deg":10,"falloff_start_deg":20}]})",
      "must not exceed cone_deg");
  fails_with(R"({"version":1,"lights":[{"type":"point","position":[0,0,0],"intensity":[-1,1,1]}]})",
             "lights[0].intensity");
  fails_with(R"({"version":2,"lights":[]})", "version");
}

// A light's samples with their point-free part computed ahead in lanes
// (LightSource::SampleAhead, as a batch of pt's paths takes them) give the
// bits of Sample computing it, for a rectangle, a disc (its centre and the
// diagonals of the concentric map among the numbers), a sun of 0.27
// degrees and a wide disc light of 30; a point light takes none.
TEST(Lights, SamplesAheadInLanesGiveTheScalarBits) {
  Light rect;
  rect.type = LightType::kArea;
  rect.position = Eigen::Vector3d(0.3, 2, -0.1);
  rect.direction = Eigen::Vector3d(0.1, -1, 0.2).normalized();
  rect.axis = Eigen::Vector3d(1, 0, 0);
  rect.width = 0.7;
  rect.height = 0.2;
  rect.radiance = Eigen::Vector3d(5, 4, 3);
  Light disc = rect;
  disc.shape = AreaShape::kDisc;
  Light sun;
  sun.type = LightType::kDistant;
  sun.direction = Eigen::Vector3d(0.2, 0.9, -0.4).normalized();
  sun.angular_radius_deg = 0.27;
  sun.irradiance = Eigen::Vector3d::Constant(1e5);
  Light wide = sun;
  wide.angular_radius_deg = 30;
  Light point;
  point.type = LightType::kPoint;
  point.position = Eigen::Vector3d(0, 1, 0);
  EXPECT_FALSE(LightSource(point).TakesAhead());
  Pcg32 rng(5);
  const size_t n = 1000;
  std::vector<double> u0(n), u1(n), x(n), y(n), z(n);
  for (size_t k = 0; k < n; ++k) {
    u0[k] = rng.NextDouble();
    u1[k] = k % 9 == 0 ? u0[k] : k % 13 == 0 ? 1 - u0[k] : rng.NextDouble();  // the map's diagonals
  }
  u0[0] = u1[0] = 0.5;  // the disc's centre
  u0[1] = u1[1] = 0;
  u0[2] = u1[2] = 0x1.fffffffffffffp-1;
  const Eigen::Vector3d p(0.1, 0, 0.2);
  for (const Light& l : {rect, disc, sun, wide}) {
    const LightSource s(l);
    ASSERT_TRUE(s.TakesAhead());
    s.SampleAhead(n, u0.data(), u1.data(), x.data(), y.data(), z.data());
    int sampled = 0;
    for (size_t k = 0; k < n; ++k) {
      LightSample a, b;
      const Eigen::Vector3d ahead(x[k], y[k], z[k]);
      const bool got = s.Sample(p, u0[k], u1[k], &a);
      ASSERT_EQ(s.Sample(p, u0[k], u1[k], &b, &ahead), got) << k;
      if (!got) continue;
      ++sampled;
      ASSERT_EQ(a.wi, b.wi) << k;
      ASSERT_EQ(a.distance, b.distance) << k;
      ASSERT_EQ(a.pdf, b.pdf) << k;
      ASSERT_EQ(a.li, b.li) << k;
      ASSERT_NEAR(a.wi.norm(), 1.0, 1e-15) << k;
      if (l.type == LightType::kDistant)  // inside the disc
        ASSERT_GE(a.wi.dot(l.direction), std::cos(l.angular_radius_deg * kDegToRad) - 1e-15) << k;
    }
    EXPECT_EQ(sampled, static_cast<int>(n));  // every sample sends light to p
  }
}

}  // namespace
}  // namespace mr
