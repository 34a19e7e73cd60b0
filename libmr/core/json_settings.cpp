#include "core/json_settings.h"

#include <algorithm>

#include "core/check.h"

namespace mr {

namespace {

// Levenshtein distance: insertions, deletions and substitutions.
size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

}  // namespace

JsonSettings::JsonSettings(const JsonNode& block) : block_(block) {
  if (!block.json().is_object()) block.Fail(fmt::format("expected an object, got {}", block.TypeName()));
}

void JsonSettings::Declare(SettingDecl d) {
  for (const SettingDecl& e : decl_) MR_CHECK(e.key != d.key);  // one name, one setting
  decl_.push_back(std::move(d));
}

void JsonSettings::Integer(const char* key, int* v, int64_t lo, int64_t hi) {
  Declare({.key = key, .type = "integer", .default_value = *v, .lo = double(lo), .hi = double(hi)});
  if (block_.Has(key)) *v = static_cast<int>(block_.Child(key).Integer(lo, hi));
}

void JsonSettings::Number(const char* key, double* v, double lo, double hi) {
  Declare({.key = key, .type = "number", .default_value = *v, .lo = lo, .hi = hi});
  if (block_.Has(key)) *v = block_.Child(key).Number(lo, hi);
}

void JsonSettings::Bool(const char* key, bool* v) {
  Declare({.key = key, .type = "bool", .default_value = *v});
  if (block_.Has(key)) *v = block_.Child(key).Bool();
}

void JsonSettings::OneOf(const char* key, std::string* v, const std::vector<std::string>& options) {
  Declare({.key = key, .type = "string", .default_value = *v, .choices = options});
  if (block_.Has(key)) *v = block_.Child(key).OneOf(options);
}

std::optional<JsonNode> JsonSettings::Take(const char* key) {
  Declare({.key = key, .type = "node"});
  if (!block_.Has(key)) return std::nullopt;
  return block_.Child(key);
}

JsonNode JsonSettings::Require(const char* key) {
  Declare({.key = key, .type = "node"});
  // A required key misspelt is named as the unknown key it is (Done, which
  // would name it, is not reached).
  if (!block_.Has(key))
    for (const std::string& k : Unread())
      if (EditDistance(k, key) <= 2)
        block_.Child(k).Fail(fmt::format("unknown key (did you mean \"{}\", which is required here?)", key));
  return block_.Required(key);
}

std::vector<std::string> JsonSettings::Unread() const {
  std::vector<std::string> unread;
  for (const auto& [k, v] : block_.json().items()) {
    bool read = false;
    for (const SettingDecl& d : decl_) read = read || d.key == k;
    if (!read) unread.push_back(k);
  }
  return unread;
}

void JsonSettings::Header(const char* format, const char* what) {
  const JsonNode f = Require("format");
  const JsonNode v = Require("version");
  if (f.String() != format) f.Fail(fmt::format("expected \"{}\"", format));
  if (v.Integer(1, 1000) != 1) v.Fail(fmt::format("this mr reads {} version 1", what));
}

void JsonSettings::Done(const char* also) const {
  const std::vector<std::string> unread = Unread();
  if (unread.empty()) return;
  std::string list;
  for (const SettingDecl& d : decl_) list += (list.empty() ? "" : ", ") + d.key;
  if (also) list += std::string("; ") + also;
  block_.Child(unread.front()).Fail(fmt::format("unknown key (allowed here: {})", list));
}

}  // namespace mr
