// Helpers shared by the tests.
#pragma once

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
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
