// What the renderer sees: the Embree scene of real and virtual geometry, a
// material and a normal transform per geometry, and the environment.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "geometry/asset.h"
#include "geometry/embree_scene.h"
#include "geometry/enclosure.h"
#include "geometry/mesh.h"
#include "light/environment.h"
#include "light/light_source.h"
#include "render/bsdf.h"
#include "scene/scene.h"

namespace mr {

class RenderScene {
 public:
  RenderScene();
  // The captured room (or any real geometry), in world coordinates.  With
  // material.albedo_from_vertex_colors the mesh's vertex colours are its
  // albedo (mr-fuse's de-lit room), with material.albedo_texture the
  // texture at its uvs (read here): mr::Error when the mesh has none.
  uint32_t AddReal(const Mesh& mesh, const Material& material);
  // A virtual object: `mesh` in object coordinates, placed by world_from_object.
  uint32_t AddVirtual(const Mesh& mesh, const Eigen::Affine3d& world_from_object, const Material& material);
  // An asset's materials on geometry `id` (AddVirtual of MergeParts(asset,
  // &triangle_material)): each triangle shaded by its part's material
  // (PbrBsdf), base colour and metallic-roughness textures at the mesh's
  // uvs (mip level from the ray's cone: AssetBsdfAt), loaded once
  // per image.  Alpha (base colour's A x the texture's): MASK cuts the
  // surface where alpha < alphaCutoff, BLEND lets a ray through with
  // probability 1 - alpha (stochastic transparency, the same for the same
  // ray), both in Embree's filters, so every ray (camera, shadow, bounce)
  // sees the same cut surface.  `name` names the asset in messages.  Not
  // used: occlusion textures (a path tracer computes occlusion).
  void SetAssetMaterials(uint32_t id, const Asset& asset, std::vector<int> triangle_material, const Mesh& mesh,
                         const std::string& name);
  bool has_asset_material(uint32_t id) const { return surfaces_.at(id).asset != nullptr; }
  // The textures of geometry `id`'s asset: how many, and their bytes (every
  // mip level; each image once however many materials sample it).
  int64_t asset_textures(uint32_t id) const;
  int64_t asset_texture_bytes(uint32_t id) const;
  // The BSDF of an asset's material at a hit, and the diffuse albedo there
  // (base colour x (1 - metallic) x (1 - transmission): what methods that
  // treat the diffuse lobe apart take).  `inside`: the ray meets the
  // surface from behind its normals (leaving a solid glass: the relative
  // ior is 1/ior there).
  // `footprint`: the width (world units, on the surface) a lookup stands
  // for, from the ray's cone (0: mip level 0).
  Bsdf AssetBsdfAt(const Hit& hit, bool inside, double footprint, Eigen::Vector3d* diffuse_albedo) const;
  // The radiance an asset's material emits at a hit: emissiveFactor x
  // KHR_materials_emissive_strength x the emissive texture (sRGB), as
  // glTF defines it (W/(sr m^2) in mr's units: the asset's numbers taken
  // as the scene's radiance scale).
  Eigen::Vector3d AssetEmissionAt(const Hit& hit, double footprint) const;
  // The absorption coefficient (per metre, per channel) inside a solid
  // transmissive asset material (KHR_materials_volume: -ln(attenuation
  // colour) / attenuation distance); zero elsewhere.
  Eigen::Vector3d AssetAbsorption(const Hit& hit) const;
  void SetEnvironment(EnvironmentMap env) { env_ = std::move(env); }
  // A light of lights.json; a virtual light makes the scene differ from the real one.
  void AddLight(const Light& light);
  void ClearLights();
  // Moves virtual object `i` (AddVirtual's order) to world_from_object: the
  // world at another frame.  A transform that collapses it (|det| < 1e-18:
  // a scale of 0) hides it until it is moved back.  Commit() again before
  // the next query.
  void SetVirtualTransform(size_t i, const Eigen::Affine3d& world_from_object);
  bool virtual_hidden(size_t i) const { return virtual_hidden_.at(i); }
  // How many edges of virtual object `i`, where it stands now, cross a real
  // surface (a real surface lies between the edge's ends, both farther from
  // it than 1e-4 of the object's size): > 0 for an object passing through
  // the table or a wall, 0 for one resting on it.  0 while hidden.  After
  // Commit().
  int64_t RealCrossings(size_t i) const;
  void Commit();

  const EmbreeScene& embree() const { return *embree_; }
  const EnvironmentMap& environment() const { return env_; }
  const std::vector<LightSource>& lights() const { return lights_; }
  // Next-event estimation samples each local light (point, spot, area) while
  // there are at most kAllLocalLightsUpTo of them; beyond, one per estimate,
  // picked in proportion to its power (luminance: intensity x 4 pi, the
  // spot's cone, radiance x pi x area).  Distant lights are always each
  // sampled.  The probability is 1 for every light while each is sampled.
  static constexpr size_t kAllLocalLightsUpTo = 16;
  bool picks_local_light() const { return local_lights_.size() > kAllLocalLightsUpTo; }
  // For u in [0, 1): the picked local light's index in lights(), and its
  // probability in *prob.
  size_t PickLocalLight(double u, double* prob) const;
  double LightPickProbability(size_t light_index) const;
  // The nearest area light of `which` (bit 1: real lights, bit 2: virtual)
  // that the ray o + t d (d unit) meets at 0 < t < t_max from its emitting
  // side: its index in lights() (lights().size(): none), with *t and
  // *radiance set.  Beyond kAllLocalLightsUpTo area lights through a BVH of
  // their shapes that Commit() builds (each candidate confirmed by
  // LightSource::HitArea); otherwise, and until Commit() after the lights
  // change, by testing each.
  size_t NearestAreaLight(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max, unsigned which, double* t,
                          Eigen::Vector3d* radiance) const;
  bool has_distant_area_light() const { return has_distant_area_light_; }
  bool has_area_light() const { return has_area_light_; }  // positioned (lights.json "area")
  const Material& material(uint32_t geometry_id) const { return surfaces_.at(geometry_id).material; }
  const Bsdf& bsdf(uint32_t geometry_id) const { return surfaces_.at(geometry_id).bsdf; }
  // The material's diffuse and glossy lobes alone (bsdf = their sum), for
  // methods that treat the lobes differently (ic, vpl).
  const Bsdf& diffuse_bsdf(uint32_t geometry_id) const { return surfaces_.at(geometry_id).diffuse; }
  const Bsdf& glossy_bsdf(uint32_t geometry_id) const { return surfaces_.at(geometry_id).glossy; }
  // Whether the geometry's albedo varies over it (vertex colours, texture).
  bool has_varying_albedo(uint32_t geometry_id) const {
    const Surface& s = surfaces_.at(geometry_id);
    return !s.vertex_albedo.empty() || s.texture.width() > 0;
  }
  // The diffuse albedo at a hit: the vertex colours interpolated over the
  // triangle (barycentric), or the texture at the interpolated uv
  // (bilinear, repeating), where the geometry has them, each channel
  // clamped to [0, 1 - specular] so that the surface stays
  // energy-conserving; else the material's.
  Eigen::Vector3d AlbedoAt(const Hit& hit) const;
  // The BSDF, and its diffuse lobe alone, of a geometry's material with
  // its albedo replaced by `albedo` (AlbedoAt).
  Bsdf BsdfWith(uint32_t geometry_id, const Eigen::Vector3d& albedo) const;
  // An RGB texture at uv: bilinear between texel centres, repeating, v = 0
  // at the bottom row (the OBJ/PLY convention).  Non-finite uv: black.
  static Eigen::Vector3d SampleTexture(const Image& texture, const Eigen::Vector2d& uv);
  Bsdf DiffuseBsdfWith(uint32_t geometry_id, const Eigen::Vector3d& albedo) const;
  // Whether any surface has a glossy lobe.
  bool has_glossy() const { return has_glossy_; }
  // Whether any real surface has a glossy lobe (real surfaces take
  // lights.json-style materials, never an asset's).
  bool has_glossy_real() const { return has_glossy_real_; }
  // Unit world-space geometric normal of a hit (Embree reports instance
  // normals in object space).
  Eigen::Vector3d WorldNormal(const Hit& hit) const;
  // A hit's shading normal where its surface has one (material.normals
  // "vertex", an asset with normals; docs/methods.md, "Shading normals"):
  // `n` the vertex normals interpolated (barycentric) and, on an asset
  // material with a normal texture, bent by it in the tangent frame; world
  // space, unit, on the side the mesh's normals point to (not turned to
  // face a ray).  `shift` moves a ray origin from the flat triangle to the
  // smooth surface the vertex normals describe (Hanika 2021, "Hacking the
  // shadow terminator"): the barycentric mean of the point's projections
  // onto the vertices' tangent planes, minus the point.  Returns false
  // where the surface is shaded by its geometric normal.
  struct ShadingNormal {
    Eigen::Vector3d n, shift;
    bool mapped = false;  // a normal map bent it
  };
  bool ShadingNormalAt(const Hit& hit, ShadingNormal* out) const;
  // Whether anything virtual (geometry not hidden, or a light) exists:
  // without it I_m = I_r.
  bool has_virtual() const { return has_virtual_; }
  bool has_virtual_geometry() const { return has_virtual_geometry_; }
  // Geometry ids of the virtual objects, in the order they were added.
  const std::vector<uint32_t>& virtual_ids() const { return virtual_ids_; }
  // A length for ray-origin offsets: 1e-5 of the scene's extent.
  double epsilon() const { return epsilon_; }
  Eigen::AlignedBox3f bounds() const { return embree_->Bounds(); }
  // World bounds of each piece of geometry, real and virtual (after Commit).
  const std::vector<Eigen::AlignedBox3d>& geometry_bounds() const { return geometry_bounds_; }
  const std::vector<Eigen::AlignedBox3d>& virtual_bounds() const { return virtual_bounds_; }
  // Each virtual object's bounding sphere (centre, radius), by the order of
  // virtual_ids: centred on its box, its radius the farthest vertex's
  // distance from there (at most half the box's diagonal; a third of it for
  // a sphere's mesh) times the placement's largest stretch, grown 1e-6.
  // Radius -1 while the object is hidden.
  const std::vector<Eigen::Vector4d>& virtual_spheres() const { return virtual_spheres_; }
  // Whether a closed real surface provably keeps every virtual object and
  // light away from a camera at `eye` (geometry/enclosure.h); `why` says which.
  bool VirtualEnclosedAwayFrom(const Eigen::Vector3d& eye, std::string* why) const;
  const ClosedSurfaces& closed_surfaces() const { return closed_; }

 private:
  struct AssetShading;
  struct Surface {
    Material material;
    Bsdf bsdf;
    Eigen::Matrix3d normal_to_world;
    Bsdf diffuse{Material()}, glossy{Material()};
    std::vector<Eigen::Vector3f> vertex_albedo;  // empty: the material's albedo everywhere
    Image texture;                               // albedo texture (RGB); empty: none
    std::vector<Eigen::Vector2f> uvs;            // with texture: the mesh's, per vertex
    std::vector<Eigen::Vector3i> triangles;      // with either, or normals: the mesh's, by primitive id
    std::shared_ptr<const AssetShading> asset;   // an asset's materials; null: `material`
    // Shading normals: the mesh's vertex normals and positions (object
    // coordinates); empty: the geometric normal shades.
    std::vector<Eigen::Vector3f> normals, positions;
    Eigen::Matrix3d linear = Eigen::Matrix3d::Identity();  // world_from_object's
  };
  Eigen::Vector3d NormalMapped(const Surface& s, const Hit& hit, const Eigen::Vector3d& n_obj) const;
  double WorldScale(uint32_t id) const;  // a placement's linear scale (cube root of |det|)
  void SetSurface(uint32_t id, const Material& material, const Eigen::Matrix3d& normal_to_world, const Mesh& mesh);
  bool has_glossy_ = false, has_glossy_real_ = false;
  std::unique_ptr<EmbreeScene> embree_;
  std::vector<Surface> surfaces_;  // by geometry id
  EnvironmentMap env_;
  std::vector<LightSource> lights_;
  std::vector<size_t> local_lights_;              // indices into lights_
  std::vector<double> local_cdf_;                 // running sums of their powers
  std::vector<double> light_power_;               // by index into lights_ (0 for distant)
  struct AreaLightBvh;                            // render_scene.cpp
  std::shared_ptr<const AreaLightBvh> area_bvh_;  // null: test each area light
  ClosedSurfaces closed_;
  std::vector<Eigen::AlignedBox3d> geometry_bounds_, virtual_bounds_;
  std::vector<uint32_t> virtual_ids_;
  std::vector<uint32_t> virtual_prototypes_;                     // EmbreeScene prototype of each
  std::vector<Eigen::AlignedBox3d> virtual_object_bounds_;       // in object coordinates
  std::vector<double> virtual_object_radii_;                     // the farthest vertex from the box's centre
  std::vector<Eigen::Vector4d> virtual_spheres_;                 // world, as virtual_spheres()
  std::vector<Eigen::Affine3d> virtual_poses_;                   // world_from_object now
  std::vector<std::vector<Eigen::Vector3f>> virtual_positions_;  // object coordinates
  std::vector<std::vector<std::pair<int, int>>> virtual_edges_;  // each once
  std::vector<char> virtual_hidden_;
  bool closed_built_ = false;
  bool has_virtual_ = false, has_virtual_geometry_ = false, has_distant_area_light_ = false, has_area_light_ = false;
  double epsilon_ = 1e-5;
};

// An albedo texture as RGB (linear: 8-bit files decode through sRGB unless
// they say otherwise; one grey channel Y is repeated).  mr::Error naming the
// file when it has neither R, G, B nor Y.
Image ReadAlbedoTexture(const fs::path& path);

// The diffuse albedo of an asset at each vertex of MergeParts(asset): its
// part's base colour x (1 - metallic) x (1 - transmission), times the base
// colour texture at the vertex's uv (level 0; each image decoded once), for
// methods that shade per vertex (prt).  `name` names the asset in messages.
std::vector<Eigen::Vector3f> AssetVertexAlbedo(const Asset& asset, const std::string& name);

// A virtual object's mesh as LoadRenderScene adds it (the same vertices and
// triangles, in the same order): an asset's parts merged where it is shaded
// by its file's materials, else the mesh file as ReadMesh reads it.
Mesh ReadVirtualMesh(const SceneVirtual& v);

// Builds a RenderScene from a validated scene description: reads the meshes
// and the environment map (NaN/Inf pixels are an error naming the file and
// pixel; albedo_from_vertex_colors on a mesh without colours names the mesh).
// `frame`: the world at that frame (its environment map and lights when
// they are per frame, the objects where their trajectories put them).
void LoadRenderScene(const Scene& scene, RenderScene* out, int frame = 0);

// The environment map and lights file of `frame` (per-frame patterns: the
// frame's own or the last earlier one's, *from its frame; mr::Error naming
// the pattern when none exists up to it); nullopt when the scene names none.
// An environment video is its own file for every frame; *from is the frame
// of the video that `frame` takes (the last one past its end).
std::optional<fs::path> EnvironmentAt(const Scene& scene, int frame, int* from = nullptr);
std::optional<fs::path> LightsAt(const Scene& scene, int frame, int* from = nullptr);
// The environment of `frame` as stored (before environment_scale and the
// rotation): the map file's pixels, or the video's frame (8-bit sRGB
// decoded to linear, codes / 255 through the sRGB curve).  *name names it
// in messages ("env.mp4 frame 12"), *from as EnvironmentAt.  The scene must
// name an environment.
Image EnvironmentImageAt(const Scene& scene, int frame, std::string* name = nullptr, int* from = nullptr);
// A key of the environment of `frame` that changes only when its content
// does: a map file's ContentHash, a video frame's pixels' hash (two equal
// frames of a video are no change).  0 when the scene names none.
uint64_t EnvironmentKey(const Scene& scene, int frame, int* from = nullptr);
// Loads them into `out` (the lights replacing its lights); Commit() after.
void LoadEnvironment(const Scene& scene, int frame, RenderScene* out);
// The lights of `frame`: the lights file's (none without one) and the
// scene's virtual lights posed for the frame; replaces the scene's lights.
void LoadLights(const Scene& scene, const std::optional<fs::path>& path, int frame, RenderScene* out);

}  // namespace mr
