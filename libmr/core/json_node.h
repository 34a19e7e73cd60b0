// Validation of JSON file formats (scene.json, lights.json, ...): walks an
// object checking keys, types and ranges, and names the key path and the
// file in every message, e.g.
//   lights.json: lights[2].cone_deg: expected a number in [0, 90], got 120
#pragma once

#include <string>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Core>

#include "core/error.h"
#include "core/json.h"

namespace mr {

// Walks a JSON object, checking keys and types, remembering the key path.
class JsonNode {
 public:
  JsonNode(const Json& j, std::string path, const std::string* file) : j_(&j), path_(std::move(path)), file_(file) {}

  [[noreturn]] void Fail(const std::string& what) const { throw Error(FileLoc{*file_, 0, 0, path_}, what); }
  const std::string& path() const { return path_; }
  const Json& json() const { return *j_; }

  bool Has(const char* key) const { return j_->contains(key); }
  JsonNode Child(const std::string& key) const {
    return JsonNode(j_->at(key), path_.empty() ? key : path_ + "." + key, file_);
  }
  JsonNode Index(size_t i) const { return JsonNode(j_->at(i), fmt::format("{}[{}]", path_, i), file_); }
  JsonNode Required(const char* key) const {
    if (!j_->contains(key))
      JsonNode(Json(), path_.empty() ? key : path_ + "." + key, file_).Fail("missing required key");
    return Child(key);
  }

  std::string TypeName() const {
    if (j_->is_array()) return fmt::format("an array of {}", j_->size());
    return j_->type_name();
  }

  std::string String() const {
    if (!j_->is_string()) Fail(fmt::format("expected a string, got {}", TypeName()));
    return j_->get<std::string>();
  }
  std::string OneOf(const std::vector<std::string>& options) const {
    std::string s = String();
    for (const auto& o : options)
      if (s == o) return s;
    std::string list;
    for (const auto& o : options) list += (list.empty() ? "" : ", ") + o;
    Fail(fmt::format("\"{}\" is not one of {}", s, list));
  }
  bool Bool() const {
    if (!j_->is_boolean()) Fail(fmt::format("expected true or false, got {}", TypeName()));
    return j_->get<bool>();
  }
  double Number(double lo, double hi) const {
    if (!j_->is_number()) Fail(fmt::format("expected a number in [{}, {}], got {}", lo, hi, TypeName()));
    double v = j_->get<double>();
    if (!(v >= lo && v <= hi)) Fail(fmt::format("expected a number in [{}, {}], got {}", lo, hi, v));
    return v;
  }
  int64_t Integer(int64_t lo, int64_t hi) const {
    if (!j_->is_number_integer())
      Fail(fmt::format("expected an integer in [{}, {}], got {}", lo, hi, j_->is_number() ? j_->dump() : TypeName()));
    int64_t v = j_->get<int64_t>();
    if (v < lo || v > hi) Fail(fmt::format("expected an integer in [{}, {}], got {}", lo, hi, v));
    return v;
  }
  std::vector<double> Numbers(size_t n, double lo, double hi) const {
    auto fail = [&](const std::string& got) {
      Fail(fmt::format("expected {} numbers in [{},{}], got {}", n, lo, hi, got));
    };
    if (!j_->is_array()) fail(TypeName());
    if (j_->size() != n) fail(std::to_string(j_->size()));
    std::vector<double> v;
    for (const auto& e : *j_) {
      if (!e.is_number()) fail(fmt::format("a {}", e.type_name()));
      double x = e.get<double>();
      if (!(x >= lo && x <= hi)) fail(fmt::format("{}", x));
      v.push_back(x);
    }
    return v;
  }
  Eigen::Vector3d Vec3(double lo, double hi) const {
    auto v = Numbers(3, lo, hi);
    return {v[0], v[1], v[2]};
  }

 private:
  const Json* j_;  // a pointer, not a reference: a node can be assigned
  std::string path_;
  const std::string* file_;
};

}  // namespace mr
