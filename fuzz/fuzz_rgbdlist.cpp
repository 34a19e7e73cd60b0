#include <cstdint>
#include <sstream>

#include "camera/trajectory.h"
#include "core/error.h"
#include "recon/rgbd.h"

// TUM's rgb.txt / depth.txt lists, then the association of the list with
// itself shifted by 10 ms (what mr-fuse does with colour and depth).
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const auto list = mr::ReadTimestampList(in, "fuzz.txt");
    std::vector<double> a, b;
    for (const auto& e : list) {
      a.push_back(e.t);
      b.push_back(e.t + 0.01);
    }
    mr::AssociateTimestamps(a, b, 0.02);
  } catch (const mr::Error&) {
  }
  return 0;
}
