// Internal to geometry: mr's own readers of the text-and-simple mesh formats
// (OBJ, OFF, ASCII and binary STL).  OpenMesh's readers of these formats abort
// on a face corner such as "/1", drop vertices that do not parse (shifting
// every later index) and trust counts in headers (a 20-byte OFF file claiming
// 1e11 vertices allocates without bound); these readers check every count
// against the bytes the file holds before allocating or looping, and report
// every bad token with its line.  PLY stays with OpenMesh behind mesh_io.cpp's
// strict header pass.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"

namespace mr::detail {

// Vertices and polygons as the file lists them (0-based indices, checked to
// be in range), with optional per-vertex attributes.
struct MeshSoup {
  std::vector<Eigen::Vector3f> positions, normals, colors;
  std::vector<Eigen::Vector2f> uvs;
  std::vector<std::vector<int>> faces;
  // Per vertex: 1 where a coordinate is not finite (only with
  // BadVertices::kDropFaces; kReject throws at the line instead).
  std::vector<char> bad_vertex;
  std::vector<std::string> notes;  // what was ignored, one line each
  // OBJ only, for assets (asset_obj.cpp): each face's corners as (vertex,
  // uv, normal) indices into positions, obj_uvs and obj_normals (-1: none),
  // its usemtl material (index into obj_materials; -1: none), and the
  // mtllib files named, in order.
  std::vector<Eigen::Vector2f> obj_uvs;
  std::vector<Eigen::Vector3f> obj_normals;
  std::vector<std::vector<Eigen::Vector3i>> obj_corners;
  std::vector<int> obj_face_material;
  std::vector<std::string> obj_materials, obj_mtllibs;
  std::string format;  // "stl (ascii)", "stl (binary)"; empty for the others
};

// Splits a line into whitespace-separated tokens (views into `line`).
std::vector<std::string_view> Tokens(std::string_view line);
// `s` without leading blanks and trailing blanks and carriage returns.
std::string_view Trim(std::string_view s);

// Each throws mr::Error naming `name` (and the line, for text formats) on
// anything malformed.  `text` is the whole file.
MeshSoup ParseObj(const std::string& text, const std::string& name, const MeshReadOptions& options);
MeshSoup ParseOff(const std::string& text, const std::string& name, const MeshReadOptions& options);
MeshSoup ParseStl(const std::string& text, const std::string& name, const MeshReadOptions& options);

}  // namespace mr::detail
