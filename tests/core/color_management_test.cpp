// Plates through OpenColorIO (core/color_management.h) with mr's config
// (ocio/mr.ocio): codes decoded to the working space and encoded back are
// the same codes, at 8 and 10 bits, for sRGB, linear, ACEScg and a camera
// log; bad spaces are refused naming the key.
#include "core/color_management.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/file.h"
#include "test_util.h"

namespace mr {
namespace {

const char* kWorking = "Linear Rec.709 (sRGB)";

// Every grey and a lattice of colours, at 8 and 10 bits: decode, encode,
// quantise: the same code.  The worst float error is printed (measured
// 2e-2 codes at 10 bits for the logs: OpenColorIO's float32 curves).
TEST(ColorManagement, CodesRoundTripExactlyAt8And10Bits) {
  for (const char* space : {"sRGB - Texture", "Linear Rec.709 (sRGB)", "ACEScg", "S-Log3 S-Gamut3",
                            "ARRI LogC3 (EI800) AWG", "V-Log V-Gamut", "ACEScct"}) {
    const ColorTransform decode("", space, kWorking, "camera.frames_colorspace");
    const ColorTransform encode("", kWorking, space, "camera.frames_colorspace");
    for (int bits : {8, 10}) {
      const int n = (1 << bits) - 1, step = bits == 8 ? 17 : 33;
      double worst = 0;
      int64_t wrong = 0;
      auto check = [&](int r, int g, int b) {
        float px[3] = {static_cast<float>(r) / n, static_cast<float>(g) / n, static_cast<float>(b) / n};
        decode.ApplyRgb(px);
        encode.ApplyRgb(px);
        const int q[3] = {r, g, b};
        for (int c = 0; c < 3; ++c) {
          worst = std::max(worst, std::abs(static_cast<double>(px[c]) * n - q[c]));
          wrong += std::lround(px[c] * n) != q[c];
        }
      };
      for (int v = 0; v <= n; ++v) check(v, v, v);
      for (int r = 0; r <= n; r += step)
        for (int g = 0; g <= n; g += step)
          for (int b = 0; b <= n; b += step) check(r, g, b);
      std::printf("%s, %d bits: worst %.2e codes\n", space, bits, worst);
      EXPECT_EQ(wrong, 0) << space << " " << bits;
    }
  }
}

// The decodings are what the spaces define: sRGB's curve at 0.5 (0.214),
// S-Log3's 18% grey at code 420 of 1023, ACEScg's white is white.
TEST(ColorManagement, DecodingsMatchTheSpacesDefinitions) {
  float s[3] = {0.5f, 0.5f, 0.5f};
  ColorTransform("", "sRGB - Texture", kWorking, "k").ApplyRgb(s);
  EXPECT_NEAR(s[0], std::pow((0.5 + 0.055) / 1.055, 2.4), 1e-5);
  float g[3] = {420.0f / 1023, 420.0f / 1023, 420.0f / 1023};
  ColorTransform("", "S-Log3 S-Gamut3", kWorking, "k").ApplyRgb(g);
  for (float v : g) EXPECT_NEAR(v, 0.18, 2e-3);
  float w[3] = {1, 1, 1};
  ColorTransform("", "ACEScg", kWorking, "k").ApplyRgb(w);
  for (float v : w) EXPECT_NEAR(v, 1.0, 1e-3);
}

TEST(ColorManagement, AnUnknownSpaceNamesTheKeyAndTheConfigsSpaces) {
  try {
    ColorTransform("", "S-Log9", kWorking, "camera.frames_colorspace");
    FAIL() << "an unknown space was accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("camera.frames_colorspace"), std::string::npos) << m;
    EXPECT_NE(m.find("\"S-Log9\""), std::string::npos) << m;
    EXPECT_NE(m.find("\"S-Log3 S-Gamut3\""), std::string::npos) << m;  // what it has
  }
}

// A user's config whose plate space has no inverse (a singular matrix):
// decoding builds, encoding cannot, and the transform is refused when it
// is made (mr-render makes both before reading any frame).
TEST(ColorManagement, ASpaceWhoseInverseIsUndefinedIsRefused) {
  test::TempDir dir;
  std::string config = MrOcioConfig();
  config += R"(
  - !<ColorSpace>
    name: Flattened
    family: Test
    encoding: scene-linear
    to_scene_reference: !<MatrixTransform> {matrix: [1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1]}
)";
  WriteTextFile(dir / "user.ocio", config);
  const std::string path = (dir / "user.ocio").string();
  EXPECT_NO_THROW(ColorTransform(path, "Flattened", kWorking, "camera.frames_colorspace"));
  try {
    ColorTransform(path, kWorking, "Flattened", "camera.frames_colorspace");
    FAIL() << "a transform without an inverse was built";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("camera.frames_colorspace"), std::string::npos) << m;
    EXPECT_NE(m.find("user.ocio"), std::string::npos) << m;
  }
  // A file that is no config at all.
  WriteTextFile(dir / "bad.ocio", "ocio_profile_version: 2.1\ncolorspaces: [oops\n");
  EXPECT_THROW(ColorTransform((dir / "bad.ocio").string(), "ACEScg", kWorking, "camera.ocio_config"), Error);
}

}  // namespace
}  // namespace mr
