// mr's readers of OBJ, OFF and STL (mesh_formats.h says why not OpenMesh's).
// Every count read from a file is checked against the bytes that follow
// before anything is reserved or looped over, so a file of a few bytes costs
// a few bytes of work however large the numbers it claims.
#include "geometry/mesh_formats.h"

#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <map>
#include <string_view>
#include <unordered_map>

#include "core/error.h"

namespace mr::detail {

std::vector<std::string_view> Tokens(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\v' || line[i] == '\f')) ++i;
    size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\v' && line[j] != '\f') ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

namespace {

// Iterates over the lines of `text` ('\n' or "\r\n"), 1-based.
class Lines {
 public:
  explicit Lines(std::string_view text) : text_(text) {}
  bool Next(std::string_view* line) {
    if (pos_ >= text_.size()) return false;
    size_t end = text_.find('\n', pos_);
    if (end == std::string_view::npos) end = text_.size();
    *line = text_.substr(pos_, end - pos_);
    if (!line->empty() && line->back() == '\r') line->remove_suffix(1);
    pos_ = end + 1;
    ++number_;
    return true;
  }
  int number() const { return number_; }
  size_t remaining() const { return pos_ >= text_.size() ? 0 : text_.size() - pos_; }

 private:
  std::string_view text_;
  size_t pos_ = 0;
  int number_ = 0;
};

// A printable rendering of a token for messages (binary bytes escaped, long
// tokens cut), so that a corrupt file never writes control bytes to a terminal.
std::string Quote(std::string_view s) {
  std::string out = "\"";
  for (size_t i = 0; i < s.size() && i < 40; ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f && c != '"' && c != '\\')
      out += static_cast<char>(c);
    else
      out += fmt::format("\\x{:02x}", c);
  }
  if (s.size() > 40) out += "...";
  return out + "\"";
}

// A whole token as a double (classic locale; "nan" and "inf" parse, and are
// returned as such for the caller to judge).
bool ParseDouble(std::string_view s, double* v) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), *v);
  return ec == std::errc() && p == s.data() + s.size();
}

bool ParseInt(std::string_view s, int64_t* v) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), *v);
  return ec == std::errc() && p == s.data() + s.size();
}

// Reads `n` coordinates of a vertex-like record starting at tok[first];
// non-finite values are an error at the line, or mark the vertex bad.
void Coordinates(const std::vector<std::string_view>& tok, size_t first, int n, float* out, const FileLoc& loc,
                 const char* what, bool* nonfinite) {
  for (int k = 0; k < n; ++k) {
    double v = 0;
    std::string_view s = tok[first + static_cast<size_t>(k)];
    if (!ParseDouble(s, &v)) ThrowErrorAt(loc, "{}: {} is not a number", what, Quote(s));
    if (!std::isfinite(v) || std::abs(v) > 3.4e38) {
      if (!nonfinite) ThrowErrorAt(loc, "{} has a non-finite coordinate ({})", what, Quote(s));
      *nonfinite = true;
      v = 0;
    }
    out[k] = static_cast<float>(v);
  }
}

// Marks `v` as a vertex with a non-finite coordinate, or throws when the
// options reject those.
void NonFinite(MeshSoup* soup, size_t v, const MeshReadOptions& options, const FileLoc& loc, const std::string& what) {
  if (options.nonfinite == BadVertices::kReject) ThrowErrorAt(loc, "{} has a non-finite coordinate", what);
  if (soup->bad_vertex.size() <= v) soup->bad_vertex.resize(v + 1, 0);
  soup->bad_vertex[v] = 1;
}

// OBJ keywords that carry no triangle-mesh data (groups, materials, smoothing,
// free-form geometry, lines and points): ignored, and counted in the notes.
bool IsIgnoredObjKeyword(std::string_view k) {
  static const char* const kIgnored[] = {"g",        "o",     "s",     "mg",    "usemtl", "mtllib",     "maplib",
                                         "usemap",   "lod",   "vp",    "l",     "p",      "cstype",     "deg",
                                         "bmat",     "step",  "curv",  "curv2", "surf",   "parm",       "trim",
                                         "hole",     "scrv",  "sp",    "end",   "con",    "bevel",      "c_interp",
                                         "d_interp", "ctech", "stech", "call",  "csh",    "shadow_obj", "trace_obj"};
  for (const char* s : kIgnored)
    if (k == s) return true;
  return false;
}

// One face corner, "v", "v/vt", "v//vn" or "v/vt/vn" (1-based, negative
// from the end), against the counts of vertices, uvs and normals defined so
// far: 0-based (vertex, uv, normal), -1 where the corner names none.
Eigen::Vector3i ParseObjCorner(std::string_view c, const std::array<size_t, 3>& counts, const FileLoc& loc) {
  std::string_view part[3];
  int parts = 0;
  size_t start = 0;
  for (size_t i = 0; i <= c.size() && parts < 4; ++i) {
    if (i == c.size() || c[i] == '/') {
      if (parts == 3) ThrowErrorAt(loc, "face corner {}: more than three indices", Quote(c));
      part[parts++] = c.substr(start, i - start);
      start = i + 1;
    }
  }
  const char* kinds[3] = {"vertex", "texture coordinate", "normal"};
  int64_t idx[3] = {0, 0, 0};
  for (int p = 0; p < parts; ++p) {
    if (part[p].empty()) {
      if (p == 0) ThrowErrorAt(loc, "face corner {} has no vertex index", Quote(c));
      if (p == 1 && parts == 3) continue;  // v//vn
      ThrowErrorAt(loc, "face corner {}: empty index", Quote(c));
    }
    int64_t i = 0;
    if (!ParseInt(part[p], &i) || i == 0)
      ThrowErrorAt(loc, "face corner {}: {} is not a {} index (1-based, or negative from the end)", Quote(c),
                   Quote(part[p]), kinds[p]);
    const int64_t n = static_cast<int64_t>(counts[p]);
    const int64_t resolved = i > 0 ? i - 1 : n + i;
    if (resolved < 0 || resolved >= n)
      ThrowErrorAt(loc, "face corner {} uses {} {}, but {} {}s are defined before it", Quote(c), kinds[p], i, n,
                   kinds[p]);
    idx[p] = resolved;
  }
  return {static_cast<int>(idx[0]), parts >= 2 && !part[1].empty() ? static_cast<int>(idx[1]) : -1,
          parts == 3 ? static_cast<int>(idx[2]) : -1};
}

}  // namespace

MeshSoup ParseObj(const std::string& text, const std::string& name, const MeshReadOptions& options) {
  MeshSoup soup;
  std::vector<Eigen::Vector2f> vt;
  std::vector<Eigen::Vector3f> vn;
  std::map<std::string, int64_t> ignored;  // keyword -> lines
  int64_t unknown_lines = 0;
  std::string first_unknown;
  bool has_colors = false;
  int material = -1;  // the current usemtl's
  Lines lines(text);
  std::string_view raw;
  std::string joined;  // a line continued by a trailing backslash
  int first_line = 0;
  while (lines.Next(&raw)) {
    if (joined.empty()) first_line = lines.number();
    if (!raw.empty() && raw.back() == '\\') {
      joined.append(raw.substr(0, raw.size() - 1)).push_back(' ');
      continue;
    }
    std::string_view line = raw;
    if (!joined.empty()) {
      joined.append(raw);
      line = joined;
    }
    const FileLoc loc{name, first_line};
    const size_t hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);
    const std::vector<std::string_view> tok = Tokens(line);
    if (tok.empty()) {
      joined.clear();
      continue;
    }
    const std::string_view kw = tok[0];
    if (kw == "v") {
      const size_t v = soup.positions.size();
      const std::string what = fmt::format("vertex {}", v + 1);
      // x y z, x y z w (w is a rational weight: ignored), or x y z r g b.
      if (tok.size() != 4 && tok.size() != 5 && tok.size() != 7)
        ThrowErrorAt(loc, "{}: expected \"v x y z\" (optionally w, or r g b), found {} values", what, tok.size() - 1);
      bool nonfinite = false;
      float p[3];
      Coordinates(tok, 1, 3, p, loc, what.c_str(), options.nonfinite == BadVertices::kReject ? nullptr : &nonfinite);
      soup.positions.emplace_back(p[0], p[1], p[2]);
      if (nonfinite) NonFinite(&soup, v, options, loc, what);
      if (tok.size() == 7) {
        float c[3];
        Coordinates(tok, 4, 3, c, loc, (what + " colour").c_str(), nullptr);
        soup.colors.resize(v + 1, Eigen::Vector3f::Zero());
        soup.colors[v] = Eigen::Vector3f(c[0], c[1], c[2]);
        has_colors = true;
      }
    } else if (kw == "vt") {
      if (tok.size() < 2 || tok.size() > 4)
        ThrowErrorAt(loc, "texture coordinate {}: expected \"vt u [v [w]]\"", vt.size() + 1);
      float t[2] = {0, 0};
      const std::string what = fmt::format("texture coordinate {}", vt.size() + 1);
      Coordinates(tok, 1, std::min<int>(2, static_cast<int>(tok.size()) - 1), t, loc, what.c_str(), nullptr);
      vt.emplace_back(t[0], t[1]);
    } else if (kw == "vn") {
      if (tok.size() != 4) ThrowErrorAt(loc, "normal {}: expected \"vn x y z\"", vn.size() + 1);
      float n[3];
      const std::string what = fmt::format("normal {}", vn.size() + 1);
      Coordinates(tok, 1, 3, n, loc, what.c_str(), nullptr);
      vn.emplace_back(n[0], n[1], n[2]);
    } else if (kw == "f") {
      if (tok.size() < 4)
        ThrowErrorAt(loc, "face {} has {} corners, at least 3 needed", soup.faces.size() + 1, tok.size() - 1);
      std::vector<int> face;
      std::vector<Eigen::Vector3i> corners;
      face.reserve(tok.size() - 1);
      for (size_t k = 1; k < tok.size(); ++k) {
        const Eigen::Vector3i c = ParseObjCorner(tok[k], {soup.positions.size(), vt.size(), vn.size()}, loc);
        const size_t v = static_cast<size_t>(c[0]);
        face.push_back(c[0]);
        corners.push_back(c);
        // Per-vertex attributes from the corner (the last corner naming a
        // vertex wins, as in OpenMesh's reader).
        if (c[1] >= 0) {
          soup.uvs.resize(std::max(soup.uvs.size(), v + 1), Eigen::Vector2f::Zero());
          soup.uvs[v] = vt[static_cast<size_t>(c[1])];
        }
        if (c[2] >= 0) {
          soup.normals.resize(std::max(soup.normals.size(), v + 1), Eigen::Vector3f::Zero());
          soup.normals[v] = vn[static_cast<size_t>(c[2])];
        }
      }
      if (soup.positions.size() > static_cast<size_t>(std::numeric_limits<int>::max()))
        ThrowErrorAt(loc, "more vertices than mr's meshes index (2^31)");
      soup.faces.push_back(std::move(face));
      soup.obj_corners.push_back(std::move(corners));
      soup.obj_face_material.push_back(material);
    } else if (IsIgnoredObjKeyword(kw)) {
      ++ignored[std::string(kw)];
      // Kept for assets: the materials (the rest of the line is the name,
      // which may hold spaces).
      const std::string rest(Trim(line.substr(line.find(kw) + kw.size())));
      if (kw == "usemtl") {
        auto it = std::find(soup.obj_materials.begin(), soup.obj_materials.end(), rest);
        material = static_cast<int>(it - soup.obj_materials.begin());
        if (it == soup.obj_materials.end()) soup.obj_materials.push_back(rest);
      } else if (kw == "mtllib" && !rest.empty()) {
        soup.obj_mtllibs.push_back(rest);
      }
    } else {
      if (unknown_lines++ == 0) first_unknown = fmt::format("{} at line {}", Quote(kw), first_line);
    }
    joined.clear();
  }
  if (!joined.empty()) ThrowErrorAt(FileLoc{name, first_line}, "the last line ends in a continuation backslash");
  const size_t nv = soup.positions.size();
  if (has_colors) soup.colors.resize(nv, Eigen::Vector3f::Zero());
  if (!soup.uvs.empty()) soup.uvs.resize(nv, Eigen::Vector2f::Zero());
  if (!soup.normals.empty()) soup.normals.resize(nv, Eigen::Vector3f::Zero());
  soup.obj_uvs = std::move(vt);
  soup.obj_normals = std::move(vn);
  for (const auto& [kw, n] : ignored)
    soup.notes.push_back(
        fmt::format("{}: ignored {} \"{}\" line{} (no triangle data)", name, n, kw, n == 1 ? "" : "s"));
  if (unknown_lines)
    soup.notes.push_back(fmt::format("{}: ignored {} line{} with unknown keywords, the first {}", name, unknown_lines,
                                     unknown_lines == 1 ? "" : "s", first_unknown));
  return soup;
}

MeshSoup ParseOff(const std::string& text, const std::string& name, const MeshReadOptions& options) {
  MeshSoup soup;
  Lines lines(text);
  std::string_view raw;
  // The next non-empty line without its comment, tokenised; false at the end.
  auto next = [&](std::vector<std::string_view>* tok) {
    while (lines.Next(&raw)) {
      const size_t hash = raw.find('#');
      *tok = Tokens(hash == std::string_view::npos ? raw : raw.substr(0, hash));
      if (!tok->empty()) return true;
    }
    return false;
  };
  std::vector<std::string_view> tok;
  if (!next(&tok)) ThrowErrorAt(FileLoc{name}, "empty OFF file");
  // Header keyword: [ST][C][N]OFF.  4OFF (4-D) and nOFF (n-D) have no
  // meaning for a triangle mesh; "OFF BINARY" is not supported.
  const std::string_view magic = tok[0];
  const FileLoc header_loc{name, lines.number()};
  if (magic.size() < 3 || magic.substr(magic.size() - 3) != "OFF")
    ThrowErrorAt(header_loc, "not an OFF file: the first word is {}, expected OFF (or COFF, NOFF, STOFF)",
                 Quote(magic));
  std::string_view prefix = magic.substr(0, magic.size() - 3);
  bool st = false, c = false, n = false;
  if (prefix.substr(0, 2) == "ST") st = true, prefix.remove_prefix(2);
  if (!prefix.empty() && prefix[0] == 'C') c = true, prefix.remove_prefix(1);
  if (!prefix.empty() && prefix[0] == 'N') n = true, prefix.remove_prefix(1);
  if (!prefix.empty())
    ThrowErrorAt(header_loc, "OFF variant {} is not supported (OFF, COFF, NOFF, CNOFF, STOFF, STCOFF)", Quote(magic));
  std::vector<std::string_view> counts(tok.begin() + 1, tok.end());
  if (!counts.empty() && counts[0] == "BINARY") ThrowErrorAt(header_loc, "binary OFF is not supported (use ASCII OFF)");
  if (counts.empty()) {
    if (!next(&tok)) ThrowErrorAt(FileLoc{name}, "truncated: no vertex and face counts after {}", Quote(magic));
    counts = tok;
  }
  const FileLoc count_loc{name, lines.number()};
  if (counts.size() != 3 && counts.size() != 2)
    ThrowErrorAt(count_loc, "expected \"VERTICES FACES EDGES\", found {} values", counts.size());
  int64_t nv = 0, nf = 0;
  if (!ParseInt(counts[0], &nv) || nv < 0) ThrowErrorAt(count_loc, "bad vertex count {}", Quote(counts[0]));
  if (!ParseInt(counts[1], &nf) || nf < 0) ThrowErrorAt(count_loc, "bad face count {}", Quote(counts[1]));
  // Every vertex line holds at least "0 0 0\n" (6 bytes) and every face
  // "3 0 1 2\n" (8 bytes): a header claiming more than the file can hold is
  // corrupt, and is refused before anything is allocated.
  const double need = 6.0 * static_cast<double>(nv) + 8.0 * static_cast<double>(nf);
  if (need > static_cast<double>(lines.remaining()))
    ThrowErrorAt(count_loc,
                 "header declares {} vertices and {} faces, more than the {} bytes after it can hold (truncated file "
                 "or corrupt header?)",
                 nv, nf, lines.remaining());
  if (nv > std::numeric_limits<int>::max()) ThrowErrorAt(count_loc, "more vertices than mr's meshes index (2^31)");
  const size_t per_vertex = 3 + (n ? 3 : 0) + (st ? 2 : 0);
  soup.positions.reserve(static_cast<size_t>(nv));
  if (n) soup.normals.reserve(static_cast<size_t>(nv));
  if (st) soup.uvs.reserve(static_cast<size_t>(nv));
  if (c) soup.colors.reserve(static_cast<size_t>(nv));
  for (int64_t v = 0; v < nv; ++v) {
    if (!next(&tok)) ThrowErrorAt(FileLoc{name}, "truncated: {} of {} vertices present", v, nv);
    const FileLoc loc{name, lines.number()};
    const std::string what = fmt::format("vertex {}", v);
    // x y z [nx ny nz] [r g b [a]] [s t]
    const size_t colour_values = c ? tok.size() - per_vertex : 0;
    if (tok.size() < per_vertex || (c && colour_values != 3 && colour_values != 4) || (!c && tok.size() != per_vertex))
      ThrowErrorAt(loc, "{} has {} values; {} expects {}{}", what, tok.size(), Quote(magic), per_vertex,
                   c ? " plus 3 or 4 colour values" : "");
    bool nonfinite = false;
    float p[3];
    Coordinates(tok, 0, 3, p, loc, what.c_str(), options.nonfinite == BadVertices::kReject ? nullptr : &nonfinite);
    soup.positions.emplace_back(p[0], p[1], p[2]);
    if (nonfinite) NonFinite(&soup, static_cast<size_t>(v), options, loc, what);
    size_t at = 3;
    if (n) {
      float q[3];
      Coordinates(tok, at, 3, q, loc, (what + " normal").c_str(), nullptr);
      soup.normals.emplace_back(q[0], q[1], q[2]);
      at += 3;
    }
    if (c) {
      float q[3];
      Coordinates(tok, at, 3, q, loc, (what + " colour").c_str(), nullptr);
      // Integer colours are 0..255, float colours 0..1 (the OFF convention).
      const bool integers = tok[at].find_first_of(".eE") == std::string_view::npos &&
                            tok[at + 1].find_first_of(".eE") == std::string_view::npos &&
                            tok[at + 2].find_first_of(".eE") == std::string_view::npos;
      const float scale = integers ? 1.0f / 255.0f : 1.0f;
      soup.colors.emplace_back(q[0] * scale, q[1] * scale, q[2] * scale);
      at += colour_values;
    }
    if (st) {
      float q[2];
      Coordinates(tok, at, 2, q, loc, (what + " texture coordinate").c_str(), nullptr);
      soup.uvs.emplace_back(q[0], q[1]);
    }
  }
  soup.faces.reserve(static_cast<size_t>(nf));
  for (int64_t f = 0; f < nf; ++f) {
    if (!next(&tok)) ThrowErrorAt(FileLoc{name}, "truncated: {} of {} faces present", f, nf);
    const FileLoc loc{name, lines.number()};
    int64_t k = 0;
    if (!ParseInt(tok[0], &k) || k < 3 || static_cast<size_t>(k) + 1 > tok.size())
      ThrowErrorAt(loc, "face {}: expected a corner count of at least 3 and that many indices, found {}", f,
                   Quote(tok[0]));
    std::vector<int> face;
    face.reserve(static_cast<size_t>(k));
    for (int64_t i = 1; i <= k; ++i) {
      int64_t idx = 0;
      const std::string_view s = tok[static_cast<size_t>(i)];
      if (!ParseInt(s, &idx) || idx < 0 || idx >= nv)
        ThrowErrorAt(loc, "face {} uses vertex {}, but there are {} vertices (0-based)", f, Quote(s), nv);
      face.push_back(static_cast<int>(idx));
    }
    // Values after the indices are the face's colour: not used.
    soup.faces.push_back(std::move(face));
  }
  std::vector<std::string_view> rest;
  if (next(&rest))
    ThrowErrorAt(FileLoc{name, lines.number()}, "trailing data after the {} faces the header declares", nf);
  return soup;
}

namespace {

// Welds STL corners with bit-identical positions into one vertex (STL lists
// every triangle's corners separately), keeping first-appearance order.
class Welder {
 public:
  explicit Welder(MeshSoup* soup) : soup_(soup) {}
  int Add(const float p[3], bool bad) {
    Key k;
    std::memcpy(k.bits, p, sizeof(k.bits));
    auto [it, inserted] = index_.try_emplace(k, static_cast<int>(soup_->positions.size()));
    if (inserted) {
      soup_->positions.emplace_back(p[0], p[1], p[2]);
      if (bad) {
        soup_->bad_vertex.resize(soup_->positions.size(), 0);
        soup_->bad_vertex.back() = 1;
      }
    }
    return it->second;
  }

 private:
  struct Key {
    uint32_t bits[3];
    bool operator==(const Key& o) const { return std::memcmp(bits, o.bits, sizeof(bits)) == 0; }
  };
  struct Hash {
    size_t operator()(const Key& k) const {
      uint64_t h = 1469598103934665603ull;
      for (uint32_t b : k.bits) h = (h ^ b) * 1099511628211ull;
      return static_cast<size_t>(h);
    }
  };
  MeshSoup* soup_;
  std::unordered_map<Key, int, Hash> index_;
};

MeshSoup ParseBinaryStl(const std::string& text, const std::string& name, const MeshReadOptions& options,
                        uint64_t count) {
  MeshSoup soup;
  Welder weld(&soup);
  const char* p = text.data() + 84;
  soup.faces.reserve(count);
  for (uint64_t t = 0; t < count; ++t, p += 50) {
    std::vector<int> face(3);
    for (int k = 0; k < 3; ++k) {
      float q[3];
      std::memcpy(q, p + 12 + 12 * k, 12);  // after the facet normal; little-endian by the format
      const bool bad = !std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2]);
      if (bad && options.nonfinite == BadVertices::kReject)
        ThrowErrorAt(FileLoc{name}, "triangle {} corner {} has a non-finite coordinate", t, k);
      if (bad) q[0] = q[1] = q[2] = 0;
      face[static_cast<size_t>(k)] = bad ? weld.Add(q, true) : weld.Add(q, false);
    }
    soup.faces.push_back(std::move(face));
  }
  if (!soup.bad_vertex.empty()) soup.bad_vertex.resize(soup.positions.size(), 0);
  soup.format = "stl (binary)";
  return soup;
}

MeshSoup ParseAsciiStl(const std::string& text, const std::string& name, const MeshReadOptions& options) {
  MeshSoup soup;
  Welder weld(&soup);
  Lines lines(text);
  std::string_view raw;
  std::vector<std::string_view> tok;
  auto next = [&]() {
    while (lines.Next(&raw)) {
      tok = Tokens(raw);
      if (!tok.empty()) return true;
    }
    return false;
  };
  auto expect = [&](std::initializer_list<std::string_view> words, const char* form) {
    if (!next()) ThrowErrorAt(FileLoc{name}, "truncated: expected \"{}\" after line {}", form, lines.number());
    bool ok = tok.size() >= words.size();
    size_t i = 0;
    for (std::string_view w : words) ok = ok && tok[i++] == w;
    if (!ok) ThrowErrorAt(FileLoc{name, lines.number()}, "expected \"{}\", found {}", form, Quote(raw));
  };
  next();  // "solid [name]", checked by the caller
  while (true) {
    if (!next()) ThrowErrorAt(FileLoc{name}, "truncated: no \"endsolid\"");
    if (tok[0] == "endsolid") break;
    if (tok[0] != "facet" || tok.size() != 5 || tok[1] != "normal")
      ThrowErrorAt(FileLoc{name, lines.number()}, "expected \"facet normal nx ny nz\" or \"endsolid\", found {}",
                   Quote(raw));
    expect({"outer", "loop"}, "outer loop");
    std::vector<int> face;
    while (true) {
      if (!next()) ThrowErrorAt(FileLoc{name}, "truncated: no \"endloop\"");
      const FileLoc loc{name, lines.number()};
      if (tok[0] == "endloop") break;
      if (tok[0] != "vertex" || tok.size() != 4) ThrowErrorAt(loc, "expected \"vertex x y z\", found {}", Quote(raw));
      bool nonfinite = false;
      float q[3];
      Coordinates(tok, 1, 3, q, loc, "vertex", options.nonfinite == BadVertices::kReject ? nullptr : &nonfinite);
      face.push_back(weld.Add(q, nonfinite));
    }
    if (face.size() < 3) ThrowErrorAt(FileLoc{name, lines.number()}, "facet with {} vertices", face.size());
    soup.faces.push_back(std::move(face));
    expect({"endfacet"}, "endfacet");
  }
  if (next())
    ThrowErrorAt(FileLoc{name, lines.number()}, "{} after \"endsolid\"",
                 tok[0] == "solid" ? "a second solid (one solid per STL file is supported)" : "trailing data");
  soup.format = "stl (ascii)";
  if (!soup.bad_vertex.empty()) soup.bad_vertex.resize(soup.positions.size(), 0);
  return soup;
}

}  // namespace

MeshSoup ParseStl(const std::string& text, const std::string& name, const MeshReadOptions& options) {
  // Binary: an 80-byte header, a uint32 count, then 50 bytes per triangle.
  // Binary files may also start with "solid", so the size decides first.
  if (text.size() >= 84) {
    uint32_t count = 0;
    std::memcpy(&count, text.data() + 80, 4);
    const uint64_t need = 84 + 50 * static_cast<uint64_t>(count);
    if (need == text.size()) return ParseBinaryStl(text, name, options, count);
    if (text.rfind("solid", 0) != 0) {
      if (need > text.size())
        ThrowErrorAt(FileLoc{name},
                     "binary STL header declares {} triangles ({} bytes), the file holds {} bytes (truncated file or "
                     "corrupt header?)",
                     count, need, text.size());
      ThrowErrorAt(FileLoc{name}, "binary STL header declares {} triangles ({} bytes), the file holds {} bytes", count,
                   need, text.size());
    }
  }
  if (text.rfind("solid", 0) != 0)
    ThrowErrorAt(FileLoc{name}, "not an STL file (neither \"solid\" nor a binary header with a matching size)");
  return ParseAsciiStl(text, name, options);
}

}  // namespace mr::detail
