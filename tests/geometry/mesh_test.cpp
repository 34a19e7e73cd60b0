#include "geometry/mesh.h"

#include <gtest/gtest.h>

#include <cstring>
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

// Regressions (issue: the mesh readers' crash and hangs).  Each of these
// aborted inside OpenMesh, grew without bound, or hung: now each is one error
// naming the file (and line), reached after reading the file once.  A
// regression shows as an abort, or as the test running past CTest's timeout.
TEST(Mesh, ObjFaceCornerWithoutVertexIndexIsAnError) {
  test::TempDir dir;
  Write(dir / "a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf /1 2 3\n");
  EXPECT_NE(ErrorOf(dir / "a.obj").find("a.obj:4: face corner \"/1\" has no vertex index"), std::string::npos)
      << ErrorOf(dir / "a.obj");
  for (const char* face : {"f 1 2 x", "f 1 2 0", "f 1 2 4", "f 1 2 -4", "f 1/2 2 3", "f 1//9 2 3", "f 1/// 2 3",
                           "f 1 2", "f 1/2/3/4 2 3"}) {
    Write(dir / "b.obj", std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n") + face + "\n");
    EXPECT_NE(ErrorOf(dir / "b.obj").find("b.obj:5: "), std::string::npos) << face << ": " << ErrorOf(dir / "b.obj");
  }
}

TEST(Mesh, ObjVertexThatDoesNotParseIsAnErrorAtItsLine) {
  test::TempDir dir;
  // Dropped silently before, shifting every later index (4 vertices, wrong area).
  Write(dir / "n.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nv 1 1 0\nv 2 2 2\nf 1 3 4\n");
  EXPECT_NE(ErrorOf(dir / "n.obj").find("n.obj:2: vertex 2 has a non-finite coordinate (\"nan\")"), std::string::npos)
      << ErrorOf(dir / "n.obj");
  Write(dir / "x.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_NE(ErrorOf(dir / "x.obj").find("x.obj:2: vertex 2: \"zero\" is not a number"), std::string::npos)
      << ErrorOf(dir / "x.obj");
  Write(dir / "s.obj", "v 0 0\n");
  EXPECT_NE(ErrorOf(dir / "s.obj").find("s.obj:1: vertex 1: expected"), std::string::npos) << ErrorOf(dir / "s.obj");
  // Dropping faces instead, when asked: the vertex keeps its index.
  MeshReadOptions drop;
  drop.nonfinite = BadVertices::kDropFaces;
  Write(dir / "d.obj", "v 0 0 0\nv nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 3 4\nf 1 2 3\n");
  MeshReadReport rep;
  const Mesh m = ReadMesh(dir / "d.obj", drop, &rep);
  EXPECT_EQ(m.vertex_count(), 4u);
  ASSERT_EQ(m.triangle_count(), 1u);
  EXPECT_EQ(m.triangles[0], Eigen::Vector3i(0, 2, 3));
  EXPECT_EQ(rep.nonfinite_vertices, 1);
  EXPECT_EQ(rep.faces_dropped_for_nonfinite, 1);
}

TEST(Mesh, ObjIndicesAttributesAndIgnoredLines) {
  test::TempDir dir;
  // Negative (relative) indices, v/vt/vn corners, comments, a continued line,
  // groups and materials (ignored, counted), CRLF line ends.
  Write(dir / "a.obj",
        "# a quad\r\nmtllib a.mtl\r\no quad\r\nv 0 0 0\r\nv 1 0 0 1\r\nv 1 1 0\r\nv 0 1 0 0.5 0.25 1\r\n"
        "vt 0 0\r\nvt 1 1\r\nvn 0 0 1\r\nusemtl red\r\ng g1\r\nf -4/1/1 -3/1/1 \\\r\n -2/2/1 -1//1 # the quad\r\n");
  MeshReadReport rep;
  const Mesh m = ReadMesh(dir / "a.obj", {}, &rep);
  EXPECT_EQ(m.vertex_count(), 4u);
  ASSERT_EQ(m.triangle_count(), 2u);
  EXPECT_EQ(m.triangles[0], Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(m.triangles[1], Eigen::Vector3i(0, 2, 3));
  ASSERT_EQ(m.uvs.size(), 4u);
  EXPECT_EQ(m.uvs[2], Eigen::Vector2f(1, 1));
  ASSERT_EQ(m.normals.size(), 4u);
  EXPECT_EQ(m.normals[3], Eigen::Vector3f(0, 0, 1));
  ASSERT_EQ(m.colors.size(), 4u);
  EXPECT_EQ(m.colors[3], Eigen::Vector3f(0.5f, 0.25f, 1));
  std::string notes;
  for (const auto& n : rep.notes) notes += n + "\n";
  EXPECT_NE(notes.find("ignored 1 \"usemtl\" line"), std::string::npos) << notes;
  EXPECT_NE(notes.find("ignored 1 \"g\" line"), std::string::npos) << notes;
}

TEST(Mesh, OffCountsAreCheckedAgainstTheFileBeforeAllocating) {
  test::TempDir dir;
  Write(dir / "x.off", "hello\n");
  EXPECT_NE(ErrorOf(dir / "x.off").find("x.off:1: not an OFF file"), std::string::npos) << ErrorOf(dir / "x.off");
  Write(dir / "big.off", "OFF\n99999999999 1 0\n");
  EXPECT_NE(ErrorOf(dir / "big.off").find("big.off:2: header declares 99999999999 vertices"), std::string::npos)
      << ErrorOf(dir / "big.off");
  Write(dir / "faces.off", "OFF\n3 2000000000 0\n0 0 0\n1 0 0\n0 1 0\n");
  EXPECT_NE(ErrorOf(dir / "faces.off").find("2000000000 faces, more than the"), std::string::npos)
      << ErrorOf(dir / "faces.off");
  Write(dir / "neg.off", "OFF\n-3 1 0\n");
  EXPECT_NE(ErrorOf(dir / "neg.off").find("bad vertex count \"-3\""), std::string::npos) << ErrorOf(dir / "neg.off");
  Write(dir / "idx.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
  EXPECT_NE(ErrorOf(dir / "idx.off").find("idx.off:6: face 0 uses vertex \"3\", but there are 3 vertices"),
            std::string::npos)
      << ErrorOf(dir / "idx.off");
  Write(dir / "nan.off", "OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n");
  EXPECT_NE(ErrorOf(dir / "nan.off").find("nan.off:4: vertex 1 has a non-finite coordinate"), std::string::npos)
      << ErrorOf(dir / "nan.off");
  Write(dir / "trail.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n");
  EXPECT_NE(ErrorOf(dir / "trail.off").find("trailing data"), std::string::npos) << ErrorOf(dir / "trail.off");
  // Counts on the OFF line, comments, and a coloured variant.
  Write(dir / "c.off",
        "COFF 3 1 0 # counts on the first line\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n"
        "0 1 0 0 0 255 255\n3 0 1 2\n");
  const Mesh m = ReadMesh(dir / "c.off");
  EXPECT_EQ(m.triangle_count(), 1u);
  ASSERT_EQ(m.colors.size(), 3u);
  EXPECT_EQ(m.colors[1], Eigen::Vector3f(0, 1, 0));
}

TEST(Mesh, StlHeadersAreCheckedAgainstTheFileSize) {
  test::TempDir dir;
  // The first 200 bytes of a text file, named .stl: neither ASCII STL nor a
  // binary one whose declared size matches.
  std::string text;
  while (text.size() < 200) text += "Lorem ipsum dolor sit amet, consectetur adipiscing elit. ";
  Write(dir / "t.stl", text.substr(0, 200));
  EXPECT_NE(ErrorOf(dir / "t.stl").find("t.stl: binary STL header declares"), std::string::npos)
      << ErrorOf(dir / "t.stl");
  // A binary STL claiming 4e9 triangles in 84 bytes.
  std::string bin(84, '\0');
  const uint32_t count = 4000000000u;
  std::memcpy(&bin[80], &count, 4);
  Write(dir / "b.stl", bin);
  EXPECT_NE(ErrorOf(dir / "b.stl").find("declares 4000000000 triangles"), std::string::npos) << ErrorOf(dir / "b.stl");
  // A well-formed binary STL of two triangles sharing an edge: corners welded.
  std::string two(84, '\0');
  const uint32_t n2 = 2;
  std::memcpy(&two[80], &n2, 4);
  const float tris[2][12] = {{0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 0}};
  for (const auto& t : tris) {
    two.append(reinterpret_cast<const char*>(t), 48);
    two.append(2, '\0');
  }
  Write(dir / "two.stl", two);
  MeshReadReport rep;
  const Mesh m = ReadMesh(dir / "two.stl", {}, &rep);
  EXPECT_EQ(m.vertex_count(), 4u);
  EXPECT_EQ(m.triangle_count(), 2u);
  EXPECT_EQ(rep.format, "stl (binary)");
  // ASCII: a malformed facet names its line.
  Write(dir / "a.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0\n");
  EXPECT_NE(ErrorOf(dir / "a.stl").find("a.stl:5: expected \"vertex x y z\""), std::string::npos)
      << ErrorOf(dir / "a.stl");
  Write(dir / "c.stl",
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
        "endloop\nendfacet\n");
  EXPECT_NE(ErrorOf(dir / "c.stl").find("truncated: no \"endsolid\""), std::string::npos) << ErrorOf(dir / "c.stl");
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
