// OBJ with its MTL materials as an asset: mr's own OBJ parser
// (mesh_formats.h) with each corner's uv and normal kept, vertices split
// where a vertex has several (seams), one part per usemtl material, and an
// MTL parser mapping each material onto glTF's metallic-roughness model the
// way Blender's OBJ importer (3.4) maps it onto the Principled BSDF:
//   Kd -> base colour, map_Kd -> base colour texture, d (or 1 - Tr) ->
//   alpha (blended below 1), map_d -> ignored (reported), Ke -> emission,
//   Ni -> ior, Pr -> roughness (else 1 - sqrt(Ns / 1000), clamped),
//   Pm -> metallic (else 0), map_Pr / map_Pm -> their textures (one
//   channel each: reported, mr's textures pack them as glTF does, so only
//   the G channel of map_Pr and B of map_Pm are read when they share a
//   file), Ks -> the dielectric lobe's colour (specular_color), map_Bump /
//   bump / norm -> a tangent-space normal map (as Blender reads it) with
//   -bm its scale.  Texture options -o and -s become the texture
//   transform; other options are read past and reported.
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string_view>

#include "core/error.h"
#include "geometry/asset_detail.h"
#include "geometry/mesh_formats.h"

namespace mr::detail {

namespace {

class MtlReader {
 public:
  MtlReader(const fs::path& path, Asset* asset) : path_(path), name_(path.string()), asset_(asset) {}

  // Reads every newmtl of the file into materials, by name.
  void Read(std::map<std::string, AssetMaterial>* materials) {
    const std::string text = ReadTextFile(path_);
    AssetMaterial* m = nullptr;
    size_t start = 0;
    for (int line = 1; start <= text.size(); ++line) {
      size_t end = text.find('\n', start);
      if (end == std::string::npos) end = text.size();
      std::string_view l(text.data() + start, end - start);
      start = end + 1;
      if (const size_t hash = l.find('#'); hash != std::string_view::npos) l = l.substr(0, hash);
      l = Trim(l);
      const std::vector<std::string_view> tok = Tokens(l);
      if (tok.empty()) continue;
      loc_ = FileLoc{name_, line};
      const std::string_view kw = tok[0];
      if (kw == "newmtl") {
        const std::string n = Rest(l, kw);
        if (n.empty()) ThrowErrorAt(loc_, "newmtl without a name");
        m = &(*materials)[n];
        *m = AssetMaterial();
        m->name = n;
        has_pr_ = false;
        m->metallic = 0;                            // MTL's default is a dielectric
        m->base_color.head<3>().setConstant(0.8f);  // Blender's default Kd
        continue;
      }
      if (!m) ThrowErrorAt(loc_, "{} before any newmtl", std::string(kw));
      Keyword(kw, tok, l, m);
    }
    for (auto& [n, mat] : *materials) {
      // MTL multiplies map_Kd by Kd; without a Kd the texture alone (as Blender writes and reads it).
      if (mat.base_color_texture.present() && !has_kd_.count(n)) mat.base_color.head<3>().setOnes();
      CheckMaterial(mat, name_, "material " + n);
    }
    for (const auto& [kw, lines] : ignored_)
      asset_->report.ignored.push_back(fmt::format("{}: {} ({} line{})", name_, kw, lines, lines == 1 ? "" : "s"));
  }

 private:
  void Keyword(std::string_view kw, const std::vector<std::string_view>& tok, std::string_view l, AssetMaterial* m) {
    if (kw == "Kd") {
      m->base_color.head<3>() = Color(tok);
      has_kd_.insert(m->name);
    } else if (kw == "Ks") {
      m->specular_color = Color(tok);
    } else if (kw == "Ke") {
      m->emissive = Color(tok);
    } else if (kw == "Ns") {
      if (!has_pr_) m->roughness = static_cast<float>(1 - std::sqrt(std::clamp(Num(tok, 1), 0.0, 1000.0) / 1000));
    } else if (kw == "Pr") {
      m->roughness = static_cast<float>(Num(tok, 1));
      has_pr_ = true;
    } else if (kw == "Pm") {
      m->metallic = static_cast<float>(Num(tok, 1));
    } else if (kw == "Ni") {
      m->ior = static_cast<float>(std::clamp(Num(tok, 1), 1.0, 10.0));
    } else if (kw == "d") {
      SetAlpha(m, Num(tok, tok.size() > 2 && tok[1] == "-halo" ? 2 : 1));
    } else if (kw == "Tr") {
      SetAlpha(m, 1 - Num(tok, 1));
    } else if (kw == "map_Kd") {
      m->base_color_texture = Texture(l, kw);
    } else if (kw == "map_Bump" || kw == "map_bump" || kw == "bump" || kw == "norm") {
      m->normal_texture = Texture(l, kw, &m->normal_scale);
    } else if (kw == "map_Ke") {
      m->emissive_texture = Texture(l, kw);
      if (m->emissive.maxCoeff() <= 0) m->emissive.setOnes();
    } else if (kw == "map_Pr" || kw == "map_Pm") {
      m->metallic_roughness_texture = Texture(l, kw);
      Ignored(fmt::format("{}: read as glTF's metallic-roughness texture (G roughness, B metallic)", kw));
    } else if (kw == "Ka") {
      Ignored("Ka (ambient colour: the captured light is the ambient)");
    } else if (kw == "illum" || kw == "Tf" || kw == "sharpness" || kw == "map_Ka" || kw == "map_Ks" || kw == "map_Ns" ||
               kw == "map_d" || kw == "disp" || kw == "decal" || kw == "refl" || kw == "Pc" || kw == "Pcr" ||
               kw == "aniso" || kw == "anisor" || kw == "Ps" || kw == "map_Ps") {
      Ignored(std::string(kw));
    } else {
      Ignored(fmt::format("unknown keyword {}", std::string(kw)));
    }
  }

  // What follows the keyword `kw` (a view into `l`), trimmed.
  static std::string Rest(std::string_view l, std::string_view kw) {
    return std::string(Trim(l.substr(static_cast<size_t>(kw.data() - l.data()) + kw.size())));
  }
  double Num(const std::vector<std::string_view>& tok, size_t i) const {
    if (i >= tok.size()) ThrowErrorAt(loc_, "{}: a number is missing", std::string(tok[0]));
    double v = 0;
    const std::string s(tok[i]);
    char* end = nullptr;
    v = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || *end != '\0' || !std::isfinite(v))
      ThrowErrorAt(loc_, "{}: \"{}\" is not a finite number", std::string(tok[0]), s);
    return v;
  }
  Eigen::Vector3f Color(const std::vector<std::string_view>& tok) const {
    if (tok.size() > 1 && (tok[1] == "spectral" || tok[1] == "xyz"))
      ThrowErrorAt(loc_, "{} {}: mr reads RGB colours", std::string(tok[0]), std::string(tok[1]));
    const double r = Num(tok, 1);
    // "Kd r" alone is grey.
    return tok.size() >= 4 ? Eigen::Vector3f(static_cast<float>(r), static_cast<float>(Num(tok, 2)),
                                             static_cast<float>(Num(tok, 3)))
                           : Eigen::Vector3f::Constant(static_cast<float>(r));
  }
  void SetAlpha(AssetMaterial* m, double a) {
    m->base_color[3] = static_cast<float>(std::clamp(a, 0.0, 1.0));
    m->alpha_mode = m->base_color[3] < 1 ? AlphaMode::kBlend : AlphaMode::kOpaque;
  }
  void Ignored(const std::string& what) { ++ignored_[what]; }

  // A map_ statement: options, then the file name (the rest of the line,
  // which may hold spaces).
  AssetTexture Texture(std::string_view l, std::string_view kw, float* bump_scale = nullptr) {
    static const std::map<std::string, int> kArgs = {
        {"-blendu", 1}, {"-blendv", 1}, {"-boost", 1}, {"-cc", 1}, {"-clamp", 1}, {"-imfchan", 1}, {"-mm", 2},
        {"-texres", 1}, {"-type", 1},   {"-bm", 1},    {"-o", 3},  {"-s", 3},     {"-t", 3}};
    const std::string rest = Rest(l, kw);
    const std::vector<std::string_view> tok = Tokens(rest);
    AssetTexture t;
    size_t i = 0;
    while (i < tok.size() && tok[i].size() > 1 && tok[i][0] == '-') {
      const std::string opt(tok[i]);
      auto it = kArgs.find(opt);
      if (it == kArgs.end()) break;  // a file name starting with '-'
      std::vector<double> args;
      ++i;
      for (int k = 0; k < it->second && i < tok.size(); ++k) {
        char* end = nullptr;
        const std::string s(tok[i]);
        const double v = std::strtod(s.c_str(), &end);
        if (end == s.c_str() || *end != '\0') {
          if (k == 0 && opt != "-clamp" && opt != "-blendu" && opt != "-blendv" && opt != "-imfchan" && opt != "-type")
            ThrowErrorAt(loc_, "{} {}: \"{}\" is not a number", std::string(kw), opt, s);
          if (k == 0) ++i;  // on/off or a channel letter
          break;
        }
        args.push_back(v);
        ++i;
      }
      if (opt == "-bm" && bump_scale && !args.empty())
        *bump_scale = static_cast<float>(args[0]);
      else if (opt == "-o" && args.size() >= 2)
        t.offset = Eigen::Vector2f(static_cast<float>(args[0]), static_cast<float>(args[1]));
      else if (opt == "-s" && args.size() >= 2)
        t.scale = Eigen::Vector2f(static_cast<float>(args[0]), static_cast<float>(args[1]));
      else if (opt == "-clamp")
        t.wrap_s = t.wrap_t = TextureWrap::kClamp;
      else
        Ignored(fmt::format("{} option {}", std::string(kw), opt));
    }
    if (i >= tok.size()) ThrowErrorAt(loc_, "{}: no file name", std::string(kw));
    const std::string file(rest.substr(static_cast<size_t>(tok[i].data() - rest.data())));
    fs::path f = file;
    if (f.is_relative()) f = (path_.parent_path() / f).lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(f, ec)) ThrowErrorAt(loc_, "{}: {} does not exist", std::string(kw), f.string());
    for (size_t k = 0; k < asset_->images.size(); ++k)
      if (asset_->images[k].file == f) t.image = static_cast<int>(k);
    if (t.image < 0) {
      asset_->images.push_back({.name = file, .file = f});
      t.image = static_cast<int>(asset_->images.size() - 1);
    }
    return t;
  }

  fs::path path_;
  std::string name_;
  Asset* asset_;
  FileLoc loc_;
  bool has_pr_ = false;
  std::set<std::string> has_kd_;            // materials that give Kd
  std::map<std::string, int64_t> ignored_;  // what was read past -> lines
};

// OBJ's v runs up the image, glTF's (and an asset's) down it.
Eigen::Vector2f UvDown(const Eigen::Vector2f& uv) { return {uv.x(), 1 - uv.y()}; }

// One part per material: the faces of that material, fan-triangulated,
// each distinct (vertex, uv, normal) corner one vertex.
AssetPart BuildPart(const MeshSoup& soup, int material, const std::string& name) {
  AssetPart part;
  part.name = name;
  std::map<std::tuple<int, int, int>, int> index;
  auto vertex = [&](const Eigen::Vector3i& c) {
    auto [it, inserted] = index.try_emplace({c[0], c[1], c[2]}, static_cast<int>(part.mesh.positions.size()));
    if (inserted) {
      part.mesh.positions.push_back(soup.positions[static_cast<size_t>(c[0])]);
      if (!soup.obj_uvs.empty())
        part.mesh.uvs.push_back(c[1] >= 0 ? UvDown(soup.obj_uvs[static_cast<size_t>(c[1])]) : Eigen::Vector2f::Zero());
      if (!soup.obj_normals.empty())
        part.mesh.normals.push_back(c[2] >= 0 ? soup.obj_normals[static_cast<size_t>(c[2])] : Eigen::Vector3f::Zero());
      if (!soup.colors.empty()) part.mesh.colors.push_back(soup.colors[static_cast<size_t>(c[0])]);
    }
    return it->second;
  };
  for (size_t f = 0; f < soup.obj_corners.size(); ++f) {
    if (soup.obj_face_material[f] != material) continue;
    const auto& c = soup.obj_corners[f];
    const int a = vertex(c[0]);
    for (size_t k = 1; k + 1 < c.size(); ++k) part.mesh.triangles.emplace_back(a, vertex(c[k]), vertex(c[k + 1]));
  }
  return part;
}

}  // namespace

Asset ReadObjAsset(const fs::path& path) {
  const std::string name = path.string();
  MeshSoup soup = ParseObj(ReadTextFile(path), name, MeshReadOptions{});
  Asset asset;
  asset.report.format = "obj";
  std::map<std::string, AssetMaterial> library;
  for (const std::string& lib : soup.obj_mtllibs) {
    fs::path f = lib;
    if (f.is_relative()) f = (path.parent_path() / f).lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(f, ec)) ThrowErrorAt(FileLoc{name}, "mtllib {}: {} does not exist", lib, f.string());
    MtlReader(f, &asset).Read(&library);
  }
  // Materials in the order usemtl first names them; a name no MTL defines
  // takes the default material (reported, as Blender does).
  std::vector<int> material_of(soup.obj_materials.size(), -1);
  for (size_t i = 0; i < soup.obj_materials.size(); ++i) {
    auto it = library.find(soup.obj_materials[i]);
    if (it == library.end()) {
      asset.report.ignored.push_back(
          fmt::format("usemtl {}: no such material in the mtllib files (the default material)", soup.obj_materials[i]));
      continue;
    }
    material_of[i] = static_cast<int>(asset.materials.size());
    asset.materials.push_back(it->second);
  }
  std::vector<int> used(soup.obj_materials.size() + 1, 0);
  for (int m : soup.obj_face_material) used[static_cast<size_t>(m + 1)] = 1;
  for (int m = -1; m < static_cast<int>(soup.obj_materials.size()); ++m) {
    if (!used[static_cast<size_t>(m + 1)]) continue;
    AssetPart part =
        BuildPart(soup, m, m < 0 ? std::string("(no usemtl)") : soup.obj_materials[static_cast<size_t>(m)]);
    part.material = m < 0 ? -1 : material_of[static_cast<size_t>(m)];
    asset.parts.push_back(std::move(part));
  }
  if (asset.parts.empty()) ThrowErrorAt(FileLoc{name}, "no faces");
  for (const std::string& n : soup.notes)
    if (n.find("\"usemtl\"") == std::string::npos && n.find("\"mtllib\"") == std::string::npos)
      asset.report.ignored.push_back(n);
  return asset;
}

}  // namespace mr::detail
