// Fuzzes mr's OBJ, OFF and STL readers through ReadMesh; built once per
// format with MR_FUZZ_MESH_EXT (".obj", ".off", ".stl").  The readers must
// answer every input with a mesh or an mr::Error, in time linear in its size.
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <string>

#include "core/error.h"
#include "geometry/mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = "/tmp/mr-fuzz-" + std::to_string(getpid()) + MR_FUZZ_MESH_EXT;
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  for (mr::BadVertices bad : {mr::BadVertices::kReject, mr::BadVertices::kDropFaces}) {
    try {
      mr::MeshReadOptions opt;
      opt.nonfinite = bad;
      mr::ReadMesh(path, opt);
    } catch (const mr::Error&) {
    }
  }
  return 0;
}
