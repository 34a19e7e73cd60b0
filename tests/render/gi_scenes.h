// Purpose-built scenes and helpers shared by the GI method tests (gi_test,
// vct_test): cameras, a constant sky with a sun, an open corner with a
// virtual sphere on the floor, and an integrating sphere.
#pragma once

#include "core/math.h"
#include "geometry/asset.h"
#include "geometry/primitives.h"
#include "light/lights_file.h"
#include "render/path_tracer.h"
#include "render/pt.h"

namespace mr::gi_test {

inline CameraModel Pinhole(int w, int h, double f) {
  return CameraModel("LENSMODEL_PINHOLE", {f, f, (w - 1) / 2.0, (h - 1) / 2.0}, w, h);
}

inline Rigid3 LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z);
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = -y;  // image y points down
  R.col(2) = z;
  if (R.determinant() < 0) R.col(0) = -R.col(0);
  return Rigid3(Eigen::Quaterniond(R), eye);
}

inline double Mean(const Image& img) {
  double s = 0;
  for (float v : img.values()) s += v;
  return s / static_cast<double>(img.values().size());
}

inline Image Difference(const FrameMethod& r) {
  Image m = r.Mixed();
  const Image real = r.Real();
  for (size_t i = 0; i < m.values().size(); ++i) m.values()[i] -= real.values()[i];
  return m;
}

// A sky of constant radiance with a sun `sun` times brighter in one pixel.
inline EnvironmentMap Sky(double sun) {
  Image img = Image::Rgb(64, 32);
  for (float& v : img.values()) v = 0.5f;
  for (int c = 0; c < 3; ++c) img.at(20, 8, c) = static_cast<float>(0.5 * sun);
  return EnvironmentMap(img, "sky");
}

inline Material Diffuse(double a) {
  Material m;
  m.albedo = Eigen::Vector3d::Constant(a);
  return m;
}

// Floor and a back wall, a virtual sphere resting on the floor (contact).
inline void OpenCorner(RenderScene* s, double sun, bool with_object = true) {
  s->AddReal(Quad({-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}), Diffuse(0.6));
  s->AddReal(Quad({-2, 0, 1}, {2, 0, 1}, {2, 2, 1}, {-2, 2, 1}), Diffuse(0.7));
  if (with_object) {
    Eigen::Affine3d t = Eigen::Affine3d::Identity();
    t.translate(Eigen::Vector3d(0, 0.3, 0));
    s->AddVirtual(UvSphere(0.3f, 24), t, Diffuse(0.8));
  }
  s->SetEnvironment(Sky(sun));
  s->Commit();
}

// A floor of half-width `half` (albedo 0.6), a virtual sphere of radius r
// (albedo 0.8, `segments` rings) resting on it at the origin, under Sky(sun).
inline void SphereOnFloor(RenderScene* s, float half, float r, int segments, double sun) {
  s->AddReal(Quad({-half, 0, -half}, {half, 0, -half}, {half, 0, half}, {-half, 0, half}), Diffuse(0.6));
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.translate(Eigen::Vector3d(0, r, 0));
  s->AddVirtual(UvSphere(r, segments), t, Diffuse(0.8));
  s->SetEnvironment(Sky(sun));
  s->Commit();
}

// A glTF transmissive material: smooth, ior `ior`, `thickness` metres (0:
// a thin wall).
inline AssetMaterial GlassMaterial(float ior, float thickness) {
  AssetMaterial m;
  m.metallic = 0;
  m.roughness = 0;
  m.transmission = 1;
  m.ior = ior;
  m.thickness = thickness;
  return m;
}

// A virtual object of `mesh` with GlassMaterial(ior, thickness), placed by
// `world_from_object`; its geometry id.  The caller commits the scene.
inline uint32_t AddGlassAsset(RenderScene* s, const Mesh& mesh, float ior, float thickness,
                              const Eigen::Affine3d& world_from_object = Eigen::Affine3d::Identity()) {
  Asset a;
  a.parts.push_back({.name = "glass", .mesh = mesh, .material = 0});
  a.materials.push_back(GlassMaterial(ior, thickness));
  std::vector<int> triangle_material;
  const Mesh merged = MergeParts(a, &triangle_material);
  const uint32_t id = s->AddVirtual(merged, world_from_object, Material());
  s->SetAssetMaterials(id, a, triangle_material, merged, "glass.glb");
  return id;
}

inline const Rigid3 kCornerCamera = LookAt({0.3, 1.2, -2.2}, {0, 0.3, 0.2});

// Integrating sphere: a closed sphere of albedo rho with a point light of
// intensity I at its centre.  Every point receives E_d = I / R^2 directly,
// and the indirect irradiance of a sphere is uniform, rho E_d / (1 - rho), so
// a wall seen from the centre has L = rho / pi x E_d / (1 - rho): 31.5 x E_d
// at rho = 0.99, 99 bounces' worth of light.  The sphere is tessellated
// (48 x 96 facets: their distance to the centre varies by 0.1%); the
// tolerance, 4%, covers that and the Monte Carlo error of the counts used.
constexpr double kRho = 0.99;

inline void IntegratingSphere(RenderScene* s) {
  s->AddReal(UvSphere(1.0f, 48), Diffuse(kRho));
  Light l;
  l.type = LightType::kPoint;
  l.position = Eigen::Vector3d(0, 0, 0);
  l.intensity = Eigen::Vector3d::Ones();
  s->AddLight(l);
  s->Commit();
}

}  // namespace mr::gi_test
