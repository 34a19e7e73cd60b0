// glTF 2.0 through tinygltf (docs/dependencies.md says why): tinygltf parses
// the JSON, resolves buffers and image bytes (files, data: URIs, the GLB
// chunk); everything it hands over is checked here before use: every
// accessor against its buffer view and buffer, every index against its
// vertex count, every attribute for finite values.
// Debian's libtinygltf is a shared library: its implementation is built
// there; the image decoder is replaced by KeepImageBytes below, and image
// files beside a .gltf are not read here (SkipImageFiles below).
#include <tiny_gltf.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <set>

#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include "core/error.h"
#include "geometry/asset.h"
#include "geometry/asset_detail.h"

namespace mr::detail {

namespace {

namespace tg = tinygltf;

// Keeps an image's bytes as they are: mr decodes them where they are used.
// `model` is the model being read (its buffers and views are read before
// its images): tinygltf 2.7 hands over an image's buffer view without
// checking that it lies inside its buffer (found by fuzz/fuzz_glb), so the
// view is checked here before a byte is read.
bool KeepImageBytes(tg::Image* image, const int index, std::string* err, std::string*, int, int,
                    const unsigned char* bytes, int size, void* model) {
  if (image->bufferView >= 0) {
    const tg::Model& m = *static_cast<const tg::Model*>(model);
    const tg::BufferView& bv = m.bufferViews.at(static_cast<size_t>(image->bufferView));
    const size_t held = m.buffers.at(static_cast<size_t>(bv.buffer)).data.size();
    if (bv.byteOffset > held || bv.byteLength > held - bv.byteOffset || size < 0) {
      *err += fmt::format("image {}: its buffer view {} reaches past its buffer ({} bytes at {}, the buffer holds {})",
                          index, image->bufferView, bv.byteLength, bv.byteOffset, held);
      return false;
    }
  }
  image->image.assign(bytes, bytes + size);
  image->width = image->height = image->component = -1;
  return true;
}

// The image files a .gltf names (resolved beside it, percent-decoded), which
// tinygltf would read whole only for mr to read them again where it decodes
// them (an asset with nine 4k PNGs: 2.1 s and 240 MB of the read): the file
// reader given to tinygltf refuses these, so that tinygltf keeps the uri
// (its documented behaviour for an image file it cannot read) and mr reads
// the file where it decodes it.  A file that is also a buffer is read.
struct SkipImageFiles {
  std::set<fs::path> images, buffers;

  static bool Read(std::vector<unsigned char>* out, std::string* err, const std::string& file, void* self) {
    const auto& s = *static_cast<const SkipImageFiles*>(self);
    const fs::path p = fs::path(file).lexically_normal();
    if (s.images.count(p) && !s.buffers.count(p)) {
      if (err) *err += "image file " + file + " is read where it is decoded\n";
      return false;
    }
    return tg::ReadWholeFile(out, err, file, nullptr);
  }
};

// A URI's path with its %XX escapes decoded (RFC 3986; glTF URIs are
// escaped: "my%20tex.png" is the file "my tex.png").
std::string PercentDecoded(const std::string& uri) {
  std::string out;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      out += static_cast<char>(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += uri[i];
    }
  }
  return out;
}

// The image and buffer files `gltf` names (nothing where its JSON does not
// parse: tinygltf then says what is wrong).
SkipImageFiles FilesNamedIn(const fs::path& gltf) {
  SkipImageFiles s;
  std::ifstream in(gltf, std::ios::binary);
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return s;
  auto collect = [&](const char* key, std::set<fs::path>* into) {
    const auto it = j.find(key);
    if (it == j.end() || !it->is_array()) return;
    for (const auto& e : *it) {
      if (!e.is_object() || !e.contains("uri") || !e["uri"].is_string()) continue;
      const std::string uri = e["uri"].get<std::string>();
      if (uri.rfind("data:", 0) != 0) into->insert((gltf.parent_path() / PercentDecoded(uri)).lexically_normal());
    }
  };
  collect("images", &s.images);
  collect("buffers", &s.buffers);
  return s;
}

struct Reader {
  const tg::Model& m;
  std::string name;  // the file, for messages
  Asset* out;

  [[noreturn]] void Fail(const std::string& what) const { ThrowErrorAt(FileLoc{name}, "{}", what); }

  // An accessor's elements as floats, `n` components each (the accessor's
  // own count must match), normalised integers mapped as the
  // specification says; sparse substitutions applied.
  std::vector<float> Floats(int index, int n, const char* what) const {
    const tg::Accessor& a = At(m.accessors, index, "accessor", what);
    const int comps = tg::GetNumComponentsInType(static_cast<uint32_t>(a.type));
    if (comps != n)
      Fail(fmt::format("{}: accessor {} has {} components per element, expected {}", what, index, comps, n));
    std::vector<float> v(a.count * static_cast<size_t>(n), 0.0f);
    if (a.bufferView >= 0) ReadElements(a, a.bufferView, a.byteOffset, a.count, nullptr, &v, what, index);
    if (a.sparse.isSparse) ApplySparse(a, &v, what, index);
    return v;
  }
  std::vector<uint32_t> Indices(int index, const char* what) const {
    const tg::Accessor& a = At(m.accessors, index, "accessor", what);
    if (a.type != TINYGLTF_TYPE_SCALAR) Fail(fmt::format("{}: accessor {} is not scalar", what, index));
    if (a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
        a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
      Fail(fmt::format("{}: accessor {} of indices is not of unsigned integers", what, index));
    std::vector<uint32_t> v(a.count, 0);
    if (a.bufferView >= 0) ReadElements(a, a.bufferView, a.byteOffset, a.count, &v, nullptr, what, index);
    if (a.sparse.isSparse) Fail(fmt::format("{}: sparse index accessors are not read by mr", what));
    return v;
  }

  template <class T>
  const T& At(const std::vector<T>& list, int i, const char* kind, const std::string& what) const {
    if (i < 0 || static_cast<size_t>(i) >= list.size())
      Fail(fmt::format("{}: {} {} does not exist ({} in the file)", what, kind, i, list.size()));
    return list[static_cast<size_t>(i)];
  }

  // The bytes of `count` elements of accessor `a`'s type starting at
  // `offset` in buffer view `view`, checked to lie inside it.
  void ReadElements(const tg::Accessor& a, int view, size_t offset, size_t count, std::vector<uint32_t>* ints,
                    std::vector<float>* floats, const std::string& what, int index) const {
    const tg::BufferView& bv = At(m.bufferViews, view, "buffer view", what);
    const tg::Buffer& buf = At(m.buffers, bv.buffer, "buffer", what);
    const int csize = tg::GetComponentSizeInBytes(static_cast<uint32_t>(a.componentType));
    const int comps = tg::GetNumComponentsInType(static_cast<uint32_t>(a.type));
    if (csize <= 0 || comps <= 0) Fail(fmt::format("{}: accessor {} has an unknown type", what, index));
    const size_t elem = static_cast<size_t>(csize) * static_cast<size_t>(comps);
    const size_t stride = bv.byteStride ? bv.byteStride : elem;
    if (bv.byteOffset > buf.data.size() || bv.byteLength > buf.data.size() - bv.byteOffset)
      Fail(fmt::format("{}: buffer view {} reaches past its buffer ({} bytes at {}, the buffer holds {})", what, view,
                       bv.byteLength, bv.byteOffset, buf.data.size()));
    if (count > 0) {
      // offset + stride (count - 1) + elem <= byteLength, without overflow.
      const size_t len = bv.byteLength;
      if (offset > len || elem > len - offset || (count - 1) > (len - offset - elem) / stride)
        Fail(fmt::format("{}: accessor {} claims {} elements, more than its buffer view {} holds ({} bytes)", what,
                         index, count, view, len));
    }
    const unsigned char* base = buf.data.data() + bv.byteOffset + offset;
    for (size_t i = 0; i < count; ++i)
      for (int c = 0; c < comps; ++c) {
        const unsigned char* p = base + i * stride + static_cast<size_t>(c) * static_cast<size_t>(csize);
        const size_t k = i * static_cast<size_t>(comps) + static_cast<size_t>(c);
        if (ints) (*ints)[k] = ReadUnsigned(p, a.componentType);
        if (floats) (*floats)[k] = ReadFloat(p, a.componentType, a.normalized);
      }
  }
  static uint32_t ReadUnsigned(const unsigned char* p, int type) {
    if (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) return p[0];
    if (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    uint32_t v;
    std::memcpy(&v, p, 4);
    return v;
  }
  // glTF 2.0, "Animations" / KHR_mesh_quantization: normalised signed
  // values map to max(c / (2^(n-1) - 1), -1), unsigned to c / (2^n - 1).
  static float ReadFloat(const unsigned char* p, int type, bool normalized) {
    switch (type) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float v;
        std::memcpy(&v, p, 4);
        return v;
      }
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        const int8_t v = static_cast<int8_t>(p[0]);
        return normalized ? std::max(v / 127.0f, -1.0f) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return normalized ? p[0] / 255.0f : p[0];
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? std::max(v / 32767.0f, -1.0f) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? v / 65535.0f : v;
      }
      default: {
        uint32_t v;
        std::memcpy(&v, p, 4);
        return static_cast<float>(v);
      }
    }
  }
  void ApplySparse(const tg::Accessor& a, std::vector<float>* v, const std::string& what, int index) const {
    const auto& s = a.sparse;
    if (s.count < 0 || static_cast<size_t>(s.count) > a.count)
      Fail(fmt::format("{}: accessor {} has {} sparse values for {} elements", what, index, s.count, a.count));
    tg::Accessor ia;
    ia.componentType = s.indices.componentType;
    ia.type = TINYGLTF_TYPE_SCALAR;
    std::vector<uint32_t> idx(static_cast<size_t>(s.count));
    if (s.indices.byteOffset < 0 || s.values.byteOffset < 0)
      Fail(fmt::format("{}: accessor {} has a negative sparse offset", what, index));
    ReadElements(ia, s.indices.bufferView, static_cast<size_t>(s.indices.byteOffset), idx.size(), &idx, nullptr, what,
                 index);
    const int comps = tg::GetNumComponentsInType(static_cast<uint32_t>(a.type));
    std::vector<float> val(idx.size() * static_cast<size_t>(comps));
    ReadElements(a, s.values.bufferView, static_cast<size_t>(s.values.byteOffset), idx.size(), nullptr, &val, what,
                 index);
    for (size_t i = 0; i < idx.size(); ++i) {
      if (idx[i] >= a.count)
        Fail(fmt::format("{}: accessor {}'s sparse index {} is past its {} elements", what, index, idx[i], a.count));
      for (int c = 0; c < comps; ++c)
        (*v)[idx[i] * static_cast<size_t>(comps) + static_cast<size_t>(c)] =
            val[i * static_cast<size_t>(comps) + static_cast<size_t>(c)];
    }
  }

  // --- materials --------------------------------------------------------

  static const tg::Value* Ext(const tg::ExtensionMap& e, const char* name) {
    auto it = e.find(name);
    return it == e.end() || !it->second.IsObject() ? nullptr : &it->second;
  }
  static float Number(const tg::Value* obj, const char* key, float fallback) {
    if (!obj || !obj->Has(key) || !obj->Get(key).IsNumber()) return fallback;
    return static_cast<float>(obj->Get(key).GetNumberAsDouble());
  }
  template <int N>
  static Eigen::Matrix<float, N, 1> Vector(const tg::Value* obj, const char* key, Eigen::Matrix<float, N, 1> v) {
    if (!obj || !obj->Has(key) || !obj->Get(key).IsArray() || obj->Get(key).ArrayLen() != N) return v;
    for (int i = 0; i < N; ++i)
      if (obj->Get(key).Get(i).IsNumber()) v[i] = static_cast<float>(obj->Get(key).Get(i).GetNumberAsDouble());
    return v;
  }

  AssetTexture Texture(int index, int texcoord, const tg::ExtensionMap& ext, const std::string& what) const {
    AssetTexture t;
    if (index < 0) return t;
    const tg::Texture& tex = At(m.textures, index, "texture", what);
    if (tex.source < 0) {
      out->report.ignored.push_back(
          fmt::format("{}: texture {} has no image mr reads (an extension's only)", what, index));
      return t;
    }
    At(m.images, tex.source, "image", what);
    t.image = tex.source;
    t.texcoord = texcoord;
    if (tex.sampler >= 0) {
      const tg::Sampler& s = At(m.samplers, tex.sampler, "sampler", what);
      auto wrap = [](int w) {
        return w == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE     ? TextureWrap::kClamp
               : w == TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT ? TextureWrap::kMirror
                                                            : TextureWrap::kRepeat;
      };
      t.wrap_s = wrap(s.wrapS);
      t.wrap_t = wrap(s.wrapT);
    }
    if (const tg::Value* tt = Ext(ext, "KHR_texture_transform")) {
      t.offset = Vector<2>(tt, "offset", t.offset);
      t.scale = Vector<2>(tt, "scale", t.scale);
      t.rotation = Number(tt, "rotation", 0);
      if (tt->Has("texCoord") && tt->Get("texCoord").IsInt()) t.texcoord = tt->Get("texCoord").GetNumberAsInt();
    }
    if (t.texcoord < 0 || t.texcoord > 1)
      Fail(fmt::format("{}: TEXCOORD_{} (mr reads sets 0 and 1)", what, t.texcoord));
    return t;
  }

  AssetMaterial Material(size_t i) const {
    const tg::Material& g = m.materials[i];
    const std::string what = fmt::format("material {} ({})", i, g.name.empty() ? "unnamed" : g.name);
    AssetMaterial a;
    a.name = g.name.empty() ? fmt::format("material{}", i) : g.name;
    const auto& pbr = g.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() == 4) a.base_color = Eigen::Vector4d(pbr.baseColorFactor.data()).cast<float>();
    a.base_color_texture =
        Texture(pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord, pbr.baseColorTexture.extensions, what);
    a.metallic = static_cast<float>(pbr.metallicFactor);
    a.roughness = static_cast<float>(pbr.roughnessFactor);
    a.metallic_roughness_texture = Texture(pbr.metallicRoughnessTexture.index, pbr.metallicRoughnessTexture.texCoord,
                                           pbr.metallicRoughnessTexture.extensions, what);
    a.normal_texture = Texture(g.normalTexture.index, g.normalTexture.texCoord, g.normalTexture.extensions, what);
    a.normal_scale = static_cast<float>(g.normalTexture.scale);
    a.occlusion_texture =
        Texture(g.occlusionTexture.index, g.occlusionTexture.texCoord, g.occlusionTexture.extensions, what);
    if (a.occlusion_texture.present())
      out->report.ignored.push_back(what + ": occlusionTexture (a path tracer computes occlusion)");
    if (g.emissiveFactor.size() == 3) a.emissive = Eigen::Vector3d(g.emissiveFactor.data()).cast<float>();
    a.emissive_texture =
        Texture(g.emissiveTexture.index, g.emissiveTexture.texCoord, g.emissiveTexture.extensions, what);
    a.emissive_strength = Number(Ext(g.extensions, "KHR_materials_emissive_strength"), "emissiveStrength", 1);
    a.alpha_mode = g.alphaMode == "MASK"    ? AlphaMode::kMask
                   : g.alphaMode == "BLEND" ? AlphaMode::kBlend
                                            : AlphaMode::kOpaque;
    a.alpha_cutoff = static_cast<float>(g.alphaCutoff);
    a.double_sided = g.doubleSided;
    if (const tg::Value* t = Ext(g.extensions, "KHR_materials_transmission")) {
      a.transmission = Number(t, "transmissionFactor", 0);
      if (t->Has("transmissionTexture") && t->Get("transmissionTexture").IsObject()) {
        const tg::Value& ti = t->Get("transmissionTexture");
        a.transmission_texture = Texture(ti.Has("index") ? ti.Get("index").GetNumberAsInt() : -1,
                                         ti.Has("texCoord") ? ti.Get("texCoord").GetNumberAsInt() : 0, {}, what);
      }
    }
    a.ior = Number(Ext(g.extensions, "KHR_materials_ior"), "ior", 1.5f);
    if (const tg::Value* v = Ext(g.extensions, "KHR_materials_volume")) {
      a.thickness = Number(v, "thicknessFactor", 0);
      a.attenuation_distance = Number(v, "attenuationDistance", 0);
      a.attenuation_color = Vector<3>(v, "attenuationColor", a.attenuation_color);
    }
    CheckMaterial(a, name, what);
    for (const auto& [ext, v] : g.extensions)
      if (std::find(SupportedGltfExtensions().begin(), SupportedGltfExtensions().end(), ext) ==
          SupportedGltfExtensions().end())
        out->report.ignored.push_back(fmt::format("{}: {} (not read by mr)", what, ext));
    return a;
  }

  // --- geometry ---------------------------------------------------------

  // Triangles of a primitive: its indices (or 0..n-1), strips and fans
  // converted (glTF 2.0, 3.7.2.1), points and lines refused.
  std::vector<Eigen::Vector3i> Triangles(const tg::Primitive& p, size_t vertices, const std::string& what) const {
    std::vector<uint32_t> idx;
    if (p.indices >= 0) {
      idx = Indices(p.indices, what.c_str());
    } else {
      idx.resize(vertices);
      for (size_t i = 0; i < vertices; ++i) idx[i] = static_cast<uint32_t>(i);
    }
    for (uint32_t i : idx)
      if (i >= vertices) Fail(fmt::format("{}: index {} is past its {} vertices", what, i, vertices));
    const int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
    std::vector<Eigen::Vector3i> tris;
    auto add = [&](uint32_t a, uint32_t b, uint32_t c) {
      tris.emplace_back(static_cast<int>(a), static_cast<int>(b), static_cast<int>(c));
    };
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      if (idx.size() % 3) Fail(fmt::format("{}: {} indices is not a whole number of triangles", what, idx.size()));
      for (size_t i = 0; i + 2 < idx.size(); i += 3) add(idx[i], idx[i + 1], idx[i + 2]);
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      for (size_t i = 0; i + 2 < idx.size(); ++i)
        i % 2 ? add(idx[i + 1], idx[i], idx[i + 2]) : add(idx[i], idx[i + 1], idx[i + 2]);
    } else if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
      for (size_t i = 1; i + 1 < idx.size(); ++i) add(idx[i], idx[i + 1], idx[0]);
    } else {
      const char* kind = mode == TINYGLTF_MODE_POINTS ? "points" : "lines";
      Fail(fmt::format("{}: a primitive of {} (mr renders surfaces: triangles, strips and fans)", what, kind));
    }
    return tris;
  }

  // A primitive's vertices and triangles, in the coordinates of its mesh.
  AssetPart Primitive(const tg::Primitive& p, const std::string& what) const {
    AssetPart part;
    part.name = what;
    part.material = p.material;
    if (p.material >= 0) At(m.materials, p.material, "material", what);
    if (!p.targets.empty()) Fail(fmt::format("{}: morph targets (mr renders rigid assets)", what));
    auto attr = [&](const char* key) {
      auto it = p.attributes.find(key);
      return it == p.attributes.end() ? -1 : it->second;
    };
    if (attr("POSITION") < 0) Fail(fmt::format("{}: no POSITION attribute", what));
    const std::string w = what + " POSITION";
    part.mesh.positions = Vectors<3>(Floats(attr("POSITION"), 3, w.c_str()), w, true);
    const size_t n = part.mesh.positions.size();
    auto read = [&]<int N>(const char* key, std::integral_constant<int, N>) {
      std::vector<Eigen::Matrix<float, N, 1>> v;
      if (attr(key) < 0) return v;
      const std::string wk = what + " " + key;
      v = Vectors<N>(Floats(attr(key), N, wk.c_str()), wk, false);
      if (v.size() != n) Fail(fmt::format("{}: {} values for {} vertices", wk, v.size(), n));
      return v;
    };
    part.mesh.normals = read("NORMAL", std::integral_constant<int, 3>());
    part.mesh.uvs = read("TEXCOORD_0", std::integral_constant<int, 2>());
    part.uvs1 = read("TEXCOORD_1", std::integral_constant<int, 2>());
    part.tangents = read("TANGENT", std::integral_constant<int, 4>());
    if (attr("COLOR_0") >= 0) {
      const tg::Accessor& a = At(m.accessors, attr("COLOR_0"), "accessor", what);
      const int comps = tg::GetNumComponentsInType(static_cast<uint32_t>(a.type));
      const std::string wk = what + " COLOR_0";
      const std::vector<float> c = Floats(attr("COLOR_0"), comps == 4 ? 4 : 3, wk.c_str());
      if (a.count != n) Fail(fmt::format("{}: {} values for {} vertices", wk, a.count, n));
      for (size_t i = 0; i < n; ++i) {
        Eigen::Vector3f rgb(c[i * comps], c[i * comps + 1], c[i * comps + 2]);
        if (!rgb.allFinite()) Fail(fmt::format("{}: vertex {} has a non-finite value", wk, i));
        part.mesh.colors.push_back(rgb.cwiseMax(0.0f).cwiseMin(1.0f));
      }
    }
    part.mesh.triangles = Triangles(p, n, what);
    return part;
  }

  // Flat floats to vectors; non-finite values are an error (positions) or
  // set to zero and reported (other attributes: a NaN normal is replaced
  // by the face's).
  template <int N>
  std::vector<Eigen::Matrix<float, N, 1>> Vectors(const std::vector<float>& f, const std::string& what,
                                                  bool positions) const {
    std::vector<Eigen::Matrix<float, N, 1>> v(f.size() / N);
    int64_t bad = 0;
    for (size_t i = 0; i < v.size(); ++i) {
      v[i] = Eigen::Map<const Eigen::Matrix<float, N, 1>>(f.data() + i * N);
      if (!v[i].allFinite()) {
        if (positions) Fail(fmt::format("{}: vertex {} has a non-finite coordinate", what, i));
        v[i].setZero();
        ++bad;
      }
    }
    if (bad) out->report.ignored.push_back(fmt::format("{}: {} non-finite values set to 0", what, bad));
    return v;
  }

  static Eigen::Matrix4d LocalTransform(const tg::Node& n) {
    if (n.matrix.size() == 16) return Eigen::Map<const Eigen::Matrix4d>(n.matrix.data());  // column-major
    Eigen::Affine3d t = Eigen::Affine3d::Identity();
    if (n.translation.size() == 3) t.translate(Eigen::Vector3d(n.translation.data()));
    if (n.rotation.size() == 4)  // x, y, z, w
      t.rotate(Eigen::Quaterniond(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]).normalized());
    if (n.scale.size() == 3) t.scale(Eigen::Vector3d(n.scale.data()));
    return t.matrix();
  }

  // Every node of the default scene (all root nodes where none is given),
  // depth first; a node met twice on one path is a cycle.
  void Walk(int index, const Eigen::Matrix4d& parent, std::vector<int>* path) {
    const tg::Node& n = At(m.nodes, index, "node", "the scene");
    if (std::find(path->begin(), path->end(), index) != path->end())
      Fail(fmt::format("node {} is its own ancestor (the node hierarchy has a cycle)", index));
    path->push_back(index);
    const Eigen::Matrix4d world = parent * LocalTransform(n);
    if (!world.allFinite()) Fail(fmt::format("node {} ({}): a non-finite transform", index, n.name));
    const std::string node_name = n.name.empty() ? fmt::format("node{}", index) : n.name;
    if (n.skin >= 0)
      Fail(fmt::format("node {} ({}): a skinned mesh (mr renders rigid assets: apply the pose in the exporter)", index,
                       node_name));
    if (n.camera >= 0) out->report.ignored.push_back(fmt::format("node {} ({}): a camera", index, node_name));
    if (n.mesh >= 0) {
      const tg::Mesh& mesh = At(m.meshes, n.mesh, "mesh", node_name);
      for (size_t k = 0; k < mesh.primitives.size(); ++k) {
        const std::string what =
            fmt::format("{}/{}[{}]", node_name, mesh.name.empty() ? fmt::format("mesh{}", n.mesh) : mesh.name, k);
        AssetPart part = Primitive(mesh.primitives[k], what);
        TransformPart(world, &part);
        out->parts.push_back(std::move(part));
      }
    }
    for (int c : n.children) Walk(c, world, path);
    path->pop_back();
  }
};

}  // namespace

Asset ReadGltf(const fs::path& path) {
  const std::string name = path.string();
  const std::string ext = LowerExtension(path);
  tg::TinyGLTF loader;
  tg::Model model;
  loader.SetImageLoader(KeepImageBytes, &model);
  SkipImageFiles skip;
  if (ext == ".gltf") {
    skip = FilesNamedIn(path);
    loader.SetFsCallbacks({&tg::FileExists, &tg::ExpandFilePath, &SkipImageFiles::Read, &tg::WriteWholeFile, &skip});
  }
  std::string err, warn;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) ThrowErrorAt(FileLoc{name}, "no such file");
  const bool ok = ext == ".glb" ? loader.LoadBinaryFromFile(&model, &err, &warn, name)
                                : loader.LoadASCIIFromFile(&model, &err, &warn, name);
  if (!ok) {
    std::string e = err.empty() ? "not a glTF file tinygltf reads" : err;
    while (!e.empty() && (e.back() == '\n' || e.back() == ' ')) e.pop_back();
    ThrowErrorAt(FileLoc{name}, "{}", e);
  }
  Asset asset;
  asset.report.format = ext == ".glb" ? "glb" : "gltf";
  asset.report.extensions_used = model.extensionsUsed;
  asset.report.extensions_required = model.extensionsRequired;
  for (const std::string& e : model.extensionsRequired)
    if (std::find(SupportedGltfExtensions().begin(), SupportedGltfExtensions().end(), e) ==
        SupportedGltfExtensions().end())
      ThrowErrorAt(FileLoc{name}, "the asset requires {}, which mr does not read (mr reads {})", e,
                   fmt::join(SupportedGltfExtensions(), ", "));
  for (const std::string& e : model.extensionsUsed)
    if (std::find(SupportedGltfExtensions().begin(), SupportedGltfExtensions().end(), e) ==
        SupportedGltfExtensions().end())
      asset.report.ignored.push_back(fmt::format("extension {} (optional; not read by mr)", e));
  Reader r{model, name, &asset};
  for (size_t i = 0; i < model.images.size(); ++i) {
    tg::Image& im = model.images[i];
    AssetImage a;
    const bool data_uri = im.uri.rfind("data:", 0) == 0;
    a.name = im.uri.empty() || data_uri ? fmt::format("image {} (embedded)", i) : im.uri;
    if (!im.uri.empty() && !data_uri) a.file = (path.parent_path() / PercentDecoded(im.uri)).lexically_normal();
    a.bytes = std::move(im.image);  // the model's copy is not used again
    a.mime_type = im.mimeType;
    asset.images.push_back(std::move(a));
  }
  for (size_t i = 0; i < model.materials.size(); ++i) asset.materials.push_back(r.Material(i));
  asset.report.nodes = static_cast<int64_t>(model.nodes.size());
  asset.report.meshes = static_cast<int64_t>(model.meshes.size());
  for (const auto& mesh : model.meshes) asset.report.primitives += static_cast<int64_t>(mesh.primitives.size());
  std::vector<int> roots;
  if (model.defaultScene >= 0 || !model.scenes.empty()) {
    const int s = std::max(model.defaultScene, 0);
    roots = r.At(model.scenes, s, "scene", "the default scene").nodes;
  } else {
    // No scene: every node no other node lists as a child.
    std::vector<char> child(model.nodes.size(), 0);
    for (const auto& n : model.nodes)
      for (int c : n.children)
        if (c >= 0 && static_cast<size_t>(c) < child.size()) child[static_cast<size_t>(c)] = 1;
    for (size_t i = 0; i < model.nodes.size(); ++i)
      if (!child[i]) roots.push_back(static_cast<int>(i));
  }
  std::vector<int> path_stack;
  for (int root : roots) r.Walk(root, Eigen::Matrix4d::Identity(), &path_stack);
  if (!model.animations.empty())
    asset.report.ignored.push_back(
        fmt::format("{} animation{} (mr places the asset by scene.json's transform or "
                    "trajectory)",
                    model.animations.size(), model.animations.size() == 1 ? "" : "s"));
  if (!model.lights.empty())
    asset.report.ignored.push_back(
        fmt::format("{} KHR_lights_punctual light{}", model.lights.size(), model.lights.size() == 1 ? "" : "s"));
  if (!model.skins.empty() && asset.parts.empty()) asset.report.ignored.push_back("skins");
  if (asset.parts.empty()) ThrowErrorAt(FileLoc{name}, "no triangles in the asset's scene");
  if (!warn.empty()) asset.report.ignored.push_back("tinygltf: " + warn);
  return asset;
}

}  // namespace mr::detail
