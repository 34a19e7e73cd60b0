// ic, differential irradiance caching: against closed forms and pt, and the
// invariants of its records (radii, gradients, persistence across frames).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "core/image_metrics.h"
#include "core/math.h"
#include "core/report.h"
#include "geometry/primitives.h"
#include "light/lights_file.h"
#include "render/gi_scenes.h"
#include "render/irradiance_cache.h"
#include "render/pt.h"

namespace mr {
namespace {

using namespace gi_test;

TEST(Ic, IntegratingSphereWithAlbedoNearOne) {
  RenderScene s;
  IntegratingSphere(&s);
  IcSettings st;
  st.rays = 256;
  st.max_depth = 1 << 20;  // Russian roulette ends paths: no truncation
  st.photograph = false;
  IrradianceCache cache(s, st);
  IcFrameRenderer r(s, &cache, Pinhole(12, 9, 8), LookAt({0, 0, 0}, {0, 0, 1}), 0, 0);
  r.RenderPass(2);
  const double expected = kRho / kPi / (1 - kRho);
  const Image img = r.Mixed();
  EXPECT_EQ(CountNonFinite(img), 0);
  EXPECT_EQ(r.nonfinite_samples(), 0);
  EXPECT_NEAR(Mean(img), expected, 0.04 * expected);
  ASSERT_FALSE(cache.records().empty());
  for (const IcRecord& rec : cache.records()) EXPECT_TRUE(rec.e_mixed.allFinite());
}

// Irradiance gradients (Ward & Heckbert): on the floor of the open corner,
// 0.2 m before the sunlit wall's foot.  The translational gradient (a
// record of 16384 rays) against the central difference of records 5 cm
// either side (2^20 rays each: E rises 0.394 -> 0.400 -> 0.408 towards the
// wall; measured slope 0.149 / m, gradient 0.166 at 65536 rays: a gradient
// is noisier than the value it comes with, so 20%); across the wall it is
// about 0.  The rotational gradient (4096 rays) turning the normal 10
// degrees towards the wall: it must take away at least 80% of what the
// flat value misses (measured: 0.0648 -> 0.0054).
TEST(Ic, GradientsPredictTheNeighbourhood) {
  RenderScene s;
  OpenCorner(&s, 200, /*with_object=*/false);
  IcSettings st;
  st.photograph = false;
  auto eval = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& n, uint64_t index, int rays) {
    IcSettings si = st;
    si.rays = rays;
    IrradianceCache cache(s, si);
    IcRecord r;
    r.p = p;
    r.n = n.normalized();
    r.index = index;
    cache.Evaluate(&r, 0);
    return r;
  };
  const Eigen::Vector3d up = Eigen::Vector3d::UnitY();
  const IcRecord at = eval({0.3, 0, 0.8}, up, 1, 65536);
  EXPECT_EQ(at.trans_mixed, at.trans_real);  // no virtual object: the same paths
  const double slope =
      (eval({0.3, 0, 0.85}, up, 2, 1 << 20).e_mixed[0] - eval({0.3, 0, 0.75}, up, 3, 1 << 20).e_mixed[0]) / 0.1;
  std::printf("slope %.4f, gradient %.4f %.4f %.4f\n", slope, at.trans_mixed(0, 0), at.trans_mixed(0, 1),
              at.trans_mixed(0, 2));
  EXPECT_GT(slope, 0.1);
  EXPECT_NEAR(at.trans_mixed(0, 2), slope, 0.2 * slope);
  EXPECT_LT(std::abs(at.trans_mixed(0, 0)), 0.2 * slope);
  EXPECT_LT(std::abs(at.trans_mixed(0, 1)), 1e-9);  // along the normal: nothing
  const IcRecord flat = eval({0.3, 0, 0.8}, up, 1, 4096);
  const Eigen::Vector3d n2 = Eigen::AngleAxisd(10 * kPi / 180, Eigen::Vector3d::UnitX()) * up;
  const IcRecord turned = eval(flat.p, n2, 4, 4096);
  const double miss = std::abs(flat.e_mixed[0] - turned.e_mixed[0]);
  const double pred = std::abs(flat.e_mixed[0] + (flat.rot_mixed * flat.n.cross(n2))[0] - turned.e_mixed[0]);
  std::printf("turned: flat %.4f, with the gradient %.4f\n", miss, pred);
  EXPECT_LT(pred, 0.2 * miss);
}

// A new record's radius is clamped by the records made before it, R_i <=
// R_j + |x_i - x_j| (R = half the least hit distance), found in a grid
// (a finer one where the ball that can clamp it, min(R_i, r_max), is small).
// Against the search over every earlier record: the same double for every
// record (in a scene this small no ball reaches past the coarse search's two
// cells).  Searching only the fine cell a record lies in, or skipping the
// fine grid, fails here.
TEST(Ic, NeighbourClampFindsEveryRecordThatCounts) {
  RenderScene s;
  OpenCorner(&s, 1e3);
  IcSettings is;
  is.rays = 16;
  is.min_spacing_px = 0.25;  // radii below the pixel floor: the clamp decides them, not the floor
  IrradianceCache cache(s, is);
  IcFrameRenderer ic(s, &cache, Pinhole(96, 72, 80), kCornerCamera, 0, 0);
  ic.RenderPass(1);
  const std::vector<IcRecord>& recs = cache.records();  // in the order they were made
  ASSERT_GT(recs.size(), 1000u);
  int clamped_by_neighbour = 0;
  for (size_t i = 0; i < recs.size(); ++i) {
    const IcRecord& r = recs[i];
    double ri = 0.5 * r.r_hit;
    for (size_t j = 0; j < i; ++j) {
      const IcRecord& o = recs[j];
      if (o.on_virtual == r.on_virtual) ri = std::min(ri, 0.5 * o.r_hit + (o.p - r.p).norm());
    }
    clamped_by_neighbour += ri < 0.5 * r.r_hit;
    ASSERT_EQ(r.r, std::clamp(ri, r.r_min, r.r_max)) << "record " << i;
  }
  EXPECT_GT(clamped_by_neighbour, static_cast<int>(recs.size() / 20));  // the clamp is at work
}

// A 4 m glossy floor (albedo, specular, roughness) and a white (0.8) wall 1 m
// before the camera's target.
void GlossyFloorBeforeWall(RenderScene* s, double albedo, double specular, double roughness) {
  Material floor;
  floor.albedo = Eigen::Vector3d::Constant(albedo);
  floor.specular = Eigen::Vector3d::Constant(specular);
  floor.roughness = roughness;
  s->AddReal(Quad({-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}), floor);
  s->AddReal(Quad({-2, 0, 1}, {2, 0, 1}, {2, 2, 1}, {-2, 2, 1}), Diffuse(0.8));
}

// ic's settings for those scenes: 256 rays a record, 8 bounces, no
// photograph (records wherever the camera looks).
IcSettings GlossyFloorIc() {
  IcSettings is;
  is.rays = 256;
  is.max_depth = 8;
  is.photograph = false;
  return is;
}

// With glossy_cache the points glossy rays meet take their indirect light
// from the records, where a glossy path of glossy_depth bounces cut it.  A
// glossy floor reflects a back wall under a uniform sky, no photograph (so
// records are made wherever the camera looks): the floor's mean radiance
// against pt's at 1024 spp, within 1% with the cache (measured 0.09%);
// the two-bounce path leaves out the reflected walls' indirect light, the
// floor's and the ceiling's bounce (measured -10.5%).
TEST(Ic, GlossyRaysTakeTheRecordsIndirectLight) {
  RenderScene s;
  GlossyFloorBeforeWall(&s, 0.5, 0.4, 0.1);
  s.AddReal(Quad({-2, 2, -2}, {2, 2, -2}, {2, 2, 1}, {-2, 2, 1}), Diffuse(0.8));  // a ceiling
  s.SetEnvironment(Sky(1));
  s.Commit();
  const CameraModel cam = Pinhole(32, 24, 16);
  const Rigid3 pose = LookAt({0, 0.5, -1.8}, {0, 0.2, 1});
  auto floor_mean = [](const Image& m) {  // the lower half: the floor
    double v = 0;
    for (int y = m.height() / 2; y < m.height(); ++y)
      for (int x = 0; x < m.width(); ++x) v += m.at(x, y, 0) + m.at(x, y, 1) + m.at(x, y, 2);
    return v / (1.5 * m.width() * m.height());
  };
  PathTracerSettings pst;
  pst.max_depth = 8;
  PtFrameRenderer pt(s, cam, pose, pst);
  pt.RenderPass(1024);
  const double ref = floor_mean(pt.Mixed());
  auto ic = [&](bool cache) {
    IcSettings is = GlossyFloorIc();
    is.glossy_cache = cache;
    IrradianceCache c(s, is);
    IcFrameRenderer r(s, &c, cam, pose, 0, 0);
    r.RenderPass(16);
    return floor_mean(r.Mixed());
  };
  const double cached = ic(true), cut = ic(false);
  std::printf("floor's mean: pt %.5f, ic cached %.5f, ic cut %.5f\n", ref, cached, cut);
  EXPECT_LT(std::abs(cached / ref - 1), 0.01);
  EXPECT_GT(std::abs(cut / ref - 1), 3 * std::abs(cached / ref - 1));
}

// glossy_rays splits the glossy lobe at camera points: the same light (the
// floor's mean within 1% of one ray's, measured 0.08%: each ray is an
// unbiased estimate of the lobe), and less noise: the mean squared
// difference of two renders of different seeds on the glossy floor, which
// mirrors a wall with black stripes, falls below 0.6 x with four rays
// (measured 0.44 x: the lobe's part of the variance falls 4 x, the rest,
// direct light and records, stays).
TEST(Ic, GlossyRaysSplitTheLobe) {
  RenderScene s;
  GlossyFloorBeforeWall(&s, 0.2, 0.6, 0.3);
  // Black stripes on the wall: the reflection's contrast, the lobe's variance.
  for (float x0 : {-1.5f, -0.7f, 0.1f, 0.9f})
    s.AddReal(Quad({x0, 0.05, 0.95}, {x0 + 0.4f, 0.05f, 0.95f}, {x0 + 0.4f, 1.5f, 0.95f}, {x0, 1.5, 0.95}), Diffuse(0));
  s.SetEnvironment(Sky(1));
  s.Commit();
  const CameraModel cam = Pinhole(32, 24, 16);
  const Rigid3 pose = LookAt({0, 0.5, -1.8}, {0, 0.2, 1});
  auto render = [&](int glossy_rays, uint64_t seed) {
    IcSettings is = GlossyFloorIc();
    is.glossy_rays = glossy_rays;
    IrradianceCache c(s, is);
    IcFrameRenderer r(s, &c, cam, pose, seed, 0);
    r.RenderPass(4);
    return r.Mixed();
  };
  auto floor_stats = [](const Image& a, const Image& b, double* mean, double* msd) {
    double v = 0, d = 0;
    int n = 0;
    for (int y = a.height() / 2; y < a.height(); ++y)
      for (int x = 0; x < a.width(); ++x)
        for (int c = 0; c < 3; ++c, ++n) {
          v += a.at(x, y, c) + b.at(x, y, c);
          d += (a.at(x, y, c) - b.at(x, y, c)) * (a.at(x, y, c) - b.at(x, y, c));
        }
    *mean = v / (2 * n);
    *msd = d / n;
  };
  double mean1, msd1, mean4, msd4;
  floor_stats(render(1, 1), render(1, 2), &mean1, &msd1);
  floor_stats(render(4, 1), render(4, 2), &mean4, &msd4);
  std::printf("floor: one ray mean %.5f msd %.3g; four rays mean %.5f msd %.3g (%.2f x)\n", mean1, msd1, mean4, msd4,
              msd4 / msd1);
  EXPECT_LT(std::abs(mean4 / mean1 - 1), 0.01);
  EXPECT_LT(msd4, 0.6 * msd1);
}

// ic's records outside the objects' influence region (form factor bound
// 1e-3) are not made; the composite changes by less than 1e-4 relMSE.
TEST(Ic, InfluenceRegionSkipChangesLittle) {
  RenderScene s;
  SphereOnFloor(&s, 20, 0.05f, 16, 100);
  const CameraModel cam = Pinhole(32, 24, 16);
  const Rigid3 pose = LookAt({0, 3, -6}, {0, 0, 4});
  auto run = [&](double threshold, int64_t* records) {
    IcSettings is;
    is.rays = 64;
    is.max_spacing_px = 3;  // dense records, so that skipping shows
    is.influence_threshold = threshold;
    IrradianceCache cache(s, is);
    IcFrameRenderer r(s, &cache, cam, pose, 0, 0);
    r.RenderPass(2);
    *records = static_cast<int64_t>(cache.records().size());
    return Difference(r);
  };
  int64_t n_all = 0, n_some = 0;
  const Image all = run(0, &n_all), some = run(1e-3, &n_some);
  EXPECT_LT(n_some, n_all / 2);  // the skip saves work here
  double err = 0;
  for (size_t i = 0; i < all.values().size(); ++i) err += std::pow(all.values()[i] - some.values()[i], 2);
  EXPECT_LT(err / static_cast<double>(all.values().size()), 1e-4);
}

// Records persist in world space: a second frame keeps the first's records,
// and re-evaluation after t_max frames uses the
// record's own random numbers, so that it reproduces the values exactly.
TEST(Ic, RecordsPersistAcrossFramesWithoutFlicker) {
  RenderScene s;
  OpenCorner(&s, 1e3);
  const CameraModel cam = Pinhole(24, 18, 20);
  IcSettings is;
  is.rays = 64;
  is.t_max = 1;
  IrradianceCache cache(s, is);
  IcFrameRenderer f0(s, &cache, cam, kCornerCamera, 0, 0);
  f0.RenderPass(1);
  const std::vector<IcRecord> first = cache.records();
  IcFrameRenderer f1(s, &cache, cam, kCornerCamera, 0, 1);  // re-evaluates every record
  f1.RenderPass(1);
  ASSERT_GE(cache.records().size(), first.size());
  for (size_t i = 0; i < first.size(); ++i) {
    EXPECT_EQ(cache.records()[i].evaluated_frame, 1);
    ASSERT_EQ(cache.records()[i].e_mixed, first[i].e_mixed);
    ASSERT_EQ(cache.records()[i].e_real, first[i].e_real);
  }
}

// Records on the virtual objects take object_rays (at least rays; the
// report's ray count says so), and the objects' pixels, which those records
// light, vary less between seeds while the room's records keep `rays`.  On
// the open corner at 16 rays and 4 spp, the spread between two seeds over
// the sphere's whole pixels falls with object_rays 256 against 16 (measured
// 0.35-0.45 of it over four pairs of seeds, 1/4 were the records' noise
// all; bound 0.7).
TEST(Ic, ObjectRecordsTakeObjectRays) {
  RenderScene s;
  OpenCorner(&s, 1e3);
  const CameraModel cam = Pinhole(64, 48, 80);
  struct Run {
    Image mixed, mask;
    int64_t on_objects = 0, others = 0, record_rays = 0;
  };
  auto run = [&](int object_rays, uint64_t seed) {
    IcSettings is;
    is.rays = 16;
    is.object_rays = object_rays;
    is.object_direct_samples = 64;  // the direct light's noise well under the records'
    is.seed = seed;
    IrradianceCache cache(s, is);
    IcFrameRenderer r(s, &cache, cam, kCornerCamera, seed, 0);
    r.RenderPass(4);
    Run out{r.Mixed(), r.Mask()};
    for (const IcRecord& rec : cache.records()) ++(rec.on_virtual ? out.on_objects : out.others);
    Report report;
    cache.Describe(&report);
    out.record_rays = report.metrics()["ic"]["record_rays"].get<int64_t>();
    return out;
  };
  auto spread = [](const Run& a, const Run& b) {
    double sq = 0;
    int n = 0;
    for (int y = 0; y < a.mask.height(); ++y)
      for (int x = 0; x < a.mask.width(); ++x)
        if (a.mask.at(x, y, 0) == 1.0f && b.mask.at(x, y, 0) == 1.0f)
          for (int c = 0; c < 3; ++c, ++n) sq += std::pow(a.mixed.at(x, y, c) - b.mixed.at(x, y, c), 2);
    EXPECT_GT(n, 3 * 100);
    return std::sqrt(sq / std::max(n, 1));
  };
  const Run few1 = run(16, 1), few2 = run(16, 2), many1 = run(256, 1), many2 = run(256, 2);
  ASSERT_GT(many1.on_objects, 0);
  ASSERT_GT(many1.others, many1.on_objects);
  EXPECT_EQ(many1.record_rays, 256 * many1.on_objects + 16 * many1.others);
  EXPECT_EQ(few1.record_rays, 16 * (few1.on_objects + few1.others));
  const double few = spread(few1, few2), many = spread(many1, many2);
  std::printf("object records: %lld of %lld; spread between seeds %.4g with 16 rays, %.4g with 256\n",
              static_cast<long long>(many1.on_objects), static_cast<long long>(many1.on_objects + many1.others), few,
              many);
  EXPECT_LT(many, 0.7 * few);
}

}  // namespace
}  // namespace mr
