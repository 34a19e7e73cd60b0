// Fuzzes lights.json parsing and validation: any input must either parse or
// throw mr::Error, never crash.
#include <cstdint>
#include <string>

#include "core/error.h"
#include "core/json.h"
#include "light/lights_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  try {
    mr::Json j = mr::ParseJsonStrict(text, "fuzz.json");
    mr::ParseLights(j, "fuzz.json");
  } catch (const mr::Error&) {
  }
  return 0;
}
