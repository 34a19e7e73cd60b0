// Fuzzes scene.json parsing and validation, the render methods' own blocks
// included: any input must either parse or throw mr::Error, never crash.
#include <cstdint>
#include <string>

#include "core/error.h"
#include "core/json.h"
#include "render/method.h"
#include "scene/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  try {
    mr::Json j = mr::ParseJsonStrict(text, "fuzz.json");
    mr::CheckRenderSettings(mr::ParseScene(j, "/nonexistent", "fuzz.json", /*check_files=*/false));
  } catch (const mr::Error&) {
  }
  return 0;
}
