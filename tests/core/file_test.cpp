#include "core/file.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "test_util.h"

namespace mr {
namespace {

TEST(File, AtomicWriteLeavesNothingWhenTheWriterFails) {
  test::TempDir dir;
  WriteTextFile(dir / "a.txt", "old");
  EXPECT_THROW(WriteAtomically(dir / "a.txt",
                               [](const fs::path& tmp) {
                                 WriteTextFile(tmp, "half");
                                 ThrowError("disk on fire");
                               }),
               Error);
  EXPECT_EQ(ReadTextFile(dir / "a.txt"), "old");  // untouched
  EXPECT_EQ(dir.FileCount(), 1u);                 // temporary removed
  WriteTextFile(dir / "a.txt", "new");
  EXPECT_EQ(ReadTextFile(dir / "a.txt"), "new");
}

TEST(File, TemporaryKeepsTheExtension) {
  test::TempDir dir;
  fs::path seen;
  WriteAtomically(dir / "x.exr", [&](const fs::path& tmp) {
    seen = tmp;
    WriteTextFile(tmp, "");
  });
  EXPECT_EQ(seen.extension(), ".exr");
  EXPECT_EQ(seen.parent_path(), dir.path());
}

TEST(File, ErrorsNameTheFile) {
  test::TempDir dir;
  try {
    ReadTextFile(dir / "nope.txt");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), (dir / "nope.txt").string() + ": file does not exist");
  }
  EXPECT_THROW(RequireFile(dir.path()), Error);  // a folder
  EXPECT_EQ(LowerExtension("A/B.EXR"), ".exr");
}

}  // namespace
}  // namespace mr
