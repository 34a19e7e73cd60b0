#include "probe/light_sequence.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/color.h"
#include "core/error.h"
#include "core/sampling.h"
#include "core/spherical.h"
#include "test_util.h"

namespace mr {
namespace {

// A 64x32 map (R G B confidence): a sky of 1 above the horizon, 0.2 below,
// confidence 1 everywhere.
Image SkyMap4(float sky = 1.0f) {
  Image m(64, 32, {"R", "G", "B", "confidence.Y"});
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 64; ++x) {
      const float v = y < 16 ? sky : 0.2f * sky;
      for (int c = 0; c < 3; ++c) m.at(x, y, c) = v;
      m.at(x, y, 3) = 1;
    }
  return m;
}

void Disc(Image* m, int cx, int cy, float v) {
  for (int y = cy - 1; y <= cy + 1; ++y)
    for (int x = cx - 1; x <= cx + 1; ++x)
      for (int c = 0; c < 3; ++c) m->at(x, y, c) = v;
}

TEST(LightTime, MatchesByNearestTimeWithDroppedAndDuplicatedFrames) {
  // Plate at 30 fps; the light video 5 ms late, frame 3 dropped, frame 5 duplicated.
  std::vector<double> plate, light;
  for (int i = 0; i < 8; ++i) plate.push_back(i / 30.0);
  for (int i = 0; i < 8; ++i) {
    if (i == 3) continue;
    light.push_back(i / 30.0 + 0.005);
    if (i == 5) light.push_back(i / 30.0 + 0.005);
  }
  const TimeMatch m = MatchLightToPlate(light, plate, 0.01, "light.txt", "trajectory.txt");
  ASSERT_EQ(m.light_of_plate.size(), 8u);
  EXPECT_EQ(m.light_of_plate[0], 0);
  EXPECT_EQ(m.light_of_plate[2], 2);
  EXPECT_EQ(m.light_of_plate[3], -1);  // dropped: nothing within 10 ms
  EXPECT_EQ(m.light_of_plate[4], 3);
  EXPECT_EQ(m.light_of_plate[5], 4);  // the earlier of the duplicated pair
  EXPECT_EQ(m.light_of_plate[6], 6);
  EXPECT_EQ(m.unmatched, 1);
  EXPECT_NEAR(m.max_dt_seen, 0.005, 1e-12);
  // With a wider gate the dropped frame takes a neighbour.
  EXPECT_GE(MatchLightToPlate(light, plate, 0.03, "l", "p").light_of_plate[3], 0);
}

TEST(LightTime, TimestampsThatDoNotOverlapAreAClearError) {
  const std::vector<double> plate = {100.0, 100.033, 100.066}, light = {0.0, 0.033, 0.066};
  try {
    MatchLightToPlate(light, plate, 0.02, "lightcam/frames.txt", "trajectory.txt");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("lightcam/frames.txt"), std::string::npos) << what;
    EXPECT_NE(what.find("no light frame lies within"), std::string::npos) << what;
    EXPECT_NE(what.find("100.0000"), std::string::npos) << what;
  }
  EXPECT_THROW(MatchLightToPlate({0.0, 0.1, 0.05}, plate, 0.02, "l", "p"), Error);  // backwards
  EXPECT_THROW(MatchLightToPlate({}, plate, 0.02, "l", "p"), Error);
}

// Sensor noise of 10% per direction, filtered with time constant tau at
// 30 fps: in steady state the filtered noise's variance is alpha / (2 -
// alpha) of the frame's (first-order recursive filter); alpha = 1 -
// exp(-1/3) = 0.283 gives a standard deviation of 0.41 x 10%.  Measured
// over 64x16 sky directions after 30 frames, within 15% of that.
TEST(LightFilter, SensorNoiseIsReducedAsTheTimeConstantSays) {
  LightFilterOptions o;
  o.time_constant_s = 0.1;
  LightFilter f(o);
  Image out;
  for (int i = 0; i < 30; ++i) {
    Image m = SkyMap4();
    Pcg32 rng(7, static_cast<uint64_t>(i));
    for (int64_t p = 0; p < m.pixel_count(); ++p)
      for (int c = 0; c < 3; ++c) {
        const double u1 = std::max(1e-12, rng.NextDouble()), u2 = rng.NextDouble();
        m.values()[static_cast<size_t>(p * 4 + c)] *=
            static_cast<float>(1 + 0.1 * std::sqrt(-2 * std::log(u1)) * std::cos(kTwoPi * u2));
      }
    LightFrameReport r;
    out = f.Add(m, i / 30.0, 1.0, &r);
    if (i > 0) {
      EXPECT_FALSE(r.jump) << "frame " << i << " jump fraction " << r.jump_fraction;
    }
  }
  double s2 = 0;
  int n = 0;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 64; ++x, ++n) s2 += (out.at(x, y, 1) - 1.0) * (out.at(x, y, 1) - 1.0);
  const double alpha = 1 - std::exp(-1.0 / 3.0);
  EXPECT_NEAR(std::sqrt(s2 / n), 0.1 * std::sqrt(alpha / (2 - alpha)), 0.15 * 0.1 * std::sqrt(alpha / (2 - alpha)));
}

// A lamp from off to 1e4 in one frame: the lamp's directions take the new
// frame unfiltered (exactly), the frame is reported as an abrupt change,
// and the sky around it stays filtered.  Then a sun of 1e6 moves by 4
// pixels per frame: no trail where it was.
TEST(LightFilter, ALampSwitchedOnAndAMovingSunBypassTheFilter) {
  LightFilterOptions o;
  o.time_constant_s = 0.5;
  LightFilter f(o);
  f.Add(SkyMap4(), 0, 1, nullptr);
  Image lamp = SkyMap4();
  Disc(&lamp, 40, 20, 1e4f);
  LightFrameReport r;
  Image out = f.Add(lamp, 1 / 30.0, 1, &r);
  EXPECT_TRUE(r.jump);
  EXPECT_GT(r.jump_fraction, 0.9);
  EXPECT_FLOAT_EQ(out.at(40, 20, 0), 1e4f);
  EXPECT_FLOAT_EQ(out.at(39, 19, 2), 1e4f);  // the disc's corner has 3 jumping neighbours
  EXPECT_FLOAT_EQ(out.at(10, 5, 1), 1.0f);
  // The same lamp next frame: nothing jumps.
  out = f.Add(lamp, 2 / 30.0, 1, &r);
  EXPECT_FALSE(r.jump);
  EXPECT_FLOAT_EQ(out.at(40, 20, 0), 1e4f);
  // A sun moving along the sky.
  for (int i = 0; i < 4; ++i) {
    Image sun = lamp;
    Disc(&sun, 10 + 4 * i, 8, 1e6f);
    out = f.Add(sun, (3 + i) / 30.0, 1, &r);
    EXPECT_FLOAT_EQ(out.at(10 + 4 * i, 8, 0), 1e6f) << i;
    if (i > 0) {
      EXPECT_TRUE(r.jump);
      EXPECT_FLOAT_EQ(out.at(10 + 4 * (i - 1), 8, 0), 1.0f) << "a trail where the sun was, frame " << i;
    }
  }
  // One hot pixel is noise: filtered, not let through.
  Image hot = lamp;
  for (int c = 0; c < 3; ++c) hot.at(50, 5, c) = 100;
  out = f.Add(hot, 7 / 30.0, 1, &r);
  EXPECT_LT(out.at(50, 5, 0), 100 * (1 - std::exp(-1.0 / 15.0)) + 1.01);
}

// Auto-exposure: the camera halves and triples its exposure while a lamp
// switches on in a small region; the recovered exposure is the camera's
// to 1e-6 (the median ignores the lamp), and the filtered map stays at the
// first frame's scale.  A cloud dimming the whole sky is (documented as)
// taken for an exposure change.
TEST(LightFilter, RecoversAutoExposureDespiteALamp) {
  LightFilterOptions o;
  o.recover_exposure = true;
  o.time_constant_s = 0.2;
  LightFilter f(o);
  f.Add(SkyMap4(), 0, 1, nullptr);
  const double k[] = {0.5, 3.0, 3.0};
  for (int i = 0; i < 3; ++i) {
    Image m = SkyMap4(static_cast<float>(k[i]));
    if (i >= 1) Disc(&m, 30, 20, static_cast<float>(50 * k[i]));
    LightFrameReport r;
    const Image out = f.Add(m, (i + 1) / 30.0, 1, &r);
    EXPECT_NEAR(r.exposure, k[i], 1e-6 * k[i]) << i;
    EXPECT_NEAR(out.at(5, 5, 1), 1.0, 1e-6);
    if (i >= 1) {
      EXPECT_NEAR(out.at(30, 20, 1), 50.0, 1e-4);
    }
  }
  // An exposure read from the file divides directly.
  LightFilterOptions plain;
  LightFilter g(plain);
  const Image first = g.Add(SkyMap4(4), 0, 4, nullptr);
  EXPECT_FLOAT_EQ(first.at(3, 3, 0), 1.0f);
}

// Directions this frame does not see keep the last frame's light; a frame
// that sees a direction far less well than before keeps the history there;
// NaN in a frame is unseen, not propagated.
TEST(LightFilter, UnseenDirectionsAreFilledFromEarlierFrames) {
  LightFilterOptions o;
  o.time_constant_s = 0;
  LightFilter f(o);
  Image a = SkyMap4();
  for (int y = 0; y < 32; ++y)
    for (int x = 32; x < 64; ++x) a.at(x, y, 3) = 0;  // the first frame sees the west half
  Image out = f.Add(a, 0, 1, nullptr);
  EXPECT_EQ(out.at(40, 4, 3), 0.0f);
  Image b = SkyMap4(2);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) b.at(x, y, 3) = x < 16 ? 0.0f : 0.1f;  // west: unseen, or barely
  b.at(50, 4, 0) = std::numeric_limits<float>::quiet_NaN();
  LightFrameReport r;
  out = f.Add(b, 1 / 30.0, 1, &r);
  EXPECT_FLOAT_EQ(out.at(5, 4, 0), 1.0f);   // unseen now: the first frame's
  EXPECT_FLOAT_EQ(out.at(20, 4, 0), 1.0f);  // seen at a tenth the confidence: history
  EXPECT_FLOAT_EQ(out.at(20, 4, 3), 1.0f);
  EXPECT_FLOAT_EQ(out.at(40, 4, 0), 2.0f);  // first seen now
  EXPECT_EQ(out.at(50, 4, 0), 0.0f);        // NaN: unseen, never seen before
  EXPECT_NEAR(r.filled_fraction, 0.5, 1e-9);
  EXPECT_NEAR(r.seen_fraction, 0.75, 0.01);
  EXPECT_THROW(f.Add(b, 0, 1, nullptr), Error);  // back in time
  EXPECT_THROW(f.Add(SkyMap4(), 1, 0, nullptr), Error);
  EXPECT_THROW(f.Add(Image::Rgb(64, 32), 1, 1, nullptr), Error);
}

}  // namespace
}  // namespace mr
