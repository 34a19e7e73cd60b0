// Mesh reading: PLY through OpenMesh behind a strict header pass (and an
// ASCII-PLY pre-pass that finds non-standard comment lines inside element
// data, as the Stanford bunny res4 has, non-finite coordinates and
// out-of-range face indices, each with its line number); OBJ, OFF and STL
// through mr's own readers (mesh_formats.h).
#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/math.h"
#include "geometry/asset.h"
#include "geometry/mesh.h"
#include "geometry/mesh_formats.h"

namespace mr {

namespace {

// Collects vertices and polygons exactly as the file lists them.
class SoupImporter : public OpenMesh::IO::BaseImporter {
 public:
  using VH = OpenMesh::VertexHandle;
  using FH = OpenMesh::FaceHandle;
  using HH = OpenMesh::HalfedgeHandle;
  using EH = OpenMesh::EdgeHandle;
  std::vector<Eigen::Vector3f> positions, normals, colors;
  std::vector<Eigen::Vector2f> uvs;
  std::vector<std::vector<int>> faces;
  bool has_normals = false, has_colors = false, has_uvs = false;

  VH add_vertex(const OpenMesh::Vec3f& p) override {
    positions.emplace_back(p[0], p[1], p[2]);
    return VH(static_cast<int>(positions.size() - 1));
  }
  VH add_vertex() override { return add_vertex(OpenMesh::Vec3f(0, 0, 0)); }
  HH add_edge(VH, VH) override { return HH(); }
  FH add_face(const VHandles& idx) override {
    std::vector<int> f;
    for (auto v : idx) f.push_back(v.idx());
    faces.push_back(std::move(f));
    return FH(static_cast<int>(faces.size() - 1));
  }
  FH add_face(HH) override { return FH(); }
  void add_face_texcoords(FH, VH, const std::vector<OpenMesh::Vec2f>&) override {}
  void add_face_texcoords(FH, VH, const std::vector<OpenMesh::Vec3f>&) override {}
  void set_face_texindex(FH, int) override {}
  void set_point(VH v, const OpenMesh::Vec3f& p) override { At(positions, v) = Eigen::Vector3f(p[0], p[1], p[2]); }
  void set_halfedge(VH, HH) override {}
  void set_normal(VH v, const OpenMesh::Vec3f& n) override {
    has_normals = true;
    At(normals, v) = Eigen::Vector3f(n[0], n[1], n[2]);
  }
  void set_normal(VH v, const OpenMesh::Vec3d& n) override { set_normal(v, OpenMesh::Vec3f(n)); }
  void set_color(VH v, const OpenMesh::Vec3uc& c) override {
    has_colors = true;
    At(colors, v) = Eigen::Vector3f(c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f);
  }
  void set_color(VH v, const OpenMesh::Vec4uc& c) override { set_color(v, OpenMesh::Vec3uc(c[0], c[1], c[2])); }
  void set_color(VH v, const OpenMesh::Vec3f& c) override {
    has_colors = true;
    At(colors, v) = Eigen::Vector3f(c[0], c[1], c[2]);
  }
  void set_color(VH v, const OpenMesh::Vec4f& c) override { set_color(v, OpenMesh::Vec3f(c[0], c[1], c[2])); }
  void set_texcoord(VH v, const OpenMesh::Vec2f& t) override {
    has_uvs = true;
    At(uvs, v) = Eigen::Vector2f(t[0], t[1]);
  }
  void set_status(VH, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_next(HH, HH) override {}
  void set_face(HH, FH) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(HH, const OpenMesh::Vec2f&) override {}
  void set_texcoord(VH v, const OpenMesh::Vec3f& t) override { set_texcoord(v, OpenMesh::Vec2f(t[0], t[1])); }
  void set_texcoord(HH, const OpenMesh::Vec3f&) override {}
  void set_status(HH, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_color(EH, const OpenMesh::Vec3uc&) override {}
  void set_color(EH, const OpenMesh::Vec4uc&) override {}
  void set_color(EH, const OpenMesh::Vec3f&) override {}
  void set_color(EH, const OpenMesh::Vec4f&) override {}
  void set_status(EH, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_normal(FH, const OpenMesh::Vec3f&) override {}
  void set_normal(FH, const OpenMesh::Vec3d&) override {}
  void set_color(FH, const OpenMesh::Vec3uc&) override {}
  void set_color(FH, const OpenMesh::Vec4uc&) override {}
  void set_color(FH, const OpenMesh::Vec3f&) override {}
  void set_color(FH, const OpenMesh::Vec4f&) override {}
  void set_status(FH, const OpenMesh::Attributes::StatusInfo&) override {}
  void add_texture_information(int, std::string) override {}
  size_t n_vertices() const override { return positions.size(); }
  size_t n_faces() const override { return faces.size(); }
  size_t n_edges() const override { return 0; }

 private:
  template <typename T>
  T& At(std::vector<T>& v, VH h) {
    const size_t i = static_cast<size_t>(h.idx());
    if (v.size() <= i) v.resize(std::max(i + 1, positions.size()), T::Zero());
    return v[i];
  }
};

struct PlyHeader {
  bool ascii = false;
  bool binary = false;
  int64_t vertices = -1, faces = -1;
  std::vector<std::string> vertex_props;
  int header_lines = 0;
};

// Parses the PLY header of `text`; returns false when it is not a PLY.
// Bytes of a PLY scalar type, or 0 when the name is not one.
int PlyTypeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

// Parses the PLY header of `text` strictly (every line must be one of the
// keywords of the PLY specification with well-formed arguments), so that
// OpenMesh only ever sees well-formed headers.  Returns false when the file
// does not start with the "ply" magic.
bool ParsePlyHeader(const std::string& text, PlyHeader* h, const std::string& name) {
  std::istringstream in(text);
  std::string line;
  if (!std::getline(in, line) || (line != "ply" && line != "ply\r")) return false;
  h->header_lines = 1;
  std::string element;
  bool has_format = false, face_has_indices = false;
  int64_t vertex_bytes = 0;  // binary record size of a vertex
  auto fail = [&](const std::string& what) { ThrowErrorAt(FileLoc{name, h->header_lines}, "PLY header: {}", what); };
  while (std::getline(in, line)) {
    ++h->header_lines;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find('\0') != std::string::npos) fail("NUL byte in the header");
    std::istringstream ls(line);
    std::vector<std::string> tok;
    for (std::string t; ls >> t;) tok.push_back(t);
    if (tok.empty()) fail("empty line");
    const std::string& kw = tok[0];
    if (kw == "comment" || kw == "obj_info") continue;
    if (kw == "format") {
      if (has_format || tok.size() != 3 || tok[2] != "1.0")
        fail("expected \"format ascii|binary_little_endian|binary_big_endian 1.0\"");
      if (tok[1] == "ascii")
        h->ascii = true;
      else if (tok[1] == "binary_little_endian" || tok[1] == "binary_big_endian")
        h->binary = true;
      else
        fail(fmt::format("unknown format \"{}\"", tok[1]));
      has_format = true;
    } else if (kw == "element") {
      if (tok.size() != 3) fail("expected \"element NAME COUNT\"");
      char* end = nullptr;
      errno = 0;
      long long n = std::strtoll(tok[2].c_str(), &end, 10);
      if (end != tok[2].c_str() + tok[2].size() || tok[2].empty() || n < 0 || errno == ERANGE)
        fail(fmt::format("bad element count \"{}\"", tok[2]));
      element = tok[1];
      if (element == "vertex") {
        if (h->vertices >= 0) fail("two vertex elements");
        h->vertices = n;
      } else if (element == "face") {
        if (h->faces >= 0) fail("two face elements");
        h->faces = n;
      } else {
        fail(fmt::format("element \"{}\" is not supported (vertex and face only)", element));
      }
    } else if (kw == "property") {
      if (element.empty()) fail("property before any element");
      if (tok.size() == 3 && PlyTypeSize(tok[1]) > 0) {
        if (element != "vertex") fail("scalar property outside the vertex element");
        h->vertex_props.push_back(tok[2]);
        vertex_bytes += PlyTypeSize(tok[1]);
      } else if (tok.size() == 5 && tok[1] == "list" && PlyTypeSize(tok[2]) > 0 && PlyTypeSize(tok[3]) > 0 &&
                 tok[2].find("float") == std::string::npos && tok[3].find("float") == std::string::npos &&
                 tok[2] != "double" && tok[3] != "double") {
        if (element != "face" || (tok[4] != "vertex_indices" && tok[4] != "vertex_index"))
          fail("list properties are supported as face vertex_indices only");
        if (face_has_indices) fail("two vertex index lists");
        face_has_indices = true;
      } else {
        fail(fmt::format("malformed property \"{}\"", line));
      }
    } else if (kw == "end_header") {
      if (tok.size() != 1) fail("trailing words after end_header");
      if (!has_format) fail("no format line");
      if (h->vertices < 0) fail("no vertex element");
      if (h->faces > 0 && !face_has_indices) fail("faces without a vertex_indices list");
      const int64_t header_bytes = static_cast<int64_t>(in.tellg());
      // A binary file must hold every vertex record and at least 4 bytes per
      // face (count + 3 one-byte indices); ASCII at least 3 bytes per vertex
      // and 4 per face.  A header that claims more is corrupt.
      const double per_vertex = h->binary ? static_cast<double>(vertex_bytes) : 3.0;
      const double need =
          per_vertex * static_cast<double>(h->vertices) + 4.0 * static_cast<double>(std::max<int64_t>(0, h->faces));
      if (header_bytes < 0 || need > static_cast<double>(text.size()) - static_cast<double>(header_bytes))
        ThrowErrorAt(FileLoc{name},
                     "header declares {} vertices and {} faces, more than the {} bytes after it can hold "
                     "(truncated file or corrupt header?)",
                     h->vertices, std::max<int64_t>(0, h->faces),
                     static_cast<int64_t>(text.size()) - std::max<int64_t>(0, header_bytes));
      return true;
    } else {
      fail(fmt::format("unknown keyword \"{}\"", kw));
    }
  }
  ThrowErrorAt(FileLoc{name}, "PLY header has no end_header (truncated file?)");
}

// Checks the ASCII element data and returns it without non-standard comment
// lines.  Records what it found in `report`.
std::string CleanAsciiPly(const std::string& text, const PlyHeader& h, const std::string& name,
                          const MeshReadOptions& options, MeshReadReport* report, std::vector<char>* bad_vertex) {
  std::istringstream in(text);
  std::ostringstream out;
  std::string line;
  int lineno = 0;
  for (int i = 0; i < h.header_lines; ++i) {
    std::getline(in, line);
    ++lineno;
    out << line << '\n';
  }
  int xyz[3] = {-1, -1, -1};
  for (size_t i = 0; i < h.vertex_props.size(); ++i) {
    if (h.vertex_props[i] == "x") xyz[0] = static_cast<int>(i);
    if (h.vertex_props[i] == "y") xyz[1] = static_cast<int>(i);
    if (h.vertex_props[i] == "z") xyz[2] = static_cast<int>(i);
  }
  if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0) ThrowErrorAt(FileLoc{name}, "PLY vertices lack x, y or z properties");
  bad_vertex->assign(static_cast<size_t>(std::max<int64_t>(0, h.vertices)), 0);
  int64_t v = 0, f = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::string trimmed = line;
    if (!trimmed.empty() && trimmed.back() == '\r') trimmed.pop_back();
    if (trimmed.rfind("comment", 0) == 0) {
      ++report->comment_lines_skipped;
      report->notes.push_back(
          fmt::format("{}:{}: skipped a non-standard comment line inside the "
                      "element data: \"{}\"",
                      name, lineno, trimmed));
      continue;
    }
    if (trimmed.find_first_not_of(" \t") == std::string::npos) continue;
    std::istringstream ls(trimmed);
    ls.imbue(std::locale::classic());
    std::vector<std::string> tok;
    std::string t;
    while (ls >> t) tok.push_back(t);
    if (v < h.vertices) {
      if (tok.size() < h.vertex_props.size())
        ThrowErrorAt(FileLoc{name, lineno}, "vertex {} has {} values, the header declares {}", v, tok.size(),
                     h.vertex_props.size());
      for (int k = 0; k < 3; ++k) {
        const std::string& s = tok[static_cast<size_t>(xyz[k])];
        char* end = nullptr;
        double val = std::strtod(s.c_str(), &end);
        if (end == s.c_str() || *end != '\0')
          ThrowErrorAt(FileLoc{name, lineno}, "vertex {}: \"{}\" is not a number", v, s);
        if (!std::isfinite(val)) {
          if (options.nonfinite == BadVertices::kReject)
            ThrowErrorAt(FileLoc{name, lineno}, "vertex {} has a non-finite coordinate ({})", v, s);
          if (!(*bad_vertex)[static_cast<size_t>(v)]) ++report->nonfinite_vertices;
          (*bad_vertex)[static_cast<size_t>(v)] = 1;
          tok[static_cast<size_t>(xyz[k])] = "0";  // OpenMesh cannot parse "nan"; faces using it are dropped
        }
      }
      for (size_t k = 0; k < tok.size(); ++k) out << (k ? " " : "") << tok[k];
      out << '\n';
      ++v;
      continue;
    }
    if (f < h.faces) {
      char* end = nullptr;
      long n = std::strtol(tok[0].c_str(), &end, 10);
      if (*end != '\0' || n < 3 || static_cast<size_t>(n) + 1 > tok.size())
        ThrowErrorAt(FileLoc{name, lineno}, "face {}: bad vertex list \"{}\"", f, trimmed);
      for (long k = 1; k <= n; ++k) {
        long idx = std::strtol(tok[static_cast<size_t>(k)].c_str(), &end, 10);
        if (*end != '\0' || idx < 0 || idx >= h.vertices)
          ThrowErrorAt(FileLoc{name, lineno}, "face {} uses vertex \"{}\", but there are {} vertices", f,
                       tok[static_cast<size_t>(k)], h.vertices);
      }
      ++f;
    }
    out << trimmed << '\n';
  }
  if (v < h.vertices || f < h.faces)
    ThrowErrorAt(FileLoc{name}, "truncated: {} of {} vertices and {} of {} faces present", v, h.vertices, f, h.faces);
  return out.str();
}

}  // namespace

Mesh ReadMesh(const fs::path& path, const MeshReadOptions& options, MeshReadReport* report_out) {
  const std::string name = path.string();
  const FileLoc loc{name};
  const std::string ext = LowerExtension(path);
  if (ext == ".gltf" || ext == ".glb") {  // an asset's geometry: its parts as one mesh
    const Asset asset = ReadAsset(path);
    if (report_out) {
      *report_out = MeshReadReport();
      report_out->format = asset.report.format;
      report_out->notes = asset.report.ignored;
    }
    return MergeParts(asset);
  }
  if (ext != ".ply" && ext != ".obj" && ext != ".off" && ext != ".stl")
    ThrowErrorAt(loc, "unsupported mesh extension \"{}\" (use .ply .obj .off .stl, or a .gltf .glb asset)", ext);
  RequireFile(path, "mesh");

  MeshReadReport report;
  report.format = ext.substr(1);
  std::string text = ReadTextFile(path);
  if (text.empty()) ThrowErrorAt(loc, "empty file");
  detail::MeshSoup soup;
  if (ext == ".ply") {
    std::vector<char> bad_vertex;
    PlyHeader h;
    if (!ParsePlyHeader(text, &h, name)) ThrowErrorAt(loc, "not a PLY file (no \"ply\" magic)");
    report.declared_faces = h.faces;
    report.format = h.ascii ? "ply (ascii)" : "ply (binary)";
    if (h.ascii) text = CleanAsciiPly(text, h, name, options, &report, &bad_vertex);
    // OpenMesh's PLY parser feeds a soup importer: its halfedge meshes cannot
    // hold the non-manifold vertices of real scans (the Stanford bunny has
    // them) and would silently split vertices and refuse faces.
    SoupImporter importer;
    OpenMesh::IO::Options opt;
    opt += OpenMesh::IO::Options::VertexNormal;
    opt += OpenMesh::IO::Options::VertexColor;
    opt += OpenMesh::IO::Options::VertexTexCoord;
    std::istringstream in(text);
    if (!OpenMesh::IO::IOManager().read(in, ext, importer, opt))
      ThrowErrorAt(loc, "cannot parse {} (OpenMesh rejected it: corrupt or truncated?)", report.format);
    soup.positions = std::move(importer.positions);
    if (opt.check(OpenMesh::IO::Options::VertexNormal) && importer.has_normals)
      soup.normals = std::move(importer.normals);
    if (opt.check(OpenMesh::IO::Options::VertexColor) && importer.has_colors) soup.colors = std::move(importer.colors);
    if (opt.check(OpenMesh::IO::Options::VertexTexCoord) && importer.has_uvs) soup.uvs = std::move(importer.uvs);
    soup.faces = std::move(importer.faces);
    soup.bad_vertex = std::move(bad_vertex);
  } else if (ext == ".obj") {
    soup = detail::ParseObj(text, name, options);
  } else if (ext == ".off") {
    soup = detail::ParseOff(text, name, options);
  } else {
    soup = detail::ParseStl(text, name, options);
    report.format = soup.format;
  }
  if (soup.positions.empty()) ThrowErrorAt(loc, "mesh has no vertices");
  for (std::string& n : soup.notes) report.notes.push_back(std::move(n));

  Mesh mesh;
  mesh.positions = std::move(soup.positions);
  std::vector<char>& bad_vertex = soup.bad_vertex;
  if (bad_vertex.size() != mesh.positions.size()) bad_vertex.resize(mesh.positions.size(), 0);
  report.nonfinite_vertices = 0;
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    if (!bad_vertex[i] && !mesh.positions[i].allFinite()) {
      if (options.nonfinite == BadVertices::kReject) ThrowErrorAt(loc, "vertex {} has a non-finite coordinate", i);
      bad_vertex[i] = 1;
    }
    report.nonfinite_vertices += bad_vertex[i] ? 1 : 0;
  }
  mesh.normals = std::move(soup.normals);
  mesh.colors = std::move(soup.colors);
  mesh.uvs = std::move(soup.uvs);
  const size_t nv = mesh.positions.size();
  mesh.normals.resize(mesh.normals.empty() ? 0 : nv, Eigen::Vector3f::Zero());
  mesh.colors.resize(mesh.colors.empty() ? 0 : nv, Eigen::Vector3f::Zero());
  mesh.uvs.resize(mesh.uvs.empty() ? 0 : nv, Eigen::Vector2f::Zero());

  for (const auto& poly : soup.faces) {
    for (int v : poly)
      if (v < 0 || static_cast<size_t>(v) >= nv)
        ThrowErrorAt(loc, "a face uses vertex {}, but there are {} vertices", v, nv);
    if (poly.size() > 3) ++report.polygons_triangulated;
    for (size_t k = 1; k + 1 < poly.size(); ++k) {  // fan triangulation
      Eigen::Vector3i tri(poly[0], poly[k], poly[k + 1]);
      if (bad_vertex[static_cast<size_t>(tri[0])] || bad_vertex[static_cast<size_t>(tri[1])] ||
          bad_vertex[static_cast<size_t>(tri[2])]) {
        ++report.faces_dropped_for_nonfinite;
        continue;
      }
      if (IsDegenerate(mesh, tri)) {
        ++report.degenerate_faces_dropped;
        continue;
      }
      mesh.triangles.push_back(tri);
    }
  }
  if (report.declared_faces >= 0 && static_cast<int64_t>(soup.faces.size()) != report.declared_faces)
    ThrowErrorAt(loc, "the header declares {} faces, the reader found {}", report.declared_faces, soup.faces.size());
  if (report.polygons_triangulated)
    report.notes.push_back(fmt::format("{}: triangulated {} polygons (fan)", name, report.polygons_triangulated));
  if (report.degenerate_faces_dropped)
    report.notes.push_back(fmt::format("{}: dropped {} degenerate faces (zero area or repeated corner)", name,
                                       report.degenerate_faces_dropped));
  if (report.nonfinite_vertices)
    report.notes.push_back(fmt::format("{}: {} vertices have non-finite coordinates; dropped the {} faces using them",
                                       name, report.nonfinite_vertices, report.faces_dropped_for_nonfinite));
  if (mesh.triangles.empty() && !options.points) ThrowErrorAt(loc, "mesh has no usable triangles");
  if (mesh.positions.empty()) ThrowErrorAt(loc, "the file holds no vertices");
  if (report_out) *report_out = report;
  return mesh;
}

void WritePly(const fs::path& path, const Mesh& mesh, const std::string& comment) {
  mesh.Validate(path.string());
  std::ostringstream out(std::ios::binary);
  out << "ply\nformat binary_little_endian 1.0\n";
  if (!comment.empty()) out << "comment " << comment << "\n";
  out << "element vertex " << mesh.positions.size() << "\n"
      << "property float x\nproperty float y\nproperty float z\n";
  if (!mesh.normals.empty()) out << "property float nx\nproperty float ny\nproperty float nz\n";
  if (!mesh.colors.empty()) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (!mesh.uvs.empty()) out << "property float u\nproperty float v\n";
  for (const Mesh::Scalar& sc : mesh.scalars) out << "property float " << sc.name << "\n";
  out << "element face " << mesh.triangles.size() << "\n"
      << "property list uchar int vertex_indices\nend_header\n";
  auto put = [&](const void* p, size_t n) { out.write(static_cast<const char*>(p), static_cast<std::streamsize>(n)); };
  static_assert(std::endian::native == std::endian::little, "binary PLY writer assumes little-endian");
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    put(mesh.positions[i].data(), 12);
    if (!mesh.normals.empty()) put(mesh.normals[i].data(), 12);
    if (!mesh.colors.empty()) {
      uint8_t c[3];
      for (int k = 0; k < 3; ++k)
        c[k] = static_cast<uint8_t>(std::lround(Clamp(mesh.colors[i][k], 0.0f, 1.0f) * 255.0f));
      put(c, 3);
    }
    if (!mesh.uvs.empty()) put(mesh.uvs[i].data(), 8);
    for (const Mesh::Scalar& s : mesh.scalars) put(&s.values[i], 4);
  }
  for (const auto& t : mesh.triangles) {
    uint8_t n = 3;
    put(&n, 1);
    put(t.data(), 12);
  }
  WriteTextFile(path, out.str());
}

}  // namespace mr
