// Textures of assets (issue 38): an image's texels kept as codes in their
// own encoding (sRGB or linear, per the glTF specification: base colour and
// emission sRGB, the others linear; alpha always linear) with a mip-map
// chain, and filtered lookups that decode before they filter.
//
// The rule (docs/methods.md, "Asset textures"): a lookup at uv with a
// footprint w (the width in uv units of what the lookup stands for: a
// pixel's cone or a ray differential, the caller's choice) reads mip level
// log2(w x max(width, height)), bilinear within a level and linear between
// the two levels around it (trilinear); w = 0 reads level 0 bilinearly.
// Levels halve each side (odd sides round up, their last texel repeated),
// averaging in linear values; every level down to 1 x 1.  Storage: the
// file's own depth (1 byte a channel for 8-bit files, 2 for 16-bit and
// float ones), 4/3 of the level 0 in all; levels built in parallel.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "geometry/asset.h"

namespace mr {

enum class TextureEncoding { kSrgb, kLinear };

class Texture {
 public:
  Texture() = default;
  // `coded`: the file's values scaled to [0, 1] without any transfer
  // (ImageReadOptions with use_file_transfer false, default linear), 1 to 4
  // channels (grey, grey-alpha, RGB, RGBA).
  // Stored at 16 bits.
  Texture(const Image& coded, TextureEncoding encoding, std::string name);
  // `coded` as ReadImageCodes gives it (8 or 16 bits), kept at its depth.
  Texture(ImageCodes coded, TextureEncoding encoding, std::string name);

  // Linear RGBA at uv (v = 0 at the image's top row, glTF's convention),
  // wrapped per axis.  Grey repeats into RGB; a missing alpha is 1.
  Eigen::Vector4f Sample(const Eigen::Vector2f& uv, float footprint, TextureWrap wrap_s = TextureWrap::kRepeat,
                         TextureWrap wrap_t = TextureWrap::kRepeat) const;

  int width() const { return levels_.empty() ? 0 : levels_[0].width; }
  int height() const { return levels_.empty() ? 0 : levels_[0].height; }
  int levels() const { return static_cast<int>(levels_.size()); }
  int channels() const { return channels_; }
  int bits() const { return bits_; }
  size_t bytes() const;  // every level's texels
  const std::string& name() const { return name_; }

 private:
  struct Level {
    int width = 0, height = 0;
    std::vector<uint8_t> texels;  // channels_ codes a texel of bits_ bits (native order), row 0 at the top
  };
  Eigen::Vector4f Texel(const Level& l, int x, int y) const;
  Eigen::Vector4f Bilinear(const Level& l, const Eigen::Vector2f& uv, TextureWrap ws, TextureWrap wt) const;
  std::vector<Level> levels_;
  int channels_ = 0, bits_ = 16;
  TextureEncoding encoding_ = TextureEncoding::kLinear;
  std::string name_;
};

// uv through KHR_texture_transform: offset + Rotation(rotation) (scale .* uv),
// as the extension defines it (rotation counter-clockwise in uv).
Eigen::Vector2f TransformUv(const AssetTexture& t, const Eigen::Vector2f& uv);

// An asset's image read into a texture: its file, or its bytes (written to
// a temporary file and read by the same checked reader as every image).
// mr::Error naming the asset and the image when it is not a readable image.
Texture LoadAssetTexture(const AssetImage& image, TextureEncoding encoding, const std::string& asset);

}  // namespace mr
