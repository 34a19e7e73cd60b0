// A glTF 2.0 document built in memory: its JSON and one binary buffer, written
// as .glb (the buffer as the binary chunk) or .gltf (the buffer as a base64
// data URI), atomically.  Only what mr-export needs: float and index
// accessors, and arrays of JSON objects appended by name.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/json.h"

namespace mr {

namespace fs = std::filesystem;

class GltfBuilder {
 public:
  GltfBuilder();
  // Appends `item` to the top-level array `array` ("nodes", "meshes", ...);
  // returns its index there.
  int Push(const std::string& array, Json item);
  // A float accessor over `values`, `components` per element (1 SCALAR, 2
  // VEC2, 3 VEC3, 4 VEC4), with min and max where `bounds` (glTF requires
  // them for POSITION and animation inputs).  `target`: the buffer view's
  // (34962 vertex attributes, 0 none: animation data).  Throws mr::Error on
  // a non-finite value or a size that is not a multiple of `components`.
  int AddFloats(const std::vector<float>& values, int components, bool bounds, int target = 34962);
  // An unsigned 32-bit index accessor (element array buffer).
  int AddIndices(const std::vector<uint32_t>& indices);
  // Appends raw bytes to the binary buffer, 16-byte aligned (so views keep
  // any alignment they had within their own buffer); returns their offset.
  size_t AppendBytes(const std::string& bytes);
  // A buffer view over `bytes` (an image's file), no target.
  int AddBytesView(const std::string& bytes) { return AddView(bytes.data(), bytes.size(), 0); }
  // Merges a glTF document read from `path` (.glb or .gltf; its buffers and
  // images, files or data URIs, copied into this one): meshes, materials,
  // textures, images, samplers and its default scene's nodes, which become
  // children of node `parent`.  Skins, animations and cameras are left out
  // (counted in the returned note).  Throws mr::Error naming the file.
  std::string MergeAsset(const fs::path& path, int parent);
  Json& json() { return doc_; }
  const Json& json() const { return doc_; }
  // The document as .glb bytes or as .gltf text.
  std::string Glb() const;
  std::string Gltf() const;
  // Writes by the extension of `path` (.glb or .gltf), atomically; an
  // other extension is mr::Error.
  void Write(const fs::path& path) const;

 private:
  int AddView(const void* data, size_t bytes, int target);
  Json Finished(bool data_uri) const;
  Json doc_;
  std::string bin_;
};

std::string Base64Encode(const std::string& bytes);
// Throws mr::Error on a character outside the alphabet.
std::string Base64Decode(const std::string& text);

}  // namespace mr
