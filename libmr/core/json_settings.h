// A JSON settings block read by consuming it (pbrt-v4's ParameterDictionary
// and ReportUnused): each key is named once, where it is read, with its range;
// its default is the value the settings struct already holds. Done() rejects
// the keys nothing read, naming the ones declared. What was declared can be
// listed (declared()), so docs tables are checked against the code
// (tests/render/method_settings_test.cpp).
//
//   JsonSettings s(node);            // node: render.ic, say; must be an object
//   s.Integer("rays", &o.rays, 1, 1 << 24);
//   s.Bool("gradients", &o.gradients);
//   s.Done();                        // render.ic.raz: unknown key (allowed here: rays, gradients)
//
// Messages name the file and key path, as JsonNode's do.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/json.h"
#include "core/json_node.h"

namespace mr {

// One setting as the code declares it.
struct SettingDecl {
  std::string key;
  std::string type;                  // "integer", "number", "bool" or "string"
  Json default_value;                // the settings struct's value before reading
  double lo = 0, hi = 0;             // integer and number: the accepted range
  std::vector<std::string> choices;  // string: the accepted values
};

class JsonSettings {
 public:
  // Requires `block` to be an object (a message naming its path otherwise).
  explicit JsonSettings(const JsonNode& block);

  // Each reads `key` into *v when present, checked against the range or
  // choices; leaves *v (the default) otherwise. A key is declared once.
  void Integer(const char* key, int* v, int64_t lo, int64_t hi);
  void Number(const char* key, double* v, double lo, double hi);
  void Bool(const char* key, bool* v);
  // A string naming one of `choices`, each mapped to a value of T.
  template <class T>
  void Choice(const char* key, T* v, std::initializer_list<std::pair<const char*, T>> choices) {
    SettingDecl d{.key = key, .type = "string"};
    for (const auto& [name, value] : choices) {
      d.choices.push_back(name);
      if (value == *v) d.default_value = name;
    }
    Declare(std::move(d));
    if (!block_.Has(key)) return;
    const std::string s = block_.Child(key).OneOf(decl_.back().choices);
    for (const auto& [name, value] : choices)
      if (s == name) *v = value;
  }

  // A string naming one of `options`, kept as the string.
  void OneOf(const char* key, std::string* v, const std::vector<std::string>& options);
  // The node of `key` (declared, so not rejected by Done), absent or
  // present: for values the caller reads itself (a nested block, a path, a
  // list). Require fails with "missing required key" when it is absent, or,
  // where the block has an unread key within two edits of it ("camra"),
  // names that key as unknown and suggests the required one.
  std::optional<JsonNode> Take(const char* key);
  JsonNode Require(const char* key);

  // An mr file's header: "format" must be `format` ("mr-probe") and
  // "version" 1 ("this mr reads WHAT version 1" otherwise).
  void Header(const char* format, const char* what);

  // The node of a declared key, for checks across keys (Fail names it).
  JsonNode Node(const char* key) const { return block_.Child(key); }
  bool Has(const char* key) const { return block_.Has(key); }
  // Rejects every key of the block no call above declared; `also`, when
  // given, is added to the list of allowed keys in the message (keys another
  // parser reads: "or light, which makes the entry a virtual light").
  void Done(const char* also = nullptr) const;
  // The keys no call above declared, in the block's order (for blocks that
  // hold more than settings: render's method blocks).
  std::vector<std::string> Unread() const;
  const std::vector<SettingDecl>& declared() const { return decl_; }

 private:
  void Declare(SettingDecl d);

  JsonNode block_;
  std::vector<SettingDecl> decl_;
};

}  // namespace mr
