// Registration in pixels (eval/registration.h): the displacement between a
// rendered room and the plate, measured by flow on locally normalised
// images, against known shifts; a textureless frame says it cannot be
// measured; the swim of a point against the plate's own motion.
#include "eval/registration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mr {
namespace {

// A smooth texture: 60 sinusoids of wavelengths 6 to 40 px, evaluated at
// (x - dx, y - dy) (its content moved by (dx, dy)), times `gain` plus
// `offset` per channel (the plate's other exposure and white balance).
Image Texture(int w, int h, double dx, double dy, const Eigen::Vector3d& gain, double offset) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  struct Wave {
    double kx, ky, phase, amp;
  };
  std::vector<Wave> waves;
  for (int i = 0; i < 60; ++i) {
    const double lambda = 6 + 34 * u(rng), theta = 6.2831853 * u(rng);
    waves.push_back(
        {std::cos(theta) * 6.2831853 / lambda, std::sin(theta) * 6.2831853 / lambda, 6.2831853 * u(rng), 0.5 + u(rng)});
  }
  Image img(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double v = 0;
      for (const Wave& wv : waves) v += wv.amp * std::sin(wv.kx * (x - dx) + wv.ky * (y - dy) + wv.phase);
      const double g = 1 + 0.04 * v;  // positive radiance around 1
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = static_cast<float>(gain[c] * g + offset);
    }
  return img;
}

Image All(int w, int h) { return Image(w, h, {"Y"}, 1.0f); }

// A known shift of (2.5, -1.25) px with the plate 1.7 x brighter and
// tinted: the mean displacement within 0.1 px of it (DIS's sub-pixel
// refinement on a smooth texture; measured 0.01-0.03 px); with no shift,
// under 0.1 px.  A few NaN pixels in the plate are left out.
TEST(Registration, MeasuresAKnownShiftInPixels) {
  const int w = 320, h = 240;
  const Image rendered = Texture(w, h, 0, 0, Eigen::Vector3d::Ones(), 0);
  Image plate = Texture(w, h, 2.5, -1.25, Eigen::Vector3d(1.7, 1.5, 1.2), 0.05);
  for (int k = 0; k < 20; ++k) plate.at(10 + 7 * k, 50, 0) = std::nanf("");
  const RegistrationResult r = MeasureRegistration(rendered, plate, All(w, h));
  ASSERT_TRUE(r.measurable) << r.why;
  std::printf("shift (2.5, -1.25): measured (%.3f, %.3f), mean %.3f px, p90 %.3f, stderr %.4f, %lld usable of %lld\n",
              r.mean_flow.x(), r.mean_flow.y(), r.mean_px, r.p90_px, r.stderr_px,
              static_cast<long long>(r.usable_pixels), static_cast<long long>(r.region_pixels));
  EXPECT_NEAR(r.mean_flow.x(), 2.5, 0.1);
  EXPECT_NEAR(r.mean_flow.y(), -1.25, 0.1);
  EXPECT_NEAR(r.mean_px, std::hypot(2.5, 1.25), 0.1);
  EXPECT_GT(r.usable_pixels, w * h / 4);  // the texture test keeps about a third of a smooth texture
  const RegistrationResult same =
      MeasureRegistration(rendered, Texture(w, h, 0, 0, Eigen::Vector3d(2, 2, 2), 0), All(w, h));
  ASSERT_TRUE(same.measurable);
  EXPECT_LT(same.mean_px, 0.1);
  // Only where the room is: the region outside is not looked at.
  Image left = Image(w, h, {"Y"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w / 2; ++x) left.at(x, y, 0) = 1;
  const RegistrationResult half = MeasureRegistration(rendered, plate, left);
  EXPECT_LT(half.region_pixels, w * h / 2 + 1);
  EXPECT_NEAR(half.mean_flow.x(), 2.5, 0.1);
}

// A textureless wall (a smooth ramp: no edges, no texture) cannot be
// registered: not measurable, and the reason says so.
TEST(Registration, ATexturelessFrameSaysSo) {
  const int w = 160, h = 120;
  Image ramp(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) ramp.at(x, y, c) = 0.5f + 0.001f * static_cast<float>(x);
  const RegistrationResult r = MeasureRegistration(ramp, ramp, All(w, h));
  EXPECT_FALSE(r.measurable);
  EXPECT_EQ(r.why.rfind("textureless", 0), 0u) << r.why;
  EXPECT_EQ(r.ToJson()["measurable"], false);
}

// The swim: a point whose projection the poses move exactly as the plate's
// content moved has none; one the poses hold still while the plate moves
// swims by the plate's motion.
TEST(Registration, SwimIsThePosesMotionLessThePlates) {
  const int w = 320, h = 240;
  const std::vector<Eigen::Vector2f> flow =
      PlateFlow(Texture(w, h, 0, 0, Eigen::Vector3d::Ones(), 0), Texture(w, h, 3, 1, Eigen::Vector3d::Ones(), 0));
  const Eigen::Vector2d at(160, 120);
  EXPECT_LT(Swim(flow, w, h, at, at + Eigen::Vector2d(3, 1)), 0.1);
  EXPECT_NEAR(Swim(flow, w, h, at, at), std::hypot(3.0, 1.0), 0.1);
  EXPECT_TRUE(std::isnan(Swim(flow, w, h, Eigen::Vector2d(-5, 10), at)));
}

}  // namespace
}  // namespace mr
