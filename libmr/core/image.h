// Float32 images with named channels, and their I/O through OpenImageIO.
//
// Channel names follow OpenEXR's layer.channel convention: an RGB image has
// channels R, G, B; a multi-layer render has composite.R, composite.G, ...,
// mixed.R, ..., mask.Y.  Pixels are interleaved: data[(y * width + x) *
// channels + c], row 0 at the top, (0,0) the centre of the top-left pixel.
#pragma once

#include "core/check.h"

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/file.h"

namespace mr {

class Image {
 public:
  Image() = default;
  Image(int width, int height, std::vector<std::string> channel_names, float fill = 0.0f);
  static Image Rgb(int width, int height, float fill = 0.0f);
  static Image Rgba(int width, int height, float fill = 0.0f);
  static Image Gray(int width, int height, float fill = 0.0f);  // channel "Y"

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return static_cast<int>(names_.size()); }
  bool empty() const { return data_.empty(); }
  int64_t pixel_count() const { return static_cast<int64_t>(width_) * height_; }
  const std::vector<std::string>& channel_names() const { return names_; }
  // Index of a channel by exact name, or -1.
  int ChannelIndex(const std::string& name) const;

  float& at(int x, int y, int c) { return data_[Index(x, y, c)]; }
  float at(int x, int y, int c) const { return data_[Index(x, y, c)]; }
  float* data() { return data_.data(); }
  const float* data() const { return data_.data(); }
  std::vector<float>& values() { return data_; }
  const std::vector<float>& values() const { return data_; }

  // Layer names in order of first appearance ("" for unprefixed channels).
  std::vector<std::string> LayerNames() const;
  // The channels of `layer` with the prefix removed ("mixed" -> R, G, B).
  Image Layer(const std::string& layer) const;
  // Appends `img`'s channels as `layer`.C (img must have the same size).
  void AppendLayer(const std::string& layer, const Image& img);
  // The layers' channels side by side, `name`.C, in order (all of one size,
  // at least one): AppendLayer of each, in one pass over the pixels.
  static Image Stack(const std::vector<std::pair<std::string, const Image*>>& layers);

 private:
  size_t Index(int x, int y, int c) const {
    MR_DCHECK(x >= 0 && x < width_ && y >= 0 && y < height_ && c >= 0 && static_cast<size_t>(c) < names_.size());
    return (static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x)) * names_.size() +
           static_cast<size_t>(c);
  }
  int width_ = 0, height_ = 0;
  std::vector<std::string> names_;
  std::vector<float> data_;
};

struct ChannelStats {
  std::string name;
  double min = 0, max = 0, mean = 0;  // over finite values
  int64_t nan_count = 0, inf_count = 0;
};
std::vector<ChannelStats> ComputeStats(const Image& img);
// Counts of NaN and +-Inf over all channels.
int64_t CountNonFinite(const Image& img);

// Separable Gaussian blur of every channel (sigma in pixels; edges clamp).
void GaussianBlur(Image* img, double sigma_px);

// The transfer function of stored integer pixels.
enum class Transfer { kSrgb, kLinear };
const char* ToString(Transfer t);

enum class NonFinite { kReject, kAllow };

struct ImageReadOptions {
  // Transfer assumed for 8/16-bit files that do not state theirs.
  Transfer default_ldr_transfer = Transfer::kSrgb;
  // When false, integer pixels are decoded with default_ldr_transfer even
  // when the file states another (kLinear then gives raw code values / max).
  bool use_file_transfer = true;
  // kReject: NaN/Inf pixels are an error naming the file, the count and the
  // first offending pixel.  kAllow: kept as they are (mr-info counts them).
  NonFinite nonfinite = NonFinite::kReject;
  // Refuse images with more pixels than this (corrupt headers claim huge
  // sizes), or more values (pixels x channels) than max_values.
  int64_t max_pixels = int64_t{1} << 28;
  int64_t max_values = int64_t{1} << 32;
};

struct ImageFileInfo {
  std::string format;      // OIIO format name: "openexr", "png", "hdr", ...
  std::string pixel_type;  // stored type: "half", "float", "uint8", "uint16"
  bool decoded_from_ldr = false;
  Transfer transfer = Transfer::kLinear;  // how integer pixels were decoded
  int subimages = 1;
  std::map<std::string, std::string> attributes;  // selected metadata, as text
};

Image ReadImage(const fs::path& path, const ImageReadOptions& options = {}, ImageFileInfo* info = nullptr);
// An image's stored codes, unconverted (asset textures keep them so): an
// 8-bit file gives bits 8 (a byte a value), any other integer file bits 16
// (two bytes a value, native order), a float file its values clamped to
// [0, 1] and coded in 16 bits.  Interleaved, row 0 at the top.  The same
// checks and messages as ReadImage; no transfer is applied.
struct ImageCodes {
  int width = 0, height = 0, channels = 0, bits = 8;
  std::vector<uint8_t> bytes;
};
ImageCodes ReadImageCodes(const fs::path& path, const ImageReadOptions& options = {});
// Header only: size and channel names without reading pixels.
ImageFileInfo ReadImageHeader(const fs::path& path, int* width, int* height, std::vector<std::string>* channels);

enum class PixelType { kDefault, kFloat, kHalf, kUint8, kUint16 };

struct ImageWriteOptions {
  // kDefault: float for EXR, float for HDR, uint8 for PNG/JPEG, uint16 for TIFF.
  PixelType pixel_type = PixelType::kDefault;
  // Half floats: values beyond +-65504 are refused (mr::Error giving the
  // count) unless clamp_half, which clamps them and reports the count.
  bool clamp_half = false;
  Transfer ldr_transfer = Transfer::kSrgb;  // encoding for integer formats
  // Provenance stored as EXR/PNG/TIFF metadata (mr:tool, mr:version, mr:command_line).
  std::string tool, command_line;
  std::map<std::string, std::string> attributes;
  int jpeg_quality = 95;
};

struct ImageWriteResult {
  int64_t clamped_half = 0;  // values clamped to +-65504
  int64_t clipped_ldr = 0;   // values outside [0,1] clipped for integer output
};

// Atomic: writes a temporary beside `path` and renames it.  Format by extension:
// .exr .hdr .png .jpg/.jpeg .tif/.tiff.
ImageWriteResult WriteImage(const fs::path& path, const Image& img, const ImageWriteOptions& options = {});

}  // namespace mr
