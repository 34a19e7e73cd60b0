// Triangle meshes: an indexed face set in plain arrays (no OpenMesh types in
// the interface), read through OpenMesh and written as binary PLY.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/file.h"

namespace mr {

struct Mesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;  // per vertex; empty or positions.size()
  std::vector<Eigen::Vector3f> colors;   // per vertex, linear [0,1]; empty or positions.size()
  std::vector<Eigen::Vector2f> uvs;      // per vertex; empty or positions.size()
  std::vector<Eigen::Vector3i> triangles;
  // Further per-vertex scalars written as float PLY properties after the
  // standard ones (mr-fuse: albedo_r/g/b, confidence).  Not read back.
  struct Scalar {
    std::string name;
    std::vector<float> values;
  };
  std::vector<Scalar> scalars;

  size_t vertex_count() const { return positions.size(); }
  size_t triangle_count() const { return triangles.size(); }
  Eigen::AlignedBox3f Bounds() const;
  double SurfaceArea() const;
  // Area-weighted vertex normals from the faces (counter-clockwise = front).
  void ComputeNormals();
  // Throws mr::Error (naming `name`) on out-of-range indices, attribute
  // arrays of the wrong length, or non-finite positions.
  void Validate(const std::string& name) const;
};

// A face is degenerate when two corners coincide or its area is below
// kDegenerateAreaFraction * (longest edge)^2, i.e. it has no usable normal.
inline constexpr double kDegenerateAreaFraction = 1e-12;
bool IsDegenerate(const Mesh& m, const Eigen::Vector3i& tri);

enum class BadVertices {
  kReject,    // non-finite vertex coordinates are an error naming the file
  kDropFaces  // faces using them are dropped and counted
};

struct MeshReadOptions {
  BadVertices nonfinite = BadVertices::kReject;
  bool points = false;  // a point cloud: a file without faces is read (its vertices), not refused
};

// What the reader found and did; nothing is dropped without a count here.
struct MeshReadReport {
  std::string format;                    // "ply (ascii)", "ply (binary)", "obj", "off", "stl"
  int64_t declared_faces = -1;           // from the header where the format has one
  int64_t polygons_triangulated = 0;     // faces with more than 3 corners
  int64_t faces_rejected_by_reader = 0;  // non-manifold/complex faces OpenMesh refused
  int64_t degenerate_faces_dropped = 0;
  int64_t nonfinite_vertices = 0;
  int64_t faces_dropped_for_nonfinite = 0;
  int64_t comment_lines_skipped = 0;  // non-standard PLY comments inside element data
  std::vector<std::string> notes;     // one line per event, for reports and mr-info
};

// OBJ, PLY (ASCII and binary), OFF, STL.  Throws mr::Error naming the file.
Mesh ReadMesh(const fs::path& path, const MeshReadOptions& options = {}, MeshReadReport* report = nullptr);
// Binary little-endian PLY with normals, colours (uchar) and uvs when present.  Atomic.
void WritePly(const fs::path& path, const Mesh& mesh, const std::string& comment = "");

}  // namespace mr
