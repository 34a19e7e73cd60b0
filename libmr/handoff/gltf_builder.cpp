#include "handoff/gltf_builder.h"

#include <algorithm>
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

std::string Base64Decode(const std::string& text) {
  std::string out;
  uint32_t acc = 0;
  int bits = 0;
  for (char ch : text) {
    if (ch == '=' || ch == '\n' || ch == '\r') continue;
    int v;
    if (ch >= 'A' && ch <= 'Z')
      v = ch - 'A';
    else if (ch >= 'a' && ch <= 'z')
      v = ch - 'a' + 26;
    else if (ch >= '0' && ch <= '9')
      v = ch - '0' + 52;
    else if (ch == '+')
      v = 62;
    else if (ch == '/')
      v = 63;
    else
      throw Error("base64: a character outside the alphabet");
    acc = acc << 6 | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((acc >> bits) & 0xff);
    }
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

size_t GltfBuilder::AppendBytes(const std::string& bytes) {
  while (bin_.size() % 16) bin_ += '\0';
  const size_t offset = bin_.size();
  bin_ += bytes;
  return offset;
}

namespace {

// A glTF file's JSON and, for a .glb, its binary chunk.
Json ReadGltf(const fs::path& path, std::string* bin) {
  const std::string data = ReadTextFile(path);
  if (data.size() >= 20 && data.compare(0, 4, "glTF") == 0) {
    uint32_t json_length = 0, kind = 0;
    std::memcpy(&json_length, data.data() + 12, 4);
    std::memcpy(&kind, data.data() + 16, 4);
    if (kind != 0x4E4F534A || 20 + static_cast<size_t>(json_length) > data.size())
      throw Error(fmt::format("{}: a .glb whose first chunk is not its JSON", path.string()));
    const size_t b = 20 + json_length;
    if (b + 8 <= data.size()) {
      uint32_t bin_length = 0;
      std::memcpy(&bin_length, data.data() + b, 4);
      if (b + 8 + bin_length > data.size())
        throw Error(fmt::format("{}: its binary chunk claims more than the file holds", path.string()));
      *bin = data.substr(b + 8, bin_length);
    }
    return Json::parse(data.substr(20, json_length));
  }
  return Json::parse(data);
}

// The bytes a URI names: a data URI, or a file beside the glTF.
std::string UriBytes(const std::string& uri, const fs::path& base, const fs::path& asset) {
  if (uri.rfind("data:", 0) == 0) {
    const size_t comma = uri.find(',');
    if (comma == std::string::npos || uri.find(";base64") > comma)
      throw Error(fmt::format("{}: a data URI that is not base64", asset.string()));
    return Base64Decode(uri.substr(comma + 1));
  }
  std::string path;  // percent-decoded
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size()) {
      path += static_cast<char>(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      path += uri[i];
    }
  }
  return ReadTextFile(base / path);
}

// Adds `by` to every integer at `key` in `j` (an index into an array that
// moved), where present.
void Offset(Json& j, const char* key, int by) {
  if (j.is_object() && j.contains(key) && j[key].is_number_integer()) j[key] = j[key].get<int>() + by;
}

// Every texture reference in a material, extensions included: objects under
// keys ending in "Texture" that hold an "index".
void OffsetTextures(Json& j, int by) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string& k = it.key();
      if (k.size() >= 7 && k.compare(k.size() - 7, 7, "Texture") == 0 && it->is_object()) Offset(*it, "index", by);
      OffsetTextures(*it, by);
    }
  } else if (j.is_array()) {
    for (Json& e : j) OffsetTextures(e, by);
  }
}

int Count(const Json& doc, const char* array) { return doc.contains(array) ? static_cast<int>(doc[array].size()) : 0; }

}  // namespace

std::string GltfBuilder::MergeAsset(const fs::path& path, int parent) {
  std::string glb_bin;
  Json a;
  try {
    a = ReadGltf(path, &glb_bin);
  } catch (const Json::exception& e) {
    throw Error(fmt::format("{}: not a glTF document: {}", path.string(), e.what()));
  }
  const fs::path base = path.parent_path();
  // Buffers: each copied into ours at an offset.
  std::vector<size_t> buffer_offset;
  for (const Json& buf : a.value("buffers", Json::array())) {
    const std::string bytes = buf.contains("uri") ? UriBytes(buf["uri"].get<std::string>(), base, path) : glb_bin;
    buffer_offset.push_back(AppendBytes(bytes));
  }
  const int views = Count(doc_, "bufferViews"), accessors = Count(doc_, "accessors"), meshes = Count(doc_, "meshes"),
            materials = Count(doc_, "materials"), textures = Count(doc_, "textures"), images = Count(doc_, "images"),
            samplers = Count(doc_, "samplers"), nodes = Count(doc_, "nodes");
  for (Json v : a.value("bufferViews", Json::array())) {
    const size_t b = v.value("buffer", 0);
    if (b >= buffer_offset.size()) throw Error(fmt::format("{}: a buffer view names buffer {}", path.string(), b));
    v["byteOffset"] = buffer_offset[b] + v.value("byteOffset", size_t{0});
    v["buffer"] = 0;
    Push("bufferViews", v);
  }
  for (Json acc : a.value("accessors", Json::array())) {
    Offset(acc, "bufferView", views);
    if (acc.contains("sparse")) {
      Offset(acc["sparse"]["indices"], "bufferView", views);
      Offset(acc["sparse"]["values"], "bufferView", views);
    }
    Push("accessors", acc);
  }
  for (Json img : a.value("images", Json::array())) {
    if (img.contains("uri")) {  // into the buffer: a .glb holds no files
      const std::string uri = img["uri"].get<std::string>();
      const std::string lower = LowerExtension(uri);
      if (!img.contains("mimeType"))
        img["mimeType"] = lower == ".png" ? "image/png" : lower == ".jpg" || lower == ".jpeg" ? "image/jpeg" : "";
      img["bufferView"] = AddBytesView(UriBytes(uri, base, path));
      img.erase("uri");
    } else {
      Offset(img, "bufferView", views);
    }
    Push("images", img);
  }
  for (const Json& smp : a.value("samplers", Json::array())) Push("samplers", smp);
  for (Json t : a.value("textures", Json::array())) {
    Offset(t, "source", images);
    Offset(t, "sampler", samplers);
    Push("textures", t);
  }
  for (Json m : a.value("materials", Json::array())) {
    OffsetTextures(m, textures);
    Push("materials", m);
  }
  for (Json m : a.value("meshes", Json::array())) {
    for (Json& prim : m["primitives"]) {
      for (auto& [k, v] : prim["attributes"].items()) v = v.get<int>() + accessors;
      Offset(prim, "indices", accessors);
      Offset(prim, "material", materials);
      if (prim.contains("targets"))
        for (Json& t : prim["targets"])
          for (auto& [k, v] : t.items()) v = v.get<int>() + accessors;
    }
    Push("meshes", m);
  }
  int left_out = 0;
  for (Json n : a.value("nodes", Json::array())) {
    Offset(n, "mesh", meshes);
    if (n.contains("children"))
      for (Json& c : n["children"]) c = c.get<int>() + nodes;
    for (const char* k : {"skin", "camera"})
      if (n.contains(k)) n.erase(k), ++left_out;
    Push("nodes", n);
  }
  // The asset's scene's roots under `parent`.
  const Json scenes = a.value("scenes", Json::array());
  const size_t scene = a.value("scene", 0);
  Json& children = doc_["nodes"][static_cast<size_t>(parent)]["children"];
  if (children.is_null()) children = Json::array();
  if (scene < scenes.size())
    for (const Json& r : scenes[scene].value("nodes", Json::array())) children.push_back(r.get<int>() + nodes);
  for (const char* list : {"extensionsUsed", "extensionsRequired"})
    for (const Json& e : a.value(list, Json::array())) {
      Json& mine = doc_[list];
      if (mine.is_null()) mine = Json::array();
      if (std::find(mine.begin(), mine.end(), e) == mine.end()) mine.push_back(e);
    }
  left_out += Count(a, "animations") + Count(a, "skins");
  return left_out ? fmt::format("{} skins, cameras and animations left out", left_out) : "";
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
