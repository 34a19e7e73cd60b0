#include "cli/info.h"

#include <gtest/gtest.h>

#include "camera/camera_model.h"
#include "cli/tool.h"
#include "core/image.h"
#include "test_util.h"

namespace mr {
namespace {

// Messages quoting a corrupt file never send binary to a terminal; UTF-8 file
// names, newlines and tabs pass unchanged.
TEST(Tool, PrintableMessageEscapesBinaryButKeepsUtf8) {
  EXPECT_EQ(PrintableMessage("plain: text\tand\nlines"), "plain: text\tand\nlines");
  EXPECT_EQ(PrintableMessage("ünïcødé.obj € \xf0\x9f\x98\x80"), "ünïcødé.obj € \xf0\x9f\x98\x80");
  EXPECT_EQ(PrintableMessage(std::string("a\x01\x1b[31mred\xff\xfe\x7f", 13)), "a\\x01\\x1b[31mred\\xff\\xfe\\x7f");
  EXPECT_EQ(PrintableMessage(std::string("nul\0", 4)), "nul\\x00");
  EXPECT_EQ(PrintableMessage("\xc3"), "\\xc3");                    // a cut sequence
  EXPECT_EQ(PrintableMessage("\xc0\xaf"), "\\xc0\\xaf");           // an overlong '/'
  EXPECT_EQ(PrintableMessage("\xed\xa0\x80"), "\\xed\\xa0\\x80");  // a surrogate
}

TEST(Info, DescribesEveryKindAndFlagsUnsoundFiles) {
  test::TempDir dir;
  CameraModel("LENSMODEL_OPENCV4", {500, 500, 319.5, 239.5, 0, 0, 0, 0}, 640, 480).Write(dir / "c.cameramodel");
  FileInfo c = DescribeFile(dir / "c.cameramodel");
  EXPECT_EQ(c.kind, "camera model");
  EXPECT_TRUE(c.sound);
  EXPECT_EQ(c.json["width"], 640);

  Image img = Image::Rgb(4, 4, 1.0f);
  img.at(0, 0, 0) = std::numeric_limits<float>::infinity();
  WriteImage(dir / "inf.exr", img);
  FileInfo i = DescribeFile(dir / "inf.exr");
  EXPECT_EQ(i.kind, "image");
  EXPECT_FALSE(i.sound);
  EXPECT_EQ(i.json["channels"][0]["inf"], 1);

  WriteTextFile(dir / "t.txt", "0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n");
  FileInfo t = DescribeFile(dir / "t.txt");
  EXPECT_EQ(t.kind, "trajectory");
  EXPECT_EQ(t.json["path_length_m"], 1.0);

  FileInfo missing = DescribeFile(dir / "nope.exr");
  EXPECT_FALSE(missing.sound);
  ASSERT_EQ(missing.problems.size(), 1u);
  EXPECT_NE(missing.problems[0].find("nope.exr"), std::string::npos);
}

}  // namespace
}  // namespace mr
