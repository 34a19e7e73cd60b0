// The one Embree 3 scene of mr: real and virtual geometry with ray masks.
//
// Every geometry is real (the captured room) or virtual (an inserted object).
// A ray carries a visibility mask: RayMask::kReal sees real geometry only
// (the "real" rays of differential rendering, for I_r), kAll sees both (the
// "mixed" rays, for I_m).  Virtual objects can be instanced: one prototype
// mesh placed by several transforms.  A ray that sees one kind only
// traverses that kind's tree alone, and moving an object does not rebuild
// the room's tree (embree_scene.cpp).  Embree types stay in the .cpp.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "geometry/mesh.h"

namespace mr {

enum RayMask : uint32_t { kMaskReal = 1u, kMaskVirtual = 2u, kMaskAll = 3u };

struct Ray {
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();
  Eigen::Vector3f direction = Eigen::Vector3f::UnitZ();  // need not be unit; t is in its units
  float tnear = 0.0f;
  float tfar = std::numeric_limits<float>::infinity();
  uint32_t mask = kMaskAll;
  // A cone around the ray for texture footprints (a pixel's, then widened
  // by each bounce; docs/methods.md, "Asset textures"): its width at the
  // origin and its growth per unit t (radians).  0: a thin ray (level 0).
  float cone_width = 0.0f, cone_spread = 0.0f;
};

inline constexpr uint32_t kInvalidId = 0xffffffffu;

struct Hit {
  float t = std::numeric_limits<float>::infinity();
  Eigen::Vector2f uv = Eigen::Vector2f::Zero();                // barycentrics of corners 1 and 2
  Eigen::Vector3f geometric_normal = Eigen::Vector3f::Zero();  // world space, unnormalised
  uint32_t geometry_id = kInvalidId;                           // the mesh (for an instance: the instance's id)
  uint32_t primitive_id = kInvalidId;
  bool is_virtual = false;
  bool valid() const { return geometry_id != kInvalidId; }
};

class EmbreeScene {
 public:
  EmbreeScene();
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // A mesh in world coordinates; returns its geometry id.
  uint32_t AddMesh(const Mesh& mesh, bool is_virtual);
  // A mesh to instance; returns a prototype id for AddInstance.
  uint32_t AddPrototype(const Mesh& mesh);
  // Places prototype `prototype` with world_from_object as virtual geometry
  // (instances are the inserted objects: the room is never instanced);
  // returns the geometry id.
  uint32_t AddInstance(uint32_t prototype, const Eigen::Affine3f& world_from_object);
  // Moves instance `id` (AddInstance's); a singular transform (an object
  // scaled to nothing) disables it: no ray meets it until it is moved back.
  // Commit() again before the next query.
  void SetInstanceTransform(uint32_t id, const Eigen::Affine3f& world_from_object);
  // Hits on prototype `prototype` count only where `accept(primitive, u, v,
  // ray_key)` is true (an asset's alpha cutout: Embree's intersection and
  // occlusion filters); ray_key hashes the ray's origin and direction (as
  // the prototype sees them), for stochastic transparency that is the same
  // for the same ray.  Called from many threads: it must be thread-safe and
  // a pure function of its arguments.  Before Commit().
  using HitFilter = std::function<bool(uint32_t primitive, float u, float v, uint64_t ray_key)>;
  void SetPrototypeFilter(uint32_t prototype, HitFilter accept);
  // Builds the acceleration structures; call after the last Add (or move)
  // and before any query.
  void Commit();
  // What the last Commit() built and kept, for reports: "the objects' tree
  // and the tree of both rebuilt; the room's kept", or, once the tree of
  // both is dropped in a large room, why.  Empty before the first commit.
  const std::string& last_commit() const;

  size_t geometry_count() const;

  // Closest hit; false (and hit->valid() false) when the ray escapes.
  bool Intersect(const Ray& ray, Hit* hit) const;
  // Any hit in (tnear, tfar).
  bool Occluded(const Ray& ray) const;
  // Streams of independent rays (rtcIntersect1M / rtcOccluded1M).
  void Intersect(std::span<const Ray> rays, std::span<Hit> hits) const;
  void Occluded(std::span<const Ray> rays, std::span<char> occluded) const;
  // Packets of up to 8 coherent rays (rtcIntersect8); rays.size() <= 8.
  void IntersectPacket8(std::span<const Ray> rays, std::span<Hit> hits) const;

  Eigen::AlignedBox3f Bounds() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mr
