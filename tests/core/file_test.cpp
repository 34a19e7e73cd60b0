#include "core/file.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>

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

// A full disk: every write is checked, and the message names the file and
// gives the system's reason.
TEST(File, FullDiskIsAnErrorNamingTheFile) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "/dev/full is absent";
  try {
    OutputFile out("/dev/full", "out.bin");
    const std::string block(1 << 16, 'x');
    for (int i = 0; i < 4; ++i) out.Write(block.data(), block.size());
    out.Close();
    ADD_FAILURE() << "a write to /dev/full succeeded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("out.bin: write failed: No space left on device"), std::string::npos)
        << e.what();
  }
}

// A file-size limit (ulimit -f) with SIGXFSZ ignored, as every tool runs:
// the write fails with EFBIG, the temporary is removed, the old file stays.
// In a child process, so that the limit does not outlive the test.
TEST(File, FileSizeLimitIsAnErrorAndLeavesNothing) {
  test::TempDir dir;
  WriteTextFile(dir / "a.txt", "old");
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    rlimit limit{4096, 4096};
    setrlimit(RLIMIT_FSIZE, &limit);
    try {
      WriteTextFile(dir / "a.txt", std::string(100000, 'y'));
    } catch (const Error& e) {
      _exit(std::string(e.what()).find("a.txt: write failed: File too large") != std::string::npos ? 0 : 3);
    }
    _exit(2);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 0) << "2: no error; 3: the wrong message";
  EXPECT_EQ(ReadTextFile(dir / "a.txt"), "old");
  EXPECT_EQ(dir.FileCount(), 1u);
}

// The temporaries a killed run left are removed by the next run; those of a
// live process, and another host's (a render farm sharing the folder), stay.
TEST(File, StaleTemporariesOfDeadProcessesAreRemoved) {
  test::TempDir dir;
  const pid_t child = fork();  // a process that is surely gone once reaped
  ASSERT_GE(child, 0);
  if (child == 0) _exit(0);
  waitpid(child, nullptr, 0);
  char host[256] = {0};
  gethostname(host, sizeof(host) - 1);
  const std::string dead = fmt::format(".mr-tmp-{}@{}@0-frame.exr", child, host);
  const std::string other_host = fmt::format(".mr-tmp-{}@not-{}@0-frame.exr", child, host);
  const std::string alive = TemporaryName("frame", 7) + ".exr";  // this process's
  for (const std::string& n : {dead, other_host, alive, std::string("00000.exr")}) WriteTextFile(dir / n, "x");
  EXPECT_EQ(RemoveStaleTemporaries(dir.path()), 1);
  EXPECT_FALSE(fs::exists(dir / dead));
  EXPECT_TRUE(fs::exists(dir / other_host));
  EXPECT_TRUE(fs::exists(dir / alive));
  EXPECT_TRUE(fs::exists(dir / "00000.exr"));
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
