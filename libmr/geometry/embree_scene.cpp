#include "geometry/embree_scene.h"

#include <embree3/rtcore.h>

#include <cstring>
#include <mutex>
#include <string>

#include <fmt/format.h>
#include <fmt/ranges.h>

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

// Whether the ray's segment [tnear, tfar] meets `box` (slab test; an axis
// the ray is parallel to gives inf or NaN bounds, which std::max and
// std::min pass over: conservative, never a false miss for a grown box).
bool MeetsBox(const Ray& r, const Eigen::AlignedBox3f& box) {
  float t0 = r.tnear, t1 = r.tfar;
  for (int k = 0; k < 3; ++k) {
    const float inv = 1.0f / r.direction[k];
    float a = (box.min()[k] - r.origin[k]) * inv, b = (box.max()[k] - r.origin[k]) * inv;
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return t0 <= t1;
}

}  // namespace

// Three scenes: the real geometry (parts[0]), the virtual (parts[1]), and
// both (parts[2]: twins of every geometry under the same ids; Embree 3
// attaches a geometry to one scene only, and a triangle twin shares its
// buffers).  A ray that sees one kind only (kMaskReal, kMaskVirtual)
// traverses that kind's tree alone: a mask is tested at the primitives,
// after the traversal, so in one tree of both a virtual blocker test in a
// fused room of 700 000 triangles would walk the room's tree.  A ray that
// sees both traverses parts[2], one tree.  A moved object would rebuild
// that tree, room and all (0.13-0.15 s a frame for that room on 2
// threads): past kRebuildBothUpTo real triangles the first move drops
// parts[2] instead, and from then on a ray that sees both meets the
// virtual part, then the real part up to what it met there (the closest
// hit of the two; an occlusion test stops at the first), two calls into
// Embree.  docs/benchmarks.md, "Each kind of ray in its own tree".  Ids are
// assigned here, unique over the parts.
struct EmbreeScene::Impl {
  static constexpr size_t kRebuildBothUpTo = 100000;  // real triangles: some 20 ms a rebuild on 2 cores
  static constexpr unsigned kBoth = 4;                // Route's bit for parts[2]
  std::string error;
  RTCDevice device = nullptr;
  struct Part {
    RTCScene scene = nullptr;
    size_t count = 0;         // geometries in it
    bool dirty = false;       // changed since its last commit
    Eigen::AlignedBox3f box;  // its bounds, grown by 1e-4 of their diagonal
  };
  Part parts[3];                   // [0] real, [1] virtual, [2] both (null once dropped)
  std::vector<RTCGeometry> twins;  // by geometry id: its twin in parts[2]
  size_t real_triangles = 0;
  bool moved = false;           // an object moved since the last commit
  bool committed_once = false;  // Commit() ran
  std::string last_commit;      // EmbreeScene::last_commit()
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
  // Masks, commits and attaches `g` to its kind's part and `twin` to
  // parts[2] under one id; its id.
  uint32_t Attach(RTCGeometry g, RTCGeometry twin, bool virt, bool instance, const char* what) {
    const auto id = static_cast<uint32_t>(is_virtual.size());
    for (const int k : {virt ? 1 : 0, 2}) {
      RTCGeometry gk = k == 2 ? twin : g;
      Part& part = parts[k];
      rtcSetGeometryMask(gk, virt ? kMaskVirtual : kMaskReal);
      rtcCommitGeometry(gk);
      if (part.scene) {
        rtcAttachGeometryByID(part.scene, gk, id);
        ++part.count;
        part.dirty = true;
      }
      rtcReleaseGeometry(gk);
    }
    Check(what);
    twins.push_back(parts[2].scene ? twin : nullptr);
    is_virtual.push_back(virt);
    is_instance.push_back(instance);
    return id;
  }
  // The scenes a ray meets, in order: kBoth (parts[2]) alone, or the
  // virtual part (kMaskVirtual's bit) and then the real one (kMaskReal's);
  // 0: nothing.  A ray that misses the objects' bounds does not meet their
  // part (a slab test costs less than a call into Embree).
  unsigned Route(const Ray& r) const {
    const bool real = r.mask & kMaskReal && parts[0].count, virt = r.mask & kMaskVirtual && parts[1].count;
    if (real && virt && parts[2].scene) return kBoth;
    return (virt && MeetsBox(r, parts[1].box) ? kMaskVirtual : 0u) | (real ? kMaskReal : 0u);
  }
  RTCScene SceneOf(unsigned bit) const { return parts[bit == kBoth ? 2 : bit == kMaskVirtual ? 1 : 0].scene; }
  // Runs the stream `records` (one per ray of `rays`, `stride` bytes apart)
  // through each scene its rays meet, in Route's order: through
  // `whole(scene, ctx, first, n)` where every ray meets that scene, else
  // through `by_pointer(scene, ctx, pointers, n)` over those that do.  A
  // closest-hit query's real part sees the virtual part's hit as tfar, an
  // occlusion query's sees a blocked ray as inactive (tfar -inf).
  template <class Whole, class ByPointer>
  void Stream(std::span<const Ray> rays, char* records, size_t stride, Whole&& whole, ByPointer&& by_pointer) const {
    if (rays.empty()) return;
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    std::vector<unsigned> route(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) route[i] = Route(rays[i]);
    std::vector<void*> pointers;
    for (const unsigned bit : {kBoth, unsigned{kMaskVirtual}, unsigned{kMaskReal}}) {
      size_t meet = 0;
      for (unsigned r : route) meet += (r & bit) != 0;
      if (meet == rays.size()) {
        whole(SceneOf(bit), &ctx, records, static_cast<unsigned>(rays.size()));
      } else if (meet) {
        pointers.clear();
        for (size_t i = 0; i < rays.size(); ++i)
          if (route[i] & bit) pointers.push_back(records + i * stride);
        by_pointer(SceneOf(bit), &ctx, pointers.data(), static_cast<unsigned>(pointers.size()));
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
  for (auto& part : impl_->parts) {  // parts[2] holds twins of both kinds
    part.scene = rtcNewScene(impl_->device);
    rtcSetSceneFlags(part.scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(part.scene, RTC_BUILD_QUALITY_HIGH);
  }
  impl_->Check("creating the scene");
}

EmbreeScene::~EmbreeScene() {
  for (int k : {2, 1, 0})  // the twins before the geometry whose buffers they share
    if (impl_->parts[k].scene) rtcReleaseScene(impl_->parts[k].scene);
  for (RTCScene s : impl_->prototypes) rtcReleaseScene(s);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

uint32_t EmbreeScene::AddMesh(const Mesh& mesh, bool is_virtual) {
  MR_CHECK(!impl_->committed);
  RTCGeometry g = MakeTriangleGeometry(impl_->device, mesh);
  if (!is_virtual) impl_->real_triangles += mesh.triangles.size();
  return impl_->Attach(g, TwinTriangles(impl_->device, g, mesh), is_virtual, false, "adding a mesh");
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
  const Eigen::Matrix<float, 3, 4> m = world_from_object.matrix().topRows<3>();
  for (RTCGeometry& gi : g) {
    gi = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(gi, impl_->prototypes[prototype]);
    rtcSetGeometryTransform(gi, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, m.data());  // column-major 3x4
  }
  return impl_->Attach(g[0], g[1], /*virt=*/true, /*instance=*/true, "adding an instance");
}

void EmbreeScene::SetInstanceTransform(uint32_t id, const Eigen::Affine3f& world_from_object) {
  MR_CHECK(id < impl_->is_instance.size() && impl_->is_instance[id]);
  if (!world_from_object.matrix().allFinite()) ThrowError("instance transform has NaN or Inf");
  Impl& im = *impl_;
  const bool singular = std::abs(world_from_object.linear().determinant()) < 1e-20f;
  const Eigen::Matrix<float, 3, 4> m = world_from_object.matrix().topRows<3>();
  for (RTCGeometry g : {rtcGetGeometry(im.parts[1].scene, id), im.parts[2].scene ? im.twins[id] : nullptr}) {
    if (!g) continue;
    if (singular) {
      rtcDisableGeometry(g);
    } else {
      rtcEnableGeometry(g);
      rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, m.data());
    }
    rtcCommitGeometry(g);
  }
  im.parts[1].dirty = im.parts[2].dirty = true;
  im.moved = im.moved || im.committed_once;  // placing an object before the first commit is no move
  impl_->Check("moving an instance");
  impl_->committed = false;
}

void EmbreeScene::Commit() {
  Impl& im = *impl_;
  std::string dropped;
  if (im.moved && im.parts[2].scene && im.real_triangles > Impl::kRebuildBothUpTo) {
    rtcReleaseScene(im.parts[2].scene);  // and its twins with it
    im.parts[2] = Impl::Part();
    std::fill(im.twins.begin(), im.twins.end(), nullptr);
    dropped = fmt::format(
        "; the tree of both dropped: the room has {} triangles (past {} a rebuild costs more than a ray of both "
        "kinds meeting the objects' tree and then the room's)",
        im.real_triangles, Impl::kRebuildBothUpTo);
  }
  im.moved = false;
  std::vector<std::string> built, kept;
  const char* names[3] = {"the room's tree", "the objects' tree", "the tree of both"};
  for (int k = 0; k < 3; ++k) {
    const Impl::Part& part = im.parts[k];
    if (part.scene && part.count) (part.dirty ? built : kept).push_back(names[k]);
  }
  im.last_commit = built.empty() ? "nothing rebuilt" : fmt::format("{} rebuilt", fmt::join(built, " and "));
  if (!kept.empty()) im.last_commit += fmt::format("; {} kept", fmt::join(kept, " and "));
  im.last_commit += dropped;
  for (auto& part : im.parts)
    if (part.scene && part.dirty) {
      rtcCommitScene(part.scene);
      part.dirty = false;
      alignas(16) RTCBounds b;
      rtcGetSceneBounds(part.scene, &b);
      part.box = Eigen::AlignedBox3f(Eigen::Vector3f(b.lower_x, b.lower_y, b.lower_z),
                                     Eigen::Vector3f(b.upper_x, b.upper_y, b.upper_z));
      if (!part.box.isEmpty()) {
        const float grow = 1e-4f * part.box.diagonal().norm() + 1e-6f;
        part.box.extend(part.box.min() - Eigen::Vector3f::Constant(grow));
        part.box.extend(part.box.max() + Eigen::Vector3f::Constant(grow));
      }
    }
  impl_->Check("building the scene");
  impl_->committed = im.committed_once = true;
}

size_t EmbreeScene::geometry_count() const { return impl_->is_virtual.size(); }

const std::string& EmbreeScene::last_commit() const { return impl_->last_commit; }

bool EmbreeScene::Intersect(const Ray& ray, Hit* hit) const {
  MR_CHECK(impl_->committed);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  ToRTC(ray, &rh.ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  const unsigned route = impl_->Route(ray);
  for (const unsigned bit :
       {Impl::kBoth, unsigned{kMaskVirtual}, unsigned{kMaskReal}})  // the real part up to the virtual hit
    if (route & bit) rtcIntersect1(impl_->SceneOf(bit), &ctx, &rh);
  impl_->Fill(rh, hit);
  return hit->valid();
}

bool EmbreeScene::Occluded(const Ray& ray) const {
  MR_CHECK(impl_->committed);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  ToRTC(ray, &r);
  const unsigned route = impl_->Route(ray);
  for (const unsigned bit : {Impl::kBoth, unsigned{kMaskVirtual}, unsigned{kMaskReal}})
    if (route & bit && !(r.tfar < 0)) rtcOccluded1(impl_->SceneOf(bit), &ctx, &r);
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
  // Each scene over the rays that meet it, in Route's order (Stream).
  unsigned route[8] = {};
  for (size_t i = 0; i < rays.size(); ++i) route[i] = impl_->Route(rays[i]);
  for (const unsigned bit : {Impl::kBoth, unsigned{kMaskVirtual}, unsigned{kMaskReal}}) {
    alignas(32) int meet[8];
    bool any = false;
    for (size_t i = 0; i < 8; ++i) {
      meet[i] = route[i] & bit ? -1 : 0;  // 0 past the packet's rays
      any = any || meet[i];
    }
    if (any) rtcIntersect8(meet, impl_->SceneOf(bit), &ctx, &rh);
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
