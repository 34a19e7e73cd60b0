#include "core/json.h"

#include <set>
#include <vector>

#include "core/error.h"

namespace mr {

namespace {
FileLoc LocAtByte(const std::string& text, size_t byte, const std::string& file) {
  FileLoc loc{file, 1, 1, ""};
  for (size_t i = 0; i < byte && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++loc.line;
      loc.column = 1;
    } else {
      ++loc.column;
    }
  }
  return loc;
}
}  // namespace

Json ParseJsonStrict(const std::string& text, const std::string& file) {
  // Track keys per open object to reject duplicates.
  std::vector<std::set<std::string>> keys;
  std::string duplicate;
  auto cb = [&](int depth, Json::parse_event_t event, Json& parsed) {
    (void)depth;
    switch (event) {
      case Json::parse_event_t::object_start:
        keys.emplace_back();
        break;
      case Json::parse_event_t::object_end:
        if (!keys.empty()) keys.pop_back();
        break;
      case Json::parse_event_t::key:
        if (!keys.empty() && !keys.back().insert(parsed.get<std::string>()).second && duplicate.empty())
          duplicate = parsed.get<std::string>();
        break;
      default:
        break;
    }
    return true;
  };
  try {
    Json j = Json::parse(text, cb, /*allow_exceptions=*/true, /*ignore_comments=*/false);
    if (!duplicate.empty()) ThrowErrorAt(FileLoc{file}, "duplicate key \"{}\"", duplicate);
    return j;
  } catch (const Json::parse_error& e) {
    std::string what = e.what();
    // Drop nlohmann's "[json.exception.parse_error.101] parse error at line 1, column 2: ".
    auto pos = what.find(": ");
    if (pos != std::string::npos) what = what.substr(pos + 2);
    size_t byte = e.byte > 0 ? e.byte - 1 : 0;
    throw Error(LocAtByte(text, byte, file), "invalid JSON: " + what);
  } catch (const Json::exception& e) {
    // out_of_range.406: a number too large for a double (1e999); found by fuzz/fuzz_scene.
    std::string what = e.what();
    auto pos = what.find("] ");
    if (pos != std::string::npos) what = what.substr(pos + 2);
    ThrowErrorAt(FileLoc{file}, "invalid JSON: {}", what);
  }
}

Json ReadJsonFile(const fs::path& path) { return ParseJsonStrict(ReadTextFile(path), path.string()); }

}  // namespace mr
