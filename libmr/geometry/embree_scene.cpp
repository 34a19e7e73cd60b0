#include "geometry/embree_scene.h"

#include <embree3/rtcore.h>

#include <cstring>
#include <mutex>
#include <string>

#include "core/check.h"
#include "core/error.h"

namespace mr {

namespace {

void ErrorCallback(void* user, RTCError code, const char* str) {
  auto* msg = static_cast<std::string*>(user);
  if (code != RTC_ERROR_NONE && msg->empty()) *msg = str ? str : "unknown Embree error";
}

RTCGeometry MakeTriangleGeometry(RTCDevice device, const Mesh& mesh) {
  mesh.Validate("mesh given to Embree");
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                        3 * sizeof(float), mesh.positions.size()));
  auto* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(uint32_t), mesh.triangles.size()));
  MR_CHECK(v && idx);
  for (size_t i = 0; i < mesh.positions.size(); ++i) std::memcpy(v + 3 * i, mesh.positions[i].data(), 12);
  for (size_t i = 0; i < mesh.triangles.size(); ++i)
    for (int k = 0; k < 3; ++k) idx[3 * i + k] = static_cast<uint32_t>(mesh.triangles[i][k]);
  rtcCommitGeometry(g);
  return g;
}

void ToRTC(const Ray& r, RTCRay* out) {
  out->org_x = r.origin.x();
  out->org_y = r.origin.y();
  out->org_z = r.origin.z();
  out->dir_x = r.direction.x();
  out->dir_y = r.direction.y();
  out->dir_z = r.direction.z();
  out->tnear = r.tnear;
  out->tfar = r.tfar;
  out->time = 0;
  out->mask = r.mask;
  out->id = 0;
  out->flags = 0;
}

uint64_t Mix(uint64_t h, float f) {
  uint32_t b = 0;
  std::memcpy(&b, &f, 4);
  h ^= b + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
  return h * 0xBF58476D1CE4E5B9ull;
}

// Embree's filter for a prototype with a HitFilter (its user data): a hit
// the filter refuses is not a hit.
void FilterHits(const RTCFilterFunctionNArguments* args) {
  const auto& accept = *static_cast<const EmbreeScene::HitFilter*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    uint64_t key = 0;
    for (float f : {RTCRayN_org_x(args->ray, args->N, i), RTCRayN_org_y(args->ray, args->N, i),
                    RTCRayN_org_z(args->ray, args->N, i), RTCRayN_dir_x(args->ray, args->N, i),
                    RTCRayN_dir_y(args->ray, args->N, i), RTCRayN_dir_z(args->ray, args->N, i)})
      key = Mix(key, f);
    if (!accept(RTCHitN_primID(args->hit, args->N, i), RTCHitN_u(args->hit, args->N, i),
                RTCHitN_v(args->hit, args->N, i), key))
      args->valid[i] = 0;
  }
}

// A twin of triangle geometry `g` over the same vertex and index buffers
// (Embree 3 attaches a geometry to one scene only).
RTCGeometry TwinTriangles(RTCDevice device, RTCGeometry g, const Mesh& mesh) {
  RTCGeometry t = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetSharedGeometryBuffer(t, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                             rtcGetGeometryBufferData(g, RTC_BUFFER_TYPE_VERTEX, 0), 0, 3 * sizeof(float),
                             mesh.positions.size());
  rtcSetSharedGeometryBuffer(t, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                             rtcGetGeometryBufferData(g, RTC_BUFFER_TYPE_INDEX, 0), 0, 3 * sizeof(uint32_t),
                             mesh.triangles.size());
  return t;
}

}  // namespace

// Two levels.  The real geometry is one scene (parts[0]), built once: the
// room does not move.  The virtual geometry is another (parts[1]), and the
// top scene holds an instance of the real part beside twins of the virtual
// geometries (Embree 3 attaches a geometry to one scene only; a triangle
// twin shares its buffers).  A ray that sees one kind only (kMaskReal,
// kMaskVirtual) traverses that kind's tree, not the other's: a mask is
// tested at the primitives, after the traversal, so a virtual blocker test
// in a fused room of 700 000 triangles would otherwise walk the room's
// tree.  A moved object rebuilds the top scene and the virtual part, not
// the room's tree (0.15 s a frame for that room on 2 threads).  Ids are
// assigned here and shared by a geometry and its twin.
struct EmbreeScene::Impl {
  std::string error;
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;  // top: the real part's instance and the virtual geometry
  struct Part {
    RTCScene scene = nullptr;
    size_t count = 0;    // geometries in it
    bool dirty = false;  // changed since its last commit
  };
  Part parts[2];                                     // [0] real, [1] virtual
  uint32_t real_instance = RTC_INVALID_GEOMETRY_ID;  // the real part's id in the top scene
  uint32_t next_id = 0;
  std::vector<RTCGeometry> twins;  // by geometry id: a virtual geometry's twin in parts[1]
  std::vector<RTCScene> prototypes;
  std::vector<std::unique_ptr<HitFilter>> filters;  // user data of the prototypes' filters
  std::vector<char> is_virtual;                     // by geometry id
  size_t geometries = 0;
  bool committed = false;

  void Check(const char* what) {
    if (!error.empty()) {
      std::string e = std::move(error);
      error.clear();
      ThrowError("Embree: {}: {}", what, e);
    }
  }
  void Record(uint32_t id, bool v) {
    if (is_virtual.size() <= id) is_virtual.resize(id + 1, 0);
    is_virtual[id] = v;
  }
  // Masks, commits and attaches `g`: a real one to the real part, a virtual
  // one to the top scene and its `twin` to the virtual part, under one id;
  // its id.
  uint32_t Attach(RTCGeometry g, RTCGeometry twin, bool virt, const char* what) {
    const uint32_t id = next_id++;
    Part& part = parts[virt ? 1 : 0];
    rtcSetGeometryMask(g, virt ? kMaskVirtual : kMaskReal);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(virt ? scene : part.scene, g, id);
    rtcReleaseGeometry(g);
    if (virt) {
      rtcSetGeometryMask(twin, kMaskVirtual);
      rtcCommitGeometry(twin);
      rtcAttachGeometryByID(part.scene, twin, id);
      rtcReleaseGeometry(twin);
      if (twins.size() <= id) twins.resize(id + 1, nullptr);
      twins[id] = twin;
    }
    ++part.count;
    ++geometries;
    part.dirty = true;
    Check(what);
    Record(id, virt);
    return id;
  }
  // The scene a ray with `mask` traverses; null: it can meet nothing.
  RTCScene For(uint32_t mask) const {
    if (mask == kMaskVirtual || !parts[0].count) return parts[1].count ? parts[1].scene : nullptr;
    if (mask == kMaskReal || !parts[1].count) return parts[0].scene;
    return scene;
  }
  // Runs the stream `records` (one per ray of `rays`, `stride` bytes
  // apart) through `whole(scene, ctx, first, n)` where every ray is bound
  // for the same scene (For), else through `by_pointer(scene, ctx,
  // pointers, n)` once per scene, each ray in its scene's pointer array; a
  // ray that can meet nothing keeps its miss.
  template <class Whole, class ByPointer>
  void Stream(std::span<const Ray> rays, char* records, size_t stride, Whole&& whole, ByPointer&& by_pointer) const {
    if (rays.empty()) return;
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    const RTCScene first = For(rays[0].mask);
    bool one = true;
    for (const Ray& r : rays) one = one && For(r.mask) == first;
    if (one) {
      if (first) whole(first, &ctx, records, static_cast<unsigned>(rays.size()));
      return;
    }
    std::vector<void*> pointers;
    for (RTCScene s : {scene, parts[0].scene, parts[1].scene}) {  // every target For gives
      pointers.clear();
      for (size_t i = 0; i < rays.size(); ++i)
        if (For(rays[i].mask) == s) pointers.push_back(records + i * stride);
      if (!pointers.empty()) by_pointer(s, &ctx, pointers.data(), static_cast<unsigned>(pointers.size()));
    }
  }
  void Fill(const RTCRayHit& rh, Hit* hit) const {
    *hit = Hit();
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return;
    // Through an instance, instID[0] is its id in the scene queried: the
    // real part's (the mesh is geomID in it) or a virtual object's.
    const uint32_t inst = rh.hit.instID[0];
    const uint32_t id = inst == RTC_INVALID_GEOMETRY_ID || inst == real_instance ? rh.hit.geomID : inst;
    hit->t = rh.ray.tfar;
    hit->uv = Eigen::Vector2f(rh.hit.u, rh.hit.v);
    hit->geometric_normal = Eigen::Vector3f(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
    hit->geometry_id = id;
    hit->primitive_id = rh.hit.primID;
    hit->is_virtual = id < is_virtual.size() && is_virtual[id];
  }
};

EmbreeScene::EmbreeScene() : impl_(std::make_unique<Impl>()) {
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device) ThrowError("Embree: cannot create a device");
  rtcSetDeviceErrorFunction(impl_->device, ErrorCallback, &impl_->error);
  if (!rtcGetDeviceProperty(impl_->device, RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED))
    ThrowError("this Embree build lacks ray masks, which mr needs for real/virtual rays");
  for (RTCScene* s : {&impl_->scene, &impl_->parts[0].scene, &impl_->parts[1].scene}) {
    *s = rtcNewScene(impl_->device);
    rtcSetSceneFlags(*s, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(*s, RTC_BUILD_QUALITY_HIGH);
  }
  impl_->Check("creating the scene");
}

EmbreeScene::~EmbreeScene() {
  for (auto& part : impl_->parts)  // before the scene that owns the buffers they share
    if (part.scene) rtcReleaseScene(part.scene);
  for (RTCScene s : impl_->prototypes) rtcReleaseScene(s);
  if (impl_->scene) rtcReleaseScene(impl_->scene);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

uint32_t EmbreeScene::AddMesh(const Mesh& mesh, bool is_virtual) {
  MR_CHECK(!impl_->committed);
  RTCGeometry g = MakeTriangleGeometry(impl_->device, mesh);
  return impl_->Attach(g, is_virtual ? TwinTriangles(impl_->device, g, mesh) : nullptr, is_virtual, "adding a mesh");
}

uint32_t EmbreeScene::AddPrototype(const Mesh& mesh) {
  RTCScene s = rtcNewScene(impl_->device);
  rtcSetSceneFlags(s, RTC_SCENE_FLAG_ROBUST);
  RTCGeometry g = MakeTriangleGeometry(impl_->device, mesh);
  rtcAttachGeometry(s, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(s);
  impl_->Check("building a prototype");
  impl_->prototypes.push_back(s);
  return static_cast<uint32_t>(impl_->prototypes.size() - 1);
}

void EmbreeScene::SetPrototypeFilter(uint32_t prototype, HitFilter accept) {
  MR_CHECK(!impl_->committed);
  MR_CHECK_LT(prototype, impl_->prototypes.size());
  impl_->filters.push_back(std::make_unique<HitFilter>(std::move(accept)));
  RTCScene s = impl_->prototypes[prototype];
  RTCGeometry g = rtcGetGeometry(s, 0);
  rtcSetGeometryUserData(g, impl_->filters.back().get());
  rtcSetGeometryIntersectFilterFunction(g, FilterHits);
  rtcSetGeometryOccludedFilterFunction(g, FilterHits);
  rtcCommitGeometry(g);
  rtcCommitScene(s);
  impl_->Check("setting a prototype's hit filter");
}

uint32_t EmbreeScene::AddInstance(uint32_t prototype, const Eigen::Affine3f& world_from_object) {
  MR_CHECK(!impl_->committed);
  MR_CHECK_LT(prototype, impl_->prototypes.size());
  if (!world_from_object.matrix().allFinite()) ThrowError("instance transform has NaN or Inf");
  if (std::abs(world_from_object.linear().determinant()) < 1e-20f) ThrowError("instance transform is singular");
  RTCGeometry g[2];
  Eigen::Matrix<float, 3, 4> m = world_from_object.matrix().topRows<3>();
  for (RTCGeometry& gi : g) {
    gi = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(gi, impl_->prototypes[prototype]);
    rtcSetGeometryTransform(gi, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, m.data());  // column-major 3x4
  }
  return impl_->Attach(g[0], g[1], /*virt=*/true, "adding an instance");
}

void EmbreeScene::SetInstanceTransform(uint32_t id, const Eigen::Affine3f& world_from_object) {
  MR_CHECK(id < impl_->twins.size() && impl_->twins[id]);  // an instance's id
  if (!world_from_object.matrix().allFinite()) ThrowError("instance transform has NaN or Inf");
  for (RTCGeometry g : {rtcGetGeometry(impl_->scene, id), impl_->twins[id]}) {
    if (std::abs(world_from_object.linear().determinant()) < 1e-20f) {
      rtcDisableGeometry(g);
    } else {
      rtcEnableGeometry(g);
      Eigen::Matrix<float, 3, 4> m = world_from_object.matrix().topRows<3>();
      rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, m.data());
    }
    rtcCommitGeometry(g);
  }
  impl_->parts[1].dirty = true;
  impl_->Check("moving an instance");
  impl_->committed = false;
}

void EmbreeScene::Commit() {
  Impl& m = *impl_;
  for (auto& part : m.parts)
    if (part.dirty) {
      rtcCommitScene(part.scene);
      part.dirty = false;
      if (&part == &m.parts[0] && m.real_instance != RTC_INVALID_GEOMETRY_ID)  // the room grew
        rtcCommitGeometry(rtcGetGeometry(m.scene, m.real_instance));
    }
  if (m.parts[0].count && m.real_instance == RTC_INVALID_GEOMETRY_ID) {
    RTCGeometry g = rtcNewGeometry(m.device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(g, m.parts[0].scene);
    const Eigen::Matrix<float, 3, 4> identity = Eigen::Matrix<float, 3, 4>::Identity();
    rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, identity.data());
    rtcSetGeometryMask(g, kMaskReal);
    rtcCommitGeometry(g);
    m.real_instance = m.next_id++;
    rtcAttachGeometryByID(m.scene, g, m.real_instance);
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(m.scene);
  impl_->Check("building the scene");
  impl_->committed = true;
}

size_t EmbreeScene::geometry_count() const { return impl_->geometries; }

bool EmbreeScene::Intersect(const Ray& ray, Hit* hit) const {
  MR_CHECK(impl_->committed);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  ToRTC(ray, &rh.ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  if (RTCScene s = impl_->For(ray.mask)) rtcIntersect1(s, &ctx, &rh);
  impl_->Fill(rh, hit);
  return hit->valid();
}

bool EmbreeScene::Occluded(const Ray& ray) const {
  MR_CHECK(impl_->committed);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  ToRTC(ray, &r);
  RTCScene s = impl_->For(ray.mask);
  if (!s) return false;
  rtcOccluded1(s, &ctx, &r);
  return r.tfar < 0;  // Embree sets tfar = -inf on a hit
}

void EmbreeScene::Intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  MR_CHECK(impl_->committed);
  MR_CHECK_EQ(rays.size(), hits.size());
  std::vector<RTCRayHit> rh(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) {
    ToRTC(rays[i], &rh[i].ray);
    rh[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh[i].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  }
  impl_->Stream(
      rays, reinterpret_cast<char*>(rh.data()), sizeof(RTCRayHit),
      [](RTCScene s, RTCIntersectContext* ctx, char* p, unsigned n) {
        rtcIntersect1M(s, ctx, reinterpret_cast<RTCRayHit*>(p), n, sizeof(RTCRayHit));
      },
      [](RTCScene s, RTCIntersectContext* ctx, void** p, unsigned n) {
        rtcIntersect1Mp(s, ctx, reinterpret_cast<RTCRayHit**>(p), n);
      });
  for (size_t i = 0; i < rays.size(); ++i) impl_->Fill(rh[i], &hits[i]);
}

void EmbreeScene::Occluded(std::span<const Ray> rays, std::span<char> occluded) const {
  MR_CHECK(impl_->committed);
  MR_CHECK_EQ(rays.size(), occluded.size());
  std::vector<RTCRay> r(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) ToRTC(rays[i], &r[i]);
  impl_->Stream(
      rays, reinterpret_cast<char*>(r.data()), sizeof(RTCRay),
      [](RTCScene s, RTCIntersectContext* ctx, char* p, unsigned n) {
        rtcOccluded1M(s, ctx, reinterpret_cast<RTCRay*>(p), n, sizeof(RTCRay));
      },
      [](RTCScene s, RTCIntersectContext* ctx, void** p, unsigned n) {
        rtcOccluded1Mp(s, ctx, reinterpret_cast<RTCRay**>(p), n);
      });
  for (size_t i = 0; i < rays.size(); ++i) occluded[i] = r[i].tfar < 0;
}

void EmbreeScene::IntersectPacket8(std::span<const Ray> rays, std::span<Hit> hits) const {
  MR_CHECK(impl_->committed);
  MR_CHECK(rays.size() <= 8 && rays.size() == hits.size());
  alignas(32) int valid[8];
  alignas(32) RTCRayHit8 rh;
  std::memset(&rh, 0, sizeof(rh));
  for (int i = 0; i < 8; ++i) {
    const bool active = static_cast<size_t>(i) < rays.size();
    valid[i] = active ? -1 : 0;
    rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    if (!active) continue;
    const Ray& r = rays[static_cast<size_t>(i)];
    rh.ray.org_x[i] = r.origin.x();
    rh.ray.org_y[i] = r.origin.y();
    rh.ray.org_z[i] = r.origin.z();
    rh.ray.dir_x[i] = r.direction.x();
    rh.ray.dir_y[i] = r.direction.y();
    rh.ray.dir_z[i] = r.direction.z();
    rh.ray.tnear[i] = r.tnear;
    rh.ray.tfar[i] = r.tfar;
    rh.ray.mask[i] = r.mask;
  }
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  // One scene for the packet: a kind's part where every ray sees that kind only.
  bool one_mask = true;
  for (const Ray& r : rays) one_mask = one_mask && r.mask == rays[0].mask;
  RTCScene s = one_mask && !rays.empty() ? impl_->For(rays[0].mask) : impl_->scene;
  if (s) rtcIntersect8(valid, s, &ctx, &rh);
  for (size_t i = 0; i < rays.size(); ++i) {
    RTCRayHit one;
    one.ray.tfar = rh.ray.tfar[i];
    one.hit.u = rh.hit.u[i];
    one.hit.v = rh.hit.v[i];
    one.hit.Ng_x = rh.hit.Ng_x[i];
    one.hit.Ng_y = rh.hit.Ng_y[i];
    one.hit.Ng_z = rh.hit.Ng_z[i];
    one.hit.geomID = rh.hit.geomID[i];
    one.hit.primID = rh.hit.primID[i];
    one.hit.instID[0] = rh.hit.instID[0][i];
    impl_->Fill(one, &hits[i]);
  }
}

Eigen::AlignedBox3f EmbreeScene::Bounds() const {
  MR_CHECK(impl_->committed);
  alignas(16) RTCBounds b;
  rtcGetSceneBounds(impl_->scene, &b);
  return Eigen::AlignedBox3f(Eigen::Vector3f(b.lower_x, b.lower_y, b.lower_z),
                             Eigen::Vector3f(b.upper_x, b.upper_y, b.upper_z));
}

}  // namespace mr
