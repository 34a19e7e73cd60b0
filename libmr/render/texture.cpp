#include "render/texture.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <fstream>

#include "core/color.h"
#include "core/error.h"
#include "core/parallel.h"

namespace mr {

namespace {

// sRGB codes of `bits` bits to linear, once each.
const std::vector<float>& SrgbTable(int bits) {
  auto make = [](int n) {
    std::vector<float> v(static_cast<size_t>(n));
    for (size_t i = 0; i < v.size(); ++i) v[i] = SrgbToLinear(static_cast<float>(i) / static_cast<float>(n - 1));
    return v;
  };
  static const std::vector<float> t8 = make(256), t16 = make(65536);
  return bits == 8 ? t8 : t16;
}

// Linear values to 8-bit sRGB codes: the code is the number of thresholds
// (the linear values halfway between codes) below v, which is
// round(255 LinearToSrgb(v)) without a power per value.
uint8_t SrgbCode8(float v) {
  static const std::array<float, 255> thresholds = [] {
    std::array<float, 255> t{};
    for (size_t k = 0; k < t.size(); ++k) t[k] = SrgbToLinear((static_cast<float>(k) + 0.5f) / 255.0f);
    return t;
  }();
  return static_cast<uint8_t>(std::upper_bound(thresholds.begin(), thresholds.end(), v) - thresholds.begin());
}

// Integer texel coordinate i wrapped into [0, n).
int Wrap(int i, int n, TextureWrap w) {
  switch (w) {
    case TextureWrap::kClamp:
      return std::clamp(i, 0, n - 1);
    case TextureWrap::kMirror: {
      const int period = 2 * n, m = ((i % period) + period) % period;
      return m < n ? m : period - 1 - m;
    }
    default:
      return ((i % n) + n) % n;
  }
}

}  // namespace

namespace {

ImageCodes Codes16(const Image& coded) {
  ImageCodes c{coded.width(), coded.height(), coded.channels(), 16, {}};
  c.bytes.resize(coded.values().size() * 2);
  auto* out = reinterpret_cast<uint16_t*>(c.bytes.data());
  for (size_t i = 0; i < coded.values().size(); ++i)
    out[i] = static_cast<uint16_t>(std::lround(std::clamp(coded.values()[i], 0.0f, 1.0f) * 65535.0f));
  return c;
}

}  // namespace

Texture::Texture(const Image& coded, TextureEncoding encoding, std::string name)
    : Texture(Codes16(coded), encoding, std::move(name)) {}

Texture::Texture(ImageCodes coded, TextureEncoding encoding, std::string name)
    : channels_(coded.channels), bits_(coded.bits), encoding_(encoding), name_(std::move(name)) {
  MR_CHECK(channels_ >= 1 && channels_ <= 4 && coded.width > 0 && coded.height > 0);
  MR_CHECK((bits_ == 8 || bits_ == 16) && coded.bytes.size() == static_cast<size_t>(coded.width) *
                                                                    static_cast<size_t>(coded.height) *
                                                                    static_cast<size_t>(channels_ * bits_ / 8));
  levels_.push_back({coded.width, coded.height, std::move(coded.bytes)});
  const float max_code = bits_ == 8 ? 255.0f : 65535.0f;
  // Each level the average of 2 x 2 texels of the one above, in linear
  // values, coded back at the texture's own depth; rows in parallel (each
  // written by one task: the same bytes whatever the thread count).
  while (levels_.back().width > 1 || levels_.back().height > 1) {
    const Level& up = levels_.back();
    Level next{(up.width + 1) / 2, (up.height + 1) / 2, {}};
    next.texels.resize(static_cast<size_t>(next.width) * static_cast<size_t>(next.height) *
                       static_cast<size_t>(channels_ * bits_ / 8));
    ParallelFor(0, next.height, [&](int64_t y64) {
      const int y = static_cast<int>(y64);
      for (int x = 0; x < next.width; ++x) {
        Eigen::Vector4f sum = Eigen::Vector4f::Zero();
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx)
            sum += Texel(up, std::min(2 * x + dx, up.width - 1), std::min(2 * y + dy, up.height - 1));
        const Eigen::Vector4f avg = sum / 4;
        const size_t at = (static_cast<size_t>(y) * static_cast<size_t>(next.width) + static_cast<size_t>(x)) *
                          static_cast<size_t>(channels_);
        for (int c = 0; c < channels_; ++c) {
          // Back to the level's encoding (grey: R; alpha: the last channel).
          const bool alpha = channels_ == 2 ? c == 1 : c == 3;
          const float v = channels_ <= 2 && !alpha ? avg[0] : avg[alpha ? 3 : c];
          const bool srgb = encoding_ == TextureEncoding::kSrgb && !alpha;
          if (bits_ == 8 && srgb) {
            next.texels[at + static_cast<size_t>(c)] = SrgbCode8(v);
            continue;
          }
          const float e = std::clamp(srgb ? LinearToSrgb(v) : v, 0.0f, 1.0f);
          const auto code = static_cast<uint16_t>(std::lround(e * max_code));
          if (bits_ == 8)
            next.texels[at + static_cast<size_t>(c)] = static_cast<uint8_t>(code);
          else
            reinterpret_cast<uint16_t*>(next.texels.data())[at + static_cast<size_t>(c)] = code;
        }
      }
    });
    levels_.push_back(std::move(next));
  }
}

size_t Texture::bytes() const {
  size_t b = 0;
  for (const Level& l : levels_) b += l.texels.size();
  return b;
}

Eigen::Vector4f Texture::Texel(const Level& l, int x, int y) const {
  const size_t at =
      (static_cast<size_t>(y) * static_cast<size_t>(l.width) + static_cast<size_t>(x)) * static_cast<size_t>(channels_);
  uint32_t t[4];
  if (bits_ == 8)
    for (int c = 0; c < channels_; ++c) t[c] = l.texels[at + static_cast<size_t>(c)];
  else
    for (int c = 0; c < channels_; ++c) t[c] = reinterpret_cast<const uint16_t*>(l.texels.data())[at + c];
  const float scale = bits_ == 8 ? 1.0f / 255.0f : 1.0f / 65535.0f;
  const std::vector<float>& srgb = SrgbTable(bits_);
  auto decode = [&](uint32_t c) {
    return encoding_ == TextureEncoding::kSrgb ? srgb[c] : static_cast<float>(c) * scale;
  };
  switch (channels_) {
    case 1:
      return {decode(t[0]), decode(t[0]), decode(t[0]), 1};
    case 2:
      return {decode(t[0]), decode(t[0]), decode(t[0]), static_cast<float>(t[1]) * scale};
    case 3:
      return {decode(t[0]), decode(t[1]), decode(t[2]), 1};
    default:
      return {decode(t[0]), decode(t[1]), decode(t[2]), static_cast<float>(t[3]) * scale};
  }
}

Eigen::Vector4f Texture::Bilinear(const Level& l, const Eigen::Vector2f& uv, TextureWrap ws, TextureWrap wt) const {
  // Texel centres at (i + 0.5) / width.
  const float x = uv.x() * l.width - 0.5f, y = uv.y() * l.height - 0.5f;
  const float fx = std::floor(x), fy = std::floor(y);
  const float tx = x - fx, ty = y - fy;
  const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
  const int xa = Wrap(x0, l.width, ws), xb = Wrap(x0 + 1, l.width, ws);
  const int ya = Wrap(y0, l.height, wt), yb = Wrap(y0 + 1, l.height, wt);
  return (1 - ty) * ((1 - tx) * Texel(l, xa, ya) + tx * Texel(l, xb, ya)) +
         ty * ((1 - tx) * Texel(l, xa, yb) + tx * Texel(l, xb, yb));
}

Eigen::Vector4f Texture::Sample(const Eigen::Vector2f& uv, float footprint, TextureWrap wrap_s,
                                TextureWrap wrap_t) const {
  if (levels_.empty()) return Eigen::Vector4f::Ones();
  if (!uv.allFinite()) return Eigen::Vector4f(0, 0, 0, 1);
  // Wrapped into one period first, so that far-away uvs keep float precision.
  Eigen::Vector2f u = uv;
  for (int a = 0; a < 2; ++a) {
    const TextureWrap w = a == 0 ? wrap_s : wrap_t;
    if (w == TextureWrap::kRepeat) u[a] -= std::floor(u[a]);
    if (w == TextureWrap::kMirror) u[a] -= 2 * std::floor(u[a] / 2);
  }
  const float size = static_cast<float>(std::max(width(), height()));
  const float lod = footprint > 0 && std::isfinite(footprint) ? std::log2(footprint * size) : 0.0f;
  if (!(lod > 0)) return Bilinear(levels_[0], u, wrap_s, wrap_t);
  const float top = static_cast<float>(levels_.size() - 1);
  if (lod >= top) return Bilinear(levels_.back(), u, wrap_s, wrap_t);
  const int l0 = static_cast<int>(lod);
  const float t = lod - static_cast<float>(l0);
  return (1 - t) * Bilinear(levels_[static_cast<size_t>(l0)], u, wrap_s, wrap_t) +
         t * Bilinear(levels_[static_cast<size_t>(l0 + 1)], u, wrap_s, wrap_t);
}

Eigen::Vector2f TransformUv(const AssetTexture& t, const Eigen::Vector2f& uv) {
  const float c = std::cos(t.rotation), s = std::sin(t.rotation);
  const Eigen::Vector2f scaled = t.scale.cwiseProduct(uv);
  // KHR_texture_transform's matrix: translation * rotation * scale, where
  // its rotation matrix is [c s; -s c] in (u, v) with v down.
  return t.offset + Eigen::Vector2f(c * scaled.x() + s * scaled.y(), -s * scaled.x() + c * scaled.y());
}

Texture LoadAssetTexture(const AssetImage& image, TextureEncoding encoding, const std::string& asset) {
  ImageReadOptions opt;
  opt.use_file_transfer = false;
  opt.default_ldr_transfer = Transfer::kLinear;  // codes / max: the texture decodes
  const std::string name = asset + ": " + image.name;
  fs::path file = image.file;
  fs::path temporary;
  if (!image.bytes.empty()) {
    static std::atomic<int> counter{0};
    temporary = fs::temp_directory_path() / fmt::format("mr-texture-{}-{}", getpid(), counter++);
    std::ofstream out(temporary, std::ios::binary);
    out.write(reinterpret_cast<const char*>(image.bytes.data()), static_cast<std::streamsize>(image.bytes.size()));
    out.close();  // a full disk shows at the close
    if (!out) ThrowError("{}: cannot write a temporary copy to decode it ({})", name, temporary.string());
    file = temporary;
  }
  struct Remove {
    fs::path p;
    ~Remove() {
      std::error_code ec;
      if (!p.empty()) fs::remove(p, ec);
    }
  } remove{temporary};
  ImageCodes codes;
  try {
    codes = ReadImageCodes(file, opt);
  } catch (const Error& e) {
    ThrowError("{}: {}", name, e.what());
  }
  if (codes.channels > 4) ThrowError("{}: {} channels (a texture has 1 to 4)", name, codes.channels);
  return Texture(std::move(codes), encoding, image.name);
}

}  // namespace mr
