// The render.<method> tables of docs/formats.md against the settings each
// method declares (JsonSettings): same keys in the same order, same defaults,
// same ranges, so that the docs and the code cannot drift apart.
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "render/method.h"

namespace mr {
namespace {

std::string Trim(std::string s) {
  const auto b = s.find_first_not_of(" `"), e = s.find_last_not_of(" `");
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

// The rows (cells, backticks kept) of each "#### `render.<name>`" table.
std::map<std::string, std::vector<std::vector<std::string>>> DocTables() {
  std::ifstream in(std::string(MR_SOURCE_DIR) + "/docs/formats.md");
  EXPECT_TRUE(in) << "docs/formats.md";
  std::map<std::string, std::vector<std::vector<std::string>>> tables;
  std::string line, current;
  while (std::getline(in, line)) {
    if (line.rfind("#### `render.", 0) == 0) {
      current = Trim(line.substr(5)).substr(7);
      tables[current];
    } else if (!current.empty() && line.rfind("|", 0) == 0) {
      std::vector<std::string> cells;
      std::stringstream ss(line.substr(1));
      for (std::string cell; std::getline(ss, cell, '|');) cells.push_back(cell);
      if (cells.size() >= 3 && Trim(cells[0]) != "key" && cells[0].find("---") == std::string::npos)
        tables[current].push_back(cells);
    } else if (!current.empty() && line.empty() && !tables[current].empty()) {
      current.clear();
    }
  }
  return tables;
}

// The default as docs/formats.md writes it.
std::string DocDefault(const SettingDecl& d) {
  if (d.type == "string") return "\"" + d.default_value.get<std::string>() + "\"";
  return d.default_value.dump();
}

std::string DocRange(const SettingDecl& d) {
  if (d.type == "bool") return "";
  if (d.type == "string") {
    std::string s;
    for (const std::string& c : d.choices) s += (s.empty() ? "`" : ", `") + c + "`";
    return s;
  }
  return fmt::format("[{}, {}]", d.lo, d.hi);
}

TEST(MethodSettings, DocsTablesMatchTheDeclarations) {
  const auto tables = DocTables();
  for (const MethodInfo& m : RenderMethodRegistry()) {
    SCOPED_TRACE("render." + m.name);
    const std::vector<SettingDecl> decl = RenderMethodSettings(m);
    // What the table should say, for the failure message.
    std::string expected;
    for (const SettingDecl& d : decl)
      expected += fmt::format("| `{}` | {} | {} | ... |\n", d.key, DocDefault(d), DocRange(d));
    const auto it = tables.find(m.name);
    if (decl.empty()) {
      EXPECT_TRUE(it == tables.end() || it->second.empty()) << "render." << m.name << " declares no settings";
      continue;
    }
    ASSERT_TRUE(it != tables.end()) << "docs/formats.md has no \"#### `render." << m.name << "`\" table:\n" << expected;
    const auto& rows = it->second;
    ASSERT_EQ(rows.size(), decl.size()) << "expected rows:\n" << expected;
    for (size_t i = 0; i < decl.size(); ++i) {
      const SettingDecl& d = decl[i];
      SCOPED_TRACE(d.key);
      EXPECT_EQ(Trim(rows[i][0]), d.key) << "expected rows:\n" << expected;
      // Defaults and ranges compare as values (1e-3 and 0.001 are the same).
      const Json doc_default = Json::parse(Trim(rows[i][1]), nullptr, false);
      if (d.type == "integer" || d.type == "number") {
        ASSERT_TRUE(doc_default.is_number()) << rows[i][1];
        EXPECT_EQ(doc_default.get<double>(), d.default_value.get<double>());
        const Json range = Json::parse(Trim(rows[i][2]), nullptr, false);
        ASSERT_TRUE(range.is_array() && range.size() == 2) << rows[i][2] << ", expected " << DocRange(d);
        EXPECT_EQ(range[0].get<double>(), d.lo);
        EXPECT_EQ(range[1].get<double>(), d.hi);
      } else {
        EXPECT_EQ(doc_default, d.default_value) << rows[i][1] << ", expected " << DocDefault(d);
        EXPECT_EQ(Trim(rows[i][2]), Trim(DocRange(d)));
      }
      EXPECT_FALSE(Trim(rows[i][3]).empty()) << "the meaning of render." << m.name << "." << d.key;
    }
  }
  for (const auto& [name, rows] : tables) {
    bool known = false;
    for (const MethodInfo& m : RenderMethodRegistry()) known = known || m.name == name;
    EXPECT_TRUE(known) << "docs/formats.md documents render." << name << ", which is no method";
  }
}

// Settings are read by consuming them: an unread key is rejected, listing the
// declared keys; a key read twice is a programming error.
TEST(MethodSettings, UnreadKeysAreRejectedNamingTheDeclaredOnes) {
  const std::string file = "scene.json";
  const Json block = {{"rays", 8}, {"raz", 1}};
  JsonSettings s(JsonNode(block, "render.ic", &file));
  int rays = 256;
  bool gradients = true;
  s.Integer("rays", &rays, 1, 1 << 24);
  s.Bool("gradients", &gradients);
  EXPECT_EQ(rays, 8);
  EXPECT_TRUE(gradients);
  try {
    s.Done();
    FAIL() << "raz was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("render.ic.raz: unknown key (allowed here: rays, gradients)"),
              std::string::npos)
        << e.what();
  }
  const Json bad = {{"rays", 0}};
  JsonSettings b(JsonNode(bad, "render.ic", &file));
  EXPECT_THROW(b.Integer("rays", &rays, 1, 1 << 24), Error);
  const Json not_object = Json::array();
  EXPECT_THROW(JsonSettings(JsonNode(not_object, "render.ic", &file)), Error);
}

TEST(MethodSettings, ChoicesMapNamesToValues) {
  const std::string file = "scene.json";
  const Json block = {{"relight", "delta"}};
  JsonSettings s(JsonNode(block, "render.vct", &file));
  bool split = true;
  s.Choice("relight", &split, {{"delta", false}, {"split", true}});
  EXPECT_FALSE(split);
  EXPECT_EQ(s.declared().at(0).default_value, "split");
  const Json wrong = {{"relight", "both"}};
  JsonSettings w(JsonNode(wrong, "render.vct", &file));
  EXPECT_THROW(w.Choice("relight", &split, {{"delta", false}, {"split", true}}), Error);
}

}  // namespace
}  // namespace mr
