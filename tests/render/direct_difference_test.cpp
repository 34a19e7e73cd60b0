// The shared differential direct light (render/path_common.h,
// EnvironmentDifference through DirectDiffuse): the difference a virtual
// sphere makes to a real floor point's environment light, against a fine
// quadrature of the same integral over the sphere's cone of directions.
#include <gtest/gtest.h>

#include <cmath>

#include "core/math.h"
#include "geometry/primitives.h"
#include "render/path_common.h"
#include "render/render_scene.h"

namespace mr {
namespace {

constexpr double kAlbedo = 0.6;

Eigen::Vector3d SampleUniformSphereVector(Sampler& rng) {
  const auto [u0, u1] = rng.Next2D();
  const auto d = SampleUniformSphere(u0, u1);
  return {d[0], d[1], d[2]};
}

Material Diffuse(double a) {
  Material m;
  m.albedo = Eigen::Vector3d::Constant(a);
  return m;
}

// A floor (y = 0, 10 m across) and a virtual sphere of radius r at `centre`.
void FloorAndSphere(RenderScene* s, const EnvironmentMap& env, const Eigen::Vector3d& centre, float r) {
  s->AddReal(Quad({-5, 0, -5}, {5, 0, -5}, {5, 0, 5}, {-5, 0, 5}), Diffuse(kAlbedo));
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.translate(centre);
  s->AddVirtual(UvSphere(r, 48), t, Diffuse(0.8));
  s->SetEnvironment(env);
  s->Commit();
}

// The floor's vertex at the origin, seen from (1, 0.5, 0).
PathVertex FloorVertex(const RenderScene& s) {
  const Eigen::Vector3d eye(1, 0.5, 0);
  const Ray ray = MakeRay(eye, -eye.normalized(), kMaskReal);
  Hit hit;
  EXPECT_TRUE(s.embree().Intersect(ray, &hit));
  PathVertex v = MakeVertex(s, ray, hit);
  v.bsdf = DiffuseLobe(s, v);
  return v;
}

// -(a/pi) integral of Le cos over the directions from v.p in which the
// sphere (centre, r) is met: a midpoint rule of n x n cells, equal in solid
// angle, over its cone.
double Quadrature(const RenderScene& s, const PathVertex& v, const Eigen::Vector3d& centre, double r, int n) {
  const Eigen::Vector3d to = centre - v.p;
  const double d = to.norm(), one_minus_max = 1 - std::sqrt(1 - r * r / (d * d));
  Eigen::Vector3d axis = to / d, t, b;
  CoordinateSystem(axis, &t, &b);
  const double cell = kTwoPi * one_minus_max / (n * n);
  double sum = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double om = (i + 0.5) / n * one_minus_max, c = 1 - om, sn = std::sqrt(om * (2 - om));
      const double phi = kTwoPi * (j + 0.5) / n;
      const Eigen::Vector3d w = sn * std::cos(phi) * t + sn * std::sin(phi) * b + c * axis;
      const double cos_n = w.dot(v.frame.n);
      if (cos_n <= 0 || !s.embree().Occluded(MakeRay(v.origin, w, kMaskVirtual))) continue;
      sum += s.environment().Eval(w).mean() * cos_n * cell;
    }
  return -kAlbedo / kPi * sum;
}

struct Estimate {
  double mean = 0, stderr_ = 0;
  int64_t rays = 0, virtual_tests = 0;  // virtual_tests: the lights' virtual shadow rays traced
};

// The mean over n stratified samples of DirectDiffuse's mixed - real, with
// `shadows` samples of the objects' shadows in each.
Estimate Difference(const RenderScene& s, const PathVertex& v, int n, int shadows = 1) {
  double sum = 0, sum2 = 0;
  Estimate e;
  for (int i = 0; i < n; ++i) {
    Sampler g = Sampler::Stratified(7, static_cast<uint32_t>(i));
    Eigen::Vector3d m = Eigen::Vector3d::Zero(), r = Eigen::Vector3d::Zero();
    e.rays += DirectDiffuse(
        s, v, v.albedo, false, true, true, g, &m, &r,
        [&](Ray sr) {
          const VirtualTest t = TestVirtualBlockers(s, sr);
          e.virtual_tests += t != VirtualTest::kSkipped;
          return t == VirtualTest::kBlocked ? 0.0 : 1.0;
        },
        shadows);
    const double dd = (m - r).mean();
    sum += dd;
    sum2 += dd * dd;
  }
  e.mean = sum / n;
  e.stderr_ = std::sqrt(std::max(0.0, sum2 / n - e.mean * e.mean) / n);
  return e;
}

// The objects' bounding spheres, which the cones are made from: a sphere's
// mesh gets its own radius (its box's half diagonal is sqrt 3 times it,
// three times the cone's solid angle); a box turned and stretched keeps
// every placed corner inside its sphere, which is no larger than half its
// world box's diagonal; a hidden object has none.
TEST(DirectDifference, BoundingSpheresHoldTheirObjectsTightly) {
  RenderScene s;
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.translate(Eigen::Vector3d(0, 1, 0));
  s.AddVirtual(UvSphere(0.3f, 48), t, Diffuse(0.8));
  Eigen::Affine3d b = Eigen::Affine3d::Identity();
  b.translate(Eigen::Vector3d(2, 0.5, -1));
  b.rotate(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  b.scale(Eigen::Vector3d(3, 0.5, 1));
  const Mesh box = Box({-0.1f, -0.2f, -0.3f}, {0.1f, 0.2f, 0.3f});
  s.AddVirtual(box, b, Diffuse(0.5));
  s.Commit();
  const std::vector<Eigen::Vector4d>& sp = s.virtual_spheres();
  ASSERT_EQ(sp.size(), 2u);
  EXPECT_NEAR(sp[0][3], 0.3, 1e-6);
  EXPECT_LT((sp[0].head<3>() - Eigen::Vector3d(0, 1, 0)).norm(), 1e-9);
  for (const Eigen::Vector3f& q : box.positions) EXPECT_LT((b * q.cast<double>() - sp[1].head<3>()).norm(), sp[1][3]);
  EXPECT_LE(sp[1][3], 0.5 * s.virtual_bounds()[1].diagonal().norm() * (1 + 1e-6) + 1e-9);
  Eigen::Affine3d gone = Eigen::Affine3d::Identity();
  gone.linear().setZero();
  s.SetVirtualTransform(1, gone);
  EXPECT_LT(s.virtual_spheres()[1][3], 0);
  EXPECT_GE(s.virtual_spheres()[0][3], 0);
}

// The environment's sample in EnvironmentDifference is skipped where its
// row's band meets no cone (VirtualCones::MeetsBand): that must never drop a
// direction Covers takes.  Random objects seen from random points, the
// pole's own axis among them, and directions in and around their cones;
// and a band far from a small cone is met by none (the skip happens).
TEST(DirectDifference, TheBandSkipsOnlyWhatNoConeCovers) {
  Sampler rng = Sampler::Random(11, 0);
  const Eigen::Vector3d up = Eigen::Vector3d(0.2, 1, -0.1).normalized();
  int covered = 0;
  for (int k = 0; k < 400; ++k) {
    const Eigen::Vector3d p(rng.NextDouble(), rng.NextDouble(), rng.NextDouble());
    const Eigen::Vector3d n = Eigen::Vector3d(rng.NextDouble() - 0.5, 1, rng.NextDouble() - 0.5).normalized();
    std::vector<Eigen::Vector4d> spheres;
    for (int b = 0; b < 1 + k % 3; ++b) {
      // Every 8th object straight along the pole from p (its axis is +-up).
      const double dist = 0.3 + 3 * rng.NextDouble(), half = 0.01 + 0.2 * rng.NextDouble();
      const Eigen::Vector3d c = k % 8 == 0 ? Eigen::Vector3d(p + (b % 2 ? -dist : dist) * up)
                                           : Eigen::Vector3d(p + dist * SampleUniformSphereVector(rng));
      spheres.emplace_back(c.x(), c.y(), c.z(), half);
    }
    const VirtualCones cones(spheres, p, n);
    for (int i = 0; i < 200; ++i) {
      Eigen::Vector3d w = SampleUniformSphereVector(rng);
      if (!cones.cones.empty() && i % 2 == 0) {  // near a cone's rim
        const auto& c = cones.cones[static_cast<size_t>(i) % cones.cones.size()];
        const double t = std::acos(c.cos_max) * (0.98 + 0.04 * rng.NextDouble());
        const Eigen::Vector3d perp = (w - w.dot(c.axis) * c.axis).normalized();
        w = (std::cos(t) * c.axis + std::sin(t) * perp).normalized();
      }
      if (!cones.Covers(w)) continue;
      ++covered;
      const double s = w.dot(up);
      ASSERT_TRUE(cones.MeetsBand(up, s, s)) << k << " " << i;
    }
  }
  EXPECT_GT(covered, 5000);
  // A sphere 0.1 across 2 m away on the horizon: nothing within 10 degrees of the pole.
  const std::vector<Eigen::Vector4d> one = {{2.05, 0, 0, 0.05}};
  const VirtualCones cone(one, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitY());
  EXPECT_FALSE(cone.MeetsBand(Eigen::Vector3d::UnitY(), std::cos(0.17), 1.0));
  EXPECT_TRUE(cone.MeetsBand(Eigen::Vector3d::UnitY(), -0.01, 0.01));
}

// Under a constant sky the difference is the sphere's form factor,
// -a L (r/d)^2 for a sphere straight above; the faceted sphere is inscribed
// (48 segments: its silhouette 0.3% smaller).  The estimate is stratified:
// 4096 samples land within 1% of the quadrature, which itself is within
// 1% of the analytic value.
TEST(DirectDifference, ConstantSkyMatchesTheSpheresFormFactor) {
  RenderScene s;
  const Eigen::Vector3d centre(0, 1, 0);
  FloorAndSphere(&s, EnvironmentMap::Constant(Eigen::Vector3d::Constant(0.5)), centre, 0.3f);
  const PathVertex v = FloorVertex(s);
  ASSERT_LT(v.p.norm(), 1e-5);
  const double analytic = -kAlbedo * 0.5 * 0.09;
  const double quad = Quadrature(s, v, centre, 0.3, 400);
  EXPECT_NEAR(quad / analytic, 1.0, 0.01);
  const Estimate e = Difference(s, v, 4096);
  EXPECT_NEAR(e.mean / quad, 1.0, 0.01) << e.mean << " vs " << quad << " (stderr " << e.stderr_ << ")";
}

// The sun (1e4 x the sky, in one texel of 64 x 32) straight behind the
// sphere: the sun's shadow and the sky's together, within 2% of the
// quadrature (the sun's texel is 5.6 degrees, the sphere 35, so it is whole
// in the shadow; 400 x 400 cells resolve the texel's edges to 0.1%).
TEST(DirectDifference, SunBehindTheObject) {
  Image img = Image::Rgb(64, 32);
  for (float& x : img.values()) x = 0.5f;
  for (int c = 0; c < 3; ++c) img.at(20, 8, c) = 5000.0f;
  const EnvironmentMap env(img, "sky");
  Eigen::Vector3d sun = Eigen::Vector3d::UnitY();
  double best = 0;
  for (int i = 0; i < 32; ++i) {  // the brightest of the environment's samples
    Eigen::Vector3d w;
    double pdf = 0;
    const double le = env.Sample((i + 0.5) / 32, 0.5, &w, &pdf).mean();
    if (le > best) best = le, sun = w;
  }
  ASSERT_GT(best, 1000);
  ASSERT_GT(sun.y(), 0.4) << "the sun must stand above the floor";
  const Eigen::Vector3d centre = sun * 1.2;
  RenderScene s;
  FloorAndSphere(&s, env, centre, 0.35f);
  const PathVertex v = FloorVertex(s);
  const double quad = Quadrature(s, v, centre, 0.35, 400);
  const Estimate e = Difference(s, v, 4096);
  EXPECT_NEAR(e.mean / quad, 1.0, 0.02) << e.mean << " vs " << quad << " (stderr " << e.stderr_ << ")";
}

// A sphere below the floor's horizon makes no difference: nothing is
// sampled and no ray is traced.
TEST(DirectDifference, AnObjectBelowTheHorizonCostsNothing) {
  RenderScene s;
  FloorAndSphere(&s, EnvironmentMap::Constant(Eigen::Vector3d::Constant(0.5)), {0, -1, 0}, 0.3f);
  const PathVertex v = FloorVertex(s);
  Sampler g = Sampler::Stratified(7, 0);
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  EXPECT_EQ(EnvironmentDifference(s, v, g, &m), 0);
  EXPECT_EQ(m, Eigen::Vector3d::Zero());
  const Estimate e = Difference(s, v, 256);
  EXPECT_EQ(e.mean, 0.0);
}

// DirectDiffuse's `shadows` (the methods' shadow_samples): the objects'
// shadows from n samples, the light itself from one.  A floor point under a
// sphere that hides part of a distant disc light (5 degrees in radius, its
// centre 4 degrees off the sphere's edge as the point sees it) and of a
// constant sky: the difference's mean stays (1 and 8 samples within three
// of their standard errors combined, 2048 calls each), its spread over the
// calls falls (8: below 0.6 of one's; measured: printed), and where no
// object can block (the sphere below the horizon) the extra samples trace
// nothing and the difference stays zero (to rounding).
TEST(DirectDifference, ShadowSamplesKeepTheMeanAndTraceOnlyWhereAnObjectBlocks) {
  const double r = 0.3, edge = std::asin(r / 1.0);  // the sphere's angular radius from the origin
  Light sun;
  sun.type = LightType::kDistant;
  const double off = edge - 4 * kDegToRad;  // the disc's centre this far from the vertical
  sun.direction = Eigen::Vector3d(std::sin(off), std::cos(off), 0);
  sun.angular_radius_deg = 5;
  sun.irradiance = Eigen::Vector3d::Constant(20);
  auto scene = [&](const Eigen::Vector3d& centre, RenderScene* s) {
    s->AddReal(Quad({-5, 0, -5}, {5, 0, -5}, {5, 0, 5}, {-5, 0, 5}), Diffuse(kAlbedo));
    Eigen::Affine3d t = Eigen::Affine3d::Identity();
    t.translate(centre);
    s->AddVirtual(UvSphere(static_cast<float>(r), 48), t, Diffuse(0.8));
    s->SetEnvironment(EnvironmentMap::Constant(Eigen::Vector3d::Constant(0.5)));
    s->AddLight(sun);
    s->Commit();
  };
  RenderScene s;
  scene({0, 1, 0}, &s);
  const PathVertex v = FloorVertex(s);
  const Estimate one = Difference(s, v, 2048, 1), eight = Difference(s, v, 2048, 8);
  const double spread1 = one.stderr_ * std::sqrt(2048.0), spread8 = eight.stderr_ * std::sqrt(2048.0);
  std::printf("shadow samples: mean %.5f (1) %.5f (8), spread %.4f %.4f, rays %lld %lld\n", one.mean, eight.mean,
              spread1, spread8, static_cast<long long>(one.rays), static_cast<long long>(eight.rays));
  ASSERT_LT(one.mean, -1e-3);
  EXPECT_NEAR(eight.mean, one.mean, 3 * std::hypot(one.stderr_, eight.stderr_));
  EXPECT_LT(spread8, 0.6 * spread1);

  RenderScene below;
  scene({0, -1, 0}, &below);
  const PathVertex w = FloorVertex(below);
  const Estimate b1 = Difference(below, w, 256, 1), b8 = Difference(below, w, 256, 8);
  EXPECT_NEAR(b1.mean, 0.0, 1e-12);  // the solutions' sums in another order: rounding
  EXPECT_NEAR(b8.mean, 0.0, 1e-12);
  EXPECT_EQ(b8.virtual_tests, 0);
  EXPECT_EQ(b8.rays, b1.rays) << "the extra shadow samples traced rays where no object can block";
}

}  // namespace
}  // namespace mr
