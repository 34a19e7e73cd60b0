#include "render/render_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <type_traits>

#include <Eigen/SVD>

#include "core/error.h"
#include "core/file.h"
#include "core/hash.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/video.h"
#include "render/texture.h"
#include "scene/frames.h"

namespace mr {

RenderScene::RenderScene() : embree_(std::make_unique<EmbreeScene>()) {}

uint32_t RenderScene::AddReal(const Mesh& mesh, const Material& material) {
  uint32_t id = embree_->AddMesh(mesh, /*is_virtual=*/false);
  closed_.Add(mesh);
  geometry_bounds_.push_back(mesh.Bounds().cast<double>());
  SetSurface(id, material, Eigen::Matrix3d::Identity(), mesh);
  has_glossy_real_ = has_glossy_real_ || material.IsGlossy();
  return id;
}

namespace {

bool Collapses(const Eigen::Affine3d& t) { return !(std::abs(t.linear().determinant()) >= 1e-18); }

}  // namespace

uint32_t RenderScene::AddVirtual(const Mesh& mesh, const Eigen::Affine3d& world_from_object, const Material& material) {
  uint32_t proto = embree_->AddPrototype(mesh);
  uint32_t id = embree_->AddInstance(proto, Eigen::Affine3f::Identity());
  virtual_prototypes_.push_back(proto);
  geometry_bounds_.emplace_back();
  virtual_bounds_.emplace_back();
  virtual_ids_.push_back(id);
  virtual_object_bounds_.push_back(mesh.Bounds().cast<double>());
  double far2 = 0;
  const Eigen::Vector3d centre = virtual_object_bounds_.back().center();
  for (const Eigen::Vector3f& q : mesh.positions) far2 = std::max(far2, (q.cast<double>() - centre).squaredNorm());
  virtual_object_radii_.push_back(std::sqrt(far2));
  virtual_spheres_.emplace_back(0, 0, 0, -1);
  virtual_hidden_.push_back(0);
  virtual_poses_.push_back(world_from_object);
  virtual_positions_.push_back(mesh.positions);
  std::vector<std::pair<int, int>> edges;
  for (const Eigen::Vector3i& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) edges.emplace_back(std::minmax(t[k], t[(k + 1) % 3]));
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  virtual_edges_.push_back(std::move(edges));
  SetSurface(id, material, Eigen::Matrix3d::Identity(), mesh);
  SetVirtualTransform(virtual_ids_.size() - 1, world_from_object);
  return id;
}

void RenderScene::SetVirtualTransform(size_t i, const Eigen::Affine3d& world_from_object) {
  const uint32_t id = virtual_ids_.at(i);
  if (!world_from_object.matrix().allFinite()) ThrowError("virtual object transform has NaN or Inf");
  const bool hidden = Collapses(world_from_object);
  embree_->SetInstanceTransform(id, world_from_object.cast<float>());
  virtual_hidden_[i] = hidden;
  virtual_poses_[i] = world_from_object;
  Eigen::AlignedBox3d wb;  // empty while hidden
  if (!hidden) {
    const Eigen::AlignedBox3d& ob = virtual_object_bounds_[i];
    for (int k = 0; k < 8; ++k)
      wb.extend(world_from_object * ob.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)));
    surfaces_[id].normal_to_world = world_from_object.linear().inverse().transpose();
    surfaces_[id].linear = world_from_object.linear();
  }
  geometry_bounds_[id] = wb;
  virtual_bounds_[i] = wb;
  virtual_spheres_[i] = Eigen::Vector4d(0, 0, 0, -1);
  if (!hidden) {
    // |L x| <= sigma_max |x|; the world box's centre is the object box's, placed.
    const double stretch = Eigen::JacobiSVD<Eigen::Matrix3d>(world_from_object.linear()).singularValues()[0];
    const double r = std::min(virtual_object_radii_[i] * stretch, 0.5 * wb.diagonal().norm());
    virtual_spheres_[i] << wb.center(), r * (1 + 1e-6) + 1e-9;
  }
  has_virtual_geometry_ = std::count(virtual_hidden_.begin(), virtual_hidden_.end(), 0) > 0;
  has_virtual_ = has_virtual_geometry_ ||
                 std::any_of(lights_.begin(), lights_.end(), [](const LightSource& l) { return l.is_virtual(); });
}

void RenderScene::SetSurface(uint32_t id, const Material& material, const Eigen::Matrix3d& normal_to_world,
                             const Mesh& mesh) {
  if (surfaces_.size() <= id)
    surfaces_.resize(id + 1, Surface{Material(), Bsdf(Material()), Eigen::Matrix3d::Identity()});
  Material d = material, g = material;
  d.specular.setZero();
  g.albedo.setZero();
  surfaces_[id] = Surface{material, Bsdf(material), normal_to_world, Bsdf(d), Bsdf(g), {}, {}, {}, {}, nullptr};
  if (material.normals == Material::Normals::kVertex) {
    if (mesh.normals.size() != mesh.positions.size())
      ThrowError("material.normals is \"vertex\" but the mesh has no vertex normals");
    surfaces_[id].normals = mesh.normals;
    surfaces_[id].positions = mesh.positions;
    surfaces_[id].triangles = mesh.triangles;
  }
  if (material.albedo_from_vertex_colors) {
    if (mesh.colors.size() != mesh.positions.size())
      ThrowError("material.albedo_from_vertex_colors is set but the mesh has no vertex colours");
    surfaces_[id].vertex_albedo = mesh.colors;
    surfaces_[id].triangles = mesh.triangles;
  }
  if (!material.albedo_texture.empty()) {
    if (mesh.uvs.size() != mesh.positions.size())
      ThrowError("material.albedo_texture is set but the mesh has no texture coordinates");
    surfaces_[id].texture = ReadAlbedoTexture(material.albedo_texture);
    surfaces_[id].uvs = mesh.uvs;
    surfaces_[id].triangles = mesh.triangles;
  }
  has_glossy_ = has_glossy_ || material.IsGlossy();
}

struct RenderScene::AssetShading {
  std::vector<int> triangle_material;  // by primitive id; -1: glTF's default material
  std::vector<AssetMaterial> materials;
  std::vector<std::shared_ptr<const Texture>> textures;  // by image; null where no material samples it
  std::vector<Eigen::Vector2f> uvs;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<Eigen::Vector4f> tangents;  // with a normal texture: per vertex (AssetTangents)
  const AssetMaterial& MaterialOf(uint32_t primitive) const;
  Eigen::Vector2f UvAt(uint32_t primitive, float u, float v) const;
  Eigen::Vector2f UvAt(const Hit& hit) const { return UvAt(hit.primitive_id, hit.uv.x(), hit.uv.y()); }
  bool Accepts(uint32_t primitive, float u, float v, uint64_t ray_key) const;
  std::vector<float> uv_density;  // by triangle: sqrt(uv area / object area)
  // `footprint` in uv units (0: level 0); KHR_texture_transform's scale
  // scales it with the uvs.
  Eigen::Vector4f Sample(const AssetTexture& t, const Eigen::Vector2f& uv, float footprint = 0) const {
    return textures[static_cast<size_t>(t.image)]->Sample(TransformUv(t, uv), footprint * t.scale.cwiseAbs().maxCoeff(),
                                                          t.wrap_s, t.wrap_t);
  }
  // A world footprint on triangle `primitive` in uv units; `world_scale`:
  // the placement's linear scale.
  float UvFootprint(uint32_t primitive, double footprint, double world_scale) const {
    if (!(footprint > 0) || uv_density.empty()) return 0;
    return static_cast<float>(footprint / world_scale * uv_density[std::min<size_t>(primitive, uv_density.size() - 1)]);
  }
};

const AssetMaterial& RenderScene::AssetShading::MaterialOf(uint32_t primitive) const {
  static const AssetMaterial kDefault = [] {  // glTF 2.0, 3.9.6: the default material
    AssetMaterial m;
    m.metallic = 1;
    m.roughness = 1;
    return m;
  }();
  const int mi = triangle_material[std::min<size_t>(primitive, triangle_material.size() - 1)];
  return mi >= 0 ? materials[static_cast<size_t>(mi)] : kDefault;
}

Eigen::Vector2f RenderScene::AssetShading::UvAt(uint32_t primitive, float u, float v) const {
  const Eigen::Vector3i& t = triangles[std::min<size_t>(primitive, triangles.size() - 1)];
  return (1 - u - v) * uvs[static_cast<size_t>(t[0])] + u * uvs[static_cast<size_t>(t[1])] +
         v * uvs[static_cast<size_t>(t[2])];
}

// glTF 2.0, 3.9.4: alpha is the base colour's, factor times texture; MASK
// renders where alpha >= alphaCutoff, BLEND covers alpha of the pixel
// (here: a ray passes with probability 1 - alpha, from its key).
bool RenderScene::AssetShading::Accepts(uint32_t primitive, float u, float v, uint64_t ray_key) const {
  const AssetMaterial& m = MaterialOf(primitive);
  if (m.alpha_mode == AlphaMode::kOpaque) return true;
  float alpha = m.base_color[3];
  if (m.base_color_texture.present() && !uvs.empty()) alpha *= Sample(m.base_color_texture, UvAt(primitive, u, v))[3];
  if (m.alpha_mode == AlphaMode::kMask) return alpha >= m.alpha_cutoff;
  uint64_t h = (ray_key ^ (0x9E3779B97F4A7C15ull * (primitive + 1))) * 0xBF58476D1CE4E5B9ull;
  h ^= h >> 31;
  return static_cast<float>(h >> 40) * (1.0f / 16777216.0f) < alpha;
}

void RenderScene::SetAssetMaterials(uint32_t id, const Asset& asset, std::vector<int> triangle_material,
                                    const Mesh& mesh, const std::string& name) {
  MR_CHECK(triangle_material.size() == mesh.triangles.size());
  // PbrBsdf's tables built here, on the loading thread: their build is a
  // parallel loop, which inside a render's own parallel loop could steal a
  // task that waits on the same static (TBB has no isolation there).
  GetPbrTables();
  auto a = std::make_shared<AssetShading>();
  a->triangle_material = std::move(triangle_material);
  a->materials = asset.materials;
  a->textures.resize(asset.images.size());
  // The images the materials sample, each once (with the encoding of its
  // first use), then decoded in parallel: an asset's textures are most of
  // its load (nine 4k PNGs: 0.6 s of decoding and 0.3 s of mip-maps each).
  std::vector<std::pair<int, TextureEncoding>> wanted;
  auto load = [&](const AssetTexture& t, TextureEncoding e) {
    if (!t.present()) return;
    if (mesh.uvs.size() != mesh.positions.size())
      ThrowErrorAt(FileLoc{name}, "a material samples {} but the asset has no texture coordinates",
                   asset.images[static_cast<size_t>(t.image)].name);
    if (std::none_of(wanted.begin(), wanted.end(), [&](const auto& w) { return w.first == t.image; }))
      wanted.emplace_back(t.image, e);
  };
  bool normal_maps = false;
  for (const AssetMaterial& m : asset.materials) {
    load(m.base_color_texture, TextureEncoding::kSrgb);
    load(m.metallic_roughness_texture, TextureEncoding::kLinear);
    if (!mesh.normals.empty()) load(m.normal_texture, TextureEncoding::kLinear);
    if (m.transmission > 0) load(m.transmission_texture, TextureEncoding::kLinear);
    if (m.emissive.maxCoeff() > 0) load(m.emissive_texture, TextureEncoding::kSrgb);
    normal_maps = normal_maps || (m.normal_texture.present() && !mesh.normals.empty());
  }
  ParallelFor(0, static_cast<int64_t>(wanted.size()), [&](int64_t i) {
    const auto [image, e] = wanted[static_cast<size_t>(i)];
    a->textures[static_cast<size_t>(image)] =
        std::make_shared<const Texture>(LoadAssetTexture(asset.images[static_cast<size_t>(image)], e, name));
  });
  a->uvs = mesh.uvs;
  a->triangles = mesh.triangles;
  if (!mesh.uvs.empty()) {
    a->uv_density.reserve(mesh.triangles.size());
    for (const Eigen::Vector3i& t : mesh.triangles) {
      const auto P = [&](int k) { return mesh.positions[static_cast<size_t>(t[k])].cast<double>(); };
      const auto U = [&](int k) { return mesh.uvs[static_cast<size_t>(t[k])].cast<double>(); };
      const double area = (P(1) - P(0)).cross(P(2) - P(0)).norm();
      const Eigen::Vector2d e1 = U(1) - U(0), e2 = U(2) - U(0);
      const double uv_area = std::abs(e1.x() * e2.y() - e1.y() * e2.x());
      const double d = area > 0 ? std::sqrt(uv_area / area) : 0.0;
      a->uv_density.push_back(std::isfinite(d) ? static_cast<float>(d) : 0.0f);
    }
  }
  if (normal_maps) a->tangents = AssetTangents(asset, mesh);
  Surface& s = surfaces_.at(id);
  if (!mesh.normals.empty()) {  // glTF: flat normals only where the asset gives none
    s.normals = mesh.normals;
    s.positions = mesh.positions;
    s.triangles = mesh.triangles;
  }
  const bool cut = std::any_of(asset.materials.begin(), asset.materials.end(),
                               [](const AssetMaterial& m) { return m.alpha_mode != AlphaMode::kOpaque; });
  const auto vi = std::find(virtual_ids_.begin(), virtual_ids_.end(), id);
  if (cut && vi != virtual_ids_.end()) {
    std::shared_ptr<const AssetShading> shading = a;
    embree_->SetPrototypeFilter(
        virtual_prototypes_[static_cast<size_t>(vi - virtual_ids_.begin())],
        [shading](uint32_t prim, float u, float v, uint64_t key) { return shading->Accepts(prim, u, v, key); });
  }
  s.asset = std::move(a);
  has_glossy_ = true;
}

int64_t RenderScene::asset_textures(uint32_t id) const {
  const auto& a = surfaces_.at(id).asset;
  return a ? std::count_if(a->textures.begin(), a->textures.end(), [](const auto& t) { return t != nullptr; }) : 0;
}

int64_t RenderScene::asset_texture_bytes(uint32_t id) const {
  int64_t b = 0;
  if (const auto& a = surfaces_.at(id).asset)
    for (const auto& t : a->textures)
      if (t) b += static_cast<int64_t>(t->bytes());
  return b;
}

namespace {

// glTF 2.0 appendix B with KHR_materials_transmission: the metal at weight
// m, the dielectric's transmission at T (1 - m), its diffuse base at
// (1 - m)(1 - T) (the dielectric coat over both).
struct AssetLobeWeights {
  double metal, glass, diffuse;
};
AssetLobeWeights LobeWeights(double metallic, double transmission) {
  const double m = std::clamp(metallic, 0.0, 1.0), t = std::clamp(transmission, 0.0, 1.0);
  return {m, t * (1 - m), (1 - m) * (1 - t)};
}

}  // namespace

Eigen::Vector3d RenderScene::AssetEmissionAt(const Hit& hit, double footprint) const {
  const AssetShading* a = surfaces_.at(hit.geometry_id).asset.get();
  if (!a) return Eigen::Vector3d::Zero();
  const AssetMaterial& m = a->MaterialOf(hit.primitive_id);
  if (!(m.emissive.maxCoeff() > 0) || !(m.emissive_strength > 0)) return Eigen::Vector3d::Zero();
  Eigen::Vector3d e = m.emissive.cast<double>() * m.emissive_strength;
  if (m.emissive_texture.present() && !a->uvs.empty())
    e = e.cwiseProduct(a->Sample(m.emissive_texture, a->UvAt(hit),
                                 a->UvFootprint(hit.primitive_id, footprint, WorldScale(hit.geometry_id)))
                           .head<3>()
                           .cast<double>());
  return e.cwiseMax(0.0);
}

Eigen::Vector3d RenderScene::AssetAbsorption(const Hit& hit) const {
  const AssetShading* a = surfaces_.at(hit.geometry_id).asset.get();
  if (!a) return Eigen::Vector3d::Zero();
  const AssetMaterial& m = a->MaterialOf(hit.primitive_id);
  if (m.transmission <= 0 || m.thickness <= 0 || m.attenuation_distance <= 0) return Eigen::Vector3d::Zero();
  Eigen::Vector3d sigma;
  for (int c = 0; c < 3; ++c)
    sigma[c] = -std::log(std::clamp(static_cast<double>(m.attenuation_color[c]), 1e-30, 1.0)) / m.attenuation_distance;
  return sigma;
}

double RenderScene::WorldScale(uint32_t id) const {
  const double det = std::abs(surfaces_.at(id).linear.determinant());
  return det > 0 ? std::cbrt(det) : 1.0;
}

Bsdf RenderScene::AssetBsdfAt(const Hit& hit, bool inside, double footprint, Eigen::Vector3d* diffuse_albedo) const {
  const AssetShading& a = *surfaces_.at(hit.geometry_id).asset;
  const AssetMaterial& m = a.MaterialOf(hit.primitive_id);
  Eigen::Vector4f base = m.base_color;
  float metallic = m.metallic, roughness = m.roughness, transmission = m.transmission;
  if (!a.uvs.empty()) {
    const Eigen::Vector2f uv = a.UvAt(hit);
    const float w = a.UvFootprint(hit.primitive_id, footprint, WorldScale(hit.geometry_id));
    if (m.transmission_texture.present() && transmission > 0)
      transmission *= a.Sample(m.transmission_texture, uv, w)[0];
    if (m.base_color_texture.present()) base = base.cwiseProduct(a.Sample(m.base_color_texture, uv, w));
    if (m.metallic_roughness_texture.present()) {
      const Eigen::Vector4f mr = a.Sample(m.metallic_roughness_texture, uv, w);
      roughness *= mr[1];
      metallic *= mr[2];
    }
  }
  const PbrParams p{.base_color = base.head<3>().cast<double>(),
                    .metallic = metallic,
                    .roughness = roughness,
                    .ior = m.ior,
                    .specular_color = m.specular_color.cast<double>()};
  const AssetLobeWeights w = LobeWeights(p.metallic, transmission);
  *diffuse_albedo = p.base_color * w.diffuse;
  if (!(w.glass > 0)) return Bsdf(PbrBsdf(p));
  // glTF: without KHR_materials_volume's thickness the surface is a thin wall.
  const bool thin = !(m.thickness > 0);
  const double ior = std::clamp(static_cast<double>(m.ior), 1.0, 3.0);
  const GlassParams g{.alpha = Square(std::clamp(p.roughness, 0.0, 1.0)),
                      .eta = thin || !inside ? ior : 1 / ior,
                      .thin = thin,
                      .tint = p.base_color};
  // The opaque part (weight 1 - glass) keeps the metal at weight m overall:
  // its own metallic is m / (1 - glass).
  PbrParams opaque = p;
  opaque.metallic = w.glass < 1 ? std::clamp(w.metal / (1 - w.glass), 0.0, 1.0) : 0.0;
  return Bsdf(PbrBsdf(opaque), GlassBsdf(g), w.glass);
}

Eigen::Vector3d RenderScene::AlbedoAt(const Hit& hit) const {
  const Surface& s = surfaces_[hit.geometry_id];
  if ((s.vertex_albedo.empty() && s.texture.width() == 0) || hit.primitive_id >= s.triangles.size())
    return s.material.albedo;
  const Eigen::Vector3i& t = s.triangles[hit.primitive_id];
  const double u = hit.uv.x(), v = hit.uv.y();
  // A concrete return type: an Eigen expression would refer to at()'s
  // temporaries after they are gone.
  auto lerp = [&](const auto& at) -> std::decay_t<decltype(at(0))> {
    return (1 - u - v) * at(t[0]) + u * at(t[1]) + v * at(t[2]);
  };
  Eigen::Vector3d a;
  if (!s.vertex_albedo.empty()) {
    a = lerp([&](int i) -> Eigen::Vector3d { return s.vertex_albedo[static_cast<size_t>(i)].cast<double>(); });
  } else {
    const Eigen::Vector2d st =
        lerp([&](int i) -> Eigen::Vector2d { return s.uvs[static_cast<size_t>(i)].cast<double>(); });
    a = SampleTexture(s.texture, st);
  }
  const Eigen::Vector3d hi = (Eigen::Vector3d::Ones() - s.material.specular).cwiseMax(0.0);
  return a.cwiseMax(0.0).cwiseMin(hi);
}

Image ReadAlbedoTexture(const fs::path& path) {
  const Image tex = ReadImage(path);
  const int r = tex.ChannelIndex("R"), g = tex.ChannelIndex("G"), b = tex.ChannelIndex("B");
  const int y = tex.ChannelIndex("Y");
  const bool rgb = r >= 0 && g >= 0 && b >= 0;
  if (!rgb && y < 0) ThrowErrorAt(FileLoc{path.string()}, "an albedo texture needs R, G, B or Y channels");
  Image out = Image::Rgb(tex.width(), tex.height());
  for (int yy = 0; yy < tex.height(); ++yy)
    for (int x = 0; x < tex.width(); ++x)
      for (int c = 0; c < 3; ++c) out.at(x, yy, c) = tex.at(x, yy, rgb ? (c == 0 ? r : c == 1 ? g : b) : y);
  return out;
}

Eigen::Vector3d RenderScene::SampleTexture(const Image& tex, const Eigen::Vector2d& uv) {
  // Texel centres at (i + 0.5) / W; v = 0 is the bottom row; repeating.
  const int W = tex.width(), H = tex.height();
  const double x = uv.x() * W - 0.5, y = (1.0 - uv.y()) * H - 0.5;
  if (!std::isfinite(x) || !std::isfinite(y)) return Eigen::Vector3d::Zero();
  const double fx = std::floor(x), fy = std::floor(y);
  const double ax = x - fx, ay = y - fy;
  auto wrap = [](double i, int n) {
    const double m = std::fmod(i, static_cast<double>(n));
    return static_cast<int>(m < 0 ? m + n : m);
  };
  const int x0 = wrap(fx, W), x1 = wrap(fx + 1, W), y0 = wrap(fy, H), y1 = wrap(fy + 1, H);
  Eigen::Vector3d out;
  for (int c = 0; c < 3; ++c)
    out[c] = (1 - ay) * ((1 - ax) * tex.at(x0, y0, c) + ax * tex.at(x1, y0, c)) +
             ay * ((1 - ax) * tex.at(x0, y1, c) + ax * tex.at(x1, y1, c));
  return out;
}

Bsdf RenderScene::BsdfWith(uint32_t id, const Eigen::Vector3d& albedo) const {
  Material m = surfaces_.at(id).material;
  m.albedo = albedo;
  return Bsdf(m);
}

Bsdf RenderScene::DiffuseBsdfWith(uint32_t id, const Eigen::Vector3d& albedo) const {
  Material m = surfaces_.at(id).material;
  m.albedo = albedo;
  m.specular.setZero();
  return Bsdf(m);
}

namespace {

// A local light's power (luminance) for the pick; 0 for distant lights.
double LocalPower(const Light& l) {
  switch (l.type) {
    case LightType::kPoint:
      return Luminance(l.intensity) * kFourPi;
    case LightType::kSpot:
      return Luminance(l.intensity) * kTwoPi * (1 - std::cos(l.cone_deg * kDegToRad));
    case LightType::kArea:
      return Luminance(l.radiance) * kPi * l.Area();
    case LightType::kDistant:
      return 0;
  }
  return 0;
}

}  // namespace

struct RenderScene::AreaLightBvh {
  EmbreeScene shapes;              // rects as two triangles, discs as circumscribed 32-gons
  std::vector<uint32_t> light_of;  // by triangle
};

namespace {

// The area light's outline as triangles appended to `m`; a disc's 32-gon
// circumscribes it, so that every hit on the disc is a candidate.
void AppendAreaShape(const Light& l, Mesh* m) {
  Eigen::Vector3d t = l.axis - l.axis.dot(l.direction) * l.direction;
  t = t.norm() > 1e-12 ? Eigen::Vector3d(t.normalized()) : Eigen::Vector3d(l.direction.unitOrthogonal());
  const Eigen::Vector3d b = l.direction.cross(t);
  std::vector<Eigen::Vector3d> ring;
  if (l.shape == AreaShape::kRect) {
    const double w = 0.5 * l.width, h = 0.5 * l.height;
    ring = {-w * t - h * b, w * t - h * b, w * t + h * b, -w * t + h * b};
  } else {
    const int n = 32;
    const double r = 0.5 * l.width / std::cos(kPi / n) * (1 + 1e-6);
    for (int k = 0; k < n; ++k) ring.push_back(r * (std::cos(kTwoPi * k / n) * t + std::sin(kTwoPi * k / n) * b));
  }
  const int base = static_cast<int>(m->positions.size());
  m->positions.push_back(l.position.cast<float>());
  for (const auto& q : ring) m->positions.push_back((l.position + q).cast<float>());
  const int n = static_cast<int>(ring.size());
  for (int k = 0; k < n; ++k) m->triangles.emplace_back(base, base + 1 + k, base + 1 + (k + 1) % n);
}

}  // namespace

size_t RenderScene::NearestAreaLight(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max, unsigned which,
                                     double* t, Eigen::Vector3d* radiance) const {
  auto wanted = [&](const LightSource& l) { return (which & (l.is_virtual() ? 2u : 1u)) != 0; };
  size_t met = lights_.size();
  double nearest = t_max, tt = 0;
  if (!area_bvh_) {
    for (size_t i = 0; i < lights_.size(); ++i) {
      if (!wanted(lights_[i])) continue;
      const Eigen::Vector3d le = lights_[i].HitArea(o, d, nearest, &tt);
      if (le.maxCoeff() > 0) {
        *radiance = le;  // the nearest one met hides those behind it
        nearest = tt;
        met = i;
      }
    }
  } else {
    Ray ray;
    ray.origin = o.cast<float>();
    ray.direction = d.cast<float>();
    ray.tfar = static_cast<float>(std::min(t_max, 1e30));
    ray.mask = kMaskAll;
    for (int guard = 0; guard < 64; ++guard) {  // candidates, nearest first
      Hit hit;
      if (!area_bvh_->shapes.Intersect(ray, &hit)) break;
      const size_t i = area_bvh_->light_of.at(hit.primitive_id);
      if (wanted(lights_[i])) {
        const Eigen::Vector3d le = lights_[i].HitArea(o, d, nearest, &tt);
        if (le.maxCoeff() > 0) {
          *radiance = le;
          nearest = tt;
          met = i;
          break;
        }
      }
      ray.tnear = std::nextafter(hit.t, std::numeric_limits<float>::infinity());
    }
  }
  if (met < lights_.size()) *t = nearest;
  return met;
}

size_t RenderScene::PickLocalLight(double u, double* prob) const {
  const double total = local_cdf_.back();
  size_t k = 0;
  if (total > 0) {
    k = static_cast<size_t>(std::upper_bound(local_cdf_.begin(), local_cdf_.end(), u * total) - local_cdf_.begin());
    k = std::min(k, local_cdf_.size() - 1);
    while (k > 0 && !(light_power_[local_lights_[k]] > 0)) --k;  // u * total on a sum's edge
  } else {
    k = std::min(static_cast<size_t>(u * static_cast<double>(local_lights_.size())), local_lights_.size() - 1);
  }
  *prob = LightPickProbability(local_lights_[k]);
  return local_lights_[k];
}

double RenderScene::LightPickProbability(size_t i) const {
  if (!picks_local_light() || lights_.at(i).light().type == LightType::kDistant) return 1;
  const double total = local_cdf_.back();
  return total > 0 ? light_power_[i] / total : 1.0 / static_cast<double>(local_lights_.size());
}

void RenderScene::AddLight(const Light& light) {
  lights_.emplace_back(light);
  area_bvh_.reset();  // Commit() builds it again
  light_power_.push_back(LocalPower(light));
  if (light.type != LightType::kDistant) {
    local_lights_.push_back(lights_.size() - 1);
    local_cdf_.push_back((local_cdf_.empty() ? 0.0 : local_cdf_.back()) + light_power_.back());
  }
  has_virtual_ = has_virtual_ || light.is_virtual;
  has_distant_area_light_ = has_distant_area_light_ || (light.type == LightType::kDistant && !light.IsDelta());
  has_area_light_ = has_area_light_ || light.type == LightType::kArea;
}

int64_t RenderScene::RealCrossings(size_t i) const {
  if (virtual_hidden_.at(i)) return 0;
  const Eigen::Affine3d& t = virtual_poses_[i];
  const auto& p = virtual_positions_[i];
  // An edge crosses where a real surface lies between its ends and both
  // ends lie farther from that surface than 1e-4 of the object's size: an
  // object resting on a surface touches it without crossing it, also where
  // the surface's stored coordinates (6 decimals in an OBJ) are rougher
  // than a fine mesh's nearly level edges at the contact.
  Eigen::AlignedBox3d box;
  for (const auto& v : p) box.extend(t * v.cast<double>());
  const double clearance = 1e-4 * box.diagonal().norm();
  int64_t n = 0;
  for (const auto& [a, b] : virtual_edges_[i]) {
    const Eigen::Vector3d pa = t * p[static_cast<size_t>(a)].cast<double>();
    const Eigen::Vector3d d = t * p[static_cast<size_t>(b)].cast<double>() - pa;
    const double len = d.norm();
    if (!(len > 0)) continue;
    Ray r;
    r.origin = pa.cast<float>();
    r.direction = (d / len).cast<float>();
    r.tfar = static_cast<float>(len);
    r.mask = kMaskReal;
    // The surfaces along the edge, nearest first (a touch at one end does
    // not hide a crossing beyond it); at most 4.
    for (int k = 0; k < 4; ++k) {
      Hit hit;
      if (!embree_->Intersect(r, &hit)) break;
      const double cosine = std::abs(hit.geometric_normal.cast<double>().normalized().dot(d / len));
      const double th = static_cast<double>(hit.t);
      if (std::min(th, len - th) * cosine > clearance) {
        ++n;
        break;
      }
      r.tnear = std::nextafter(hit.t, std::numeric_limits<float>::infinity());
    }
  }
  return n;
}

void RenderScene::ClearLights() {
  lights_.clear();
  area_bvh_.reset();
  local_lights_.clear();
  local_cdf_.clear();
  light_power_.clear();
  has_virtual_ = has_virtual_geometry_;
  has_distant_area_light_ = false;
  has_area_light_ = false;
}

void RenderScene::Commit() {
  embree_->Commit();
  const size_t areas = std::count_if(lights_.begin(), lights_.end(),
                                     [](const LightSource& l) { return l.light().type == LightType::kArea; });
  if (!area_bvh_ && areas > kAllLocalLightsUpTo) {
    auto bvh = std::make_shared<AreaLightBvh>();
    Mesh m;
    for (size_t i = 0; i < lights_.size(); ++i) {
      if (lights_[i].light().type != LightType::kArea) continue;
      const size_t before = m.triangles.size();
      AppendAreaShape(lights_[i].light(), &m);
      bvh->light_of.insert(bvh->light_of.end(), m.triangles.size() - before, static_cast<uint32_t>(i));
    }
    bvh->shapes.AddMesh(m, false);
    bvh->shapes.Commit();
    area_bvh_ = std::move(bvh);
  }
  if (!closed_built_) closed_.Build();  // the real geometry does not move
  closed_built_ = true;
  auto b = embree_->Bounds();
  const double extent = b.isEmpty() ? 1.0 : static_cast<double>((b.max() - b.min()).norm());
  epsilon_ = std::max(1e-6, 1e-5 * extent);
}

bool RenderScene::VirtualEnclosedAwayFrom(const Eigen::Vector3d& eye, std::string* why) const {
  if (!has_virtual_ || closed_.count() == 0) return false;
  std::vector<int> surfaces;
  auto separated = [&](const Eigen::AlignedBox3d& b) {
    int which = -1;
    if (!closed_.Separates(eye, b, &which)) return false;
    surfaces.push_back(which);
    return true;
  };
  for (const auto& b : virtual_bounds_)
    if (!separated(b)) return false;
  for (const LightSource& l : lights_) {
    if (!l.is_virtual()) continue;
    Eigen::AlignedBox3d b;  // empty: a distant light, at infinity
    if (l.light().type != LightType::kDistant) b.extend(l.light().position);
    if (!separated(b)) return false;
  }
  if (why) {
    std::sort(surfaces.begin(), surfaces.end());
    surfaces.erase(std::unique(surfaces.begin(), surfaces.end()), surfaces.end());
    *why = fmt::format(
        "every virtual object and light is on the other side of a closed real surface ({} of {}) from the camera",
        surfaces.size(), closed_.count());
  }
  return true;
}

bool RenderScene::ShadingNormalAt(const Hit& hit, ShadingNormal* out) const {
  const Surface& s = surfaces_[hit.geometry_id];
  if (s.normals.empty() || hit.primitive_id >= s.triangles.size()) return false;
  const Eigen::Vector3i& t = s.triangles[hit.primitive_id];
  const double b[3] = {1.0 - hit.uv.x() - hit.uv.y(), hit.uv.x(), hit.uv.y()};
  Eigen::Vector3d n = Eigen::Vector3d::Zero(), p = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    n += b[k] * s.normals[static_cast<size_t>(t[k])].cast<double>();
    p += b[k] * s.positions[static_cast<size_t>(t[k])].cast<double>();
  }
  Eigen::Vector3d q = Eigen::Vector3d::Zero();  // Hanika 2021, eq. 3
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d pk = s.positions[static_cast<size_t>(t[k])].cast<double>();
    const Eigen::Vector3d nk = s.normals[static_cast<size_t>(t[k])].cast<double>().normalized();
    q += b[k] * (nk.allFinite() ? Eigen::Vector3d(p - (p - pk).dot(nk) * nk) : p);
  }
  out->shift = s.linear * (q - p);
  out->mapped = false;
  Eigen::Vector3d nw = (s.normal_to_world * n).normalized();
  if (s.asset && !s.asset->tangents.empty()) {
    const Eigen::Vector3d mapped = NormalMapped(s, hit, nw);
    out->mapped = mapped != nw;
    nw = mapped;
  }
  if (!nw.allFinite() || !out->shift.allFinite()) return false;
  out->n = nw;
  return true;
}

// glTF 2.0, 3.9.3: the normal texture's RGB in [0, 1] map to [-1, 1] in the
// tangent frame (x along the tangent, y along the bitangent, z the normal),
// x and y scaled by normalTextureInfo.scale.
Eigen::Vector3d RenderScene::NormalMapped(const Surface& s, const Hit& hit, const Eigen::Vector3d& nw) const {
  const AssetShading& a = *s.asset;
  const AssetMaterial& m = a.MaterialOf(hit.primitive_id);
  if (!m.normal_texture.present() || a.uvs.empty()) return nw;
  const Eigen::Vector3i& t = a.triangles[hit.primitive_id];
  const double b[3] = {1.0 - hit.uv.x() - hit.uv.y(), hit.uv.x(), hit.uv.y()};
  Eigen::Vector3d tan = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) tan += b[k] * a.tangents[static_cast<size_t>(t[k])].head<3>().cast<double>();
  tan = s.linear * tan;
  tan -= nw * nw.dot(tan);
  if (!(tan.norm() > 0)) return nw;
  tan.normalize();
  // The handedness flips with a mirroring placement.
  const double w = a.tangents[static_cast<size_t>(t[0])].w() * (s.linear.determinant() < 0 ? -1.0 : 1.0);
  const Eigen::Vector3d bit = w * nw.cross(tan);
  const Eigen::Vector4f c = a.Sample(m.normal_texture, a.UvAt(hit));
  const double x = (2.0 * c[0] - 1) * m.normal_scale, y = (2.0 * c[1] - 1) * m.normal_scale, z = 2.0 * c[2] - 1;
  const Eigen::Vector3d out = x * tan + y * bit + z * nw;
  return out.norm() > 0 && out.allFinite() ? Eigen::Vector3d(out.normalized()) : nw;
}

Eigen::Vector3d RenderScene::WorldNormal(const Hit& hit) const {
  Eigen::Vector3d n = surfaces_[hit.geometry_id].normal_to_world * hit.geometric_normal.cast<double>();
  const double len = n.norm();
  return len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::UnitZ();
}

// An asset's materials as one of mr's simple materials, for the methods
// that take a material per object (prt's albedo, ic's and vpl's lobes
// apart): the triangle-weighted mean of base x (1 - metallic) as albedo and
// of base x metallic as specular, roughness the mean.
Material AssetMeanMaterial(const Asset& asset, const std::vector<int>& triangle_material) {
  Material m;
  Eigen::Vector3d albedo = Eigen::Vector3d::Zero(), specular = Eigen::Vector3d::Zero();
  double rough = 0;
  for (int mi : triangle_material) {
    const AssetMaterial a = mi >= 0 ? asset.materials[static_cast<size_t>(mi)] : AssetMaterial();
    const Eigen::Vector3d base = a.base_color.head<3>().cast<double>();
    albedo += base * (1 - a.metallic);
    specular += base * a.metallic;
    rough += a.roughness;
  }
  const double n = std::max<double>(1, static_cast<double>(triangle_material.size()));
  m.albedo = albedo / n;
  m.specular = specular / n;
  m.roughness = std::clamp(rough / n, 1e-3, 1.0);
  return m;
}

std::vector<Eigen::Vector3f> AssetVertexAlbedo(const Asset& asset, const std::string& name) {
  std::vector<std::unique_ptr<Texture>> textures(asset.images.size());
  auto texture = [&](const AssetTexture& at, TextureEncoding e, const Mesh& mesh) -> const Texture* {
    if (!at.present() || mesh.uvs.size() != mesh.positions.size()) return nullptr;
    auto& t = textures[static_cast<size_t>(at.image)];
    if (!t) t = std::make_unique<Texture>(LoadAssetTexture(asset.images[static_cast<size_t>(at.image)], e, name));
    return t.get();
  };
  std::vector<Eigen::Vector3f> out;
  for (const AssetPart& part : asset.parts) {
    const AssetMaterial m = part.material >= 0 ? asset.materials[static_cast<size_t>(part.material)] : AssetMaterial();
    const Texture* base = texture(m.base_color_texture, TextureEncoding::kSrgb, part.mesh);
    const Texture* mr = texture(m.metallic_roughness_texture, TextureEncoding::kLinear, part.mesh);
    const Texture* tr =
        m.transmission > 0 ? texture(m.transmission_texture, TextureEncoding::kLinear, part.mesh) : nullptr;
    auto at = [&](const Texture* t, const AssetTexture& a, size_t i) {
      return t->Sample(TransformUv(a, part.mesh.uvs[i]), 0, a.wrap_s, a.wrap_t);
    };
    for (size_t i = 0; i < part.mesh.positions.size(); ++i) {
      float metallic = m.metallic, transmission = m.transmission;
      Eigen::Vector3f a = m.base_color.head<3>();
      if (base) a = a.cwiseProduct(at(base, m.base_color_texture, i).head<3>());
      if (mr) metallic *= at(mr, m.metallic_roughness_texture, i)[2];
      if (tr) transmission *= at(tr, m.transmission_texture, i)[0];
      a *= static_cast<float>(LobeWeights(metallic, transmission).diffuse);
      out.push_back(a.cwiseMax(0.0f).cwiseMin(1.0f));
    }
  }
  return out;
}

Mesh ReadVirtualMesh(const SceneVirtual& v) {
  return v.file_materials ? MergeParts(ReadAsset(v.mesh)) : ReadMesh(v.mesh);
}

void LoadRenderScene(const Scene& scene, RenderScene* out, int frame) {
  auto with_name = [](const fs::path& mesh, auto&& add) {
    try {
      add();
    } catch (const Error& e) {
      ThrowErrorAt(FileLoc{mesh.string()}, "{}", e.message());
    }
  };
  for (const auto& r : scene.reals) {
    const Mesh mesh = ReadMesh(r.mesh);
    with_name(r.mesh, [&] { out->AddReal(mesh, r.material); });
  }
  for (const auto& v : scene.virtuals) {
    if (v.file_materials) {
      const Asset asset = ReadAsset(v.mesh);
      std::vector<int> triangle_material;
      const Mesh mesh = MergeParts(asset, &triangle_material);
      with_name(v.mesh, [&] {
        const uint32_t id =
            out->AddVirtual(mesh, v.WorldFromObjectAt(frame), AssetMeanMaterial(asset, triangle_material));
        out->SetAssetMaterials(id, asset, std::move(triangle_material), mesh, v.mesh.string());
      });
      continue;
    }
    const Mesh mesh = ReadMesh(v.mesh);
    with_name(v.mesh, [&] { out->AddVirtual(mesh, v.WorldFromObjectAt(frame), v.material); });
  }
  if (scene.lighting.environment) LoadEnvironment(scene, frame, out);
  LoadLights(scene, LightsAt(scene, frame), frame, out);
  out->Commit();
}

namespace {

// An environment video's frames, decoded in order by one reader that every
// caller shares (a render visits its frames in order; going back reopens).
// A file rewritten in place (another size or time) is opened again.
struct EnvironmentVideo {
  std::mutex mutex;
  fs::path path;
  uintmax_t size = 0;
  fs::file_time_type written{};
  std::unique_ptr<VideoReader> reader;
  int frames = 0;  // as the container says, or the stream's end once met; 0: unknown
  int index = -1;  // the frame in `image`
  Image image;
};

EnvironmentVideo& SharedEnvironmentVideo() {
  static EnvironmentVideo v;
  return v;
}

// Frame `frame` of the video, or its last frame past its end (*from).
Image EnvironmentVideoFrame(const fs::path& path, int frame, int* from) {
  EnvironmentVideo& v = SharedEnvironmentVideo();
  std::lock_guard<std::mutex> lock(v.mutex);
  std::error_code ec;
  const uintmax_t size = fs::file_size(path, ec);
  const fs::file_time_type written = fs::last_write_time(path, ec);
  if (!v.reader || v.path != path || v.size != size || v.written != written) {
    v.reader = std::make_unique<VideoReader>(path);
    v.path = path;
    v.size = size;
    v.written = written;
    v.frames = v.reader->frame_count();
    v.index = -1;
  }
  int want = std::max(0, frame);
  if (v.frames > 0) want = std::min(want, v.frames - 1);
  if (v.index == want) {
    if (from) *from = v.index;
    return v.image;
  }
  try {
    v.image = v.reader->Frame(want);
    v.index = want;
  } catch (const Error&) {
    // The stream ends before `want` (the container claimed more frames, or
    // said nothing): read it from the start to its last frame.
    if (want == 0) throw;
    v.reader = std::make_unique<VideoReader>(path);
    v.index = -1;
    for (int k = 0; k < want; ++k) {
      try {
        v.image = v.reader->Frame(k);
      } catch (const Error&) {
        if (k == 0) throw;
        break;
      }
      v.index = k;
    }
    v.frames = v.index + 1;
  }
  if (from) *from = v.index;
  return v.image;
}

}  // namespace

std::optional<fs::path> EnvironmentAt(const Scene& scene, int frame, int* from) {
  if (!scene.lighting.environment) return std::nullopt;
  if (scene.lighting.environment_video) {
    if (from) EnvironmentVideoFrame(*scene.lighting.environment, frame, from);
    return scene.lighting.environment;
  }
  const std::optional<fs::path> p = PerFrameFile(*scene.lighting.environment, frame, from);
  if (!p)
    ThrowErrorAt(FileLoc{scene.lighting.environment->string()},
                 "no environment map for frame {} or any frame before it", frame);
  return p;
}

Image EnvironmentImageAt(const Scene& scene, int frame, std::string* name, int* from) {
  if (!scene.lighting.environment) throw UsageError("the scene names no environment (lighting.environment)");
  if (scene.lighting.environment_video) {
    int f = 0;
    Image img = EnvironmentVideoFrame(*scene.lighting.environment, frame, &f);
    if (name) *name = fmt::format("{} frame {}", scene.lighting.environment->string(), f);
    if (from) *from = f;
    return img;
  }
  const fs::path p = *EnvironmentAt(scene, frame, from);
  if (name) *name = p.string();
  ImageReadOptions opt;
  opt.nonfinite = NonFinite::kAllow;  // EnvironmentMap names the first bad pixel itself
  return ReadImage(p, opt);
}

uint64_t EnvironmentKey(const Scene& scene, int frame, int* from) {
  if (!scene.lighting.environment) return 0;
  if (!scene.lighting.environment_video) return ContentHash(*EnvironmentAt(scene, frame, from));
  const Image img = EnvironmentVideoFrame(*scene.lighting.environment, frame, from);
  Hasher h;
  h.Word(static_cast<uint64_t>(img.width()));
  h.Word(static_cast<uint64_t>(img.height()));
  h.Bytes(reinterpret_cast<const char*>(img.values().data()), img.values().size() * sizeof(float));
  return h.Final();
}

std::optional<fs::path> LightsAt(const Scene& scene, int frame, int* from) {
  if (!scene.lighting.lights) return std::nullopt;
  const std::optional<fs::path> p = PerFrameFile(*scene.lighting.lights, frame, from);
  if (!p)
    ThrowErrorAt(FileLoc{scene.lighting.lights->string()}, "no lights file for frame {} or any frame before it", frame);
  return p;
}

void LoadEnvironment(const Scene& scene, int frame, RenderScene* out) {
  std::string name;
  Image img = EnvironmentImageAt(scene, frame, &name);
  out->SetEnvironment(
      EnvironmentMap(std::move(img), name, scene.lighting.environment_scale, scene.lighting.world_from_env));
}

void LoadLights(const Scene& scene, const std::optional<fs::path>& path, int frame, RenderScene* out) {
  // Distant lights are directions of the map they came from (mr-lights):
  // they turn with it.  Point and spot lights stand in the world.
  out->ClearLights();
  if (path)
    for (Light l : ReadLights(*path)) {
      if (l.type == LightType::kDistant) l.direction = scene.lighting.world_from_env * l.direction;
      out->AddLight(l);
    }
  for (const SceneVirtualLight& v : scene.virtual_lights) out->AddLight(v.At(frame));
}

}  // namespace mr
