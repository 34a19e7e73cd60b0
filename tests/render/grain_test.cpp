// The plate's grain (render/grain.h): noise measured as a function of
// intensity from textured, noisy plates; flat and noise-free plates; grain
// added deterministically and only where asked.
#include "render/grain.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/sampling.h"

namespace mr {
namespace {

double Gauss(Pcg32& rng) {
  const double u1 = std::max(1e-300, rng.NextDouble()), u2 = rng.NextDouble();
  return std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2);
}

// Signal-dependent noise, as a sensor's: shot noise grows with the signal.
double TrueSigma(double code) { return (0.5 + 3 * code) / 255; }

// A plate: a smooth ramp over [0.05, 0.95] with textured stripes over a
// third of it (texture must not read as noise) and noise TrueSigma.
Image Plate(uint64_t seed, int w = 320, int h = 240) {
  Image img = Image::Rgb(w, h);
  Pcg32 rng(seed, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double base = 0.05 + 0.9 * x / (w - 1.0);
      if (y < h / 3) base += 0.04 * std::sin(x * 0.9) * std::cos(y * 0.7);  // texture
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = static_cast<float>(base + TrueSigma(base) * Gauss(rng));
    }
  return img;
}

// Over two frames of 320x240 each bin holds ~140 patches; the lower
// quartile of 64-pixel patches' RMS has a relative spread of ~2% there, and
// its bias under pure noise is divided out: within 12% of the truth in every
// bin the ramp covers (the texture raises a third of the patches, which the
// quartile tolerates), where ignoring the texture would give up to 3x.
TEST(Grain, EstimatesSignalDependentNoiseDespiteTexture) {
  const NoiseProfile p = EstimateNoise({Plate(1), Plate(2)});
  EXPECT_GT(p.patches_used, 3000);
  for (int b = 1; b < NoiseProfile::kBins - 1; ++b) {
    const double code = (b + 0.5) / NoiseProfile::kBins;
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(p.At(c, code) / TrueSigma(code), 1, 0.12) << "bin " << b << " channel " << c;
  }
}

// A flat grey plate (one bin measured): its noise everywhere; a noise-free
// one: zero, and grain from it changes nothing (and makes no NaN).
TEST(Grain, FlatGreyPlates) {
  Image grey = Image::Rgb(256, 192);
  Pcg32 rng(3, 1);
  for (float& v : grey.values()) v = static_cast<float>(0.5 + 2.0 / 255 * Gauss(rng));
  const NoiseProfile p = EstimateNoise({grey});
  for (double code : {0.0, 0.25, 0.5, 1.0}) EXPECT_NEAR(p.At(1, code) * 255, 2.0, 0.2) << code;
  Image clean = Image::Rgb(256, 192, 0.5f);
  const NoiseProfile zero = EstimateNoise({clean});
  for (double code : {0.0, 0.5, 1.0}) EXPECT_EQ(zero.At(0, code), 0.0);
  Image copy = clean;
  AddGrain(zero, Image::Gray(256, 192, 1.0f), 1, 0, &copy);
  EXPECT_EQ(copy.values(), clean.values());
  // A fully clipped plate measures nothing: zero, not NaN.
  const NoiseProfile clipped = EstimateNoise({Image::Rgb(64, 64, 1.0f)});
  EXPECT_EQ(clipped.patches_used, 0);
  EXPECT_EQ(clipped.At(2, 0.9), 0.0);
}

// Grain added to a noise-free render under a full mask measures as the
// profile it came from; pixels of weight 0 keep their values exactly; the
// same (seed, frame) gives the same bytes, another frame other grain.
TEST(Grain, AddedGrainMatchesTheProfileAndStaysInItsMask) {
  const NoiseProfile p = EstimateNoise({Plate(4), Plate(5)});
  Image render = Image::Rgb(320, 240);
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x)
      for (int c = 0; c < 3; ++c) render.at(x, y, c) = static_cast<float>(0.05 + 0.9 * x / 319.0);
  Image mask = Image::Gray(320, 240, 1.0f);
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 16; ++x) mask.at(x, y, 0) = 0;
  Image a = render, b = render, c = render;
  AddGrain(p, mask, 7, 3, &a);
  AddGrain(p, mask, 7, 3, &b);
  AddGrain(p, mask, 7, 4, &c);
  EXPECT_EQ(a.values(), b.values());
  EXPECT_NE(a.values(), c.values());
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 16; ++x) ASSERT_EQ(a.at(x, y, 1), render.at(x, y, 1));
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 16; ++x)
      for (int ch = 0; ch < 3; ++ch) a.at(x, y, ch) = b.at(x, y, ch) = 0.5f;  // unmasked strip: not measured
  const NoiseProfile q = EstimateNoise({a});
  for (int bin = 2; bin < NoiseProfile::kBins - 1; ++bin) {
    const double code = (bin + 0.5) / NoiseProfile::kBins;
    EXPECT_NEAR(q.At(1, code) / p.At(1, code), 1, 0.15) << "bin " << bin;
  }
  // A half-covered pixel gets sqrt(1 - 0.5^2) of the noise: its plate half
  // carries the rest.
  Image half = render, full = render;
  AddGrain(p, Image::Gray(320, 240, 0.5f), 7, 3, &half);
  AddGrain(p, Image::Gray(320, 240, 1.0f), 7, 3, &full);
  const double d_half = half.at(100, 100, 0) - render.at(100, 100, 0),
               d_full = full.at(100, 100, 0) - render.at(100, 100, 0);
  EXPECT_NEAR(d_half / d_full, std::sqrt(0.75), 1e-5);
}

}  // namespace
}  // namespace mr
