#include "handoff/gltf_builder.h"

#include <cmath>
#include <cstring>
#include <limits>

#include "core/check.h"
#include "core/error.h"
#include "core/file.h"

namespace mr {

std::string Base64Encode(const std::string& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = static_cast<uint8_t>(bytes[i]) << 16 | static_cast<uint8_t>(bytes[i + 1]) << 8 |
                       static_cast<uint8_t>(bytes[i + 2]);
    for (int k = 3; k >= 0; --k) out += kAlphabet[(v >> (6 * k)) & 63];
  }
  if (i < bytes.size()) {
    const bool two = i + 1 < bytes.size();
    const uint32_t v = static_cast<uint8_t>(bytes[i]) << 16 | (two ? static_cast<uint8_t>(bytes[i + 1]) << 8 : 0);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += two ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

GltfBuilder::GltfBuilder() { doc_ = {{"asset", {{"version", "2.0"}, {"generator", "mr-export"}}}}; }

int GltfBuilder::Push(const std::string& array, Json item) {
  Json& a = doc_[array];
  if (a.is_null()) a = Json::array();
  a.push_back(std::move(item));
  return static_cast<int>(a.size()) - 1;
}

int GltfBuilder::AddView(const void* data, size_t bytes, int target) {
  while (bin_.size() % 4) bin_ += '\0';
  Json view = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", bytes}};
  if (target) view["target"] = target;
  bin_.append(static_cast<const char*>(data), bytes);
  return Push("bufferViews", std::move(view));
}

int GltfBuilder::AddFloats(const std::vector<float>& values, int components, bool bounds, int target) {
  static const char* kTypes[] = {"", "SCALAR", "VEC2", "VEC3", "VEC4"};
  MR_CHECK(components >= 1 && components <= 4);
  if (values.size() % static_cast<size_t>(components) != 0)
    throw Error(fmt::format("glTF accessor: {} floats is not a whole number of {}-vectors", values.size(), components));
  Json lo = Json::array(), hi = Json::array();
  for (int c = 0; c < components; ++c) {
    float a = std::numeric_limits<float>::infinity(), b = -a;
    for (size_t i = static_cast<size_t>(c); i < values.size(); i += static_cast<size_t>(components)) {
      if (!std::isfinite(values[i])) throw Error("glTF accessor: a non-finite value");
      a = std::min(a, values[i]);
      b = std::max(b, values[i]);
    }
    lo.push_back(a);
    hi.push_back(b);
  }
  const int view = AddView(values.data(), values.size() * sizeof(float), target);
  Json acc = {{"bufferView", view},
              {"componentType", 5126},
              {"count", values.size() / static_cast<size_t>(components)},
              {"type", kTypes[components]}};
  if (bounds && !values.empty()) acc["min"] = lo, acc["max"] = hi;
  return Push("accessors", std::move(acc));
}

int GltfBuilder::AddIndices(const std::vector<uint32_t>& indices) {
  const int view = AddView(indices.data(), indices.size() * sizeof(uint32_t), 34963);
  return Push("accessors",
              {{"bufferView", view}, {"componentType", 5125}, {"count", indices.size()}, {"type", "SCALAR"}});
}

Json GltfBuilder::Finished(bool data_uri) const {
  Json d = doc_;
  if (!bin_.empty()) {
    Json buffer = {{"byteLength", bin_.size()}};
    if (data_uri) buffer["uri"] = "data:application/octet-stream;base64," + Base64Encode(bin_);
    d["buffers"] = Json::array({buffer});
  }
  return d;
}

std::string GltfBuilder::Gltf() const { return Finished(true).dump(1) + "\n"; }

std::string GltfBuilder::Glb() const {
  std::string json = Finished(false).dump();
  while (json.size() % 4) json += ' ';
  std::string bin = bin_;
  while (bin.size() % 4) bin += '\0';
  auto u32 = [](std::string* s, uint32_t v) { s->append(reinterpret_cast<const char*>(&v), 4); };
  std::string out;
  const size_t total = 12 + 8 + json.size() + (bin.empty() ? 0 : 8 + bin.size());
  if (total > std::numeric_limits<uint32_t>::max()) throw Error("glTF: the scene exceeds the 4 GiB a .glb can hold");
  u32(&out, 0x46546C67);  // "glTF"
  u32(&out, 2);
  u32(&out, static_cast<uint32_t>(total));
  u32(&out, static_cast<uint32_t>(json.size()));
  u32(&out, 0x4E4F534A);  // "JSON"
  out += json;
  if (!bin.empty()) {
    u32(&out, static_cast<uint32_t>(bin.size()));
    u32(&out, 0x004E4942);  // "BIN\0"
    out += bin;
  }
  return out;
}

void GltfBuilder::Write(const fs::path& path) const {
  const std::string ext = LowerExtension(path);
  if (ext != ".glb" && ext != ".gltf")
    throw Error(fmt::format("{}: a glTF scene is written as .glb or .gltf, not '{}'", path.string(), ext));
  WriteTextFile(path, ext == ".glb" ? Glb() : Gltf());
}

}  // namespace mr
