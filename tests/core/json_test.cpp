#include "core/json.h"

#include <gtest/gtest.h>

#include "core/error.h"

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

}  // namespace
}  // namespace mr
