// Fuzzes the PLY header parser and ASCII pre-pass through ReadMesh.
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <string>

#include "core/error.h"
#include "geometry/mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = "/tmp/mr-fuzz-" + std::to_string(getpid()) + ".ply";
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    mr::MeshReadOptions opt;
    opt.nonfinite = mr::BadVertices::kDropFaces;
    mr::ReadMesh(path, opt);
  } catch (const mr::Error&) {
  }
  return 0;
}
