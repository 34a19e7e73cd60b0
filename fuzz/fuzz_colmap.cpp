#include <cstdint>
#include <string>

#include "camera/colmap_text.h"
#include "core/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  try {
    mr::ParseColmapCameras(text, "cameras.txt");
  } catch (const mr::Error&) {
  }
  try {
    mr::ParseColmapImages(text, "images.txt");
  } catch (const mr::Error&) {
  }
  try {
    mr::ParseColmapPoints3D(text, "points3D.txt");
  } catch (const mr::Error&) {
  }
  return 0;
}
