// Fuzzes the asset readers through ReadAsset; built once per kind with
// MR_FUZZ_ASSET_KIND: "gltf" and "glb" (tinygltf and mr's accessor checks),
// "objmtl" (an OBJ and its MTL: the input's bytes up to the first NUL are
// the OBJ, the rest the MTL file m.mtl beside it, which the OBJ names with
// "mtllib m.mtl").  Every input must give an asset or an mr::Error.
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/error.h"
#include "geometry/asset.h"

namespace {

void Write(const std::string& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = "/tmp/mr-fuzz-asset-" + std::to_string(getpid());
  static const bool made = std::filesystem::create_directories(dir) || true;
  (void)made;
  const std::string kind = MR_FUZZ_ASSET_KIND;
  std::string path;
  if (kind == "objmtl") {
    const uint8_t* nul = static_cast<const uint8_t*>(std::memchr(data, 0, size));
    const size_t obj = nul ? static_cast<size_t>(nul - data) : size;
    path = dir + "/a.obj";
    Write(path, data, obj);
    Write(dir + "/m.mtl", nul ? nul + 1 : data, nul ? size - obj - 1 : 0);
  } else {
    path = dir + "/a." + kind;
    Write(path, data, size);
  }
  try {
    mr::ReadAsset(path);
  } catch (const mr::Error&) {
  }
  return 0;
}
