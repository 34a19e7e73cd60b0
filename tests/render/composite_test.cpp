// The differential composite, the image metrics and the truth's noise
// estimate.
#include "render/render_job_fixture.h"

namespace mr {
namespace render_job_test {
namespace {

TEST(Composite, DifferentialFormulaAndNegativeClamp) {
  Image photo = Image::Rgb(2, 1, 0.5f), mixed = Image::Rgb(2, 1, 0.2f), real = Image::Rgb(2, 1, 0.4f);
  Image mask = Image::Gray(2, 1, 0.0f);
  mask.at(0, 0, 0) = 0.25f;
  mixed.at(1, 0, 0) = 0.0f;
  real.at(1, 0, 0) = 1.0f;  // a shadow deeper than the photograph allows
  CompositeResult c = Composite(photo, mixed, real, mask);
  EXPECT_FLOAT_EQ(c.composite.at(0, 0, 1), 0.25f * 0.2f + 0.75f * (0.5f + 0.2f - 0.4f));
  EXPECT_EQ(c.composite.at(1, 0, 0), 0.0f);
  EXPECT_EQ(c.clamped_negative, 1);
  EXPECT_FLOAT_EQ(c.difference.at(1, 0, 0), -1.0f);
}

// A clipped plate channel holds a lower bound: a change smaller than a
// tenth of it is hidden by the unknown excess and the plate's value kept; a
// larger one (a deep shadow across a blown-out wall) is composited and
// counted; pixels the object covers and channels that did not clip are
// never touched.
TEST(Composite, ClippedChannelsKeepTheirCodeUnderSmallChanges) {
  const Image photo = Image::Rgb(4, 1, 2.0f);
  Image clipped = Image::Rgb(4, 1, 0.0f), mask = Image::Gray(4, 1, 0.0f), comp = Image::Rgb(4, 1, 2.0f);
  for (int x = 0; x < 4; ++x) clipped.at(x, 0, 0) = 1;  // red clipped everywhere
  comp.at(0, 0, 0) = 1.9f;                              // a 5% shadow: hidden
  comp.at(1, 0, 0) = 1.0f;                              // a 50% shadow: shown
  comp.at(2, 0, 0) = 1.9f;                              // under the object
  mask.at(2, 0, 0) = 0.5f;
  comp.at(3, 0, 1) = 1.9f;  // green did not clip: composited as it is
  const ClippedChannels k = KeepClippedChannels(photo, clipped, mask, &comp);
  EXPECT_EQ(comp.at(0, 0, 0), 2.0f);
  EXPECT_EQ(comp.at(1, 0, 0), 1.0f);
  EXPECT_EQ(comp.at(2, 0, 0), 1.9f);
  EXPECT_EQ(comp.at(3, 0, 1), 1.9f);
  EXPECT_EQ(k.kept, 1);
  EXPECT_EQ(k.changed, 1);
}

TEST(Metrics, KnownValues) {
  Image a = Image::Rgb(8, 8, 0.5f), b = Image::Rgb(8, 8, 0.5f);
  ImageMetrics same = CompareImages(a, b);
  EXPECT_EQ(same.rmse, 0.0);
  EXPECT_NEAR(same.ssim, 1.0, 1e-12);
  a.at(2, 3, 1) = 0.6f;  // one value off by 0.1 out of 192
  ImageMetrics m = CompareImages(a, b);
  EXPECT_NEAR(m.rmse, std::sqrt(0.01 / 192), 1e-7);
  EXPECT_NEAR(m.relmse, 0.01 / (0.25 + kRelMseEpsilon) / 192, 1e-8);
  EXPECT_NEAR(m.psnr, 10 * std::log10(1.0 / (0.01 / 192)), 1e-4);
  EXPECT_LT(m.ssim, 1.0);
  Image region = Image::Gray(8, 8, 0.0f);
  region.at(2, 3, 0) = 1;
  EXPECT_NEAR(CompareImages(a, b, &region).rmse, std::sqrt(0.01 / 3), 1e-7);
  EXPECT_THROW(CompareImages(a, Image::Rgb(4, 4)), Error);
}

// EstimateTruthNoise from a render stopped part-way: per pixel a true
// difference d and samples d + sigma g (g standard normal); the means of
// the first n1 and of all n samples.  The truth's variance is sigma^2 / n, so
// the estimate must be the mean of sigma^2 / n / (T^2 + 0.01).  30 000
// values: the estimate's own relative spread is about sqrt(2 / 30000) =
// 0.8%; 5% is six of those.  Equal and unequal parts.
TEST(TruthNoise, EstimateIsTheVarianceOfTheMeanOfAllSamples) {
  for (const auto& [n1, n] : {std::pair{32, 64}, std::pair{3, 10}}) {
    Pcg32 rng(7, static_cast<uint64_t>(n1));
    auto gauss = [&] {
      const double u1 = std::max(1e-12, rng.NextDouble()), u2 = rng.NextDouble();
      return std::sqrt(-2 * std::log(u1)) * std::cos(kTwoPi * u2);
    };
    const int w = 100, h = 100;
    Image real = Image::Rgb(w, h), mixed = Image::Rgb(w, h), real_half = Image::Rgb(w, h),
          mixed_half = Image::Rgb(w, h);
    double expected = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          const double photo = 0.2 + 0.01 * c, d = -0.1 + 0.002 * x, sigma = 0.05 + 0.001 * y;
          // The mean of n1 samples and of the other n - n1, drawn as their sums.
          const double a = d + sigma * gauss() / std::sqrt(n1), b = d + sigma * gauss() / std::sqrt(n - n1);
          const double t = (n1 * a + (n - n1) * b) / n;
          real.at(x, y, c) = real_half.at(x, y, c) = static_cast<float>(photo);
          mixed_half.at(x, y, c) = static_cast<float>(photo + a);
          mixed.at(x, y, c) = static_cast<float>(photo + t);
          expected += sigma * sigma / n / ((photo + t) * (photo + t) + kRelMseEpsilon);
        }
    expected /= 3.0 * w * h;
    const TruthNoise noise = EstimateTruthNoise(mixed_half, real_half, mixed, real, n1, n);
    EXPECT_NEAR(noise.region_relmse / expected, 1.0, 0.05) << n1 << " of " << n;
    EXPECT_NEAR(noise.relmse, noise.region_relmse, 1e-12);  // every pixel changed
  }
  EXPECT_THROW(EstimateTruthNoise(Image::Rgb(2, 2), Image::Rgb(2, 2), Image::Rgb(2, 2), Image::Rgb(2, 2), 4, 4), Error);
}

// mr-synth's truth states its own noise, and pt's error against it falls as
// 1/spp down to it: a render at s spp and the n-spp truth are independent
// estimates of the same image, so the expected error is
// v/s + v/n = noise (n/s + 1), with v the per-sample variance (the same
// tracer).  Checked on the small capture with a diffuse table top, truth
// 64 spp, pt 1..64 spp: the error never under the stated noise (half of
// it: the estimates' own spread), at 64 spp between 1.2 and 5 times it (2
// ideally; pt's plate reflections lower its variance), and with the noise
// taken off the error falls by 8-32x from 1 to 16 spp (16 ideally).
// Measured 2026-12-03: noise 8.2e-4, 1.56x it at 64 spp, a fall of 14.8.
// With the glossy table top the sun's reflection in the table lights the
// room through caustic paths (camera -> wall or floor -> glossy table ->
// sun): rare samples thousands of times the mean, so that one seed's error
// rose from 32 to 64 spp (5.8e-3 to 1.1e-2; issue 22) -- a heavy tail no
// fixed number of samples can check.
TEST(TruthNoise, PtFallsAsOneOverSppDownToTheTruthsNoise) {
  test::TempDir dir;
  SynthOptions so;
  so.out = dir.path() / "cap";
  so.frames = 1;
  so.truth_spp = 64;
  so.probe = false;
  so.table_top = "diffuse";
  Report rs("mr-synth", "test");
  RunSynth(so, &rs);
  const double noise = rs.metrics()["truth_noise_region_relmse"];
  ASSERT_GT(noise, 0.0);
  EXPECT_LE(rs.metrics()["truth_noise_relmse"].get<double>(), noise);  // the unchanged pixels carry none
  RenderOptions o;
  o.spp = 64;
  o.out_dir = dir.path() / "pt";
  Report r("mr-render", "test");
  RunRenderJob(ReadScene(so.out / "scene.json"), o, &r);
  const Json& curve = r.metrics()["curve"];
  ASSERT_EQ(curve.size(), 7u);  // 1, 2, 4, ..., 64 spp
  std::string figures;
  for (const auto& c : curve)
    figures += fmt::format(" {}:{:.3g}", c["spp"].get<int>(), c["region_relmse"].get<double>());
  for (const auto& c : curve) EXPECT_GT(c["region_relmse"].get<double>(), 0.5 * noise) << figures;
  const double e1 = curve[0]["region_relmse"], e16 = curve[4]["region_relmse"], e64 = curve[6]["region_relmse"];
  EXPECT_GT(e64 / noise, 1.2) << "noise " << noise << figures;
  EXPECT_LT(e64 / noise, 5.0) << "noise " << noise << figures;
  const double fall = (e1 - noise) / (e16 - noise);
  EXPECT_GT(fall, 8.0) << "noise " << noise << figures;
  EXPECT_LT(fall, 32.0) << "noise " << noise << figures;
}

// --truth-region-spp: the object's region (found by a pilot of its own seed)
// takes 8x the samples.  Outside it the truth is the plain truth's, bit for
// bit (the same samples in the same order); inside, its stated noise falls
// by at least 4x (8x for independent samples, 1/N; stratified samples fall
// faster where the integrand is smooth, so up to 64x is accepted; the
// pilot's region and the scoring region, ChangedRegion, are not the same
// pixels; measured 25x) and it agrees with the plain
// truth within their joint noise (mean squared difference at most 3x the
// sum of both noise figures, each relMSE-normalised alike).  Small capture,
// diffuse table top (no caustic fireflies to dominate one of the figures).
TEST(TruthNoise, RegionSamplesConvergeTheObjectsRegionOnly) {
  test::TempDir dir;
  SynthOptions so;
  so.frames = 1;
  so.truth_spp = 32;
  so.probe = false;
  so.table_top = "diffuse";
  so.out = dir.path() / "plain";
  Report plain_report("mr-synth", "test");
  RunSynth(so, &plain_report);
  so.out = dir.path() / "region";
  so.truth_region_spp = 256;
  Report region_report("mr-synth", "test");
  RunSynth(so, &region_report);
  const double plain_noise = plain_report.metrics()["truth_noise_region_relmse"];
  const double region_noise = region_report.metrics()["truth_noise_region_relmse"];
  const double share = region_report.metrics()["truth_region_share"];
  EXPECT_GT(share, 0.05);
  EXPECT_LT(share, 0.95);
  EXPECT_GT(plain_noise / region_noise, 4.0) << plain_noise << " " << region_noise;
  EXPECT_LT(plain_noise / region_noise, 64.0) << plain_noise << " " << region_noise;

  const Image plain = ReadImage(dir.path() / "plain" / "truth" / "00000.exr");
  const Image region = ReadImage(dir.path() / "region" / "truth" / "00000.exr");
  const Image photo = ReadImage(dir.path() / "plain" / "photos" / "00000.exr");
  const Image changed = ChangedRegion(plain, photo);
  int64_t same = 0, differ = 0;
  double sum = 0;
  int64_t values = 0;
  for (int y = 0; y < plain.height(); ++y)
    for (int x = 0; x < plain.width(); ++x) {
      bool equal = true;
      for (int c = 0; c < 3; ++c) {
        equal &= plain.at(x, y, c) == region.at(x, y, c);
        if (changed.at(x, y, 0) > 0) {
          const double t = plain.at(x, y, c), d = t - region.at(x, y, c);
          sum += d * d / (t * t + kRelMseEpsilon);
          ++values;
        }
      }
      (equal ? same : differ)++;
    }
  // Pixels outside the grown pilot region are untouched: at least the
  // share the pilot left out.
  EXPECT_GE(static_cast<double>(same) / (same + differ), 1.0 - share - 1e-9) << same << " " << differ;
  ASSERT_GT(values, 0);
  EXPECT_LT(sum / values, 3 * (plain_noise + region_noise)) << plain_noise << " " << region_noise;

  so.out = dir.path() / "odd";
  so.truth_region_spp = 255;
  Report odd_report("mr-synth", "test");
  EXPECT_THROW(RunSynth(so, &odd_report), UsageError);
  so.truth_region_spp = 16;
  EXPECT_THROW(RunSynth(so, &odd_report), UsageError);
}

}  // namespace
}  // namespace render_job_test
}  // namespace mr
