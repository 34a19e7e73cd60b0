// Strict JSON loading: syntax errors name file:line:col, duplicate keys are
// rejected (nlohmann silently keeps the last one), and a small helper walks
// objects with key paths for validation messages.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "core/file.h"

namespace mr {

using Json = nlohmann::json;

// Parses `text` (named `file` in messages).  Throws mr::Error.
Json ParseJsonStrict(const std::string& text, const std::string& file);
Json ReadJsonFile(const fs::path& path);

}  // namespace mr
