#include "geometry/asset.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <set>

#include "core/error.h"
#include "core/file.h"
#include "test_util.h"

namespace mr {
namespace {

const fs::path kAssets = fs::path(MR_SOURCE_DIR) / "tests" / "data" / "assets";

const AssetPart& Part(const Asset& a, const std::string& material) {
  for (const AssetPart& p : a.parts)
    if (p.material >= 0 && a.materials[static_cast<size_t>(p.material)].name == material) return p;
  throw std::runtime_error("no part of material " + material);
}
const AssetMaterial& Mat(const Asset& a, const std::string& name) {
  for (const AssetMaterial& m : a.materials)
    if (m.name == name) return m;
  throw std::runtime_error("no material " + name);
}

// The scene tests/data/assets/make_blender_assets.py builds, as Blender's
// exporters wrote it (Y up): a textured cube, a gold sphere at x = 2 and a
// glass slab at x = -2 whose node rotates it 90 degrees about y and scales it.
void ExpectBlenderScene(const Asset& a, bool has_tangent_free_normals = true) {
  ASSERT_EQ(a.parts.size(), 3u);
  const Eigen::AlignedBox3f sphere = Part(a, "gold").mesh.Bounds();
  EXPECT_NEAR(sphere.center().x(), 2, 1e-5);
  EXPECT_NEAR(sphere.center().y(), 0.5, 1e-5);
  EXPECT_NEAR(sphere.sizes().x(), 1, 1e-5);
  // The slab: local size (0.1, 1, 2) after the exporter's axis change,
  // turned 90 degrees about y by its node: 2 along x, 0.1 along z.
  const Eigen::AlignedBox3f slab = Part(a, "glass").mesh.Bounds();
  EXPECT_NEAR(slab.center().x(), -2, 1e-5);
  EXPECT_NEAR(slab.sizes().x(), 2, 1e-5);
  EXPECT_NEAR(slab.sizes().y(), 1, 1e-5);
  EXPECT_NEAR(slab.sizes().z(), 0.1, 1e-5);
  EXPECT_EQ(Part(a, "painted").mesh.triangle_count(), 12u);
  EXPECT_EQ(Part(a, "gold").mesh.triangle_count(), 16u * 6 * 2 + 16 * 2);
  if (has_tangent_free_normals) {
    // Smooth shading: the sphere's normals point away from its centre.
    const Mesh& m = Part(a, "gold").mesh;
    ASSERT_EQ(m.normals.size(), m.positions.size());
    for (size_t i = 0; i < m.positions.size(); ++i)
      EXPECT_GT(m.normals[i].dot((m.positions[i] - sphere.center()).normalized()), 0.95f) << i;
  }
  const AssetMaterial& gold = Mat(a, "gold");
  EXPECT_NEAR(gold.base_color[1], 0.766, 1e-5);
  EXPECT_NEAR(gold.roughness, 0.3, 1e-5);
  EXPECT_NEAR(Mat(a, "glass").ior, 1.45, 1e-5);
  EXPECT_TRUE(Mat(a, "painted").base_color_texture.present());
  EXPECT_TRUE(Mat(a, "painted").normal_texture.present());
}

TEST(Asset, BlenderGlbAndGltf) {
  for (const char* f : {"blender.glb", "blender.gltf"}) {
    SCOPED_TRACE(f);
    const Asset a = ReadAsset(kAssets / "blender" / f);
    ExpectBlenderScene(a);
    EXPECT_NEAR(Mat(a, "gold").metallic, 1, 1e-6);
    EXPECT_NEAR(Mat(a, "glass").transmission, 1, 1e-6);
    EXPECT_NEAR(Mat(a, "glass").metallic, 0, 1e-6);
    EXPECT_TRUE(Mat(a, "painted").metallic_roughness_texture.present());
    EXPECT_TRUE(Mat(a, "painted").double_sided);
    ASSERT_EQ(a.images.size(), 3u);
    for (const AssetImage& im : a.images) {
      if (std::string(f) == "blender.glb") {  // the .glb holds its images
        EXPECT_TRUE(im.file.empty()) << im.name;
        ASSERT_GT(im.bytes.size(), 8u) << im.name;
        EXPECT_EQ(std::memcmp(im.bytes.data(), "\x89PNG", 4), 0) << im.name;
      } else {  // image files are read where they are decoded, not twice
        EXPECT_TRUE(im.bytes.empty()) << im.name;
        EXPECT_TRUE(fs::is_regular_file(im.file)) << im.name;
      }
    }
    // Uvs and normals came with every part; Blender writes no COLOR_0.
    for (const AssetPart& p : a.parts) {
      EXPECT_EQ(p.mesh.uvs.size(), p.mesh.positions.size()) << p.name;
      EXPECT_TRUE(p.mesh.colors.empty()) << p.name;
    }
  }
}

// A public sample model written by another program (COLLADA2GLTF; Khronos's
// BoxTextured, tests/data/assets/khronos/LICENSE.md): data: URIs for its
// buffer and image, unsigned-short indices, byte strides, a node matrix
// (a quarter turn about x) applied to the positions and normals, and uvs up
// to 6 in u (the sampler repeats).
TEST(Asset, KhronosBoxTextured) {
  const Asset a = ReadAsset(kAssets / "khronos" / "BoxTextured.gltf");
  ASSERT_EQ(a.parts.size(), 1u);
  const Mesh& m = a.parts[0].mesh;
  EXPECT_EQ(m.triangle_count(), 12u);
  EXPECT_EQ(m.vertex_count(), 24u);
  const Eigen::AlignedBox3f b = m.Bounds();
  EXPECT_NEAR(b.min().x(), -0.5, 1e-6);
  EXPECT_NEAR(b.max().z(), 0.5, 1e-6);
  // The file's first normal is +z; the node's matrix (column-major, its
  // third column (0, 1, 0)) turns +z into +y.
  EXPECT_NEAR(m.normals[0].y(), 1, 1e-6);
  for (size_t i = 0; i < m.positions.size(); ++i)  // normals stay outward
    EXPECT_GT(m.normals[i].dot(m.positions[i]), 0.4f) << i;
  float umax = 0;
  for (const Eigen::Vector2f& uv : m.uvs) umax = std::max(umax, uv.x());
  EXPECT_NEAR(umax, 6, 1e-6);
  const AssetMaterial& t = Mat(a, "Texture");
  EXPECT_EQ(t.metallic, 0);
  EXPECT_EQ(t.roughness, 1);  // the default
  ASSERT_TRUE(t.base_color_texture.present());
  const AssetImage& im = a.images[static_cast<size_t>(t.base_color_texture.image)];
  EXPECT_EQ(im.bytes.size(), 3750u);
  EXPECT_EQ(std::memcmp(im.bytes.data(), "\x89PNG", 4), 0);
  EXPECT_EQ(t.base_color_texture.wrap_s, TextureWrap::kRepeat);
}

// Blender's OBJ exporter writes roughness as Ns = 1000 (1 - r)^2 and no Pm:
// read back as its importer does (asset_obj.cpp).
TEST(Asset, BlenderObjWithMtl) {
  const Asset a = ReadAsset(kAssets / "blender" / "blender.obj");
  ExpectBlenderScene(a);
  EXPECT_EQ(a.report.format, "obj");
  EXPECT_NEAR(Mat(a, "glass").roughness, 0, 1e-6);
  EXPECT_NEAR(Mat(a, "gold").metallic, 0, 1e-6);  // MTL without Pm: a dielectric
  EXPECT_EQ(a.images[static_cast<size_t>(Mat(a, "painted").base_color_texture.image)].file,
            (kAssets / "blender" / "checker.png").lexically_normal());
  EXPECT_NEAR(Mat(a, "painted").normal_scale, 1, 1e-6);
  // The cube's 8 corners split by their uvs and normals into 24 vertices (4 per face).
  EXPECT_EQ(Part(a, "painted").mesh.vertex_count(), 24u);
  // Its uvs as the glTF exporter wrote them (v down the image: OBJ's v flipped).
  auto uv_set = [](const Mesh& m) {
    std::set<std::pair<long, long>> s;
    for (const auto& uv : m.uvs) s.insert({std::lround(uv.x() * 1e4), std::lround(uv.y() * 1e4)});
    return s;
  };
  EXPECT_EQ(uv_set(Part(a, "painted").mesh),
            uv_set(Part(ReadAsset(kAssets / "blender" / "blender.glb"), "painted").mesh));
}

// --- files written here, for each case a reader must refuse or convert -----

std::string Base64(const std::vector<uint8_t>& b) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string s;
  for (size_t i = 0; i < b.size(); i += 3) {
    const uint32_t v = (uint32_t(b[i]) << 16) | (i + 1 < b.size() ? uint32_t(b[i + 1]) << 8 : 0) |
                       (i + 2 < b.size() ? uint32_t(b[i + 2]) : 0);
    s += t[(v >> 18) & 63];
    s += t[(v >> 12) & 63];
    s += i + 1 < b.size() ? t[(v >> 6) & 63] : '=';
    s += i + 2 < b.size() ? t[v & 63] : '=';
  }
  return s;
}

// A glTF of one primitive: `positions` (xyz floats) then `indices`
// (uint16) in one buffer; `extra` is spliced into the primitive, `root`
// into the top level, `node` into the node.
struct MiniGltf {
  std::vector<float> positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
  std::vector<uint16_t> indices = {0, 1, 2, 2, 1, 3};
  int mode = 4;
  size_t position_count = 4;  // the accessor's claim
  std::string primitive_extra, root_extra, node_extra;

  std::string Json() const {
    std::vector<uint8_t> buf(positions.size() * 4 + indices.size() * 2);
    std::memcpy(buf.data(), positions.data(), positions.size() * 4);
    std::memcpy(buf.data() + positions.size() * 4, indices.data(), indices.size() * 2);
    return fmt::format(
        R"({{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0 {}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "mode": {} {}}}]}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": {}, "type": "VEC3"}},
                {{"bufferView": 1, "componentType": 5123, "count": {}, "type": "SCALAR"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {}}},
                  {{"buffer": 0, "byteOffset": {}, "byteLength": {}}}],
  "buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{}"}}] {}}})",
        node_extra, mode, primitive_extra, position_count, indices.size(), positions.size() * 4, positions.size() * 4,
        indices.size() * 2, buf.size(), Base64(buf), root_extra);
  }
};

std::string ErrorOf(const fs::path& f) {
  try {
    ReadAsset(f);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

class AssetFiles : public ::testing::Test {
 protected:
  fs::path Write(const std::string& name, const std::string& text) {
    const fs::path f = dir_ / name;
    WriteTextFile(f, text);
    return f;
  }
  test::TempDir dir_;
};

TEST_F(AssetFiles, MinimalGltfReads) {
  const Asset a = ReadAsset(Write("a.gltf", MiniGltf().Json()));
  ASSERT_EQ(a.parts.size(), 1u);
  EXPECT_EQ(a.parts[0].mesh.triangle_count(), 2u);
  EXPECT_EQ(a.parts[0].material, -1);
}

TEST_F(AssetFiles, StripsAndFansAreTriangles) {
  MiniGltf g;
  g.indices = {0, 1, 2, 3};
  g.mode = 5;  // strip: (0 1 2), (2 1 3): both counter-clockwise seen from +z
  Asset a = ReadAsset(Write("s.gltf", g.Json()));
  ASSERT_EQ(a.parts[0].mesh.triangle_count(), 2u);
  const Mesh& m = a.parts[0].mesh;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3f n = (m.positions[size_t(t[1])] - m.positions[size_t(t[0])])
                                  .cross(m.positions[size_t(t[2])] - m.positions[size_t(t[0])]);
    EXPECT_GT(n.z(), 0) << t.transpose();
  }
  g.mode = 6;  // fan of 4 indices: 2 triangles
  EXPECT_EQ(ReadAsset(Write("f.gltf", g.Json())).parts[0].mesh.triangle_count(), 2u);
}

TEST_F(AssetFiles, MirroringNodeKeepsFrontFaces) {
  MiniGltf g;
  g.node_extra = R"(, "scale": [-1, 1, 1])";
  const Mesh m = ReadAsset(Write("m.gltf", g.Json())).parts[0].mesh;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3f n = (m.positions[size_t(t[1])] - m.positions[size_t(t[0])])
                                  .cross(m.positions[size_t(t[2])] - m.positions[size_t(t[0])]);
    EXPECT_GT(n.z(), 0);  // still facing +z: the winding flipped with the mirror
  }
}

TEST_F(AssetFiles, RefusalsNameTheFileAndWhat) {
  MiniGltf g;
  g.position_count = 40;  // more than the buffer holds
  EXPECT_NE(ErrorOf(Write("b.gltf", g.Json())).find("claims 40 elements, more than its buffer view"),
            std::string::npos);
  g = MiniGltf();
  g.indices = {0, 1, 7};
  EXPECT_NE(ErrorOf(Write("i.gltf", g.Json())).find("index 7 is past its 4 vertices"), std::string::npos);
  g = MiniGltf();
  g.mode = 1;
  EXPECT_NE(ErrorOf(Write("l.gltf", g.Json())).find("a primitive of lines"), std::string::npos);
  g = MiniGltf();
  g.positions[4] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(ErrorOf(Write("n.gltf", g.Json())).find("vertex 1 has a non-finite coordinate"), std::string::npos);
  g = MiniGltf();
  g.root_extra =
      R"(, "extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"])";
  const std::string e = ErrorOf(Write("d.gltf", g.Json()));
  EXPECT_NE(e.find("d.gltf"), std::string::npos) << e;
  EXPECT_NE(e.find("requires KHR_draco_mesh_compression, which mr does not read"), std::string::npos) << e;
  g = MiniGltf();
  g.primitive_extra = R"(, "targets": [{"POSITION": 0}])";
  EXPECT_NE(ErrorOf(Write("t.gltf", g.Json())).find("morph targets"), std::string::npos);
  g = MiniGltf();
  g.node_extra = R"(, "skin": 0)";
  g.root_extra = R"(, "skins": [{"joints": [0]}])";
  EXPECT_NE(ErrorOf(Write("k.gltf", g.Json())).find("a skinned mesh"), std::string::npos);
  EXPECT_NE(ErrorOf(Write("x.gltf", "{\"asset\": ")).find("x.gltf"), std::string::npos);
  EXPECT_NE(ErrorOf(dir_ / "missing.glb").find("missing.glb"), std::string::npos);
  // A .glb whose binary chunk is shorter than its buffer claims.
  const std::string glb = ReadTextFile(kAssets / "blender" / "blender.glb");
  WriteTextFile(dir_ / "cut.glb", glb.substr(0, glb.size() - 3000));
  EXPECT_NE(ErrorOf(dir_ / "cut.glb"), "");
}

TEST_F(AssetFiles, OptionalExtensionIsReported) {
  MiniGltf g;
  g.root_extra = R"(, "extensionsUsed": ["KHR_materials_sheen"])";
  const Asset a = ReadAsset(Write("o.gltf", g.Json()));
  ASSERT_FALSE(a.report.ignored.empty());
  EXPECT_NE(a.report.ignored[0].find("KHR_materials_sheen"), std::string::npos);
}

TEST_F(AssetFiles, ImageUriWithSpacesAndDataUri) {
  fs::copy_file(kAssets / "blender" / "checker.png", dir_ / "my tex.png");
  MiniGltf g;
  g.root_extra = R"(, "images": [{"uri": "my%20tex.png"}, {"uri": "data:image/png;base64,)" +
                 Base64(std::vector<uint8_t>(std::istreambuf_iterator<char>(*std::make_unique<std::ifstream>(
                                                 kAssets / "blender" / "normal.png", std::ios::binary)),
                                             {})) +
                 R"("}], "textures": [{"source": 0}, {"source": 1}],
    "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "normalTexture": {"index": 1, "scale": 0.5}}])";
  g.primitive_extra = R"(, "material": 0)";
  const Asset a = ReadAsset(Write("u.gltf", g.Json()));
  ASSERT_EQ(a.images.size(), 2u);
  EXPECT_EQ(a.images[0].file, dir_ / "my tex.png");
  EXPECT_TRUE(a.images[0].bytes.empty());  // the file is read where it is decoded (its escaped name matched)
  EXPECT_TRUE(fs::is_regular_file(a.images[0].file));
  EXPECT_TRUE(a.images[1].file.empty());
  EXPECT_EQ(a.images[1].bytes.size(), fs::file_size(kAssets / "blender" / "normal.png"));
  EXPECT_NEAR(a.materials[0].normal_scale, 0.5, 1e-6);
}

TEST_F(AssetFiles, ObjSeamsMaterialsAndMissingLibraries) {
  Write("m.mtl", "newmtl red\nKd 1 0 0\nPr 0.2\nPm 1\nKe 0 0 0\n");
  // Two quads sharing an edge whose vertices have different uvs on each side.
  const std::string obj =
      "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
      "usemtl red\nf 1/1 2/2 3/3 4/4\nusemtl nothere\nf 2/1 5/2 6/3 3/4\n";
  const Asset a = ReadAsset(Write("q.obj", obj));
  ASSERT_EQ(a.parts.size(), 2u);
  EXPECT_EQ(a.parts[0].mesh.vertex_count(), 4u);
  EXPECT_EQ(a.parts[0].mesh.triangle_count(), 2u);
  EXPECT_EQ(a.parts[1].material, -1);  // "nothere": the default material, reported
  ASSERT_EQ(a.materials.size(), 1u);
  EXPECT_NEAR(a.materials[0].roughness, 0.2, 1e-6);
  EXPECT_NEAR(a.materials[0].metallic, 1, 1e-6);
  bool reported = false;
  for (const auto& s : a.report.ignored) reported = reported || s.find("usemtl nothere") != std::string::npos;
  EXPECT_TRUE(reported);
  EXPECT_NE(ErrorOf(Write("x.obj", "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")).find("gone.mtl"),
            std::string::npos);
  Write("bad.mtl", "newmtl a\nKd 1 nan 0\n");
  EXPECT_NE(ErrorOf(Write("y.obj", "mtllib bad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n")).find("bad.mtl:2"),
            std::string::npos);
}

}  // namespace
}  // namespace mr
