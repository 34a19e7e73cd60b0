// The RGB-D readers (recon/rgbd.h): the layouts, their intrinsics and poses, bad depth.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "camera/camera_model.h"
#include "camera/trajectory.h"
#include "core/error.h"
#include "core/image.h"
#include "geometry/primitives.h"
#include "recon/rgbd.h"
#include "test_util.h"

namespace mr {
namespace {

TEST(Rgbd, SevenScenesFolderOpensWithItsIntrinsicsAndPoses) {
  MR_REQUIRE_SHARED_DATA("rgbd-7scenes-kitchen");
  const RgbdSequence s = OpenRgbdSequence(test::SharedData("rgbd-7scenes-kitchen"));
  EXPECT_EQ(s.layout, "7scenes");
  EXPECT_EQ(s.frames.size(), 300u);
  EXPECT_EQ(s.K.fx, 585);
  EXPECT_EQ(s.K.width, 640);
  EXPECT_EQ(s.reference.size(), 300u);
  EXPECT_TRUE(s.has_color());
  DepthReadStats st;
  const DepthMap d = ReadDepth(s.frames[0].depth, {1000, 0.1, 10}, 640, 480, &st);
  EXPECT_GT(st.valid, 200000);
  EXPECT_GT(st.median_m, 0.5);
  EXPECT_LT(st.median_m, 4);
  EXPECT_EQ(SuggestDepthScale(st.median_m, 1000), 0);
  // Read as if TUM (5000 per metre): the median is implausible and 1000 is suggested.
  DepthReadStats wrong;
  ReadDepth(s.frames[0].depth, {5000, 0.1, 10}, 640, 480, &wrong);
  EXPECT_EQ(SuggestDepthScale(wrong.median_m, 5000), 1000);
}

TEST(Rgbd, TumLayoutAssociatesAndPlainLayoutNeedsACameraModel) {
  test::TempDir dir;
  fs::create_directories(dir / "depth");
  fs::create_directories(dir / "rgb");
  Image depth = Image::Gray(8, 6, 5000.0f / 65535.0f);  // 1 m
  ImageWriteOptions wo;
  wo.pixel_type = PixelType::kUint16;
  wo.ldr_transfer = Transfer::kLinear;
  WriteImage(dir / "depth/1.0.png", depth, wo);
  WriteImage(dir / "depth/2.0.png", depth, wo);
  WriteImage(dir / "rgb/1.005.png", Image::Rgb(8, 6, 0.5f));
  WriteTextFile(dir / "depth.txt", "# depth\n1.0 depth/1.0.png\n2.0 depth/2.0.png\n");
  WriteTextFile(dir / "rgb.txt", "1.005 rgb/1.005.png\n");
  RgbdOpenOptions o;
  o.intrinsics = PinholeIntrinsics{10, 10, 3.5, 2.5, 8, 6};
  const RgbdSequence s = OpenRgbdSequence(dir.path(), o);
  EXPECT_EQ(s.layout, "tum");
  EXPECT_EQ(s.depth_scale, 5000);
  ASSERT_EQ(s.frames.size(), 1u);  // 2.0 has no colour within 0.02 s
  EXPECT_EQ(s.unpaired_depth, 1);
  const DepthMap d = ReadDepth(s.frames[0].depth, {s.depth_scale, 0.1, 10}, 8, 6);
  EXPECT_FLOAT_EQ(d.at(3, 3), 1.0f);
  // Without intrinsics: one message naming the folder.
  try {
    OpenRgbdSequence(dir.path());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("intrinsics"), std::string::npos) << std::string(e.what());
  }
  // A depth map of the wrong size is named.
  try {
    ReadDepth(s.frames[0].depth, {5000, 0.1, 10}, 640, 480);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("8x6"), std::string::npos) << std::string(e.what());
  }
}

// The plain layout: depth/ and rgb/ paired by name, the intrinsics from the
// folder's .cameramodel, groundtruth.txt (TUM, timestamp = frame index) as
// the reference trajectory (bench/registration_blender.py writes one).
TEST(Rgbd, PlainLayoutReadsItsCameraModelAndGroundTruth) {
  test::TempDir dir;
  fs::create_directories(dir / "depth");
  fs::create_directories(dir / "rgb");
  ImageWriteOptions wo;
  wo.pixel_type = PixelType::kUint16;
  wo.ldr_transfer = Transfer::kLinear;
  for (const char* n : {"00000.png", "00001.png"}) {
    WriteImage(dir / "depth" / n, Image::Gray(8, 6, 1000.0f / 65535.0f), wo);  // 1 m
    WriteImage(dir / "rgb" / n, Image::Rgb(8, 6, 0.5f));
  }
  try {  // no camera model: named
    OpenRgbdSequence(dir.path());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(".cameramodel"), std::string::npos) << std::string(e.what());
  }
  CameraModel("LENSMODEL_PINHOLE", {10, 11, 3.5, 2.5}, 8, 6).Write(dir / "cam.cameramodel");
  const RgbdSequence without = OpenRgbdSequence(dir.path());
  EXPECT_EQ(without.layout, "plain");
  EXPECT_TRUE(without.reference.poses.empty());
  WriteTextFile(dir / "groundtruth.txt", "0 0 0 0 0 0 0 1\n1 0.1 0 0 0 0 0 1\n");
  const RgbdSequence s = OpenRgbdSequence(dir.path());
  ASSERT_EQ(s.frames.size(), 2u);
  EXPECT_EQ(s.K.fy, 11);
  ASSERT_EQ(s.reference.size(), 2u);
  EXPECT_DOUBLE_EQ(s.reference.poses[1].world_from_cam.translation.x(), 0.1);
  EXPECT_EQ(s.frames[1].timestamp, s.reference.poses[1].timestamp);
}

TEST(Rgbd, GarbageDepthIsRejectedAndCounted) {
  // A float depth map with NaN, Inf, negative, the 65535 marker's float
  // twin and out-of-range values: each is dropped and counted, never fused.
  test::TempDir dir;
  Image d = Image::Gray(4, 2, 2000.0f);  // 2 m in mm
  d.at(0, 0, 0) = std::nanf("");
  d.at(1, 0, 0) = INFINITY;
  d.at(2, 0, 0) = -5;
  d.at(3, 0, 0) = 1e9f;  // 1000 km
  d.at(0, 1, 0) = 0;     // no return
  ImageWriteOptions wo;
  wo.pixel_type = PixelType::kFloat;
  WriteImage(dir / "d.exr", d, wo);
  DepthReadStats st;
  const DepthMap m = ReadDepth(dir / "d.exr", {1000, 0.1, 10}, 4, 2, &st);
  EXPECT_EQ(st.valid, 3);
  EXPECT_EQ(st.rejected, 4);
  EXPECT_EQ(st.invalid_markers, 1);
  for (int x = 0; x < 4; ++x) EXPECT_EQ(m.at(x, 0), 0.0f);
  EXPECT_FLOAT_EQ(m.at(1, 1), 2.0f);
  // 8-bit "depth" is refused with the file named.
  WriteImage(dir / "d8.png", Image::Gray(4, 2, 0.5f));
  EXPECT_THROW(ReadDepth(dir / "d8.png", {1000, 0.1, 10}, 4, 2), Error);
}

}  // namespace
}  // namespace mr
