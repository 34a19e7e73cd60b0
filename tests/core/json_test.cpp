#include "core/json.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/json_settings.h"

namespace mr {
namespace {

std::string ErrorOf(const std::string& text) {
  try {
    ParseJsonStrict(text, "x.json");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Json, SyntaxErrorsGiveLineAndColumn) {
  std::string e = ErrorOf("{\n  \"a\": 1,\n  \"b\": ]\n}");
  EXPECT_EQ(e.rfind("x.json:3:8: invalid JSON", 0), 0u) << e;
  EXPECT_NE(ErrorOf("{} trailing"), "");
  EXPECT_NE(ErrorOf(""), "");
  // A number beyond the double range is an error, not std::terminate (found by fuzz_scene).
  EXPECT_EQ(ErrorOf(R"({"a": 1e999})"), "x.json: invalid JSON: number overflow parsing '1e999'");
}

TEST(Json, DuplicateKeysAreRejected) {
  EXPECT_EQ(ErrorOf(R"({"a": 1, "b": {"c": 1, "c": 2}})"), "x.json: duplicate key \"c\"");
  EXPECT_EQ(ErrorOf(R"({"a": {"c": 1}, "b": {"c": 2}})"), "");  // same key in different objects is fine
}

// Reads {"rays": int, "mesh": required, "note": optional} from `text`;
// returns the error message, or "" and the values read.
std::string SettingsErrorOf(const std::string& text, int* rays = nullptr) {
  const std::string file = "s.json";
  const Json j = ParseJsonStrict(text, file);
  try {
    JsonSettings s(JsonNode(j, "", &file));
    int r = 8;
    s.Integer("rays", &r, 1, 100);
    s.Require("mesh");
    s.Take("note");
    s.Done();
    if (rays) *rays = r;
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(JsonSettings, ReadsDeclaredKeysAndRejectsOthers) {
  int rays = 0;
  EXPECT_EQ(SettingsErrorOf(R"({"mesh": "a.ply"})", &rays), "");
  EXPECT_EQ(rays, 8);  // the default: the struct's own value
  EXPECT_EQ(SettingsErrorOf(R"({"mesh": "a.ply", "rays": 3})", &rays), "");
  EXPECT_EQ(rays, 3);
  EXPECT_EQ(SettingsErrorOf(R"({"mesh": "a", "rays": 300})"), "s.json: rays: expected an integer in [1, 100], got 300");
  EXPECT_EQ(SettingsErrorOf(R"({"mesh": "a", "ray": 3})"), "s.json: ray: unknown key (allowed here: rays, mesh, note)");
  EXPECT_EQ(SettingsErrorOf(R"({"rays": 3})"), "s.json: mesh: missing required key");
  EXPECT_EQ(SettingsErrorOf(R"([1])"), "s.json: expected an object, got an array of 1");
}

// A misspelt required key is named as the unknown key it is, as it was
// when the allowed keys were checked first, not as the required one missing.
TEST(JsonSettings, MisspeltRequiredKeyIsNamed) {
  EXPECT_EQ(SettingsErrorOf(R"({"mesj": "a.ply"})"),
            "s.json: mesj: unknown key (did you mean \"mesh\", which is required here?)");
  EXPECT_EQ(SettingsErrorOf(R"({"Mesh": "a.ply"})"),
            "s.json: Mesh: unknown key (did you mean \"mesh\", which is required here?)");
  // Far from every required key: the required one is what is missing.
  EXPECT_EQ(SettingsErrorOf(R"({"geometry": "a.ply"})"), "s.json: mesh: missing required key");
}

}  // namespace
}  // namespace mr
