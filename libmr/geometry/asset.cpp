#include "geometry/asset.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <Eigen/LU>

#include "core/error.h"
#include "core/image.h"
#include "core/spherical.h"
#include "geometry/asset_detail.h"

namespace mr {

size_t Asset::triangle_count() const {
  size_t n = 0;
  for (const AssetPart& p : parts) n += p.mesh.triangle_count();
  return n;
}

Mesh MergeParts(const Asset& asset, std::vector<int>* triangle_material) {
  Mesh m;
  bool normals = true, uvs = true, colors = true;
  for (const AssetPart& p : asset.parts) {
    normals = normals && !p.mesh.normals.empty();
    uvs = uvs && !p.mesh.uvs.empty();
    colors = colors && !p.mesh.colors.empty();
  }
  if (triangle_material) triangle_material->clear();
  for (const AssetPart& p : asset.parts) {
    const int base = static_cast<int>(m.positions.size());
    m.positions.insert(m.positions.end(), p.mesh.positions.begin(), p.mesh.positions.end());
    if (normals) m.normals.insert(m.normals.end(), p.mesh.normals.begin(), p.mesh.normals.end());
    if (uvs) m.uvs.insert(m.uvs.end(), p.mesh.uvs.begin(), p.mesh.uvs.end());
    if (colors) m.colors.insert(m.colors.end(), p.mesh.colors.begin(), p.mesh.colors.end());
    for (const Eigen::Vector3i& t : p.mesh.triangles) m.triangles.push_back(t + Eigen::Vector3i::Constant(base));
    if (triangle_material) triangle_material->insert(triangle_material->end(), p.mesh.triangles.size(), p.material);
  }
  return m;
}

std::vector<Eigen::Vector4f> AssetTangents(const Asset& asset, const Mesh& merged) {
  const size_t n = merged.positions.size();
  if (merged.normals.size() != n || merged.uvs.size() != n) return {};
  std::vector<Eigen::Vector4f> out;
  if (std::all_of(asset.parts.begin(), asset.parts.end(),
                  [](const AssetPart& p) { return p.tangents.size() == p.mesh.positions.size(); })) {
    for (const AssetPart& p : asset.parts) out.insert(out.end(), p.tangents.begin(), p.tangents.end());
    if (out.size() == n) return out;
    out.clear();
  }
  std::vector<Eigen::Vector3d> t(n, Eigen::Vector3d::Zero()), b(n, Eigen::Vector3d::Zero());
  for (const Eigen::Vector3i& tri : merged.triangles) {
    const auto P = [&](int k) { return merged.positions[static_cast<size_t>(tri[k])].cast<double>(); };
    const auto U = [&](int k) { return merged.uvs[static_cast<size_t>(tri[k])].cast<double>(); };
    const Eigen::Vector3d e1 = P(1) - P(0), e2 = P(2) - P(0);
    const Eigen::Vector2d d1 = U(1) - U(0), d2 = U(2) - U(0);
    const double det = d1.x() * d2.y() - d2.x() * d1.y();
    if (!(std::abs(det) > 0)) continue;
    const Eigen::Vector3d dpdu = (d2.y() * e1 - d1.y() * e2) / det, dpdv = (d1.x() * e2 - d2.x() * e1) / det;
    if (!dpdu.allFinite() || !dpdv.allFinite()) continue;
    for (int k = 0; k < 3; ++k) {
      t[static_cast<size_t>(tri[k])] += dpdu;
      b[static_cast<size_t>(tri[k])] -= dpdv;  // glTF's v runs down the image; "up" is -v
    }
  }
  out.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d nn = merged.normals[i].cast<double>().normalized();
    Eigen::Vector3d tt = t[i] - nn * nn.dot(t[i]);
    if (!(tt.norm() > 1e-12 * (t[i].norm() + 1e-300)) || !tt.allFinite()) {
      Eigen::Vector3d bb;
      CoordinateSystem(nn, &tt, &bb);  // no uv derivative here: any frame
    }
    tt.normalize();
    const float w = nn.cross(tt).dot(b[i]) < 0 ? -1.0f : 1.0f;
    out[i] << tt.cast<float>(), w;
  }
  return out;
}

bool IsAssetFile(const fs::path& path) {
  const std::string e = LowerExtension(path);
  return e == ".gltf" || e == ".glb";
}

const std::vector<std::string>& SupportedGltfExtensions() {
  static const std::vector<std::string> e = {
      "KHR_materials_emissive_strength", "KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
      "KHR_texture_transform",           "KHR_mesh_quantization"};
  return e;
}

Asset ReadAsset(const fs::path& path) {
  const std::string e = LowerExtension(path);
  if (e == ".gltf" || e == ".glb") return detail::ReadGltf(path);
  if (e == ".obj") return detail::ReadObjAsset(path);
  ThrowErrorAt(FileLoc{path.string()}, "not an asset mr reads (.gltf, .glb, .obj)");
}

namespace detail {

void TransformPart(const Eigen::Matrix4d& world, AssetPart* part) {
  const Eigen::Matrix3d m = world.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = world.topRightCorner<3, 1>();
  const double det = m.determinant();
  const Eigen::Matrix3d normal_m = std::abs(det) > 0 ? Eigen::Matrix3d(m.inverse().transpose()) : m;
  for (auto& p : part->mesh.positions) p = (m * p.cast<double>() + t).cast<float>();
  for (auto& n : part->mesh.normals) {
    const Eigen::Vector3d v = normal_m * n.cast<double>();
    n = v.norm() > 0 ? Eigen::Vector3f((v / v.norm()).cast<float>()) : Eigen::Vector3f::Zero();
  }
  for (auto& tg : part->tangents) {
    const Eigen::Vector3d v = m * tg.head<3>().cast<double>();
    tg.head<3>() = v.norm() > 0 ? Eigen::Vector3f((v / v.norm()).cast<float>()) : Eigen::Vector3f::Zero();
    if (det < 0) tg[3] = -tg[3];
  }
  if (det < 0)
    for (auto& tri : part->mesh.triangles) std::swap(tri[1], tri[2]);
}

void CheckMaterial(const AssetMaterial& m, const std::string& file, const std::string& what) {
  auto in = [&](const char* key, double v, double lo, double hi) {
    if (!(v >= lo && v <= hi))
      ThrowErrorAt(FileLoc{file}, "{}: {} is {}, expected a number in [{}, {}]", what, key, v, lo, hi);
  };
  for (int c = 0; c < 4; ++c) in("base colour", m.base_color[c], 0, 1);
  in("metallic", m.metallic, 0, 1);
  in("roughness", m.roughness, 0, 1);
  in("transmission", m.transmission, 0, 1);
  for (int c = 0; c < 3; ++c) in("emission", m.emissive[c], 0, 1e30);
  in("emissive strength", m.emissive_strength, 0, 1e30);
  in("ior", m.ior, 1, 10);
  in("thickness", m.thickness, 0, 1e30);
  in("attenuation distance", m.attenuation_distance, 0, 1e30);
  for (int c = 0; c < 3; ++c) in("attenuation colour", m.attenuation_color[c], 0, 1);
  for (int c = 0; c < 3; ++c) in("specular colour", m.specular_color[c], 0, 1e3);
  in("normal scale", m.normal_scale, -1e3, 1e3);
  in("alpha cutoff", m.alpha_cutoff, 0, 1e30);
}

}  // namespace detail

namespace {

uint32_t BigEndian(const uint8_t* p, int n) {
  uint32_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | p[i];
  return v;
}

// An embedded PNG's or JPEG's size from its header (IHDR; a JPEG's first
// start-of-frame marker); false for other formats or a short header.
bool EncodedImageSize(const std::vector<uint8_t>& b, int* w, int* h) {
  if (b.size() >= 24 && std::memcmp(b.data(), "\x89PNG\r\n\x1a\n", 8) == 0) {
    *w = static_cast<int>(BigEndian(&b[16], 4));
    *h = static_cast<int>(BigEndian(&b[20], 4));
    return true;
  }
  if (b.size() < 4 || b[0] != 0xFF || b[1] != 0xD8) return false;
  for (size_t i = 2; i + 9 < b.size();) {
    if (b[i] != 0xFF) return false;
    const uint8_t marker = b[i + 1];
    const size_t len = BigEndian(&b[i + 2], 2);
    if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
      *h = static_cast<int>(BigEndian(&b[i + 5], 2));
      *w = static_cast<int>(BigEndian(&b[i + 7], 2));
      return true;
    }
    i += 2 + len;
  }
  return false;
}

std::string ImageLine(const AssetImage& im) {
  int w = 0, h = 0;
  std::string size = "size unknown";
  if (im.bytes.empty() && !im.file.empty()) {
    std::vector<std::string> channels;
    try {
      ReadImageHeader(im.file, &w, &h, &channels);
      size = fmt::format("{} x {}, {} channels", w, h, channels.size());
    } catch (const Error& e) {
      size = e.what();
    }
  } else if (EncodedImageSize(im.bytes, &w, &h)) {
    size = fmt::format("{} x {}", w, h);
  }
  return fmt::format("  {}: {} ({})", im.name, size,
                     im.file.empty() ? fmt::format("{} bytes in the asset", im.bytes.size()) : im.file.string());
}

}  // namespace

std::vector<std::string> DescribeAsset(const Asset& a) {
  std::vector<std::string> s;
  if (a.report.nodes)
    s.push_back(
        fmt::format("nodes: {} ({} meshes, {} primitives)", a.report.nodes, a.report.meshes, a.report.primitives));
  size_t verts = 0;
  for (const AssetPart& p : a.parts) verts += p.mesh.vertex_count();
  s.push_back(fmt::format("parts: {} ({} triangles, {} vertices)", a.parts.size(), a.triangle_count(), verts));
  for (const AssetPart& p : a.parts) {
    std::string attrs;
    if (!p.mesh.normals.empty()) attrs += " normals";
    if (!p.mesh.uvs.empty()) attrs += " uv0";
    if (!p.uvs1.empty()) attrs += " uv1";
    if (!p.tangents.empty()) attrs += " tangents";
    if (!p.mesh.colors.empty()) attrs += " colours";
    s.push_back(
        fmt::format("  {}: {} triangles, material {}{}{}", p.name, p.mesh.triangle_count(),
                    p.material < 0 ? std::string("(default)") : a.materials[static_cast<size_t>(p.material)].name,
                    attrs.empty() ? "" : ";", attrs));
  }
  s.push_back(fmt::format("materials: {}", a.materials.size()));
  auto tex = [&](const char* what, const AssetTexture& t) {
    return t.present() ? fmt::format(" {}={}", what, a.images[static_cast<size_t>(t.image)].name) : std::string();
  };
  for (const AssetMaterial& m : a.materials) {
    std::string l =
        fmt::format("  {}: base [{:.3g} {:.3g} {:.3g} {:.3g}] metallic {:.3g} roughness {:.3g}", m.name,
                    m.base_color[0], m.base_color[1], m.base_color[2], m.base_color[3], m.metallic, m.roughness);
    if (m.transmission > 0) {
      l += fmt::format(" transmission {:.3g} ior {:.3g}", m.transmission, m.ior);
      l += m.thickness > 0 ? fmt::format(" solid (thickness {:.3g})", m.thickness) : std::string(" thin-walled");
      if (m.attenuation_distance > 0)
        l += fmt::format(" attenuation [{:.3g} {:.3g} {:.3g}] at {:.3g}", m.attenuation_color[0],
                         m.attenuation_color[1], m.attenuation_color[2], m.attenuation_distance);
    }
    if (m.emissive.maxCoeff() > 0) l += fmt::format(" emissive x{:.3g}", m.emissive_strength);
    if (m.alpha_mode != AlphaMode::kOpaque) l += m.alpha_mode == AlphaMode::kMask ? " alpha-mask" : " alpha-blend";
    l += tex("base", m.base_color_texture) + tex("metal-rough", m.metallic_roughness_texture) +
         tex("normal", m.normal_texture) + tex("emissive", m.emissive_texture) +
         tex("transmission", m.transmission_texture);
    s.push_back(l);
  }
  s.push_back(fmt::format("images: {}", a.images.size()));
  for (const AssetImage& im : a.images) s.push_back(ImageLine(im));
  if (!a.report.extensions_used.empty())
    s.push_back(fmt::format("extensions: {} (required: {})", fmt::join(a.report.extensions_used, ", "),
                            a.report.extensions_required.empty()
                                ? std::string("none")
                                : fmt::format("{}", fmt::join(a.report.extensions_required, ", "))));
  for (const std::string& i : a.report.ignored) s.push_back("ignored: " + i);
  return s;
}

}  // namespace mr
