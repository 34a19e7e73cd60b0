// The plate's radiometric fit (render/radiometry.h): per-frame gains with a
// calibrated uncertainty, robust to clipped, non-finite and outlying pixels,
// over any dynamic range; smoothing that keeps exposure jumps; the gains file.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/sampling.h"
#include "render/radiometry.h"
#include "test_util.h"

namespace mr {
namespace {

// A rendered room (values spread over two decades, scaled by `scale`), the
// plate g * I_r with multiplicative noise of `noise` (Gaussian), and a room
// mask covering all but a border.
struct Pair {
  Image plate, real, room;
};
Pair MakePair(const Rgb& g, double noise, uint64_t seed, double scale = 1, int w = 96, int h = 72) {
  Pair p{Image::Rgb(w, h), Image::Rgb(w, h), Image::Gray(w, h)};
  Pcg32 rng(seed, 7);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      p.room.at(x, y, 0) = x >= 2 && y >= 2 && x < w - 2 && y < h - 2;
      const double base = std::pow(10.0, -2 + 2 * rng.NextDouble()) * scale;
      for (int c = 0; c < 3; ++c) {
        const double albedo_tint = 0.6 + 0.4 * rng.NextDouble();
        const double r = base * albedo_tint;
        const double u1 = std::max(1e-12, rng.NextDouble()), u2 = rng.NextDouble();
        const double n = std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2);
        p.real.at(x, y, c) = static_cast<float>(r);
        p.plate.at(x, y, c) = static_cast<float>(g[c] * r * (1 + noise * n));
      }
    }
  return p;
}

// Noise of 10% per pixel over ~6600 pixels: the gain's standard error is
// about 0.1 / sqrt(6600) weighted by the values' spread, well under 1%.
// The fit is within 3 of its own standard errors and within 1% of the truth.
TEST(PlateGainFit, RecoversAKnownGainWithItsUncertainty) {
  const Rgb g{0.42, 0.61, 0.93};
  const Pair p = MakePair(g, 0.1, 1);
  const GainFit f = FitPlateGain(p.plate, p.real, p.room, nullptr);
  ASSERT_TRUE(f.ok) << f.why;
  for (int c = 0; c < 3; ++c) {
    EXPECT_GT(f.sigma[c], 0);
    EXPECT_LT(f.sigma[c] / g[c], 0.01);
    EXPECT_NEAR(f.gain[c], g[c], 3 * f.sigma[c]) << "channel " << c;
    EXPECT_NEAR(f.gain[c] / g[c], 1, 0.01);
  }
  EXPECT_EQ(f.room_pixels, 92 * 68);
  EXPECT_EQ(f.tiles, 64);
}

// The jackknife's standard error is calibrated: over 60 independent plates
// the truth lies within 2 standard errors of the fit in about 95% of
// channels (180 trials; at least 85% allows for the binomial spread,
// sd 1.6%, and the jackknife's own estimation noise with 64 blocks).
TEST(PlateGainFit, StandardErrorIsCalibrated) {
  const Rgb g{1.7, 1.1, 0.8};
  int within = 0, trials = 0;
  for (uint64_t seed = 1; seed <= 60; ++seed) {
    const Pair p = MakePair(g, 0.3, seed, 1, 64, 48);
    const GainFit f = FitPlateGain(p.plate, p.real, p.room, nullptr);
    ASSERT_TRUE(f.ok) << f.why;
    for (int c = 0; c < 3; ++c, ++trials) within += std::abs(f.gain[c] - g[c]) < 2 * f.sigma[c];
  }
  EXPECT_GE(within, trials * 85 / 100) << within << " of " << trials;
  EXPECT_LT(within, trials);  // an error bar that always covers is too wide to be one
}

// Stiff plates: clipped highlights (codes at 1: their plate value is the
// clip, far below g I_r), NaN and Inf in the plate and the render, and a
// patch the room model lacks (a poster: 5x brighter) leave the gain where it
// was; each is counted.
TEST(PlateGainFit, ClippedNonFiniteAndOutlyingPixelsAreLeftOut) {
  const Rgb g{0.5, 0.5, 0.5};
  Pair p = MakePair(g, 0.05, 3);
  Image codes = Image::Rgb(p.plate.width(), p.plate.height(), 0.5f);
  for (int y = 10; y < 30; ++y)
    for (int x = 10; x < 40; ++x)
      for (int c = 0; c < 3; ++c) {
        p.plate.at(x, y, c) = 1e-3f;  // what a clipped 8-bit pixel decodes to is unrelated to the render
        codes.at(x, y, c) = 1.0f;
      }
  p.plate.at(50, 50, 0) = NAN;
  p.real.at(51, 50, 1) = INFINITY;
  p.plate.at(52, 50, 2) = -INFINITY;
  for (int y = 40; y < 60; ++y)
    for (int x = 60; x < 80; ++x)
      for (int c = 0; c < 3; ++c) p.plate.at(x, y, c) *= 5;
  const GainFit f = FitPlateGain(p.plate, p.real, p.room, &codes);
  ASSERT_TRUE(f.ok) << f.why;
  EXPECT_EQ(f.clipped, 20 * 30);
  EXPECT_EQ(f.nonfinite, 3);
  EXPECT_GE(f.outliers, 20 * 20);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.gain[c] / g[c], 1, 0.01) << "channel " << c;
  // Without the clipping test the clipped pixels pull the gain down.
  const GainFit blind = FitPlateGain(p.plate, p.real, p.room, nullptr);
  ASSERT_TRUE(blind.ok);
  EXPECT_GT(blind.outliers, f.outliers);  // caught as outliers at best
}

// Dynamic range: rooms rendered at 1e-6 and at 1e6 (a dim render of a
// bright plate and the reverse) give their gains to the same relative
// accuracy; sums are in double.
TEST(PlateGainFit, GainsAcrossTwelveDecades) {
  for (const double scale : {1e-6, 1e6}) {
    const Rgb g{1 / scale, 2 / scale, 0.5 / scale};
    const Pair p = MakePair(g, 0.05, 4, scale);
    const GainFit f = FitPlateGain(p.plate, p.real, p.room, nullptr);
    ASSERT_TRUE(f.ok) << f.why;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.gain[c] / g[c], 1, 0.01) << "scale " << scale;
  }
}

// No room in view, or a black render: no fit, with the reason.
TEST(PlateGainFit, NoRoomNoFit) {
  Pair p = MakePair({1, 1, 1}, 0, 5);
  const Image none = Image::Gray(p.plate.width(), p.plate.height());
  GainFit f = FitPlateGain(p.plate, p.real, none, nullptr);
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.why.find("usable room pixels"), std::string::npos) << f.why;
  for (float& v : p.real.values()) v = 0;
  f = FitPlateGain(p.plate, p.real, p.room, nullptr);
  EXPECT_FALSE(f.ok);
}

std::vector<GainFit> Fits(const std::vector<double>& gains, double rel_noise, uint64_t seed) {
  Pcg32 rng(seed, 3);
  std::vector<GainFit> fits;
  for (double g : gains) {
    GainFit f;
    f.ok = true;
    for (int c = 0; c < 3; ++c) {
      const double u1 = std::max(1e-12, rng.NextDouble()), u2 = rng.NextDouble();
      f.gain[c] = g * (1 + rel_noise * std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2));
      f.sigma[c] = g * rel_noise;
    }
    fits.push_back(f);
  }
  return fits;
}

// An exposure that jumps by 1.6x between frames 9 and 10 (auto exposure
// after a light is switched on): the jump is found there and nowhere else,
// and smoothing (time constant 3 frames) reduces the per-frame noise (2%)
// on both sides without blending across it.
TEST(GainSmoothing, KeepsAnExposureJumpAndSmoothsTheRest) {
  std::vector<int> frames;
  std::vector<double> truth;
  for (int f = 0; f < 20; ++f) frames.push_back(f), truth.push_back(f < 10 ? 1.0 : 1.6);
  const std::vector<GainFit> fits = Fits(truth, 0.02, 9);
  const std::vector<FrameGain> s = SmoothGains(frames, fits, GainSmoothing{});
  double raw_err = 0, smooth_err = 0;
  for (int f = 0; f < 20; ++f) {
    EXPECT_EQ(s[f].jump_before, f == 10) << "frame " << f;
    for (int c = 0; c < 3; ++c) {
      raw_err += std::pow(fits[f].gain[c] / truth[f] - 1, 2);
      smooth_err += std::pow(s[f].gain[c] / truth[f] - 1, 2);
      EXPECT_NEAR(s[f].gain[c] / truth[f], 1, 0.03) << "frame " << f;  // no blending: would be off by up to 30%
      EXPECT_LT(s[f].sigma[c], fits[f].sigma[c]);
    }
  }
  EXPECT_LT(smooth_err, 0.5 * raw_err);
  // Without smoothing: the fits as they are.
  const std::vector<FrameGain> raw = SmoothGains(frames, fits, GainSmoothing{0, 1.15});
  for (int f = 0; f < 20; ++f) EXPECT_EQ(raw[f].gain, fits[f].gain);
}

// Frames without a fit (no room in view, or between --stride fits) take
// the gains of the fitted frames of their segment; one that lies past a
// jump takes the nearer side's.
TEST(GainSmoothing, UnfittedFramesTakeTheirNeighbours) {
  std::vector<int> frames;
  for (int f = 0; f < 9; ++f) frames.push_back(f);
  std::vector<GainFit> fits = Fits({1, 1, 1, 1, 1, 2, 2, 2, 2}, 0, 1);
  for (int f : {1, 4, 5, 8}) fits[static_cast<size_t>(f)] = GainFit{};
  const std::vector<FrameGain> s = SmoothGains(frames, fits, GainSmoothing{});
  EXPECT_NEAR(s[1].gain[0], 1, 1e-12);
  EXPECT_NEAR(s[4].gain[0], 1, 1e-12);  // nearer frame 3 (gain 1) than frame 6 (gain 2)
  EXPECT_NEAR(s[5].gain[0], 2, 1e-12);
  EXPECT_NEAR(s[8].gain[0], 2, 1e-12);
  EXPECT_TRUE(s[6].jump_before);
  EXPECT_FALSE(s[1].fitted);
  std::vector<GainFit> none(3);
  none[0].why = "no room";
  EXPECT_THROW(SmoothGains({0, 1, 2}, none, GainSmoothing{}), Error);
}

TEST(PlateGainsFile, RoundTripsAndRefusesBadFiles) {
  test::TempDir dir;
  std::vector<FrameGain> g(2);
  g[0].frame = 3;
  g[0].gain = {0.5, 0.25, 2e-7};
  g[1].frame = 7;
  g[1].gain = {1e6, 1, 1};
  g[1].jump_before = true;
  WritePlateGains(dir / "gains.json", g, "test");
  const std::vector<FrameGain> r = ReadPlateGains(dir / "gains.json");
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].gain, g[0].gain);
  EXPECT_EQ(r[1].frame, 7);
  EXPECT_TRUE(r[1].jump_before);
  for (
      const std::string bad :
      {R"({"version": 1, "kind": "mr-plate-gains", "frames": [{"frame": 0, "gain": [1, 0, 1]}]})",
       R"({"version": 1, "kind": "mr-plate-gains", "frames": [{"frame": 0, "gain": [1, 1]}]})",
       R"({"version": 1, "kind": "mr-plate-gains", "frames": [{"frame": 1, "gain": [1, 1, 1]}, {"frame": 1, "gain": [1, 1, 1]}]})",
       R"({"version": 1, "kind": "mr-plate-gains", "frames": [{"frame": 0, "gain": [1, 1, 1], "gian": 1}]})",
       R"({"version": 1, "kind": "mr-plate-gains", "frames": []})", R"({"version": 1, "kind": "lights"})"}) {
    WriteTextFile(dir / "bad.json", bad);
    try {
      ReadPlateGains(dir / "bad.json");
      ADD_FAILURE() << "accepted " << bad;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace mr
