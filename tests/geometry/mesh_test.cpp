#include "geometry/mesh.h"

#include <gtest/gtest.h>

#include <fstream>

#include "core/error.h"
#include "test_util.h"

namespace mr {
namespace {

std::string ErrorOf(const fs::path& p, MeshReadOptions opt = {}) {
  try {
    ReadMesh(p, opt);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

void Write(const fs::path& p, const std::string& s) { std::ofstream(p) << s; }

const char* kQuadPly =
    "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 3\nproperty list uchar int vertex_indices\nend_header\n"
    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 2 0\n"
    "4 0 1 2 3\n"  // a quad: triangulated
    "3 0 1 1\n"    // repeated corner: degenerate
    "3 0 1 4\n";

TEST(Mesh, AsciiPlyWithPolygonsAndDegenerateFaces) {
  test::TempDir dir;
  Write(dir / "q.ply", kQuadPly);
  MeshReadReport rep;
  Mesh m = ReadMesh(dir / "q.ply", {}, &rep);
  EXPECT_EQ(m.vertex_count(), 5u);
  EXPECT_EQ(m.triangle_count(), 3u);  // 2 from the quad + 1
  EXPECT_EQ(rep.polygons_triangulated, 1);
  EXPECT_EQ(rep.degenerate_faces_dropped, 1);
  EXPECT_NEAR(m.SurfaceArea(), 1.0 + 1.0, 1e-6);  // unit quad + triangle (0,0)-(1,0)-(2,2): area 1
}

TEST(Mesh, NonFiniteVerticesAreRejectedOrDroppedWithACount) {
  test::TempDir dir;
  std::string s = kQuadPly;
  s.replace(s.find("1 1 0\n"), 6, "1 nan 0\n");
  Write(dir / "nan.ply", s);
  EXPECT_EQ(ErrorOf(dir / "nan.ply"), (dir / "nan.ply").string() + ":12: vertex 2 has a non-finite coordinate (nan)");
  MeshReadOptions drop;
  drop.nonfinite = BadVertices::kDropFaces;
  MeshReadReport rep;
  Mesh m = ReadMesh(dir / "nan.ply", drop, &rep);
  EXPECT_EQ(rep.nonfinite_vertices, 1);
  EXPECT_EQ(rep.faces_dropped_for_nonfinite, 2);  // both halves of the quad
  EXPECT_EQ(m.triangle_count(), 1u);
}

TEST(Mesh, CorruptFilesGiveClearErrors) {
  test::TempDir dir;
  Write(dir / "empty.ply", "");
  EXPECT_EQ(ErrorOf(dir / "empty.ply"), (dir / "empty.ply").string() + ": empty file");
  std::string s = kQuadPly;
  Write(dir / "trunc.ply", s.substr(0, s.size() - 20));
  // Cut inside the face list: the message names the line.
  EXPECT_EQ(ErrorOf(dir / "trunc.ply").rfind((dir / "trunc.ply").string() + ":15: face 0: bad vertex list", 0), 0u)
      << ErrorOf(dir / "trunc.ply");
  Write(dir / "trunc2.ply", s.substr(0, s.find("0 1 0\n")));
  EXPECT_NE(ErrorOf(dir / "trunc2.ply")
                .find("header declares 5 vertices and 3 faces, more than the 18 bytes after it can hold (truncated"),
            std::string::npos)
      << ErrorOf(dir / "trunc2.ply");
  std::string oob = kQuadPly;
  oob.replace(oob.find("3 0 1 4"), 7, "3 0 1 9");
  Write(dir / "oob.ply", oob);
  EXPECT_NE(ErrorOf(dir / "oob.ply").find("face 2 uses vertex \"9\", but there are 5 vertices"), std::string::npos);
  // A header claiming a billion vertices is refused before anything is allocated.
  std::string huge = kQuadPly;
  huge.replace(huge.find("element vertex 5"), 16, "element vertex 1000000000");
  Write(dir / "huge.ply", huge);
  EXPECT_NE(ErrorOf(dir / "huge.ply").find("header declares 1000000000 vertices"), std::string::npos)
      << ErrorOf(dir / "huge.ply");
  // Malformed headers that made OpenMesh spin (found by fuzz/fuzz_ply).
  std::string misspelt = kQuadPly;
  misspelt.replace(misspelt.find("format"), 6, "formaM");
  Write(dir / "misspelt.ply", misspelt);
  EXPECT_EQ(ErrorOf(dir / "misspelt.ply"),
            (dir / "misspelt.ply").string() + ":2: PLY header: unknown keyword \"formaM\"");
  std::string nul = kQuadPly;
  nul.replace(nul.find("element face 3"), 14,
              std::string("element face \0"
                          "3",
                          15));
  Write(dir / "nul.ply", nul);
  EXPECT_EQ(ErrorOf(dir / "nul.ply"), (dir / "nul.ply").string() + ":7: PLY header: NUL byte in the header");
  Write(dir / "x.ply", "not a ply\n");
  EXPECT_NE(ErrorOf(dir / "x.ply").find("not a PLY"), std::string::npos);
  EXPECT_NE(ErrorOf(dir / "none.ply").find("does not exist"), std::string::npos);
  EXPECT_NE(ErrorOf(dir / "a.dae").find("unsupported mesh extension"), std::string::npos);
}

TEST(Mesh, BinaryPlyRoundTripKeepsAttributes) {
  test::TempDir dir;
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.triangles = {{0, 1, 2}, {0, 3, 1}};
  m.ComputeNormals();
  m.colors = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.5f, 0.5f, 0.5f}};
  m.uvs = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
  WritePly(dir / "m.ply", m, "test mesh");
  MeshReadReport rep;
  Mesh back = ReadMesh(dir / "m.ply", {}, &rep);
  EXPECT_EQ(rep.format, "ply (binary)");
  EXPECT_EQ(back.positions, m.positions);
  EXPECT_EQ(back.triangles, m.triangles);
  ASSERT_EQ(back.normals.size(), 4u);
  EXPECT_NEAR((back.normals[0] - m.normals[0]).norm(), 0, 1e-7);
  ASSERT_EQ(back.colors.size(), 4u);
  EXPECT_NEAR(back.colors[3].x(), 128 / 255.0f, 1e-6);  // 8-bit colour
  ASSERT_EQ(back.uvs.size(), 4u);
  EXPECT_EQ(back.uvs[3], Eigen::Vector2f(1, 1));
}

TEST(Mesh, ObjOffStlLoad) {
  test::TempDir dir;
  Write(dir / "a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n");
  Write(dir / "a.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2\n");
  Write(dir / "a.stl",
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 "
        "0\nendloop\nendfacet\nendsolid t\n");
  EXPECT_EQ(ReadMesh(dir / "a.obj").triangle_count(), 2u);
  EXPECT_EQ(ReadMesh(dir / "a.off").triangle_count(), 2u);
  EXPECT_EQ(ReadMesh(dir / "a.stl").triangle_count(), 1u);
}

TEST(Mesh, StanfordMeshesLoadWithEveryFace) {
  MR_REQUIRE_SHARED_DATA("meshes");
  // Vertex and face counts from the headers; the scans are non-manifold in
  // places, and a halfedge reader would split vertices and refuse faces.
  struct Case {
    const char* file;
    size_t v, f;
    int64_t comments;
  };
  for (const Case& c : {Case{"bun_zipper_res4.ply", 453, 946, 2}, Case{"bun_zipper_res2.ply", 8171, 16301, 0},
                        Case{"dragon_vrip_res4.ply", 5205, 11102, 0}}) {
    MeshReadReport rep;
    Mesh m = ReadMesh(test::SharedData("meshes") / c.file, {}, &rep);
    EXPECT_EQ(m.vertex_count(), c.v) << c.file;
    EXPECT_EQ(static_cast<size_t>(static_cast<int64_t>(m.triangle_count()) + rep.degenerate_faces_dropped), c.f)
        << c.file;
    EXPECT_EQ(rep.comment_lines_skipped, c.comments) << c.file;
  }
}

}  // namespace
}  // namespace mr
