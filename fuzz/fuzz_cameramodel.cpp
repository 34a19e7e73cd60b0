// Fuzzes .cameramodel parsing (libmrcal's parser and mr's checks).
#include <cstdint>
#include <string>

#include "camera/camera_model.h"
#include "core/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  try {
    mr::CameraModel m = mr::CameraModel::FromString(text, "fuzz.cameramodel");
    Eigen::Vector2d q;
    m.Project(Eigen::Vector3d(0.1, 0.2, 1.0), &q);
  } catch (const mr::Error&) {
  }
  return 0;
}
