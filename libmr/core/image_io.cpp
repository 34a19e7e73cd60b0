// Image reading and writing through OpenImageIO (kept out of public headers).
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>

#include "core/error.h"
#include "core/exr_check.h"
#include "core/image.h"
#include "core/image_format.h"
#include "core/math.h"
#include "core/png_check.h"
#include "core/stderr_capture.h"
#include "core/version.h"

namespace mr {

namespace {

std::string PixelTypeName(OIIO::TypeDesc t) {
  if (t == OIIO::TypeDesc::HALF) return "half";
  if (t == OIIO::TypeDesc::FLOAT) return "float";
  if (t == OIIO::TypeDesc::UINT8) return "uint8";
  if (t == OIIO::TypeDesc::UINT16) return "uint16";
  return t.c_str();
}

bool IsIntegerType(OIIO::TypeDesc t) {
  return t.basetype != OIIO::TypeDesc::HALF && t.basetype != OIIO::TypeDesc::FLOAT &&
         t.basetype != OIIO::TypeDesc::DOUBLE;
}

ImageFileInfo InfoFromSpec(const OIIO::ImageInput& in, const OIIO::ImageSpec& spec) {
  ImageFileInfo info;
  info.format = in.format_name();
  info.pixel_type = PixelTypeName(spec.format);
  for (const auto& p : spec.extra_attribs) {
    std::string name = p.name().string();
    if (name.rfind("mr:", 0) == 0 || name == "oiio:ColorSpace" || name == "Software" || name == "envmap" ||
        name == "openexr:envmap" || name == "compression" || name == "ExposureTime" || name == "FNumber" ||
        name == "Exif:ISOSpeedRatings" || name == "Exif:PhotographicSensitivity" || name == "oiio:BitsPerSample")
      info.attributes[name] =
          p.type() == OIIO::TypeString ? std::string(spec.get_string_attribute(name)) : p.get_string();
  }
  return info;
}

// `limits`: the most pixels and values a caller takes (null: any).
std::unique_ptr<OIIO::ImageInput> Open(const fs::path& path, OIIO::ImageSpec* spec,
                                       const ImageReadOptions* limits = nullptr) {
  RequireFile(path, "image");
  CheckPngChunks(path);
  const ExrBuffers buffers = CheckExrHeader(path);
  // OpenEXR allocates a chunk's lines (32 for PIZ, 256 for DWAB) however
  // few the image has: a 1-line image 1.4M pixels wide made it take 1.5 GB
  // on opening (fuzz_exr).
  if (limits && (buffers.pixels > limits->max_pixels || buffers.values > limits->max_values)) {
    const bool padded = buffers.pixels > buffers.width * buffers.height;
    ThrowErrorAt(FileLoc{path.string()},
                 "image is {}x{} pixels of {} channels{}, more than the limit of {} pixels and {} values (corrupt "
                 "header?)",
                 buffers.width, buffers.height, buffers.channels,
                 padded ? fmt::format(", in chunks spanning {} pixels", buffers.pixels) : "", limits->max_pixels,
                 limits->max_values);
  }
  const std::string format = ImageFormatOf(path);
  StderrCapture library_lines;  // libpng prints its errors before OpenImageIO reports them
  // The reader of the file's format only: no fallback to OpenImageIO's others.
  auto in = OIIO::ImageInput::create(format);
  std::string err;
  if (!in) {
    err = OIIO::geterror();
  } else if (!in->open(path.string(), *spec)) {
    err = in->geterror();
    in.reset();
  }
  if (!in) {
    const std::string printed = library_lines.Take();
    if (err.empty()) err = printed.empty() ? "not a readable image" : printed;
    ThrowErrorAt(FileLoc{path.string()}, "cannot read image: {}", err);
  }
  *spec = in->spec();
  return in;
}

}  // namespace

std::string ImageFormatOf(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) ThrowErrorAt(FileLoc{path.string()}, "cannot open image");
  unsigned char b[10] = {};
  in.read(reinterpret_cast<char*>(b), sizeof b);
  const std::streamsize n = in.gcount();
  auto starts = [&](std::initializer_list<int> magic) {
    if (n < static_cast<std::streamsize>(magic.size())) return false;
    size_t i = 0;
    for (int m : magic)
      if (b[i++] != m) return false;
    return true;
  };
  if (starts({0x76, 0x2f, 0x31, 0x01})) return "openexr";
  if (starts({'#', '?'})) return "hdr";
  if (starts({0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'})) return "png";
  if (starts({0xff, 0xd8, 0xff})) return "jpeg";
  if (starts({'I', 'I', 42, 0}) || starts({'M', 'M', 0, 42})) return "tiff";
  if (starts({'P', 'F'}) || starts({'P', 'f'})) return "pnm";
  ThrowErrorAt(FileLoc{path.string()}, "{}",
               n == 0 ? "is empty, not an image"
                      : "is not an OpenEXR, Radiance HDR, PNG, JPEG, TIFF or PFM image (by its first bytes)");
}

void CheckPngChunks(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return;  // the reader reports it
  unsigned char sig[8];
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (!in.read(reinterpret_cast<char*>(sig), 8) || std::memcmp(sig, kSignature, 8) != 0) return;
  std::error_code ec;
  const uint64_t size = fs::file_size(path, ec);
  if (ec) return;
  uint64_t at = 8;
  while (true) {
    unsigned char head[8];
    in.seekg(static_cast<std::streamoff>(at));
    if (!in.read(reinterpret_cast<char*>(head), 8))
      ThrowErrorAt(FileLoc{path.string()}, "PNG ends at byte {} without an IEND chunk (truncated file?)", at);
    const uint64_t length = (uint64_t{head[0]} << 24) | (uint64_t{head[1]} << 16) | (uint64_t{head[2]} << 8) | head[3];
    std::string type;
    for (int k = 4; k < 8; ++k) type += (head[k] >= 0x20 && head[k] < 0x7f) ? static_cast<char>(head[k]) : '?';
    if (length > 0x7fffffffu || at + 12 + length > size)
      ThrowErrorAt(FileLoc{path.string()},
                   "PNG chunk \"{}\" at byte {} declares {} bytes, the file holds {} more (truncated or corrupt file)",
                   type, at, length, size - std::min(size, at + 12));
    if (type == "IEND") return;
    at += 12 + length;
  }
}

// OpenEXR reads a value of a known type by its own layout, not by the size
// the attribute declares: a box2i declared as 4 bytes still takes 16, a
// channel list runs to its terminating NUL and a string vector's entries
// are allocated at the lengths they claim.  Where the two disagree OpenEXR
// goes on reading from the wrong byte, so a later "size" is garbage (1149
// bytes made it allocate a 1.7 GB string; found by fuzz/fuzz_exr).  The
// value must therefore have exactly its type's layout.
void CheckExrAttributeValue(const FileLoc& loc, const std::string& name, const std::string& type,
                            const std::vector<unsigned char>& v, size_t max_name) {
  static const std::pair<const char*, size_t> kFixed[] = {{"box2i", 16},      {"box2f", 16},   {"chromaticities", 32},
                                                          {"compression", 1}, {"double", 8},   {"envmap", 1},
                                                          {"float", 4},       {"int", 4},      {"keycode", 28},
                                                          {"lineOrder", 1},   {"m33f", 36},    {"m33d", 72},
                                                          {"m44f", 64},       {"m44d", 128},   {"rational", 8},
                                                          {"tiledesc", 9},    {"timecode", 8}, {"v2i", 8},
                                                          {"v2f", 8},         {"v2d", 16},     {"v3i", 12},
                                                          {"v3f", 12},        {"v3d", 24},     {"deepImageState", 1}};
  auto bad = [&](const std::string& why) {
    ThrowErrorAt(loc, "OpenEXR header: attribute \"{}\" of type {}: {} (corrupt file)", name, type, why);
  };
  const auto u32 = [&](size_t k) {
    return static_cast<uint64_t>(v[k] | (uint32_t{v[k + 1]} << 8) | (uint32_t{v[k + 2]} << 16) |
                                 (uint32_t{v[k + 3]} << 24));
  };
  for (const auto& [t, bytes] : kFixed)
    if (type == t) {
      if (v.size() != bytes) bad(fmt::format("{} bytes declared, the type has {}", v.size(), bytes));
      return;
    }
  if (type == "chlist") {
    // Per channel: a NUL-terminated name and 16 bytes; a NUL ends the list.
    size_t k = 0;
    while (k < v.size() && v[k] != 0) {
      const size_t start = k;
      while (k < v.size() && v[k] != 0) ++k;
      if (k - start > max_name) bad(fmt::format("a channel name longer than {} bytes", max_name));
      k += 17;
    }
    if (k + 1 != v.size()) bad(fmt::format("the channel list does not end at its declared {} bytes", v.size()));
  } else if (type == "preview") {
    if (v.size() < 8 || 8 + 4 * u32(0) * u32(4) != v.size())
      bad(fmt::format("the preview image's size does not match its declared {} bytes", v.size()));
  } else if (type == "stringvector") {
    for (size_t k = 0; k < v.size();) {
      if (k + 4 > v.size() || u32(k) > v.size() - k - 4)
        bad(fmt::format("an entry runs past the declared {} bytes", v.size()));
      k += 4 + u32(k);
    }
  } else if (type == "floatvector") {
    if (v.size() % 4 != 0) bad(fmt::format("{} bytes declared, not a whole number of floats", v.size()));
  }
}

ExrBuffers CheckExrHeader(const fs::path& path) {
  ExrBuffers most;
  std::ifstream in(path, std::ios::binary);
  if (!in) return most;  // the reader reports it
  std::error_code ec;
  const uint64_t size = fs::file_size(path, ec);
  if (ec) return most;
  const FileLoc loc{path.string()};
  unsigned char head[8];
  if (!in.read(reinterpret_cast<char*>(head), 8) || head[0] != 0x76 || head[1] != 0x2f || head[2] != 0x31 ||
      head[3] != 0x01)
    return most;
  const uint32_t flags = head[5] | (uint32_t{head[6]} << 8) | (uint32_t{head[7]} << 16);
  const bool single_tiled = flags & 0x2, long_names = flags & 0x4, deep = flags & 0x8, multipart = flags & 0x10;
  // The attributes: name, type (each NUL-terminated, at most 31 bytes, 255
  // with the long-names flag), a 4-byte size and the value; a NUL ends the
  // header.  OpenEXR reads a longer name only up to the limit and goes on
  // from the middle of it, taking later bytes for the type and the size:
  // 1149 bytes with a 32-byte name made it allocate a 1.7 GB string
  // (found by fuzz/fuzz_exr), so a longer name is refused here.
  const size_t max_name = long_names ? 255 : 31;
  auto read_name = [&](std::string* s) {
    s->clear();
    for (char c; in.get(c);) {
      if (c == '\0') return true;
      if (s->size() >= max_name)
        ThrowErrorAt(loc, "OpenEXR header: an attribute name or type longer than {} bytes{} (corrupt file)", max_name,
                     long_names ? "" : " without the long-names flag");
      s->push_back(c);
    }
    ThrowErrorAt(loc, "OpenEXR header runs past the end of the file (truncated file?)");
  };
  auto i32 = [](const unsigned char* b) {
    return static_cast<int32_t>(b[0] | (uint32_t{b[1]} << 8) | (uint32_t{b[2]} << 16) | (uint32_t{b[3]} << 24));
  };
  // A multi-part file has one header per part, each ending with a NUL, and
  // a NUL after the last (OpenEXR allocates every part's offset table on
  // opening: 1999 bytes of multi-part header took 1.9 GB; fuzz_exr).
  double need_all = 0;
  for (int part = 0;; ++part) {
    int64_t width = 0, height = 0, pixel_bytes = 0, channels = 0, tile_w = 0, tile_h = 0;
    int compression = -1;
    bool have_window = false, any = false;
    std::string part_type;
    for (std::string name, type;;) {
      read_name(&name);
      if (name.empty()) break;
      any = true;
      read_name(&type);
      unsigned char sz[4];
      if (!in.read(reinterpret_cast<char*>(sz), 4))
        ThrowErrorAt(loc, "OpenEXR header runs past the end of the file (truncated file?)");
      const int32_t n = i32(sz);
      const uint64_t at = static_cast<uint64_t>(in.tellg());
      if (n < 0 || at + static_cast<uint64_t>(n) > size)
        ThrowErrorAt(loc,
                     "OpenEXR header: attribute \"{}\" declares {} bytes, the file holds {} more (truncated or "
                     "corrupt file)",
                     name, n, size - std::min(size, at));
      std::vector<unsigned char> v(static_cast<size_t>(n));
      if (n > 0 && !in.read(reinterpret_cast<char*>(v.data()), n))
        ThrowErrorAt(loc, "OpenEXR header runs past the end of the file (truncated file?)");
      CheckExrAttributeValue(loc, name, type, v, long_names ? 255 : 31);
      if (name == "dataWindow" && type == "box2i" && n == 16) {
        width = int64_t{i32(&v[8])} - i32(&v[0]) + 1;
        height = int64_t{i32(&v[12])} - i32(&v[4]) + 1;
        have_window = true;
      } else if (name == "compression" && type == "compression" && n == 1) {
        compression = v[0];
      } else if (name == "tiles" && type == "tiledesc" && n == 9) {
        tile_w = static_cast<uint32_t>(i32(&v[0]));
        tile_h = static_cast<uint32_t>(i32(&v[4]));
      } else if (name == "type" && type == "string") {
        part_type.assign(v.begin(), v.end());
      } else if (name == "channels" && type == "chlist") {
        // name, pixel type (0 uint, 1 half, 2 float), linear, 3 reserved,
        // x and y sampling; a NUL ends the list.
        size_t k = 0;
        while (k < v.size() && v[k] != 0) {
          while (k < v.size() && v[k] != 0) ++k;
          if (k + 17 > v.size()) break;
          const int32_t t = i32(&v[k + 1]);
          pixel_bytes += t == 1 ? 2 : 4;
          ++channels;
          k += 17;
        }
      }
    }
    if (multipart && !any) break;  // the empty header after the last part
    const bool part_deep = deep || part_type == "deepscanline" || part_type == "deeptile";
    const bool tiled = (multipart ? part_type == "tiledimage" : single_tiled) && tile_w > 0 && tile_h > 0;
    if (!part_deep && have_window && width > 0 && height > 0) {  // else the reader judges
      int64_t chunks = 0;
      double padded = 0;  // the pixels OpenEXR's buffers span: whole chunks
      if (tiled) {
        chunks = ((width + tile_w - 1) / tile_w) * ((height + tile_h - 1) / tile_h);
        padded = std::max(static_cast<double>(width) * static_cast<double>(height),
                          static_cast<double>(tile_w) * static_cast<double>(tile_h));
      } else {
        // Scanlines per chunk: none, RLE, ZIPS 1; ZIP, PXR24 16; PIZ, B44,
        // B44A, DWAA 32; DWAB 256.
        static const int kLines[] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
        const int lines = compression >= 0 && compression < 10 ? kLines[compression] : 1;
        chunks = (height + lines - 1) / lines;
        padded = static_cast<double>(width) * static_cast<double>(std::max<int64_t>(height, lines));
      }
      // Bytes of pixels per byte of file (docs/formats.md, "Reading images").
      static const double kRatio[] = {1, 64, 1100, 1100, 2000, 1400, 32.0 / 3, 32.0 / 3, 500000, 500000};
      const double ratio = compression >= 0 && compression < 10 ? kRatio[compression] : 0;
      const double pixels = static_cast<double>(width) * static_cast<double>(height);
      const double need = std::max(16.0 * static_cast<double>(chunks),
                                   ratio > 0 ? pixels * static_cast<double>(pixel_bytes) / ratio : 0.0);
      need_all += need;
      if (need_all > static_cast<double>(size))
        ThrowErrorAt(loc,
                     "the OpenEXR header{} claims {}x{} pixels in {} chunks, more than the file's {} bytes can hold "
                     "(truncated or corrupt file?)",
                     multipart ? fmt::format(" of part {}", part) : "", width, height, chunks, size);
      constexpr double kMost = 9e18;
      const double values = padded * static_cast<double>(std::max<int64_t>(1, channels));
      if (values > static_cast<double>(most.values))
        most = {static_cast<int64_t>(std::min(padded, kMost)), static_cast<int64_t>(std::min(values, kMost)), width,
                height, channels};
    }
    if (!multipart) break;
  }
  return most;
}

ImageFileInfo ReadImageHeader(const fs::path& path, int* width, int* height, std::vector<std::string>* channels) {
  OIIO::ImageSpec spec;
  auto in = Open(path, &spec);
  ImageFileInfo info = InfoFromSpec(*in, spec);
  int n = 0;
  while (in->seek_subimage(n, 0)) ++n;
  info.subimages = std::max(1, n);
  if (width) *width = spec.width;
  if (height) *height = spec.height;
  if (channels) *channels = spec.channelnames;
  return info;
}

namespace {

// The pixels as interleaved floats.  Not OIIO's read_image(FLOAT): unless
// it is asked for the file's native format, OpenImageIO 2.4 reads through a
// 64 MB buffer whatever the image's size (ImageInput::read_scanlines), even
// for float files, which made every small read cost milliseconds (40 ms
// under AddressSanitizer: fuzz_exr ran 25 files a second).  The native
// bytes are read in place (float files) or into a buffer of the image's own
// size and converted here as OIIO converts them.
bool ReadPixelsAsFloat(OIIO::ImageInput& in, const OIIO::ImageSpec& spec, float* out) {
  const bool per_channel = !spec.channelformats.empty();
  if (!per_channel && spec.format == OIIO::TypeDesc::FLOAT)
    return in.read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UNKNOWN, out);  // native: read in place
  const size_t pixel_bytes = spec.pixel_bytes(true);
  std::vector<unsigned char> native(static_cast<size_t>(spec.width) * static_cast<size_t>(spec.height) * pixel_bytes);
  if (!in.read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UNKNOWN, native.data())) return false;
  const OIIO::stride_t out_pixel = static_cast<OIIO::stride_t>(spec.nchannels * sizeof(float));
  if (!per_channel)
    return OIIO::convert_image(spec.nchannels, spec.width, spec.height, 1, native.data(), spec.format, OIIO::AutoStride,
                               OIIO::AutoStride, OIIO::AutoStride, out, OIIO::TypeDesc::FLOAT, OIIO::AutoStride,
                               OIIO::AutoStride, OIIO::AutoStride);
  size_t offset = 0;
  for (int c = 0; c < spec.nchannels; ++c) {
    const OIIO::TypeDesc f = spec.channelformats[static_cast<size_t>(c)];
    if (!OIIO::convert_image(1, spec.width, spec.height, 1, native.data() + offset, f,
                             static_cast<OIIO::stride_t>(pixel_bytes), OIIO::AutoStride, OIIO::AutoStride, out + c,
                             OIIO::TypeDesc::FLOAT, out_pixel, OIIO::AutoStride, OIIO::AutoStride))
      return false;
    offset += f.size();
  }
  return true;
}

// Opens `path` for its pixels with every check a size or a header needs
// before a buffer is allocated (ReadImage and ReadImageCodes share them).
std::unique_ptr<OIIO::ImageInput> OpenForPixels(const fs::path& path, const ImageReadOptions& options,
                                                OIIO::ImageSpec* spec_out, ImageFileInfo* info_out) {
  OIIO::ImageSpec& spec = *spec_out;
  auto in = Open(path, &spec, &options);
  const FileLoc loc{path.string()};
  ImageFileInfo& info = *info_out;
  info = InfoFromSpec(*in, spec);
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
    ThrowErrorAt(loc, "image has no pixels ({}x{}, {} channels)", spec.width, spec.height, spec.nchannels);
  if (spec.depth > 1) ThrowErrorAt(loc, "volume images are not supported");
  const int64_t pixels = static_cast<int64_t>(spec.width) * spec.height;
  if (pixels > options.max_pixels)
    ThrowErrorAt(loc, "image is {}x{} = {} pixels, more than the limit of {} (corrupt header?)", spec.width,
                 spec.height, pixels, options.max_pixels);
  if (pixels * spec.nchannels > options.max_values)
    ThrowErrorAt(loc, "image is {}x{} pixels of {} channels, more than the limit of {} values (corrupt header?)",
                 spec.width, spec.height, spec.nchannels, options.max_values);
  // Radiance HDR's run-length coding holds at most 127 pixels in 8 bytes
  // (a run per component), so a header claiming more than 16 pixels a byte
  // lies: refused before the buffer is allocated (found by fuzz/fuzz_hdrenv:
  // 109 bytes claiming 83333333x2 pixels, a 2 GB allocation).
  // Any other compressed format gets a generic bound: at most 65536 values
  // a byte, far above what deflate (1032), JPEG or LZW reach on real
  // images (fuzz_exr and fuzz_hdrenv found 48 bytes of WebP named .exr
  // claiming 12663x13749 pixels, 2.8 GB of floats, before the format was
  // told by content: ImageFormatOf).  OpenEXR files are checked by their
  // header (CheckExrHeader).
  std::error_code size_ec;
  const auto bytes = static_cast<int64_t>(fs::file_size(path, size_ec));
  if (!size_ec && info.format == "hdr" && pixels > 16 * bytes + 4096)
    ThrowErrorAt(loc, "the header claims {}x{} pixels, more than the file's {} bytes can hold", spec.width, spec.height,
                 bytes);
  if (!size_ec && info.format != "openexr" && pixels * spec.nchannels > 65536 * (bytes + 1))
    ThrowErrorAt(loc, "the {} header claims {}x{} pixels of {} channels, more than the file's {} bytes can hold",
                 info.format, spec.width, spec.height, spec.nchannels, bytes);

  return in;
}

// Reads the pixels of `in` as `type`, or throws naming the file.
void ReadPixelsAs(OIIO::ImageInput& in, const OIIO::ImageSpec& spec, OIIO::TypeDesc type, void* out,
                  const FileLoc& loc) {
  StderrCapture library_lines;
  const bool ok = type == OIIO::TypeDesc::FLOAT ? ReadPixelsAsFloat(in, spec, static_cast<float*>(out))
                                                : in.read_image(0, 0, 0, spec.nchannels, type, out);
  if (ok) return;
  const std::string printed = library_lines.Take();
  std::string err = in.geterror();
  if (err.empty()) err = printed.empty() ? "unknown error" : printed;
  ThrowErrorAt(loc, "cannot read pixels (truncated or corrupt file?): {}", err);
}

}  // namespace

Image ReadImage(const fs::path& path, const ImageReadOptions& options, ImageFileInfo* info_out) {
  OIIO::ImageSpec spec;
  ImageFileInfo info;
  auto in = OpenForPixels(path, options, &spec, &info);
  const FileLoc loc{path.string()};
  std::vector<std::string> names = spec.channelnames;
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i].empty()) names[i] = fmt::format("ch{}", i);
  Image img(spec.width, spec.height, names);
  ReadPixelsAs(*in, spec, OIIO::TypeDesc::FLOAT, img.data(), loc);

  if (IsIntegerType(spec.format)) {
    info.decoded_from_ldr = true;
    std::string cs = spec.get_string_attribute("oiio:ColorSpace");
    Transfer t = options.default_ldr_transfer;
    if (options.use_file_transfer && (cs == "Linear" || cs == "linear"))
      t = Transfer::kLinear;
    else if (options.use_file_transfer && cs == "sRGB")
      t = Transfer::kSrgb;
    info.transfer = t;
    if (t == Transfer::kSrgb) {
      const int alpha = spec.alpha_channel;
      const int nc = img.channels();
      // 8-bit codes take 256 values: each decoded once (the first float seen
      // for a code, compared exactly: the same bytes as decoding every pixel).
      std::array<float, 256> seen{}, decoded{};
      std::array<bool, 256> have{};
      const bool eight = spec.format.basetype == OIIO::TypeDesc::UINT8;
      for (int64_t p = 0; p < img.pixel_count(); ++p)
        for (int c = 0; c < nc; ++c) {
          if (c == alpha) continue;
          float& v = img.data()[p * nc + c];
          if (!eight) {
            v = SrgbToLinear(v);
            continue;
          }
          const size_t k = static_cast<size_t>(std::clamp(std::lround(v * 255.0f), 0L, 255L));
          if (!have[k] || seen[k] != v) {
            have[k] = true;
            seen[k] = v;
            decoded[k] = SrgbToLinear(v);
          }
          v = decoded[k];
        }
    }
  }

  if (options.nonfinite == NonFinite::kReject) {
    int64_t nan = 0, inf = 0, first = -1;
    for (size_t i = 0; i < img.values().size(); ++i) {
      float v = img.values()[i];
      if (std::isfinite(v)) continue;
      (std::isnan(v) ? nan : inf)++;
      if (first < 0) first = static_cast<int64_t>(i);
    }
    if (first >= 0) {
      const int nc = img.channels();
      int64_t p = first / nc;
      ThrowErrorAt(loc, "{} NaN and {} Inf values; the first at pixel ({}, {}) channel {}", nan, inf, p % img.width(),
                   p / img.width(), img.channel_names()[static_cast<size_t>(first % nc)]);
    }
  }
  if (info_out) *info_out = info;
  return img;
}

ImageCodes ReadImageCodes(const fs::path& path, const ImageReadOptions& options) {
  OIIO::ImageSpec spec;
  ImageFileInfo info;
  auto in = OpenForPixels(path, options, &spec, &info);
  ImageCodes c;
  c.width = spec.width;
  c.height = spec.height;
  c.channels = spec.nchannels;
  const size_t n = static_cast<size_t>(spec.width) * static_cast<size_t>(spec.height) * spec.nchannels;
  if (IsIntegerType(spec.format) && spec.channelformats.empty()) {
    c.bits = spec.format.size() == 1 ? 8 : 16;
    c.bytes.resize(n * static_cast<size_t>(c.bits / 8));
    ReadPixelsAs(*in, spec, c.bits == 8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16, c.bytes.data(),
                 FileLoc{path.string()});
    return c;
  }
  in.reset();
  const Image img = ReadImage(path, options);  // float files: checked for NaN/Inf there
  c.bits = 16;
  c.bytes.resize(n * 2);
  auto* out = reinterpret_cast<uint16_t*>(c.bytes.data());
  for (size_t i = 0; i < n; ++i)
    out[i] = static_cast<uint16_t>(std::lround(std::clamp(img.values()[i], 0.0f, 1.0f) * 65535.0f));
  return c;
}

ImageWriteResult WriteImage(const fs::path& path, const Image& img, const ImageWriteOptions& options) {
  const FileLoc loc{path.string()};
  if (img.empty()) ThrowErrorAt(loc, "refusing to write an empty image");
  const std::string ext = LowerExtension(path);
  PixelType type = options.pixel_type;
  if (type == PixelType::kDefault) {
    if (ext == ".exr" || ext == ".hdr")
      type = PixelType::kFloat;
    else if (ext == ".tif" || ext == ".tiff")
      type = PixelType::kUint16;
    else if (ext == ".png" || ext == ".jpg" || ext == ".jpeg")
      type = PixelType::kUint8;
    else
      ThrowErrorAt(loc, "unsupported image extension \"{}\" (use .exr .hdr .png .jpg .tif)", ext);
  }
  if ((ext == ".jpg" || ext == ".jpeg") && type != PixelType::kUint8)
    ThrowErrorAt(loc, "JPEG stores 8-bit pixels only");
  if (ext == ".png" && type != PixelType::kUint8 && type != PixelType::kUint16)
    ThrowErrorAt(loc, "PNG stores 8- or 16-bit pixels only");
  if (ext == ".hdr" && (type != PixelType::kFloat || img.channels() != 3))
    ThrowErrorAt(loc, "Radiance HDR stores 3-channel float images only");

  ImageWriteResult result;
  std::vector<float> pixels = img.values();
  OIIO::TypeDesc format = OIIO::TypeDesc::FLOAT;
  if (type == PixelType::kHalf) {
    format = OIIO::TypeDesc::HALF;
    for (float& v : pixels) {
      if (std::isfinite(v) && std::abs(v) > kHalfMax) {
        ++result.clamped_half;
        v = std::copysign(kHalfMax, v);
      }
    }
    if (result.clamped_half > 0 && !options.clamp_half)
      ThrowErrorAt(loc,
                   "{} values exceed the half-float maximum 65504; write float32, or allow "
                   "clamping (--clamp-half)",
                   result.clamped_half);
  } else if (type == PixelType::kUint8 || type == PixelType::kUint16) {
    format = type == PixelType::kUint8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16;
    const int nc = img.channels();
    const int alpha = img.ChannelIndex("A");
    for (size_t i = 0; i < pixels.size(); ++i) {
      float v = pixels[i];
      if (!std::isfinite(v)) ThrowErrorAt(loc, "cannot encode NaN/Inf as an integer pixel");
      if (v < 0.0f || v > 1.0f) ++result.clipped_ldr;
      v = Clamp(v, 0.0f, 1.0f);
      if (options.ldr_transfer == Transfer::kSrgb && static_cast<int>(i % nc) != alpha) v = LinearToSrgb(v);
      pixels[i] = v;
    }
  }

  OIIO::ImageSpec spec(img.width(), img.height(), img.channels(), format);
  spec.channelnames = img.channel_names();
  spec.alpha_channel = img.ChannelIndex("A");
  if (!options.tool.empty()) spec.attribute("mr:tool", options.tool);
  spec.attribute("mr:version", kVersion);
  if (!options.command_line.empty()) spec.attribute("mr:command_line", options.command_line);
  // OpenImageIO stamps the current time (EXR capDate) unless DateTime is set;
  // an empty one keeps outputs byte-identical from run to run.
  spec.attribute("DateTime", "");
  for (const auto& [k, v] : options.attributes) spec.attribute(k, v);
  if ((format == OIIO::TypeDesc::UINT8 || format == OIIO::TypeDesc::UINT16) &&
      !options.attributes.count("oiio:ColorSpace"))  // values already encoded may name their own
    spec.attribute("oiio:ColorSpace", options.ldr_transfer == Transfer::kSrgb ? "sRGB" : "Linear");
  if (ext == ".exr") spec.attribute("compression", "zip");
  if (ext == ".jpg" || ext == ".jpeg") spec.attribute("Compression", fmt::format("jpeg:{}", options.jpeg_quality));

  // Every format but TIFF is encoded in memory, then written through mr's
  // checked file writes: OpenImageIO 2.4's writers do not report a failed
  // write (a full disk left a truncated PNG and an unreadable EXR under their
  // final names).  libtiff cannot write through a memory proxy: a TIFF is
  // written to the temporary file and read back whole before it is renamed.
  auto out = OIIO::ImageOutput::create(path.string());
  if (!out) ThrowErrorAt(loc, "cannot create image writer: {}", OIIO::geterror());
  if (ext != ".tif" && ext != ".tiff" && out->supports("ioproxy")) {
    std::vector<unsigned char> bytes;
    OIIO::Filesystem::IOVecOutput proxy(bytes);
    if (!out->set_ioproxy(&proxy)) ThrowErrorAt(loc, "cannot encode in memory: {}", out->geterror());
    if (!out->open(path.string(), spec)) ThrowErrorAt(loc, "cannot open for writing: {}", out->geterror());
    if (!out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()))
      ThrowErrorAt(loc, "cannot write pixels: {}", out->geterror());
    if (!out->close()) ThrowErrorAt(loc, "cannot finish writing: {}", out->geterror());
    out.reset();
    WriteTextFile(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    return result;
  }
  out.reset();
  WriteAtomically(path, [&](const fs::path& tmp) {
    auto writer = OIIO::ImageOutput::create(tmp.string());
    if (!writer) ThrowErrorAt(loc, "cannot create image writer: {}", OIIO::geterror());
    if (!writer->open(tmp.string(), spec)) ThrowErrorAt(loc, "cannot open for writing: {}", writer->geterror());
    if (!writer->write_image(OIIO::TypeDesc::FLOAT, pixels.data()))
      ThrowErrorAt(loc, "cannot write pixels: {}", writer->geterror());
    if (!writer->close()) ThrowErrorAt(loc, "cannot finish writing: {}", writer->geterror());
    writer.reset();
    try {
      ImageReadOptions check;
      check.nonfinite = NonFinite::kAllow;
      ReadImage(tmp, check);
    } catch (const Error& e) {
      ThrowErrorAt(loc, "write failed: the file written does not read back ({}; disk full?)", e.message());
    }
  });
  return result;
}

}  // namespace mr
