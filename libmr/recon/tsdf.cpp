#include "recon/tsdf.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numeric>
#include <unordered_map>

#include "core/error.h"
#include "core/hash.h"
#include "core/parallel.h"

namespace mr {

namespace {

constexpr int kB = TsdfVolume::kBlock;
constexpr int kVoxelsPerBlock = kB * kB * kB;
constexpr int kKeyBits = 21;
constexpr int64_t kKeyOffset = int64_t{1} << (kKeyBits - 1);

uint64_t PackKey(const Eigen::Vector3i& c) {
  const uint64_t m = (uint64_t{1} << kKeyBits) - 1;
  return ((static_cast<uint64_t>(c.x() + kKeyOffset) & m) << (2 * kKeyBits)) |
         ((static_cast<uint64_t>(c.y() + kKeyOffset) & m) << kKeyBits) |
         (static_cast<uint64_t>(c.z() + kKeyOffset) & m);
}

struct KeyHash {
  size_t operator()(uint64_t x) const { return static_cast<size_t>(MixBits(x)); }
};

int FloorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

Eigen::Vector3i BlockOf(const Eigen::Vector3i& v) {
  return {FloorDiv(v.x(), kB), FloorDiv(v.y(), kB), FloorDiv(v.z(), kB)};
}

int LocalIndex(const Eigen::Vector3i& v, const Eigen::Vector3i& b) {
  const Eigen::Vector3i l = v - b * kB;
  return l.x() + kB * (l.y() + kB * l.z());
}

bool BoxEmpty(const Eigen::AlignedBox3f& b) { return b.isEmpty(); }

// Open addressing with linear probing: block lookups dominate raycasting,
// and a flat table is several times faster than std::unordered_map's nodes.
class BlockIndex {
 public:
  static constexpr uint64_t kEmpty = ~uint64_t{0};
  int32_t Find(uint64_t key) const {
    if (slots_.empty()) return -1;
    for (size_t i = KeyHash{}(key)&mask_;; i = (i + 1) & mask_) {
      const Slot& s = slots_[i];
      if (s.key == key) return s.value;
      if (s.key == kEmpty) return -1;
    }
  }
  void Insert(uint64_t key, int32_t value) {
    if ((size_ + 1) * 2 > slots_.size()) Grow();
    Put(key, value);
    ++size_;
  }
  size_t bytes() const { return slots_.size() * sizeof(Slot); }

 private:
  struct Slot {
    uint64_t key = kEmpty;
    int32_t value = -1;
  };
  void Put(uint64_t key, int32_t value) {
    for (size_t i = KeyHash{}(key)&mask_;; i = (i + 1) & mask_)
      if (slots_[i].key == kEmpty) {
        slots_[i] = {key, value};
        return;
      }
  }
  void Grow() {
    std::vector<Slot> old = std::move(slots_);
    slots_.assign(std::max<size_t>(1024, old.size() * 2), Slot{});
    mask_ = slots_.size() - 1;
    for (const Slot& s : old)
      if (s.key != kEmpty) Put(s.key, s.value);
  }
  std::vector<Slot> slots_;
  size_t mask_ = 0, size_ = 0;
};

}  // namespace

struct TsdfVolume::Impl {
  BlockIndex index;
  std::vector<Eigen::Vector3i> coords;
  std::vector<Voxel> voxels;

  int32_t Find(const Eigen::Vector3i& b) const { return index.Find(PackKey(b)); }
  // A one-block cache: rays and cells mostly stay inside one block.
  struct Cache {
    Eigen::Vector3i block{std::numeric_limits<int>::min(), 0, 0};
    const Voxel* data = nullptr;
  };
  const Voxel* VoxelAt(const Eigen::Vector3i& v, Cache& c) const {
    const Eigen::Vector3i b = BlockOf(v);
    if (b != c.block) {
      c.block = b;
      const int32_t i = Find(b);
      c.data = i < 0 ? nullptr : &voxels[static_cast<size_t>(i) * kVoxelsPerBlock];
    }
    return c.data ? c.data + LocalIndex(v, b) : nullptr;
  }
};

TsdfVolume::TsdfVolume(const TsdfOptions& options) : options_(options), impl_(std::make_unique<Impl>()) {
  if (!(options.voxel_size > 0) || !std::isfinite(options.voxel_size))
    ThrowError("voxel size must be positive, got {}", options.voxel_size);
  trunc_ = options.truncation > 0 ? options.truncation : std::max(4 * options.voxel_size, 0.015f);
}
TsdfVolume::~TsdfVolume() = default;
TsdfVolume::TsdfVolume(TsdfVolume&&) noexcept = default;
TsdfVolume& TsdfVolume::operator=(TsdfVolume&&) noexcept = default;

int64_t TsdfVolume::block_count() const { return static_cast<int64_t>(impl_->coords.size()); }

int64_t TsdfVolume::MemoryBytes() const {
  const int64_t n = block_count();
  // Voxels, block coordinates, and the hash map's nodes and buckets (approximate).
  return n * kVoxelsPerBlock * static_cast<int64_t>(sizeof(Voxel)) + n * static_cast<int64_t>(sizeof(Eigen::Vector3i)) +
         static_cast<int64_t>(impl_->index.bytes());
}

std::vector<int32_t> TsdfVolume::AllocateBand(const DepthMap& depth, const PinholeIntrinsics& K,
                                              const Rigid3& world_from_cam, IntegrateStats* stats) {
  const float vs = options_.voxel_size;
  const float block_m = vs * kB;
  const Eigen::Matrix3f R = world_from_cam.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f t = world_from_cam.translation.cast<float>();
  const int rows = depth.height;
  std::vector<std::vector<uint64_t>> per_row(static_cast<size_t>(rows));
  ParallelFor(0, rows, [&](int64_t yi) {
    const int y = static_cast<int>(yi);
    std::vector<uint64_t>& keys = per_row[static_cast<size_t>(y)];
    uint64_t last = ~uint64_t{0};
    for (int x = 0; x < depth.width; ++x) {
      const float d = depth.at(x, y);
      if (!(d > 0)) continue;
      const Eigen::Vector3f dir_c(static_cast<float>((x - K.cx) / K.fx), static_cast<float>((y - K.cy) / K.fy), 1.0f);
      const Eigen::Vector3f dir = R * dir_c;
      // Along-ray band [d - trunc, d + trunc] in z, sampled at half a block.
      const float z0 = std::max(d - trunc_, 0.05f), z1 = d + trunc_;
      const float step = 0.5f * block_m / dir_c.norm();
      for (float z = z0;; z += step) {
        const float zz = std::min(z, z1);
        const Eigen::Vector3f p = t + dir * zz;
        const Eigen::Vector3i v(static_cast<int>(std::floor(p.x() / vs + 0.5f)),
                                static_cast<int>(std::floor(p.y() / vs + 0.5f)),
                                static_cast<int>(std::floor(p.z() / vs + 0.5f)));
        const uint64_t k = PackKey(BlockOf(v));
        if (k != last) keys.push_back(k);
        last = k;
        if (zz >= z1) break;
      }
    }
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  });
  std::vector<uint64_t> keys;
  for (auto& r : per_row) keys.insert(keys.end(), r.begin(), r.end());
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());

  std::vector<int32_t> out;
  out.reserve(keys.size());
  const uint64_t m = (uint64_t{1} << kKeyBits) - 1;
  const bool roi = !BoxEmpty(options_.roi);
  for (uint64_t k : keys) {
    if (const int32_t found = impl_->index.Find(k); found >= 0) {
      out.push_back(found);
      continue;
    }
    const Eigen::Vector3i b(static_cast<int>(static_cast<int64_t>((k >> (2 * kKeyBits)) & m) - kKeyOffset),
                            static_cast<int>(static_cast<int64_t>((k >> kKeyBits) & m) - kKeyOffset),
                            static_cast<int>(static_cast<int64_t>(k & m) - kKeyOffset));
    if (roi) {
      // The block's voxel centres span [b*8, b*8+7] * vs.
      const Eigen::AlignedBox3f box(
          b.cast<float>() * block_m - Eigen::Vector3f::Constant(0.5f * vs),
          (b.cast<float>() + Eigen::Vector3f::Ones()) * block_m - Eigen::Vector3f::Constant(0.5f * vs));
      if (!box.intersects(options_.roi)) {
        if (stats) ++stats->blocks_refused;
        continue;
      }
    }
    if (block_count() >= options_.max_blocks) {
      if (stats) ++stats->blocks_refused;
      continue;
    }
    const auto id = static_cast<int32_t>(impl_->coords.size());
    impl_->index.Insert(k, id);
    impl_->coords.push_back(b);
    impl_->voxels.resize(impl_->voxels.size() + kVoxelsPerBlock);
    out.push_back(id);
    if (stats) ++stats->blocks_new;
  }
  if (stats) stats->blocks_touched += static_cast<int64_t>(out.size());
  return out;
}

void TsdfVolume::Integrate(const std::vector<int32_t>& blocks, const DepthMap& depth, const Image* color,
                           const PinholeIntrinsics& K, const Rigid3& world_from_cam, IntegrateStats* stats) {
  const float vs = options_.voxel_size;
  const Rigid3 cam_from_world = world_from_cam.Inverse();
  const Eigen::Matrix3f R = cam_from_world.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f t = cam_from_world.translation.cast<float>();
  const float fx = static_cast<float>(K.fx), fy = static_cast<float>(K.fy), cx = static_cast<float>(K.cx),
              cy = static_cast<float>(K.cy);
  const float max_w = options_.max_weight, tr = trunc_;
  std::atomic<int64_t> updated{0};
  ParallelFor(0, static_cast<int64_t>(blocks.size()), [&](int64_t bi) {
    const int32_t id = blocks[static_cast<size_t>(bi)];
    const Eigen::Vector3i b = impl_->coords[static_cast<size_t>(id)];
    Voxel* vox = &impl_->voxels[static_cast<size_t>(id) * kVoxelsPerBlock];
    int64_t n = 0;
    // Voxel (x, y, z) of the block in the camera frame: p0 + x ex + y ey + z ez
    // (scalars in the loop: it is the hot one of fusion).
    const Eigen::Vector3f p0 = R * ((b * kB).cast<float>() * vs) + t;
    const Eigen::Vector3f ex = R.col(0) * vs, ey = R.col(1) * vs, ez = R.col(2) * vs;
    for (int z = 0; z < kB; ++z)
      for (int y = 0; y < kB; ++y) {
        const float rx = p0.x() + y * ey.x() + z * ez.x(), ry = p0.y() + y * ey.y() + z * ez.y(),
                    rz = p0.z() + y * ey.z() + z * ez.z();
        for (int x = 0; x < kB; ++x) {
          const float pcx = rx + x * ex.x(), pcy = ry + x * ex.y(), pcz = rz + x * ex.z();
          if (pcz <= 0.01f) continue;
          const int u = static_cast<int>(std::lround(fx * pcx / pcz + cx));
          const int v = static_cast<int>(std::lround(fy * pcy / pcz + cy));
          if (u < 0 || v < 0 || u >= depth.width || v >= depth.height) continue;
          const float d = depth.at(u, v);
          if (!(d > 0)) continue;
          const float sdf = d - pcz;
          if (sdf < -tr) continue;
          const float tsdf = std::min(1.0f, sdf / tr);
          Voxel& vx = vox[x + kB * (y + kB * z)];
          const float w = vx.weight, w1 = w + 1.0f;
          vx.sdf = (vx.sdf * w + tsdf) / w1;
          if (color) {
            vx.r = (vx.r * w + color->at(u, v, 0)) / w1;
            vx.g = (vx.g * w + color->at(u, v, 1)) / w1;
            vx.b = (vx.b * w + color->at(u, v, 2)) / w1;
          }
          vx.weight = std::min(w1, max_w);
          ++n;
        }
      }
    updated += n;
  });
  if (stats) stats->voxels_updated += updated.load();
}

bool TsdfVolume::Sample(const Eigen::Vector3f& p, float* sdf, float* weight, Eigen::Vector3f* color) const {
  Impl::Cache cache;
  return SampleCached(p, &cache, sdf, weight, color);
}

bool TsdfVolume::SampleCached(const Eigen::Vector3f& p, void* cache_ptr, float* sdf, float* weight,
                              Eigen::Vector3f* color) const {
  Impl::Cache& cache = *static_cast<Impl::Cache*>(cache_ptr);
  const Eigen::Vector3f g = p / options_.voxel_size;
  const Eigen::Vector3f f0 = g.array().floor();
  const Eigen::Vector3i base = f0.cast<int>();
  const Eigen::Vector3f f = g - f0;
  float s = 0, w = 0;
  Eigen::Vector3f c = Eigen::Vector3f::Zero();
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3i o(k & 1, (k >> 1) & 1, (k >> 2) & 1);
    const Voxel* v = impl_->VoxelAt(base + o, cache);
    if (!v || v->weight <= 0) return false;
    const float a = (o.x() ? f.x() : 1 - f.x()) * (o.y() ? f.y() : 1 - f.y()) * (o.z() ? f.z() : 1 - f.z());
    s += a * v->sdf;
    w += a * v->weight;
    c += a * Eigen::Vector3f(v->r, v->g, v->b);
  }
  *sdf = s;
  if (weight) *weight = w;
  if (color) *color = c;
  return true;
}

PointMaps TsdfVolume::Raycast(const PinholeIntrinsics& K, const Rigid3& world_from_cam, float near_m, float far_m,
                              const DepthMap* hint) const {
  PointMaps maps;
  maps.width = K.width;
  maps.height = K.height;
  const size_t n = static_cast<size_t>(K.width) * static_cast<size_t>(K.height);
  const Eigen::Vector3f nan = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  maps.vertices.assign(n, nan);
  maps.normals.assign(n, nan);
  const float vs = options_.voxel_size, block_m = vs * kB, tr = trunc_;
  const Eigen::Matrix3f R = world_from_cam.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f o = world_from_cam.translation.cast<float>();
  ParallelFor(0, K.height, [&](int64_t yi) {
    const int y = static_cast<int>(yi);
    Impl::Cache cache;
    for (int x = 0; x < K.width; ++x) {
      const Eigen::Vector3f dc(static_cast<float>((x - K.cx) / K.fx), static_cast<float>((y - K.cy) / K.fy), 1.0f);
      const Eigen::Vector3f d = (R * dc).normalized();
      float t = near_m, prev_t = -1, prev_s = 0;
      if (hint && hint->width == K.width && hint->height == K.height) {
        if (!(hint->at(x, y) > 0)) continue;
        t = std::max(near_m, (hint->at(x, y) - 2 * tr) * dc.norm());
      }

      while (t < far_m) {
        const Eigen::Vector3f p = o + t * d;
        const Eigen::Vector3f g = p / vs;
        const Eigen::Vector3i v(static_cast<int>(std::floor(g.x() + 0.5f)), static_cast<int>(std::floor(g.y() + 0.5f)),
                                static_cast<int>(std::floor(g.z() + 0.5f)));
        const Voxel* vx = impl_->VoxelAt(v, cache);
        if (!vx) {
          // Leave the empty block: exact exit distance along the ray.
          const Eigen::Vector3i b = BlockOf(v);
          const Eigen::Vector3f lo = (b.cast<float>() * kB - Eigen::Vector3f::Constant(0.5f)) * vs;
          const Eigen::Vector3f hi = lo + Eigen::Vector3f::Constant(block_m);
          float exit = std::numeric_limits<float>::infinity();
          for (int a = 0; a < 3; ++a) {
            if (d[a] > 1e-8f)
              exit = std::min(exit, (hi[a] - p[a]) / d[a]);
            else if (d[a] < -1e-8f)
              exit = std::min(exit, (lo[a] - p[a]) / d[a]);
          }
          t += std::max(exit, 0.0f) + 0.01f * vs;
          prev_t = -1;
          continue;
        }
        if (vx->weight <= 0) {
          t += vs;
          prev_t = -1;
          continue;
        }
        const float s = vx->sdf;
        if (s > 0) {
          prev_t = t;
          prev_s = s;
          t += std::max(vs, 0.8f * s * tr);
          continue;
        }
        if (prev_t < 0) break;  // entered from behind or from unknown space
        // Refine the crossing with trilinear samples at both ends.
        float s0 = prev_s, s1 = s;
        float a = prev_t, bnd = t;
        float sa, sb;
        if (SampleCached(o + a * d, &cache, &sa) && SampleCached(o + bnd * d, &cache, &sb) && sa > 0 && sb <= 0) {
          s0 = sa;
          s1 = sb;
        }
        const float tc = a + (bnd - a) * s0 / (s0 - s1);
        const size_t i = static_cast<size_t>(y) * K.width + x;
        maps.vertices[i] = o + tc * d;
        break;
      }
    }
  });
  // Normals from the vertex map by central differences over at least a
  // voxel (k pixels, up to 4), facing the camera: a sixth of the cost of
  // the TSDF gradient.  Wider baselines would lose thin structure (table
  // legs, edges) that constrains tracking; the gated smoothing below takes
  // out the noise instead.
  const float fx = static_cast<float>(K.fx);
  constexpr float kNormalVoxels = 1.0f;
  ParallelFor(0, K.height, [&](int64_t yi) {
    const int y = static_cast<int>(yi);
    for (int x = 0; x < K.width; ++x) {
      const size_t i = static_cast<size_t>(y) * K.width + x;
      const Eigen::Vector3f& c = maps.vertices[i];
      if (!(c.x() == c.x())) continue;
      const int k = std::clamp(static_cast<int>(std::ceil(kNormalVoxels * vs * fx / (c - o).norm())), 1, 4);
      if (x < k || y < k || x + k >= K.width || y + k >= K.height) continue;
      const size_t dy = static_cast<size_t>(k) * K.width;
      const Eigen::Vector3f &l = maps.vertices[i - k], &r = maps.vertices[i + k], &u = maps.vertices[i - dy],
                            &dn = maps.vertices[i + dy];
      if (!(l.x() == l.x() && r.x() == r.x() && u.x() == u.x() && dn.x() == dn.x())) continue;
      const float gap = 2 * k * tr;  // no normals across depth discontinuities
      if ((r - l).squaredNorm() > gap * gap || (dn - u).squaredNorm() > gap * gap) continue;
      Eigen::Vector3f nrm = (dn - u).cross(r - l);
      if (nrm.squaredNorm() <= 0) continue;
      nrm.normalize();
      if (nrm.dot(c - o) > 0) nrm = -nrm;
      maps.normals[i] = nrm;
    }
  });
  // Average each normal with its 5x5 neighbours that agree within 30
  // degrees: the residual noise of the fused surface averages out (it would
  // otherwise read as constraints in the ICP's degeneracy test), creases
  // and edges stay sharp.
  std::vector<Eigen::Vector3f> smooth(maps.normals.size(),
                                      Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  const float cos_gate = std::cos(30.0f * static_cast<float>(M_PI) / 180.0f);
  ParallelFor(0, K.height, [&](int64_t yi) {
    const int y = static_cast<int>(yi);
    for (int x = 0; x < K.width; ++x) {
      const size_t i = static_cast<size_t>(y) * K.width + x;
      const Eigen::Vector3f& n0 = maps.normals[i];
      if (!(n0.x() == n0.x())) continue;
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= K.width || yy >= K.height) continue;
          const Eigen::Vector3f& nb = maps.normals[static_cast<size_t>(yy) * K.width + xx];
          if (nb.x() == nb.x() && nb.dot(n0) > cos_gate) sum += nb;
        }
      smooth[i] = sum.normalized();
    }
  });
  maps.normals = std::move(smooth);
  return maps;
}
namespace {

struct CellVertex {
  uint64_t key;
  Eigen::Vector3f p, n, c;
  float w;
};

}  // namespace

Mesh TsdfVolume::ExtractMesh(const MeshOptions& options, std::vector<float>* confidence, MeshStats* stats) const {
  const float vs = options_.voxel_size, min_w = options.min_weight;
  const bool roi = !BoxEmpty(options.roi);
  // Blocks in key order: the mesh does not depend on allocation order.
  std::vector<int32_t> order(impl_->coords.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int32_t a, int32_t b) {
    return PackKey(impl_->coords[static_cast<size_t>(a)]) < PackKey(impl_->coords[static_cast<size_t>(b)]);
  });
  // Corner values of cell m (min corner), or false when any is unknown.
  auto corners = [&](const Eigen::Vector3i& m, Impl::Cache& cache, const Voxel* out[8]) {
    for (int k = 0; k < 8; ++k) {
      const Voxel* v = impl_->VoxelAt(m + Eigen::Vector3i(k & 1, (k >> 1) & 1, (k >> 2) & 1), cache);
      if (!v || v->weight < min_w) return false;
      out[k] = v;
    }
    return true;
  };
  static const int kEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                    {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  std::vector<std::vector<CellVertex>> per_block(order.size());
  ParallelFor(0, static_cast<int64_t>(order.size()), [&](int64_t oi) {
    const Eigen::Vector3i b = impl_->coords[static_cast<size_t>(order[static_cast<size_t>(oi)])];
    Impl::Cache cache;
    auto& out = per_block[static_cast<size_t>(oi)];
    for (int z = 0; z < kB; ++z)
      for (int y = 0; y < kB; ++y)
        for (int x = 0; x < kB; ++x) {
          const Eigen::Vector3i m = b * kB + Eigen::Vector3i(x, y, z);
          const Voxel* c[8];
          if (!corners(m, cache, c)) continue;
          int inside = 0;
          for (int k = 0; k < 8; ++k) inside += c[k]->sdf < 0;
          if (inside == 0 || inside == 8) continue;
          Eigen::Vector3f sum = Eigen::Vector3f::Zero();
          int count = 0;
          for (const auto& e : kEdges) {
            const float s0 = c[e[0]]->sdf, s1 = c[e[1]]->sdf;
            if ((s0 < 0) == (s1 < 0) || std::abs(s0 - s1) > 1.0f) continue;  // no or a spurious crossing
            const Eigen::Vector3f p0(e[0] & 1, (e[0] >> 1) & 1, (e[0] >> 2) & 1);
            const Eigen::Vector3f p1(e[1] & 1, (e[1] >> 1) & 1, (e[1] >> 2) & 1);
            sum += p0 + (p1 - p0) * (s0 / (s0 - s1));
            ++count;
          }
          if (count == 0) continue;
          const Eigen::Vector3f f = sum / static_cast<float>(count);  // in the cell, [0,1]^3
          CellVertex cv;
          cv.key = PackKey(m);
          cv.p = (m.cast<float>() + f) * vs;
          if (roi && !options.roi.contains(cv.p)) continue;
          // Trilinear gradient, colour and weight at f.
          Eigen::Vector3f grad = Eigen::Vector3f::Zero(), col = Eigen::Vector3f::Zero();
          float w = 0;
          for (int k = 0; k < 8; ++k) {
            const int ox = k & 1, oy = (k >> 1) & 1, oz = (k >> 2) & 1;
            const float wx = ox ? f.x() : 1 - f.x(), wy = oy ? f.y() : 1 - f.y(), wz = oz ? f.z() : 1 - f.z();
            const float s = c[k]->sdf;
            grad.x() += s * (ox ? 1.f : -1.f) * wy * wz;
            grad.y() += s * (oy ? 1.f : -1.f) * wx * wz;
            grad.z() += s * (oz ? 1.f : -1.f) * wx * wy;
            col += wx * wy * wz * Eigen::Vector3f(c[k]->r, c[k]->g, c[k]->b);
            w += wx * wy * wz * c[k]->weight;
          }
          cv.n = grad.squaredNorm() > 0 ? grad.normalized() : Eigen::Vector3f::UnitZ();
          cv.c = col;
          cv.w = w;
          out.push_back(cv);
        }
  });
  Mesh mesh;
  std::vector<float> conf;
  std::unordered_map<uint64_t, int32_t, KeyHash> vid;
  size_t total = 0;
  for (const auto& v : per_block) total += v.size();
  vid.reserve(total);
  mesh.positions.reserve(total);
  for (const auto& blk : per_block)
    for (const CellVertex& cv : blk) {
      vid.emplace(cv.key, static_cast<int32_t>(mesh.positions.size()));
      mesh.positions.push_back(cv.p);
      mesh.normals.push_back(cv.n);
      mesh.colors.push_back(cv.c);
      conf.push_back(cv.w);
    }
  per_block.clear();
  std::vector<std::vector<Eigen::Vector3i>> tris(order.size());
  ParallelFor(0, static_cast<int64_t>(order.size()), [&](int64_t oi) {
    const Eigen::Vector3i b = impl_->coords[static_cast<size_t>(order[static_cast<size_t>(oi)])];
    Impl::Cache cache;
    auto& out = tris[static_cast<size_t>(oi)];
    auto find = [&](const Eigen::Vector3i& m) {
      auto it = vid.find(PackKey(m));
      return it == vid.end() ? -1 : it->second;
    };
    for (int z = 0; z < kB; ++z)
      for (int y = 0; y < kB; ++y)
        for (int x = 0; x < kB; ++x) {
          const Eigen::Vector3i v = b * kB + Eigen::Vector3i(x, y, z);
          const Voxel* v0 = impl_->VoxelAt(v, cache);
          if (!v0 || v0->weight < min_w) continue;
          for (int a = 0; a < 3; ++a) {
            const int bax = (a + 1) % 3, cax = (a + 2) % 3;
            Eigen::Vector3i ea = Eigen::Vector3i::Zero(), eb = Eigen::Vector3i::Zero(), ec = Eigen::Vector3i::Zero();
            ea[a] = 1;
            eb[bax] = 1;
            ec[cax] = 1;
            Impl::Cache c2;
            const Voxel* v1 = impl_->VoxelAt(v + ea, c2);
            if (!v1 || v1->weight < min_w) continue;
            const float s0 = v0->sdf, s1 = v1->sdf;
            if ((s0 < 0) == (s1 < 0) || std::abs(s0 - s1) > 1.0f) continue;
            int q[4] = {find(v - eb - ec), find(v - ec), find(v), find(v - eb)};
            if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[3] < 0) continue;
            if (!(s0 < 0)) std::swap(q[1], q[3]);  // outside (+) toward -a: flip the winding
            // Split along the shorter diagonal.
            const float d02 = (mesh.positions[q[0]] - mesh.positions[q[2]]).squaredNorm();
            const float d13 = (mesh.positions[q[1]] - mesh.positions[q[3]]).squaredNorm();
            if (d02 <= d13) {
              out.emplace_back(q[0], q[1], q[2]);
              out.emplace_back(q[0], q[2], q[3]);
            } else {
              out.emplace_back(q[0], q[1], q[3]);
              out.emplace_back(q[1], q[2], q[3]);
            }
          }
        }
  });
  for (const auto& t : tris) mesh.triangles.insert(mesh.triangles.end(), t.begin(), t.end());
  MeshStats st;
  CleanMesh(&mesh, options.min_component_triangles, {&conf}, &st);
  if (stats) *stats = st;
  if (confidence) *confidence = std::move(conf);
  return mesh;
}

void CleanMesh(Mesh* mesh, int min_triangles, std::vector<std::vector<float>*> per_vertex, MeshStats* stats) {
  const size_t nv = mesh->positions.size();
  std::vector<int32_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int32_t x) {
    while (parent[static_cast<size_t>(x)] != x) {
      parent[static_cast<size_t>(x)] = parent[static_cast<size_t>(parent[static_cast<size_t>(x)])];
      x = parent[static_cast<size_t>(x)];
    }
    return x;
  };
  std::vector<Eigen::Vector3i> kept;
  kept.reserve(mesh->triangles.size());
  int64_t degenerate = 0;
  for (const auto& t : mesh->triangles) {
    if (IsDegenerate(*mesh, t)) {
      ++degenerate;
      continue;
    }
    kept.push_back(t);
    for (int k = 1; k < 3; ++k) {
      const int32_t a = root(t[0]), b = root(t[k]);
      if (a != b) parent[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
    }
  }
  std::vector<int64_t> size(nv, 0);
  for (const auto& t : kept) ++size[static_cast<size_t>(root(t[0]))];
  int64_t comps_dropped = 0, tris_dropped = 0;
  for (size_t i = 0; i < nv; ++i)
    if (size[i] > 0 && size[i] < min_triangles) {
      ++comps_dropped;
      tris_dropped += size[i];
    }
  std::vector<Eigen::Vector3i> out;
  out.reserve(kept.size());
  for (const auto& t : kept)
    if (size[static_cast<size_t>(root(t[0]))] >= min_triangles) out.push_back(t);
  // Compact the vertices.
  std::vector<int32_t> remap(nv, -1);
  int32_t next = 0;
  for (auto& t : out)
    for (int k = 0; k < 3; ++k) {
      int32_t& r = remap[static_cast<size_t>(t[k])];
      if (r < 0) r = next++;
      t[k] = r;
    }
  auto compact = [&](auto& arr) {
    if (arr.size() != nv) return;
    std::remove_reference_t<decltype(arr)> c(static_cast<size_t>(next));
    for (size_t i = 0; i < nv; ++i)
      if (remap[i] >= 0) c[static_cast<size_t>(remap[i])] = arr[i];
    arr = std::move(c);
  };
  compact(mesh->positions);
  compact(mesh->normals);
  compact(mesh->colors);
  compact(mesh->uvs);
  for (auto* p : per_vertex) compact(*p);
  for (auto& sc : mesh->scalars) compact(sc.values);
  mesh->triangles = std::move(out);
  if (stats) {
    stats->components_dropped += comps_dropped;
    stats->triangles_dropped += tris_dropped;
    stats->degenerate_dropped += degenerate;
  }
}

}  // namespace mr
