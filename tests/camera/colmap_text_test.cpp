#include "camera/colmap_text.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "test_util.h"

namespace mr {
namespace {

const char* kCameras =
    "# Camera list with one line of data per camera:\n"
    "1 PINHOLE 640 480 500 510 320 240\n"
    "2 OPENCV 640 480 500 510 320.5 240.5 -0.1 0.01 0.001 -0.001\n";
const char* kImages =
    "# Image list\n"
    "1 1 0 0 0 0.1 0.2 0.3 1 a.png\n"
    "10.5 20.5 7 30 40 -1\n"
    "2 0.7071067811865476 0 0.7071067811865476 0 1 2 3 2 b.png\n"
    "\n";
const char* kPoints = "7 1 2 3 255 128 0 0.5 1 0 2 5\n";

TEST(Colmap, PixelCentreConventionIsConvertedAtTheBoundary) {
  auto cams = ParseColmapCameras(kCameras, "cameras.txt");
  // COLMAP's (320, 240) is mr's (319.5, 239.5).
  EXPECT_EQ(cams.at(1).params[2], 319.5);
  EXPECT_EQ(cams.at(1).params[3], 239.5);
  auto images = ParseColmapImages(kImages, "images.txt");
  EXPECT_EQ(images.at(1).points2d[0].xy, Eigen::Vector2d(10, 20));
  EXPECT_EQ(images.at(1).points2d[0].point3d_id, 7);
  EXPECT_TRUE(images.at(2).points2d.empty());  // the empty POINTS2D line
  // images.txt is world-to-camera with qw first.
  EXPECT_EQ(images.at(2).cam_from_world.translation, Eigen::Vector3d(1, 2, 3));
  Eigen::Vector3d z_in_cam = images.at(2).cam_from_world.rotation * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR((z_in_cam - Eigen::Vector3d::UnitX()).norm(), 0, 1e-12);
  CameraModel m = ToCameraModel(cams.at(2));
  EXPECT_EQ(m.lensmodel(), "LENSMODEL_OPENCV4");
  EXPECT_EQ(m.Core(), Eigen::Vector4d(500, 510, 320, 240));
}

TEST(Colmap, TextRoundTrip) {
  test::TempDir dir;
  ColmapModel m;
  m.cameras = ParseColmapCameras(kCameras, "c");
  m.images = ParseColmapImages(kImages, "i");
  m.points3d = ParseColmapPoints3D(kPoints, "p");
  WriteColmapText(dir.path(), m);
  ColmapModel back = ReadColmapText(dir.path());
  EXPECT_EQ(back.cameras.at(2).params, m.cameras.at(2).params);
  EXPECT_EQ(back.images.at(1).points2d[0].xy, m.images.at(1).points2d[0].xy);
  EXPECT_TRUE(back.images.at(2).cam_from_world.IsApprox(m.images.at(2).cam_from_world, 1e-15));
  EXPECT_EQ(back.points3d.at(7).track.size(), 2u);
  EXPECT_EQ(back.points3d.at(7).rgb[1], 128);
  EXPECT_EQ(FormatColmapCameras(back.cameras), FormatColmapCameras(m.cameras));
}

TEST(Colmap, BadInputNamesFileAndLine) {
  auto err = [](auto fn) {
    try {
      fn();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(err([] { ParseColmapCameras("1 PINHOLE 640 480 1 2 3\n", "cameras.txt"); }),
            "cameras.txt:1: PINHOLE takes 4 parameters, got 3");
  EXPECT_EQ(err([] { ParseColmapCameras("1 BANANA 640 480 1\n", "cameras.txt"); }),
            "cameras.txt:1: unknown COLMAP camera model \"BANANA\"");
  EXPECT_EQ(err([] { ParseColmapImages("1 1 0 0 0 0 0 0 1 a.png\n1 2\n", "images.txt"); }),
            "images.txt:2: POINTS2D must be triples X Y POINT3D_ID");
  EXPECT_EQ(err([] { ParseColmapImages("1 1 0 0 0 0 0 0 1 a.png\n", "images.txt"); }),
            "images.txt:1: missing POINTS2D line after image 1");
  EXPECT_EQ(err([] { ParseColmapPoints3D("1 0 0 0 300 0 0 0\n", "points3D.txt"); }),
            "points3D.txt:1: colour component 300 outside 0..255");
  EXPECT_THROW(ToCameraModel(ColmapCamera{1, "OPENCV_FISHEYE", 10, 10, std::vector<double>(8, 1.0)}), Error);
}

}  // namespace
}  // namespace mr
