// Assets as users bring them: glTF 2.0 (.gltf with its buffers and images,
// or .glb) and OBJ with its MTL materials, read into parts (a mesh with one
// material each, in the asset's root coordinates), materials in glTF's
// metallic-roughness model and the images their textures use.  No
// third-party types here: tinygltf stays inside asset_gltf.cpp.
//
// What is read, refused and ignored (docs/formats.md, "Assets"):
//  - glTF: the default scene's node hierarchy (matrix or TRS; every node
//    instance of a mesh is its own part, its transform applied, the winding
//    flipped where the transform mirrors), every primitive of mode
//    triangles, strip or fan (strips and fans converted); POSITION, NORMAL,
//    TANGENT, TEXCOORD_0/1, COLOR_0, indices, sparse accessors and every
//    component type (KHR_mesh_quantization); materials with
//    KHR_materials_emissive_strength, _transmission, _ior, _volume and
//    KHR_texture_transform.  Refused (mr::Error naming the asset and what):
//    points and lines, skins, morph targets, an extension the asset
//    requires that mr does not support (Draco, meshopt, BasisU, ...),
//    accessors reaching past their buffer, non-finite positions, indices
//    out of range.  Ignored and reported: optional extensions mr does not
//    support, animations, cameras, KHR_lights_punctual.
//  - OBJ: v/vt/vn/f with each corner's own uv and normal (vertices split at
//    seams), usemtl groups and mtllib files: Kd, Ks, Ns, Ni, d/Tr, Ke,
//    map_Kd, map_Ks, map_d, map_Bump/bump/norm, Pr, Pm, map_Pr, map_Pm.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/file.h"
#include "geometry/mesh.h"

namespace mr {

// An image a texture samples: a file beside the asset, or bytes the asset
// holds (a .glb buffer view, a data: URI).  Decoded where it is rendered.
struct AssetImage {
  std::string name;  // for messages and reports: the URI, or "image 2 (embedded)"
  fs::path file;     // empty when embedded
  std::vector<uint8_t> bytes;
  std::string mime_type;  // "image/png", "image/jpeg", ... when stated
};

enum class TextureWrap { kRepeat, kClamp, kMirror };

// A material's use of an image.
struct AssetTexture {
  int image = -1;    // index into Asset::images; -1: no texture
  int texcoord = 0;  // which uv set (0 or 1)
  TextureWrap wrap_s = TextureWrap::kRepeat, wrap_t = TextureWrap::kRepeat;
  // KHR_texture_transform: uv' = offset + Rotation(rotation) * (scale .* uv).
  Eigen::Vector2f offset = Eigen::Vector2f::Zero(), scale = Eigen::Vector2f::Ones();
  float rotation = 0;  // radians, counter-clockwise in uv
  bool present() const { return image >= 0; }
};

enum class AlphaMode { kOpaque, kMask, kBlend };

// glTF 2.0's metallic-roughness material and the extensions mr reads; an
// OBJ's MTL material mapped onto it (asset_obj.cpp says how).  Factors
// multiply textures, as the glTF specification defines.
struct AssetMaterial {
  std::string name;
  Eigen::Vector4f base_color = Eigen::Vector4f::Ones();  // linear RGBA
  AssetTexture base_color_texture;                       // sRGB-encoded RGB(A)
  float metallic = 1, roughness = 1;                     // glTF's perceptual roughness
  AssetTexture metallic_roughness_texture;               // G: roughness, B: metallic (linear)
  AssetTexture normal_texture;                           // tangent space, +Y up (OpenGL)
  float normal_scale = 1;
  AssetTexture occlusion_texture;  // read, unused by a path tracer (reported)
  Eigen::Vector3f emissive = Eigen::Vector3f::Zero();
  float emissive_strength = 1;  // KHR_materials_emissive_strength
  AssetTexture emissive_texture;
  AlphaMode alpha_mode = AlphaMode::kOpaque;
  float alpha_cutoff = 0.5f;
  bool double_sided = false;
  float transmission = 0;  // KHR_materials_transmission
  AssetTexture transmission_texture;
  float ior = 1.5f;  // KHR_materials_ior
  // KHR_materials_volume: 0 thickness is thin-walled.
  float thickness = 0;
  float attenuation_distance = 0;  // 0: infinite (no absorption)
  Eigen::Vector3f attenuation_color = Eigen::Vector3f::Ones();
  // MTL's specular colour (Ks) where it is not a metal: a dielectric lobe's
  // tint; glTF materials leave it white.
  Eigen::Vector3f specular_color = Eigen::Vector3f::Ones();
};

// One mesh with one material, in the asset's root coordinates.
struct AssetPart {
  std::string name;  // "node/mesh[primitive]" (glTF) or the usemtl group (OBJ)
  // positions, normals (when given), uvs (set 0; glTF's convention: v = 0 at
  // the image's top row, an OBJ's v flipped on reading), colors (COLOR_0).
  Mesh mesh;
  std::vector<Eigen::Vector2f> uvs1;      // TEXCOORD_1; empty or one per vertex
  std::vector<Eigen::Vector4f> tangents;  // xyz and handedness w; empty or one per vertex
  int material = -1;                      // index into Asset::materials; -1: the default material
};

struct AssetReport {
  std::string format;  // "gltf", "glb", "obj"
  int64_t nodes = 0, meshes = 0, primitives = 0;
  std::vector<std::string> extensions_used, extensions_required;
  std::vector<std::string> ignored;  // what was read and ignored, one line each
};

struct Asset {
  std::vector<AssetPart> parts;
  std::vector<AssetMaterial> materials;
  std::vector<AssetImage> images;
  AssetReport report;
  size_t triangle_count() const;
};

// The parts as one mesh, in their order (ReadMesh of a .gltf or .glb gives
// this): a vertex attribute is kept where every part has it; *material, when
// given, receives each triangle's part material (AssetPart::material).
Mesh MergeParts(const Asset& asset, std::vector<int>* triangle_material = nullptr);

// Per-vertex tangents of MergeParts(asset) (`merged`), for normal maps: the
// asset's own where every part has them, else computed from the uvs (set
// 0) as the glTF specification asks of MikkTSpace's convention: xyz along
// increasing u, orthogonal to the vertex normal, w the handedness such that
// cross(normal, xyz) w points up the image (decreasing glTF v).  Per-vertex
// sums of the triangles' uv derivatives, angle-free (not MikkTSpace's exact
// splitting: they differ where a vertex's triangles disagree).  Empty
// without normals or uvs.
std::vector<Eigen::Vector4f> AssetTangents(const Asset& asset, const Mesh& merged);

// Whether mr reads `path` as an asset (.gltf, .glb; .obj reads as an asset
// too, with its materials).
bool IsAssetFile(const fs::path& path);

// Reads a glTF (.gltf, .glb) or OBJ file with its materials.  mr::Error
// naming the file and what is wrong; nothing is dropped without a line in
// report.ignored.
Asset ReadAsset(const fs::path& path);

// The extensions mr reads; any other listed in extensionsRequired is an error.
const std::vector<std::string>& SupportedGltfExtensions();

// What mr-info prints about an asset, one line each: parts and their
// triangles, materials, images and their sizes (from headers), extensions,
// and what was ignored.
std::vector<std::string> DescribeAsset(const Asset& asset);

}  // namespace mr
