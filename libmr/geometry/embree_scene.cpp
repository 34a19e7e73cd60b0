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

}  // namespace

// Two scenes: the real geometry (parts[0]) and the virtual (parts[1]).  A
// ray that sees one kind only (kMaskReal, kMaskVirtual) traverses that
// kind's tree alone: a mask is tested at the primitives, after the
// traversal, so in one tree of both a virtual blocker test in a fused room
// of 700 000 triangles would walk the room's tree.  A ray that sees both
// meets the virtual part first, then the real part up to what it met there
// (the closest hit of the two; an occlusion test stops at the first).  A
// moved object rebuilds the virtual part alone: the room's tree is built
// once (0.13-0.15 s a frame for that room on 2 threads otherwise).  Ids are
// assigned here, unique over both parts.
struct EmbreeScene::Impl {
  std::string error;
  RTCDevice device = nullptr;
  struct Part {
    RTCScene scene = nullptr;
    size_t count = 0;    // geometries in it
    bool dirty = false;  // changed since its last commit
  };
  Part parts[2];  // [0] real, [1] virtual
  std::vector<RTCScene> prototypes;
  std::vector<std::unique_ptr<HitFilter>> filters;  // user data of the prototypes' filters
  std::vector<char> is_virtual;                     // by geometry id
  std::vector<char> is_instance;                    // by geometry id
  bool committed = false;

  void Check(const char* what) {
    if (!error.empty()) {
      std::string e = std::move(error);
      error.clear();
      ThrowError("Embree: {}: {}", what, e);
    }
  }
  // Masks, commits and attaches `g` to its kind's part; its id.
  uint32_t Attach(RTCGeometry g, bool virt, bool instance, const char* what) {
    const auto id = static_cast<uint32_t>(is_virtual.size());
    Part& part = parts[virt ? 1 : 0];
    rtcSetGeometryMask(g, virt ? kMaskVirtual : kMaskReal);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(part.scene, g, id);
    rtcReleaseGeometry(g);
    ++part.count;
    part.dirty = true;
    Check(what);
    is_virtual.push_back(virt);
    is_instance.push_back(instance);
    return id;
  }
  RTCGeometry Geometry(uint32_t id) const { return rtcGetGeometry(parts[is_virtual[id] ? 1 : 0].scene, id); }
  // The parts a ray with `mask` meets, in order: bit 1 the virtual, bit 0
  // the real (kMaskVirtual's and kMaskReal's bits); 0: nothing.
  unsigned Route(uint32_t mask) const {
    return (mask & kMaskVirtual && parts[1].count ? kMaskVirtual : 0u) |
           (mask & kMaskReal && parts[0].count ? kMaskReal : 0u);
  }
  // Runs the stream `records` (one per ray of `rays`, `stride` bytes apart)
  // through each part its rays meet, the virtual part first: through
  // `whole(scene, ctx, first, n)` where every ray meets that part, else
  // through `by_pointer(scene, ctx, pointers, n)` over those that do.  A
  // closest-hit query's second part sees the first part's hit as tfar, an
  // occlusion query's sees a blocked ray as inactive (tfar -inf).
  template <class Whole, class ByPointer>
  void Stream(std::span<const Ray> rays, char* records, size_t stride, Whole&& whole, ByPointer&& by_pointer) const {
    if (rays.empty()) return;
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    std::vector<void*> pointers;
    for (const unsigned bit : {unsigned{kMaskVirtual}, unsigned{kMaskReal}}) {
      RTCScene s = parts[bit == kMaskVirtual ? 1 : 0].scene;
      size_t meet = 0;
      for (const Ray& r : rays) meet += (Route(r.mask) & bit) != 0;
      if (meet == rays.size()) {
        whole(s, &ctx, records, static_cast<unsigned>(rays.size()));
      } else if (meet) {
        pointers.clear();
        for (size_t i = 0; i < rays.size(); ++i)
          if (Route(rays[i].mask) & bit) pointers.push_back(records + i * stride);
        by_pointer(s, &ctx, pointers.data(), static_cast<unsigned>(pointers.size()));
      }
    }
  }
  void Fill(const RTCRayHit& rh, Hit* hit) const {
    *hit = Hit();
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return;
    // For an instance, instID[0] is its id in its part.
    const uint32_t id = rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID ? rh.hit.instID[0] : rh.hit.geomID;
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
  for (auto& part : impl_->parts) {
    part.scene = rtcNewScene(impl_->device);
    rtcSetSceneFlags(part.scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(part.scene, RTC_BUILD_QUALITY_HIGH);
  }
  impl_->Check("creating the scene");
}

EmbreeScene::~EmbreeScene() {
  for (auto& part : impl_->parts)
    if (part.scene) rtcReleaseScene(part.scene);
  for (RTCScene s : impl_->prototypes) rtcReleaseScene(s);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

uint32_t EmbreeScene::AddMesh(const Mesh& mesh, bool is_virtual) {
  MR_CHECK(!impl_->committed);
  return impl_->Attach(MakeTriangleGeometry(impl_->device, mesh), is_virtual, false, "adding a mesh");
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
  RTCGeometry g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_INSTANCE);
  rtcSetGeometryInstancedScene(g, impl_->prototypes[prototype]);
  Eigen::Matrix<float, 3, 4> m = world_from_object.matrix().topRows<3>();
  rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, m.data());  // column-major 3x4
  return impl_->Attach(g, /*virt=*/true, /*instance=*/true, "adding an instance");
}

void EmbreeScene::SetInstanceTransform(uint32_t id, const Eigen::Affine3f& world_from_object) {
  MR_CHECK(id < impl_->is_instance.size() && impl_->is_instance[id]);
  if (!world_from_object.matrix().allFinite()) ThrowError("instance transform has NaN or Inf");
  RTCGeometry g = impl_->Geometry(id);
  if (std::abs(world_from_object.linear().determinant()) < 1e-20f) {
    rtcDisableGeometry(g);
  } else {
    rtcEnableGeometry(g);
    Eigen::Matrix<float, 3, 4> m = world_from_object.matrix().topRows<3>();
    rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, m.data());
  }
  rtcCommitGeometry(g);
  impl_->parts[1].dirty = true;
  impl_->Check("moving an instance");
  impl_->committed = false;
}

void EmbreeScene::Commit() {
  for (auto& part : impl_->parts)
    if (part.dirty) {
      rtcCommitScene(part.scene);
      part.dirty = false;
    }
  impl_->Check("building the scene");
  impl_->committed = true;
}

size_t EmbreeScene::geometry_count() const { return impl_->is_virtual.size(); }

bool EmbreeScene::Intersect(const Ray& ray, Hit* hit) const {
  MR_CHECK(impl_->committed);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  ToRTC(ray, &rh.ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  const unsigned route = impl_->Route(ray.mask);
  if (route & kMaskVirtual) rtcIntersect1(impl_->parts[1].scene, &ctx, &rh);
  if (route & kMaskReal) rtcIntersect1(impl_->parts[0].scene, &ctx, &rh);  // up to the virtual hit
  impl_->Fill(rh, hit);
  return hit->valid();
}

bool EmbreeScene::Occluded(const Ray& ray) const {
  MR_CHECK(impl_->committed);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  ToRTC(ray, &r);
  const unsigned route = impl_->Route(ray.mask);
  if (route & kMaskVirtual) rtcOccluded1(impl_->parts[1].scene, &ctx, &r);
  if (route & kMaskReal && !(r.tfar < 0)) rtcOccluded1(impl_->parts[0].scene, &ctx, &r);
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
  // Each part over the rays that meet it, the virtual part first (Stream).
  for (const unsigned bit : {unsigned{kMaskVirtual}, unsigned{kMaskReal}}) {
    alignas(32) int meet[8];
    bool any = false;
    for (size_t i = 0; i < 8; ++i) {
      meet[i] = valid[i] && i < rays.size() && impl_->Route(rays[i].mask) & bit ? -1 : 0;
      any = any || meet[i];
    }
    if (any) rtcIntersect8(meet, impl_->parts[bit == kMaskVirtual ? 1 : 0].scene, &ctx, &rh);
  }
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
  Eigen::AlignedBox3f box;
  for (const auto& part : impl_->parts) {
    if (!part.count) continue;
    alignas(16) RTCBounds b;
    rtcGetSceneBounds(part.scene, &b);
    box.extend(Eigen::Vector3f(b.lower_x, b.lower_y, b.lower_z));
    box.extend(Eigen::Vector3f(b.upper_x, b.upper_y, b.upper_z));
  }
  return box;
}

}  // namespace mr
