#include "render/texture.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/color.h"
#include "core/error.h"

namespace mr {
namespace {

Image Coded(int w, int h, int channels, const std::vector<float>& values) {
  const std::vector<std::string> names[] = {{"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
  Image img(w, h, names[channels - 1]);
  img.values() = values;
  return img;
}

// A black-and-white checker of 2 x 2 texels, sRGB-coded.
Texture Checker(TextureEncoding e = TextureEncoding::kSrgb) {
  return Texture(Coded(2, 2, 1, {0, 1, 1, 0}), e, "checker");
}

TEST(Texture, TexelCentresAreExactAndDecoded) {
  const Texture t(Coded(2, 1, 3, {0.5f, 0.25f, 1, 0, 0, 0}), TextureEncoding::kSrgb, "t");
  const Eigen::Vector4f c = t.Sample({0.25f, 0.5f}, 0);
  EXPECT_NEAR(c[0], SrgbToLinear(0.5f), 1e-4);  // 16-bit codes: within 1/65535 before decoding
  EXPECT_NEAR(c[1], SrgbToLinear(0.25f), 1e-4);
  EXPECT_NEAR(c[2], 1, 1e-6);
  EXPECT_EQ(c[3], 1);  // no alpha channel: opaque
  const Texture lin(Coded(1, 1, 2, {0.5f, 0.25f}), TextureEncoding::kLinear, "grey-alpha");
  const Eigen::Vector4f g = lin.Sample({0.9f, 0.1f}, 0);
  EXPECT_NEAR(g[0], 0.5, 1e-4);
  EXPECT_NEAR(g[2], 0.5, 1e-4);   // grey repeats into RGB
  EXPECT_NEAR(g[3], 0.25, 1e-4);  // alpha is never sRGB-decoded
}

// A footprint covering the texture reads the 1 x 1 level: the average of
// the decoded values (0.5 of black and white, not sRGB's mid grey code).
TEST(Texture, WideFootprintIsTheLinearAverage) {
  const Texture t = Checker();
  ASSERT_EQ(t.levels(), 2);
  const Eigen::Vector4f c = t.Sample({0.3f, 0.8f}, 1.0f);
  EXPECT_NEAR(c[0], 0.5, 2e-3);  // re-encoded to 16-bit sRGB and back
  // Between levels: half way in log2 footprint, half of each.
  const Eigen::Vector4f at_texel = t.Sample({0.25f, 0.25f}, 0);
  const Eigen::Vector4f mid = t.Sample({0.25f, 0.25f}, std::sqrt(2.0f) / 2);
  EXPECT_NEAR(mid[0], 0.5f * at_texel[0] + 0.25f, 2e-3);
}

TEST(Texture, WrapModes) {
  const Texture t(Coded(4, 1, 1, {0, 0.25f, 0.5f, 1}), TextureEncoding::kLinear, "ramp");
  auto at = [&](float u, TextureWrap w) { return t.Sample({u, 0.5f}, 0, w, w)[0]; };
  EXPECT_NEAR(at(1.125f, TextureWrap::kRepeat), 0, 1e-4);   // texel 0 again
  EXPECT_NEAR(at(-0.125f, TextureWrap::kRepeat), 1, 1e-4);  // the last texel
  EXPECT_NEAR(at(1.5f, TextureWrap::kClamp), 1, 1e-4);
  EXPECT_NEAR(at(-3.0f, TextureWrap::kClamp), 0, 1e-4);
  EXPECT_NEAR(at(1.125f, TextureWrap::kMirror), 1, 1e-4);  // mirrored: the last texel first
  EXPECT_NEAR(at(1.875f, TextureWrap::kMirror), 0, 1e-4);
  EXPECT_TRUE(t.Sample({NAN, 0.5f}, 0).head<3>().isZero());  // non-finite uv: black, not a crash
}

// Extreme sizes: 1 x 1, and 16384 x 1 whose chain runs to 1 x 1 (15 halvings).
TEST(Texture, OneTexelAndSixteenKWide) {
  const Texture one(Coded(1, 1, 3, {0.2f, 0.4f, 0.6f}), TextureEncoding::kLinear, "one");
  EXPECT_EQ(one.levels(), 1);
  EXPECT_NEAR(one.Sample({-7.3f, 12.1f}, 5)[1], 0.4, 1e-4);
  std::vector<float> ramp(16384);
  for (size_t i = 0; i < ramp.size(); ++i) ramp[i] = static_cast<float>(i) / 16383;
  const Texture wide(Coded(16384, 1, 1, ramp), TextureEncoding::kLinear, "wide");
  EXPECT_EQ(wide.levels(), 15);
  EXPECT_NEAR(wide.Sample({0.5f, 0.5f}, 1)[0], 0.5, 1e-3);  // the whole ramp's mean
  EXPECT_NEAR(wide.Sample({(1000 + 0.5f) / 16384, 0.5f}, 0)[0], 1000.0 / 16383, 1e-4);
  EXPECT_EQ(wide.bytes(), (16384u + 8192 + 4096 + 2048 + 1024 + 512 + 256 + 128 + 64 + 32 + 16 + 8 + 4 + 2 + 1) * 2);
}

// An 8-bit file stays 8-bit (half the memory of 16-bit codes) and decodes
// to exactly what the file holds; its mip levels are the linear average
// coded back to the nearest 8-bit sRGB code, as round(255 LinearToSrgb(v)).
TEST(Texture, EightBitFilesKeepTheirCodes) {
  const fs::path png = fs::path(MR_SOURCE_DIR) / "tests/data/assets/blender/checker.png";
  const Texture t = LoadAssetTexture({.name = "checker.png", .file = png}, TextureEncoding::kSrgb, "blender.gltf");
  EXPECT_EQ(t.bits(), 8);
  EXPECT_EQ(t.bytes(), (16u * 16 + 8 * 8 + 4 * 4 + 2 * 2 + 1) * static_cast<size_t>(t.channels()));
  ImageReadOptions raw;
  raw.use_file_transfer = false;
  raw.default_ldr_transfer = Transfer::kLinear;
  const Image codes = ReadImage(png, raw);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      const Eigen::Vector4f c = t.Sample({(x + 0.5f) / 16, (y + 0.5f) / 16}, 0);
      ASSERT_NEAR(c[0], SrgbToLinear(codes.at(x, y, 0)), 1e-6) << x << " " << y;
    }
  for (int a = 0; a < 256; a += 3)
    for (int b = 0; b < 256; b += 5) {
      ImageCodes pair{2, 1, 1, 8, {static_cast<uint8_t>(a), static_cast<uint8_t>(b)}};
      const Texture p(std::move(pair), TextureEncoding::kSrgb, "pair");
      const float mean = 0.5f * (SrgbToLinear(a / 255.0f) + SrgbToLinear(b / 255.0f));
      const float want = SrgbToLinear(std::round(255 * LinearToSrgb(mean)) / 255);
      ASSERT_NEAR(p.Sample({0.5f, 0.5f}, 1)[0], want, 1e-6) << a << " " << b;
    }
}

// KHR_texture_transform: offset, rotation (counter-clockwise in uv, v down)
// and scale, in that order of application: scale, rotate, offset.
TEST(Texture, TextureTransformAsTheExtensionDefines) {
  AssetTexture t;
  t.offset = {0.5f, 0.25f};
  t.scale = {2, 3};
  t.rotation = static_cast<float>(M_PI / 2);
  const Eigen::Vector2f uv = TransformUv(t, {1, 0});  // scaled (2, 0), rotated to (0, -2)
  EXPECT_NEAR(uv.x(), 0.5, 1e-6);
  EXPECT_NEAR(uv.y(), 0.25 - 2, 1e-6);
  EXPECT_TRUE(TransformUv(AssetTexture(), {0.3f, 0.7f}).isApprox(Eigen::Vector2f(0.3f, 0.7f)));
}

TEST(Texture, AssetImagesFromFilesAndBytes) {
  const fs::path png = fs::path(MR_SOURCE_DIR) / "tests/data/assets/blender/checker.png";
  const Texture a = LoadAssetTexture({.name = "checker.png", .file = png}, TextureEncoding::kSrgb, "blender.gltf");
  EXPECT_EQ(a.width(), 16);
  EXPECT_EQ(a.levels(), 5);
  const Asset glb = ReadAsset(fs::path(MR_SOURCE_DIR) / "tests/data/assets/blender/blender.glb");
  for (const AssetImage& im : glb.images) {
    const Texture t = LoadAssetTexture(im, TextureEncoding::kLinear, "blender.glb");
    EXPECT_EQ(t.width(), 16) << im.name;
  }
  AssetImage bad{.name = "image 0 (embedded)", .bytes = {1, 2, 3, 4}};
  try {
    LoadAssetTexture(bad, TextureEncoding::kSrgb, "x.glb");
    FAIL() << "4 bytes decoded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("x.glb: image 0 (embedded)"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mr
