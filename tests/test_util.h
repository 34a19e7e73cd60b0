// Helpers shared by the tests.
#pragma once

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "core/file.h"

namespace mr::test {

// A fresh temporary folder, removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    static int counter = 0;
    path_ = std::filesystem::temp_directory_path() /
            ("mr-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }
  // Files in the folder (to check that nothing half-written was left behind).
  size_t FileCount() const {
    size_t n = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(path_)) ++n;
    return n;
  }

 private:
  std::filesystem::path path_;
};

// A folder made once per build of the test executable and shared by every
// test process (CTest runs each test in its own process, so a suite's
// SetUpTestSuite would otherwise remake it for every test): `make(dir)`
// fills it the first time, under a lock so that concurrent processes wait
// for it, and later calls return it.  Under the build folder, keyed by the
// executable's modification time: a rebuilt test makes it anew.  Callers
// copy it before changing anything in it.
inline std::filesystem::path SharedFixture(const std::string& name,
                                           const std::function<void(const std::filesystem::path&)>& make) {
  namespace fs = std::filesystem;
  struct stat st {};
  const long long stamp = ::stat("/proc/self/exe", &st) == 0 ? static_cast<long long>(st.st_mtime) : 0;
  const fs::path root = fs::path(MR_BIN_DIR).parent_path() / "test-fixtures";
  const fs::path dir = root / (name + "-" + std::to_string(stamp));
  fs::create_directories(root);
  const int lock = ::open((root / (name + ".lock")).c_str(), O_CREAT | O_RDWR, 0644);
  if (lock >= 0) ::flock(lock, LOCK_EX);
  if (!fs::exists(dir / ".complete")) {
    const fs::path tmp = root / (name + ".making-" + std::to_string(::getpid()));
    fs::remove_all(tmp);
    fs::create_directories(tmp);
    make(tmp);
    { std::ofstream(tmp / ".complete") << "made\n"; }
    fs::remove_all(dir);
    fs::rename(tmp, dir);
  }
  if (lock >= 0) {
    ::flock(lock, LOCK_UN);
    ::close(lock);
  }
  return dir;
}

// ../shared/data, or skips the test with a message saying so.
inline std::filesystem::path SharedData(const std::string& sub) {
  std::filesystem::path p = std::filesystem::path(MR_SHARED_DATA) / sub;
  return p;
}

#define MR_REQUIRE_SHARED_DATA(sub)                                        \
  do {                                                                     \
    if (!std::filesystem::exists(::mr::test::SharedData(sub)))             \
      GTEST_SKIP() << "shared test data " << ::mr::test::SharedData(sub)   \
                   << " is absent (set MR_SHARED_DATA to ../shared/data)"; \
  } while (false)

}  // namespace mr::test
