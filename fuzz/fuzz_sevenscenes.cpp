#include <cstdint>
#include <sstream>

#include "camera/trajectory.h"
#include "core/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    mr::Read7ScenesPose(in, "fuzz.pose.txt");
  } catch (const mr::Error&) {
  }
  return 0;
}
