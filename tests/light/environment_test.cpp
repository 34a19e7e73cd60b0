#include "light/environment.h"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <vector>

#include "core/error.h"
#include "core/math.h"
#include "core/sampling.h"
#include "core/spherical.h"

namespace mr {
namespace {

Image SkyWithSun(int w, int h, float sky, float sun, int sx, int sy) {
  Image img = Image::Rgb(w, h, sky);
  for (int c = 0; c < 3; ++c) img.at(sx, sy, c) = sun;
  return img;
}

// Importance sampling proportional to luminance x solid angle makes
// luminance(Le) / pdf equal to the integral for every single sample: an
// exact check of Sample, Pdf and the cell geometry together.
TEST(EnvironmentMap, SamplingIsExactlyProportionalToLuminance) {
  Image img = SkyWithSun(32, 17, 1e-6f, 1e6f, 20, 3);  // a sun 1e12 times the sky
  img.at(5, 9, 1) = 0.5f;
  EnvironmentMap env(img, "sun.exr");
  Pcg32 rng(1, 1);
  int sun_hits = 0;
  for (int i = 0; i < 20000; ++i) {
    Eigen::Vector3d dir;
    double pdf = 0;
    const double u0 = rng.NextDouble(), u1 = rng.NextDouble();
    Eigen::Vector3d le = env.Sample(u0, u1, &dir, &pdf);
    ASSERT_GT(pdf, 0);
    ASSERT_NEAR(dir.norm(), 1.0, 1e-12);
    // The sampled direction lies in the sampled cell: Eval and Pdf agree.
    ASSERT_EQ(env.Eval(dir), le);
    ASSERT_NEAR(env.Pdf(dir), pdf, 1e-12 * pdf);
    ASSERT_NEAR(Luminance(le) / pdf, env.LuminanceIntegral(), 1e-9 * env.LuminanceIntegral());
    sun_hits += le.x() > 1;
  }
  EXPECT_GT(sun_hits, 19990);  // the sun holds all but ~1e-9 of the power
}

// Sampling picks cells with exactly their weights and never a cell of zero
// weight: a black map with two lit pixels whose weights are 1 : 3
// (equal solid angle, luminance 1 : 3).  200 000 draws: the share's standard
// deviation is 0.001, the tolerance 0.005.
TEST(EnvironmentMap, SamplingMatchesWeightsAndSkipsBlackCells) {
  Image img = Image::Rgb(32, 17, 0.0f);
  for (int c = 0; c < 3; ++c) {
    img.at(7, 8, c) = 1.0f;
    img.at(20, 8, c) = 3.0f;
  }
  EnvironmentMap env(img, "two.exr");
  Pcg32 rng(3, 4);
  int bright = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d dir;
    double pdf = 0;
    const double u0 = rng.NextDouble(), u1 = rng.NextDouble();
    Eigen::Vector3d le = env.Sample(u0, u1, &dir, &pdf);
    ASSERT_GT(le.x(), 0.5);  // never a black cell
    bright += le.x() > 2;
  }
  EXPECT_NEAR(static_cast<double>(bright) / n, 0.75, 0.005);
}

// Stratified numbers must stay stratified through the map: the light a
// surface receives from a blob sun (Gaussian, sigma 1.5 pixels of 256, peak
// 2000 x the sky) with half of the sun hidden behind an edge, estimated with
// 256 samples.  Over 64 seeds the RMS error with the Sampler's stratified
// pairs must be under 0.4 of that with independent numbers (measured: 0.26;
// scattering u0's neighbours over unrelated rows, as an alias table does
// with cells, gives 0.76).
TEST(EnvironmentMap, SamplingKeepsStratification) {
  const int w = 256, h = 128;
  Image img = Image::Rgb(w, h, 1.0f);
  const double sx = 80.3, sy = 40.6;  // the sun's centre
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double r2 = (x - sx) * (x - sx) + (y - sy) * (y - sy);
      for (int c = 0; c < 3; ++c) img.at(x, y, c) += static_cast<float>(2000 * std::exp(-r2 / (2 * 1.5 * 1.5)));
    }
  EnvironmentMap env(img, "blob.exr");
  const Eigen::Vector3d sun = LatLongPixelToDirection(Eigen::Vector2d(sx, sy), w, h);
  const Eigen::Vector3d n = (sun + Eigen::Vector3d(0.3, 0.5, 0.1)).normalized();
  // An edge through the sun's centre: a half-plane of directions is hidden.
  const Eigen::Vector3d edge = sun.cross(Eigen::Vector3d(0.2, 0.9, -0.4)).normalized();
  auto f = [&](const Eigen::Vector3d& d, const Eigen::Vector3d& le, double pdf) {
    return d.dot(edge) > 0 ? 0.0 : std::max(0.0, d.dot(n)) * Luminance(le) / pdf;
  };
  // The reference: the same integral with 2^18 stratified samples.
  auto estimate = [&](auto&& next2d, int count) {
    CompensatedSum<double> sum;
    for (int i = 0; i < count; ++i) {
      const auto u = next2d(i);
      Eigen::Vector3d d;
      double pdf = 0;
      const Eigen::Vector3d le = env.Sample(u[0], u[1], &d, &pdf);
      sum += f(d, le, pdf);
    }
    return sum.Value() / count;
  };
  const double truth =
      estimate([](int i) { return Sampler::Stratified(99, static_cast<uint32_t>(i)).Next2D(); }, 1 << 18);
  double se_strat = 0, se_random = 0;
  for (int seed = 0; seed < 64; ++seed) {
    const double a =
        estimate([&](int i) { return Sampler::Stratified(seed + 1000, static_cast<uint32_t>(i)).Next2D(); }, 256);
    Pcg32 rng(static_cast<uint64_t>(seed), 5);
    const double b = estimate([&](int) { return std::array<double, 2>{rng.NextDouble(), rng.NextDouble()}; }, 256);
    se_strat += (a - truth) * (a - truth);
    se_random += (b - truth) * (b - truth);
  }
  EXPECT_GT(truth, 0);
  EXPECT_LT(std::sqrt(se_strat / se_random), 0.4);
}

TEST(EnvironmentMap, PdfIntegratesToOne) {
  Image img = SkyWithSun(16, 9, 1.0f, 50.0f, 3, 1);
  EnvironmentMap env(img, "e.exr");
  // Integrate the pdf over the sphere with 2^20 stratified uniform directions;
  // the piecewise-constant pdf makes the error ~1e-3.
  const int n = 1 << 20;
  CompensatedSum<double> s;
  for (int i = 0; i < n; ++i) {
    auto u = Sobol2D(static_cast<uint32_t>(i));
    auto d = SampleUniformSphere(u[0], u[1]);
    s += env.Pdf(Eigen::Vector3d(d[0], d[1], d[2])) / kUniformSpherePdf;
  }
  EXPECT_NEAR(s.Value() / n, 1.0, 5e-3);
}

TEST(EnvironmentMap, RotationAndConstant) {
  Image img = SkyWithSun(16, 9, 0.0f, 1.0f, 7, 4);  // just off +z: (W-1)/2 = 7.5
  Eigen::Matrix3d yaw90 = Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EnvironmentMap env(img, "e.exr", 2.0, yaw90);
  Eigen::Vector3d dir;
  double pdf;
  env.Sample(0.5, 0.5, &dir, &pdf);
  // +z of the map is rotated to +x of the world; the scale applies.
  EXPECT_GT(dir.x(), 0.9);
  EXPECT_EQ(env.Eval(dir).x(), 2.0);
  EnvironmentMap c = EnvironmentMap::Constant(Eigen::Vector3d(0.25, 0.5, 1));
  EXPECT_EQ(c.Eval(Eigen::Vector3d(0, 1, 0)), Eigen::Vector3d(0.25, 0.5, 1));
}

// SampleBand bounds every direction Sample can give for its u0: the row's
// band of latitudes about the map's pole in the world, here tilted; a map
// placed by a matrix that is not a rotation gives no band, and a black one
// no sample.
TEST(EnvironmentMap, SampleBandHoldsEverySampleOfItsRow) {
  const Image img = SkyWithSun(64, 33, 0.2f, 5e4f, 20, 9);
  const Eigen::Matrix3d tilt =
      (Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 0, 1).normalized()))
          .toRotationMatrix();
  const EnvironmentMap env(img, "e.exr", 1.0, tilt);
  Sampler rng = Sampler::Random(3, 0);
  double widest = 0;
  for (int i = 0; i < 20000; ++i) {
    // Every 16th u0 at a row's edge of the marginal (where the inversion turns).
    const double u0 = i % 16 == 0 ? (i / 16 % 34) / 33.0 * (1 - 1e-16) : rng.NextDouble(), u1 = rng.NextDouble();
    Eigen::Vector3d up, dir;
    double lo = 0, hi = 0, pdf = 0;
    ASSERT_TRUE(env.SampleBand(u0, &up, &lo, &hi));
    EXPECT_LT((up - tilt.col(1)).norm(), 1e-15);
    env.Sample(u0, u1, &dir, &pdf);
    ASSERT_GT(pdf, 0);
    const double s = dir.dot(up);
    EXPECT_GE(s, lo) << u0 << " " << u1;
    EXPECT_LE(s, hi) << u0 << " " << u1;
    widest = std::max(widest, hi - lo);
  }
  EXPECT_LT(widest, 0.1);  // a row's band, not the sphere's
  Eigen::Vector3d up;
  double lo = 0, hi = 0;
  const EnvironmentMap sheared(img, "e.exr", 1.0, Eigen::Matrix3d::Identity() * 1.001);
  ASSERT_TRUE(sheared.SampleBand(0.3, &up, &lo, &hi));
  EXPECT_TRUE(std::isinf(lo) && std::isinf(hi));
  EXPECT_FALSE(EnvironmentMap(Image::Rgb(8, 4, 0.0f), "black.exr").SampleBand(0.3, &up, &lo, &hi));
}

TEST(EnvironmentMap, NonFinitePixelsNameFileAndPixel) {
  Image img = Image::Rgb(8, 4, 1.0f);
  img.at(5, 2, 1) = std::numeric_limits<float>::quiet_NaN();
  try {
    EnvironmentMap env(img, "probe.exr");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "probe.exr: pixel (5, 2) has non-finite radiance nan in channel G; an environment map must be finite "
              "and non-negative");
  }
  img.at(5, 2, 1) = -1;
  EXPECT_THROW(EnvironmentMap(img, "probe.exr"), Error);
}

// Sample in lanes (core/lanes.h) gives the scalar calls' bits, on a turned
// map with a sun 1e12 times its sky, over 1000 pairs (chunks of 64 and a
// partial one), the square's corners included; a map with no light gives
// pdf 0 for every pair.
TEST(EnvironmentMap, SamplingInLanesGivesTheScalarBits) {
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const EnvironmentMap env(SkyWithSun(64, 33, 1e-6f, 1e6f, 40, 5), "sun.exr", 1.0, turn);
  Pcg32 rng(9);
  const size_t n = 1000;
  std::vector<double> u0(n), u1(n), pdf(n);
  std::vector<Eigen::Vector3d> dir(n), le(n);
  for (size_t k = 0; k < n; ++k) {
    u0[k] = rng.NextDouble();
    u1[k] = rng.NextDouble();
  }
  u0[0] = u1[0] = 0;
  u0[1] = u1[1] = 0x1.fffffffffffffp-1;
  env.Sample(n, u0.data(), u1.data(), dir.data(), le.data(), pdf.data());
  for (size_t k = 0; k < n; ++k) {
    Eigen::Vector3d d;
    double p;
    const Eigen::Vector3d l = env.Sample(u0[k], u1[k], &d, &p);
    ASSERT_EQ(d, dir[k]) << k;
    ASSERT_EQ(l, le[k]) << k;
    ASSERT_EQ(p, pdf[k]) << k;
    ASSERT_NEAR(d.norm(), 1.0, 1e-14) << k;
  }
  const EnvironmentMap dark(Image::Rgb(8, 4, 0.0f), "dark.exr");
  dark.Sample(n, u0.data(), u1.data(), dir.data(), le.data(), pdf.data());
  for (size_t k = 0; k < n; ++k) ASSERT_EQ(pdf[k], 0.0);
}

// EvalWithPdf in lanes gives the scalar calls' bits, on the turned map,
// over the directions Sample gave, the poles, the seam behind the map (the
// longitude +-pi) and the axes; each sampled direction finds its own cell
// (the pdf Sample gave), up to one in a thousand on a cell's edge.
TEST(EnvironmentMap, LookupsInLanesGiveTheScalarBits) {
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const EnvironmentMap env(SkyWithSun(64, 33, 1e-6f, 1e6f, 40, 5), "sun.exr", 1.0, turn);
  Pcg32 rng(4);
  std::vector<Eigen::Vector3d> dirs;
  std::vector<double> sampled_pdf;
  for (int k = 0; k < 2000; ++k) {
    Eigen::Vector3d d;
    double p;
    env.Sample(rng.NextDouble(), rng.NextDouble(), &d, &p);
    dirs.push_back(d);
    sampled_pdf.push_back(p);
  }
  const size_t sampled = dirs.size();
  for (const Eigen::Vector3d& a : {Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(0, 0, -1),
                                   Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(-1e-12, 0, -1)})
    dirs.push_back(turn * a.normalized());
  std::vector<Eigen::Vector3d> le(dirs.size());
  std::vector<double> pdf(dirs.size());
  env.EvalWithPdf(dirs.size(), dirs.data(), le.data(), pdf.data());
  int other_cell = 0;
  for (size_t k = 0; k < dirs.size(); ++k) {
    double p;
    const Eigen::Vector3d l = env.EvalWithPdf(dirs[k], &p);
    ASSERT_EQ(l, le[k]) << k;
    ASSERT_EQ(p, pdf[k]) << k;
    if (k < sampled) other_cell += p != sampled_pdf[k];
  }
  EXPECT_LE(other_cell, 2);
}

}  // namespace
}  // namespace mr
