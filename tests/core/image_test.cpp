#include "core/image.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include "core/error.h"
#include "test_util.h"

namespace mr {
namespace {

using test::TempDir;

Image Ramp(int w, int h, std::vector<std::string> names, float scale = 1.0f) {
  Image img(w, h, std::move(names));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < img.channels(); ++c) img.at(x, y, c) = scale * (x + w * y + 0.25f * c) / (w * h);
  return img;
}

TEST(Image, StackIsAppendLayerOfEach) {
  const Image a = Ramp(7, 5, {"R", "G", "B"}, 2.0f), b = Image::Gray(7, 5, 0.25f), c = Ramp(7, 5, {"X", "Y"}, -3.0f);
  Image appended;
  appended.AppendLayer("a", a);
  appended.AppendLayer("b", b);
  appended.AppendLayer("", c);
  const Image stacked = Image::Stack({{"a", &a}, {"b", &b}, {"", &c}});
  EXPECT_EQ(stacked.channel_names(), appended.channel_names());
  EXPECT_EQ(stacked.values(), appended.values());
  EXPECT_EQ(stacked.width(), 7);
  EXPECT_EQ(stacked.height(), 5);
}

TEST(Image, ExrFloatRoundTripWithLayersAndProvenance) {
  TempDir dir;
  Image img = Ramp(7, 5, {"R", "G", "B"}, 1e6f);  // beyond half range: float32 keeps it
  Image both;
  both.AppendLayer("composite", img);
  both.AppendLayer("mixed", Ramp(7, 5, {"R", "G", "B"}, 1e-6f));
  both.AppendLayer("mask", Image::Gray(7, 5, 0.5f));
  ImageWriteOptions opt;
  opt.tool = "mr-test";
  opt.command_line = "mr-test --flag 'a b'";
  WriteImage(dir / "a.exr", both, opt);
  ImageFileInfo info;
  Image back = ReadImage(dir / "a.exr", {}, &info);
  ASSERT_EQ(back.channels(), 7);
  // OpenEXR stores channels sorted by name, so layers come back alphabetically.
  EXPECT_EQ(back.LayerNames(), (std::vector<std::string>{"composite", "mask", "mixed"}));
  Image comp = back.Layer("composite");
  for (size_t i = 0; i < img.values().size(); ++i) EXPECT_EQ(comp.values()[i], img.values()[i]);
  EXPECT_EQ(back.Layer("mask").at(3, 2, 0), 0.5f);
  EXPECT_EQ(back.Layer("mixed").channel_names(), (std::vector<std::string>{"R", "G", "B"}));
  EXPECT_EQ(info.attributes["mr:tool"], "mr-test");
  EXPECT_EQ(info.attributes["mr:command_line"], "mr-test --flag 'a b'");
  EXPECT_EQ(info.pixel_type, "float");
  EXPECT_EQ(dir.FileCount(), 1u);  // no temporary left behind
}

TEST(Image, HeaderReadsSizeAndChannelsWithoutPixels) {
  TempDir dir;
  Image both;
  both.AppendLayer("composite", Image::Rgb(9, 4, 1.0f));
  both.AppendLayer("mask", Image::Gray(9, 4, 1.0f));
  WriteImage(dir / "h.exr", both);
  int w = 0, h = 0;
  std::vector<std::string> names;
  ImageFileInfo info = ReadImageHeader(dir / "h.exr", &w, &h, &names);
  EXPECT_EQ(w, 9);
  EXPECT_EQ(h, 4);
  EXPECT_EQ(names.size(), 4u);
  EXPECT_EQ(info.format, "openexr");
  EXPECT_THROW(ReadImageHeader(dir / "none.exr", &w, &h, &names), Error);
}

TEST(Image, HalfRefusesOverflowUnlessClamping) {
  TempDir dir;
  Image img = Image::Rgb(4, 4, 1.0f);
  img.at(1, 1, 0) = 7e4f;  // > 65504
  img.at(2, 2, 1) = -1e6f;
  ImageWriteOptions opt;
  opt.pixel_type = PixelType::kHalf;
  try {
    WriteImage(dir / "h.exr", img, opt);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("2 values exceed the half-float maximum"), std::string::npos) << e.what();
  }
  EXPECT_EQ(dir.FileCount(), 0u);  // nothing half-written
  opt.clamp_half = true;
  auto r = WriteImage(dir / "h.exr", img, opt);
  EXPECT_EQ(r.clamped_half, 2);
  ImageFileInfo info;
  Image back = ReadImage(dir / "h.exr", {}, &info);
  EXPECT_EQ(info.pixel_type, "half");
  EXPECT_EQ(back.at(1, 1, 0), 65504.0f);
  EXPECT_EQ(back.at(2, 2, 1), -65504.0f);
  EXPECT_EQ(back.at(0, 0, 0), 1.0f);
}

// ReadImage converts non-float pixels itself (image_io.cpp: OpenImageIO's
// own conversion reads through a 64 MB buffer): an EXR whose channels have
// different types (float, half, uint) comes back value for value.
TEST(Image, ExrWithPerChannelTypesReadsEveryChannel) {
  TempDir dir;
  const int w = 5, h = 3;
  std::vector<float> f(w * h);
  std::vector<Imath::half> hv(w * h);
  std::vector<unsigned> u(w * h);
  for (int i = 0; i < w * h; ++i) {
    f[i] = 1e-6f * std::pow(10.0f, static_cast<float>(i) * 0.8f);  // 1e-6 .. ~1e5
    hv[i] = Imath::half(0.25f * static_cast<float>(i) - 1.0f);     // exact in half
    u[i] = 1000u * static_cast<unsigned>(i);
  }
  const std::string path = (dir / "mixed.exr").string();
  {
    Imf::Header header(w, h);
    header.channels().insert("A", Imf::Channel(Imf::FLOAT));
    header.channels().insert("B", Imf::Channel(Imf::HALF));
    header.channels().insert("C", Imf::Channel(Imf::UINT));
    Imf::FrameBuffer fb;
    fb.insert("A", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(f.data()), sizeof(float), sizeof(float) * w));
    fb.insert("B",
              Imf::Slice(Imf::HALF, reinterpret_cast<char*>(hv.data()), sizeof(Imath::half), sizeof(Imath::half) * w));
    fb.insert("C", Imf::Slice(Imf::UINT, reinterpret_cast<char*>(u.data()), sizeof(unsigned), sizeof(unsigned) * w));
    Imf::OutputFile out(path.c_str(), header);
    out.setFrameBuffer(fb);
    out.writePixels(h);
  }
  const Image img = ReadImage(path);
  ASSERT_EQ(img.channels(), 3);
  // OpenImageIO orders the channels its own way (B as blue before A).
  const auto& names = img.channel_names();
  const auto index = [&](const char* n) {
    return static_cast<int>(std::find(names.begin(), names.end(), n) - names.begin());
  };
  const int a = index("A"), b = index("B"), c = index("C");
  ASSERT_TRUE(a < 3 && b < 3 && c < 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int i = y * w + x;
      EXPECT_EQ(img.at(x, y, a), f[i]) << i;
      EXPECT_EQ(img.at(x, y, b), static_cast<float>(hv[i])) << i;
      // OpenImageIO maps uint32 to [0, 1] as it does every integer type.
      EXPECT_NEAR(img.at(x, y, c), static_cast<double>(u[i]) / 4294967295.0, 1e-12) << i;
    }
}

TEST(Image, LdrRoundTripsThroughTheStatedTransfer) {
  TempDir dir;
  Image img = Ramp(16, 16, {"R", "G", "B"});
  for (const char* name : {"a.png", "a.tif", "a.jpg"}) {
    WriteImage(dir / name, img);
    ImageFileInfo info;
    Image back = ReadImage(dir / name, {}, &info);
    EXPECT_TRUE(info.decoded_from_ldr);
    EXPECT_EQ(info.transfer, Transfer::kSrgb);
    // 8-bit sRGB: a code step is at most 1/255 * dlinear/dsrgb <= 12.92^-1... bounded by
    // 0.0105 near 1; JPEG adds compression error, hence the looser bound.
    const float tol = std::string(name) == "a.jpg" ? 0.06f : (std::string(name) == "a.tif" ? 1e-4f : 0.0105f);
    for (size_t i = 0; i < img.values().size(); ++i) ASSERT_NEAR(back.values()[i], img.values()[i], tol) << name << i;
  }
  // Linear 16-bit PNG: stated as linear in the file and decoded as such.
  ImageWriteOptions lin;
  lin.pixel_type = PixelType::kUint16;
  lin.ldr_transfer = Transfer::kLinear;
  WriteImage(dir / "lin.png", img, lin);
  ImageFileInfo info;
  Image back = ReadImage(dir / "lin.png", {}, &info);
  EXPECT_EQ(info.transfer, Transfer::kLinear);
  for (size_t i = 0; i < img.values().size(); ++i) ASSERT_NEAR(back.values()[i], img.values()[i], 1.0 / 65535);
}

TEST(Image, RadianceHdrKeepsHighDynamicRange) {
  TempDir dir;
  Image img = Image::Rgb(8, 4, 1e-6f);
  img.at(3, 1, 0) = 1e6f;  // a sun twelve orders of magnitude above the sky
  WriteImage(dir / "a.hdr", img);
  Image back = ReadImage(dir / "a.hdr");
  // RGBE has an 8-bit mantissa: relative error < 2^-7.
  EXPECT_NEAR(back.at(3, 1, 0), 1e6f, 1e6f / 128);
  EXPECT_NEAR(back.at(0, 0, 1), 1e-6f, 1e-6f / 128);
}

TEST(Image, RejectsNonFinitePixelsByDefault) {
  TempDir dir;
  Image img = Image::Rgb(4, 3, 0.5f);
  img.at(2, 1, 1) = std::numeric_limits<float>::quiet_NaN();
  img.at(3, 2, 0) = std::numeric_limits<float>::infinity();
  WriteImage(dir / "nan.exr", img);
  try {
    ReadImage(dir / "nan.exr");
    FAIL();
  } catch (const Error& e) {
    std::string w = e.what();
    EXPECT_NE(w.find("nan.exr"), std::string::npos);
    EXPECT_NE(w.find("1 NaN and 1 Inf values; the first at pixel (2, 1) channel G"), std::string::npos) << w;
  }
  ImageReadOptions allow;
  allow.nonfinite = NonFinite::kAllow;
  Image back = ReadImage(dir / "nan.exr", allow);
  EXPECT_EQ(CountNonFinite(back), 2);
  auto stats = ComputeStats(back);
  EXPECT_EQ(stats[1].nan_count, 1);
  EXPECT_EQ(stats[0].inf_count, 1);
  EXPECT_FLOAT_EQ(stats[0].max, 0.5f);
}

// ReadImageCodes keeps a file's codes: 8-bit files a byte a value, 16-bit
// ones two, float files clamped to [0, 1] in 16 bits; the same codes
// ReadImage decodes (linear transfer: code / max exactly), and the same
// errors for a bad file.
TEST(Image, CodesAreTheFilesOwnAtItsDepth) {
  TempDir dir;
  Image img = Ramp(8, 4, {"R", "G", "B"}, 1.5f);  // values to 1.5: the float file clamps
  ImageWriteOptions lin;
  lin.ldr_transfer = Transfer::kLinear;
  WriteImage(dir / "a8.png", img, lin);
  lin.pixel_type = PixelType::kUint16;
  WriteImage(dir / "a16.png", img, lin);
  WriteImage(dir / "a.exr", img);
  ImageReadOptions raw;
  raw.use_file_transfer = false;
  raw.default_ldr_transfer = Transfer::kLinear;
  for (const auto& [name, bits] : {std::pair{"a8.png", 8}, std::pair{"a16.png", 16}, std::pair{"a.exr", 16}}) {
    const ImageCodes c = ReadImageCodes(dir / name, raw);
    ASSERT_EQ(c.bits, bits) << name;
    ASSERT_EQ(c.width, 8);
    ASSERT_EQ(c.height, 4);
    ASSERT_EQ(c.channels, 3);
    ASSERT_EQ(c.bytes.size(), 8u * 4 * 3 * (bits / 8));
    const Image back = ReadImage(dir / name, raw);
    const double max = bits == 8 ? 255.0 : 65535.0;
    for (size_t i = 0; i < back.values().size(); ++i) {
      const double code = bits == 8 ? c.bytes[i] : reinterpret_cast<const uint16_t*>(c.bytes.data())[i];
      const double want = std::clamp(static_cast<double>(back.values()[i]), 0.0, 1.0);
      ASSERT_NEAR(code / max, want, std::string(name) == "a.exr" ? 0.5 / 65535 : 1e-7) << name << " " << i;
    }
  }
  { std::ofstream(dir / "text.png") << "this is not a png"; }
  try {
    ReadImageCodes(dir / "text.png");
    FAIL() << "text decoded";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind((dir / "text.png").string(), 0), 0u) << e.what();
  }
}

TEST(Image, BadFilesGiveOneClearError) {
  TempDir dir;
  auto expect_error = [](const fs::path& p, const std::string& needle) {
    try {
      ReadImage(p);
      ADD_FAILURE() << "no error for " << p;
    } catch (const Error& e) {
      std::string w = e.what();
      EXPECT_EQ(w.rfind(p.string(), 0), 0u) << w;  // starts with the file name
      EXPECT_NE(w.find(needle), std::string::npos) << w;
    }
  };
  expect_error(dir / "missing.exr", "does not exist");
  { std::ofstream(dir / "empty.exr"); }
  expect_error(dir / "empty.exr", "is empty, not an image");
  { std::ofstream(dir / "text.png") << "this is not a png"; }
  expect_error(dir / "text.png", "is not an OpenEXR, Radiance HDR, PNG, JPEG, TIFF or PFM image");
  // A PNG named .exr is read as the PNG it is.
  WriteImage(dir / "small.png", Image::Rgb(4, 3, 0.5f));
  fs::copy_file(dir / "small.png", dir / "png-named.exr");
  EXPECT_EQ(ReadImage(dir / "png-named.exr").width(), 4);
  // A truncated EXR: the header survives, the pixels do not.
  Image img = Ramp(64, 64, {"R", "G", "B"});
  WriteImage(dir / "full.exr", img);
  std::string bytes;
  {
    std::ifstream in(dir / "full.exr", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  {
    std::ofstream(dir / "trunc.exr", std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  }
  expect_error(dir / "trunc.exr", "");
  // Huge dimensions claimed by a header are refused before allocation.
  ImageReadOptions small;
  small.max_pixels = 100;
  try {
    ReadImage(dir / "full.exr", small);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("more than the limit"), std::string::npos);
  }
}

// fuzz/fuzz_exr's finding: 645 bytes of EXR whose header claims a data
// window just under the pixel limit took OpenEXR 1.9 GB on opening.  The
// header is checked first (core/exr_check.h): that file is refused naming
// it (its attributes run past its end), and so is a valid EXR whose data
// window is patched to claim 16384x16384 pixels (ZIP holds at most ~1032
// bytes of pixels a byte; the chunk table alone needs 16 KB); mr's own EXRs
// of a constant image, compressed as far as deflate goes, still read.
TEST(Image, ExrHeaderClaimingMoreThanTheFileHoldsIsRefused) {
  TempDir dir;
  auto refused = [&](const fs::path& path, const std::string& what) {
    try {
      ImageReadOptions o;
      o.nonfinite = NonFinite::kAllow;
      ReadImage(path, o);
      ADD_FAILURE() << path << " was read";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path.filename().string()), std::string::npos) << e.what();
    }
  };
  fs::copy_file(fs::path(MR_SOURCE_DIR) / "fuzz" / "corpus" / "exr" / "oom-b526670278ab", dir / "fuzzed.exr");
  refused(dir / "fuzzed.exr", "OpenEXR header");

  const Image flat = Image::Rgb(512, 512, 0.25f);
  WriteImage(dir / "flat.exr", flat);
  EXPECT_EQ(ReadImage(dir / "flat.exr").values(), flat.values());
  ImageReadOptions few;
  few.max_values = 512 * 512 * 3 - 1;
  try {
    ReadImage(dir / "flat.exr", few);
    ADD_FAILURE() << "read past max_values";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("512x512 pixels of 3 channels, more than the limit of 268435456 pixels and "
                                         "786431 values"),
              std::string::npos)
        << e.what();
  }
  // OpenEXR allocates whole chunks (16 lines for ZIP) however few lines the
  // image has (fuzz_exr: a 1-line PIZ image 1.4M pixels wide took 1.5 GB):
  // a 100000x1 image spans 1.6M pixels there, past a 1M-pixel limit.
  WriteImage(dir / "line.exr", Image::Rgb(100000, 1, 0.5f));
  ImageReadOptions million;
  million.max_pixels = 1000000;
  try {
    ReadImage(dir / "line.exr", million);
    ADD_FAILURE() << "read past max_pixels";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("100000x1 pixels of 3 channels, in chunks spanning 1600000 pixels"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(ReadImage(dir / "line.exr").width(), 100000);
  ImageWriteOptions half;
  half.pixel_type = PixelType::kHalf;
  WriteImage(dir / "flat-half.exr", flat, half);
  EXPECT_EQ(ReadImage(dir / "flat-half.exr").width(), 512);

  // The data window patched: xMin yMin xMax yMax after "dataWindow\0box2i\0" and its size.
  std::string bytes = ReadTextFile(dir / "flat.exr");
  const std::string key = std::string("dataWindow") + '\0' + "box2i" + '\0';
  const size_t at = bytes.find(key);
  ASSERT_NE(at, std::string::npos);
  const int32_t big = 16383;
  std::memcpy(&bytes[at + key.size() + 4 + 8], &big, 4);
  std::memcpy(&bytes[at + key.size() + 4 + 12], &big, 4);
  WriteTextFile(dir / "claims.exr", bytes);
  refused(dir / "claims.exr", "claims 16384x16384 pixels");

  // A value whose layout disagrees with its declared size: OpenEXR reads by
  // the layout and goes on from the wrong byte (fuzz_exr: a channel list
  // not ending where declared made it allocate a 1.7 GB string).
  fs::copy_file(fs::path(MR_SOURCE_DIR) / "fuzz" / "corpus" / "exr" / "chlist-overrun.exr", dir / "chlist.exr");
  refused(dir / "chlist.exr", "the channel list does not end at its declared 461 bytes");
  const std::string window = ReadTextFile(dir / "flat.exr");
  std::string shrunk = window;
  const int32_t four = 4;  // dataWindow's box2i declared as 4 bytes
  std::memcpy(&shrunk[at + key.size()], &four, 4);
  WriteTextFile(dir / "box.exr", shrunk);
  refused(dir / "box.exr", "4 bytes declared, the type has 16");
  // A name past 31 bytes without the long-names flag: OpenEXR stops reading
  // it at the limit and takes the rest for the type and the size.
  std::string renamed = window;
  const size_t comp = renamed.find(std::string("compression") + '\0' + "compression");
  ASSERT_NE(comp, std::string::npos);
  renamed.replace(comp, 11, "compression_with_a_name_over_31_bytes");
  WriteTextFile(dir / "name.exr", renamed);
  refused(dir / "name.exr", "longer than 31 bytes without the long-names flag");
  // 48 bytes of WebP named .exr, claiming 12663x13749 pixels (fuzz_exr):
  // not a format mr reads, refused by its first bytes before 2.8 GB are
  // allocated.  A format mr does read gets the generic bound: a JPEG whose
  // frame header is patched to claim 12000x12000 pixels.
  fs::copy_file(fs::path(MR_SOURCE_DIR) / "fuzz" / "corpus" / "exr" / "webp-claiming-2.8GB.exr", dir / "webp.exr");
  refused(dir / "webp.exr", "is not an OpenEXR, Radiance HDR, PNG, JPEG, TIFF or PFM image");
  WriteImage(dir / "small.jpg", Image::Rgb(16, 16, 0.5f));
  std::string jpeg = ReadTextFile(dir / "small.jpg");
  size_t sof = std::string::npos;
  for (size_t i = 2; i + 9 < jpeg.size(); ++i)
    if (static_cast<unsigned char>(jpeg[i]) == 0xff && (static_cast<unsigned char>(jpeg[i + 1]) & 0xfc) == 0xc0) {
      sof = i;  // SOF0..SOF3: length (2), precision (1), height (2), width (2)
      break;
    }
  ASSERT_NE(sof, std::string::npos);
  for (size_t k : {sof + 5, sof + 7}) {
    jpeg[k] = static_cast<char>(12000 >> 8);
    jpeg[k + 1] = static_cast<char>(12000 & 0xff);
  }
  WriteTextFile(dir / "claims.jpg", jpeg);
  refused(dir / "claims.jpg", "the jpeg header claims 12000x12000 pixels of 3 channels, more than the file's");
  // Every part's header of a multi-part file is checked (fuzz_exr: a
  // second part's header made OpenEXR take 1.9 GB on opening 1999 bytes).
  fs::copy_file(fs::path(MR_SOURCE_DIR) / "fuzz" / "corpus" / "exr" / "multipart-second-header.exr",
                dir / "multipart.exr");
  refused(dir / "multipart.exr", "declares 1836213513 bytes");
}

TEST(Image, WriterRejectsWhatAFormatCannotHold) {
  TempDir dir;
  Image rgba = Image::Rgba(2, 2, 0.5f);
  EXPECT_THROW(WriteImage(dir / "a.hdr", rgba), Error);
  EXPECT_THROW(WriteImage(dir / "a.bmpx", rgba), Error);
  Image nan = Image::Rgb(2, 2, std::numeric_limits<float>::quiet_NaN());
  EXPECT_THROW(WriteImage(dir / "a.png", nan), Error);
  EXPECT_THROW(WriteImage(dir / "nofolder" / "a.exr", rgba), Error);
  EXPECT_EQ(dir.FileCount(), 0u);
}

TEST(Image, SrgbTransferRoundTrips) {
  for (float v = 0; v <= 1.0f; v += 1.0f / 64) EXPECT_NEAR(SrgbToLinear(LinearToSrgb(v)), v, 1e-6f);
  EXPECT_NEAR(SrgbToLinear(0.5f), 0.21404f, 1e-5f);
}

}  // namespace
}  // namespace mr
