#include "transfer/formfactor.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cstring>
#include <fstream>
#include <map>

#include "core/color.h"
#include "core/error.h"
#include "core/hash.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "core/sh.h"
#include "core/spherical.h"
#include "geometry/embree_scene.h"
#include "light/environment.h"
#include "transfer/cube.h"

namespace mr {

static_assert(std::endian::native == std::endian::little, "the .ffc reader and writer assume a little-endian machine");

uint64_t MeshHash(const Mesh& mesh) {
  // The .ffc header's mesh hash: FNV-1a from offset basis 1469598103934665603
  // (the standard basis less its last digit), fixed by every .ffc written.
  Fnv1a h(1469598103934665603ULL);
  const uint64_t nv = mesh.positions.size(), nt = mesh.triangles.size();
  h.Bytes(&nv, sizeof nv);
  h.Bytes(&nt, sizeof nt);
  for (const auto& p : mesh.positions) h.Bytes(p.data(), 3 * sizeof(float));
  for (const auto& t : mesh.triangles) h.Bytes(t.data(), 3 * sizeof(int));
  return h.value();
}

int TransferCoefficients(const TransferOptions& o) {
  return o.basis == TransferBasis::kCube ? CubeCellCount(o.resolution) : ShCount(o.order);
}

std::vector<Eigen::Vector3d> TransferNormals(const Mesh& mesh, TransferStats* stats) {
  std::vector<Eigen::Vector3d> face_sum(mesh.positions.size(), Eigen::Vector3d::Zero());
  for (const auto& t : mesh.triangles) {
    if (IsDegenerate(mesh, t)) {
      ++stats->degenerate_faces;
      continue;
    }
    const Eigen::Vector3d p0 = mesh.positions[static_cast<size_t>(t[0])].cast<double>();
    const Eigen::Vector3d fn = (mesh.positions[static_cast<size_t>(t[1])].cast<double>() - p0)
                                   .cross(mesh.positions[static_cast<size_t>(t[2])].cast<double>() - p0);
    for (int k = 0; k < 3; ++k) face_sum[static_cast<size_t>(t[k])] += fn;
  }
  std::vector<Eigen::Vector3d> n(mesh.positions.size(), Eigen::Vector3d::Zero());
  const bool given = mesh.normals.size() == mesh.positions.size();
  if (!given) stats->normals_computed = static_cast<int64_t>(n.size());
  for (size_t i = 0; i < n.size(); ++i) {
    const double len = face_sum[i].norm();
    if (!(len > 0)) {
      ++stats->vertices_without_normal;
      continue;
    }
    const Eigen::Vector3d computed = face_sum[i] / len;
    if (given) {
      const Eigen::Vector3d g = mesh.normals[i].cast<double>();
      if (g.allFinite() && g.norm() > 0 && g.dot(computed) > 0) {
        n[i] = g.normalized();
        continue;
      }
      ++stats->normals_flipped;  // flipped, zero or non-finite: the faces decide
    }
    n[i] = computed;
  }
  std::map<std::pair<int, int>, int> edges;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++edges[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}];
  for (const auto& [e, c] : edges) stats->nonmanifold_edges += c > 2;
  return n;
}

namespace {

// The quadrature over the sphere shared by both bases: one direction per
// sub-cell (its centre, where visibility is sampled) and the sub-cell's
// corners, from which the cosine-weighted solid angle is integrated exactly.
struct Quadrature {
  std::vector<Eigen::Vector3d> dir;
  std::vector<double> weight;                           // solid angle
  std::vector<std::array<Eigen::Vector3d, 4>> corners;  // unit, in order around the sub-cell
  std::vector<Eigen::Vector3d> vector_form_factor;      // integral of w dw over the sub-cell
  std::vector<int> cell;
  std::vector<double> sh;  // dir.size() x ShCount(order), for the SH basis
};

// Lambert's formula: the integral of w over a spherical polygon with unit
// vertices v is 1/2 sum_i angle(v_i, v_i+1) * unit(v_i x v_i+1), oriented
// towards the polygon.
Eigen::Vector3d VectorFormFactor(const Eigen::Vector3d* v, int n) {
  Eigen::Vector3d phi = Eigen::Vector3d::Zero(), centre = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d& a = v[i];
    const Eigen::Vector3d& b = v[(i + 1) % n];
    const Eigen::Vector3d c = a.cross(b);
    const double len = c.norm();
    if (len > 0) phi += std::atan2(len, a.dot(b)) * c / len;
    centre += a;
  }
  phi *= 0.5;
  return phi.dot(centre) < 0 ? Eigen::Vector3d(-phi) : phi;
}

// (1/pi) integral over the sub-cell of max(0, n.w) dw: exact, by clipping
// the spherical polygon to the hemisphere of n (great-arc edges cross the
// horizon where their chords do) and applying Lambert's formula.
double CosineWeightedSolidAngle(const Quadrature& q, size_t d, const Eigen::Vector3d& n) {
  const auto& c = q.corners[d];
  double h[4];
  int above = 0;
  for (int i = 0; i < 4; ++i) above += (h[i] = n.dot(c[static_cast<size_t>(i)])) > 0;
  if (above == 4) return n.dot(q.vector_form_factor[d]) / kPi;
  if (above == 0) return 0;
  Eigen::Vector3d poly[8];
  int m = 0;
  for (int i = 0; i < 4; ++i) {
    const int j = (i + 1) % 4;
    if (h[i] > 0) poly[m++] = c[static_cast<size_t>(i)];
    if ((h[i] > 0) != (h[j] > 0)) {
      const double t = h[i] / (h[i] - h[j]);
      poly[m++] = ((1 - t) * c[static_cast<size_t>(i)] + t * c[static_cast<size_t>(j)]).normalized();
    }
  }
  return std::max(0.0, n.dot(VectorFormFactor(poly, m))) / kPi;
}

Quadrature MakeQuadrature(const TransferOptions& o) {
  Quadrature q;
  const int n = o.resolution, s = o.supersample;
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (int b = 0; b < s; ++b)
          for (int a = 0; a < s; ++a) {
            const double step = 2.0 / (n * s);
            const double a0 = -1 + (i * s + a) * step, b0 = -1 + (j * s + b) * step;
            q.dir.push_back(CubeDirection(f, a0 + step / 2, b0 + step / 2));
            q.weight.push_back(CubeRectSolidAngle(a0, b0, a0 + step, b0 + step));
            const std::array<Eigen::Vector3d, 4> c = {CubeDirection(f, a0, b0), CubeDirection(f, a0 + step, b0),
                                                      CubeDirection(f, a0 + step, b0 + step),
                                                      CubeDirection(f, a0, b0 + step)};
            q.corners.push_back(c);
            q.vector_form_factor.push_back(VectorFormFactor(c.data(), 4));
            q.cell.push_back((f * n + j) * n + i);
          }
  if (o.basis == TransferBasis::kSh) {
    const int c = ShCount(o.order);
    q.sh.resize(q.dir.size() * static_cast<size_t>(c));
    for (size_t d = 0; d < q.dir.size(); ++d) ShEvaluate(q.dir[d], o.order, &q.sh[d * static_cast<size_t>(c)]);
  }
  return q;
}

}  // namespace

void TransferOptions::Check() const {
  if (resolution < 1 || resolution > 256)
    throw UsageError(fmt::format("--resolution {} is outside 1..256", resolution));
  if (order < 1 || order > kMaxShOrder)
    throw UsageError(fmt::format("--order {} is outside 1..{}", order, kMaxShOrder));
  if (supersample < 1 || supersample > 16)
    throw UsageError(fmt::format("--supersample {} is outside 1..16", supersample));
  if (bounces < 0 || bounces > 16) throw UsageError(fmt::format("--bounces {} is outside 0..16", bounces));
  if (!(albedo >= 0 && albedo < 1)) throw UsageError(fmt::format("--albedo {} is outside [0, 1)", albedo));
  if (chunk < 1) throw UsageError(fmt::format("chunk {} must be at least 1", chunk));
}

namespace {

using ChunkSink = std::function<void(const float* data, int64_t vertices)>;

// With a sink and no bounces, the vertices are computed o.chunk at a time
// and handed to the sink in order (out.data stays empty): memory is bounded
// by the chunk, not the mesh.
VertexTransfer ComputeTransferImpl(const Mesh& mesh, const TransferOptions& o, TransferStats* stats,
                                   const std::vector<char>* needed, const ChunkSink* sink) {
  o.Check();
  mesh.Validate("mesh");
  VertexTransfer out;
  TransferHeader& h = out.header;
  h.basis = o.basis;
  h.resolution = o.resolution;
  h.order = o.basis == TransferBasis::kSh ? o.order : 0;
  h.supersample = o.supersample;
  h.bounces = o.bounces;
  h.albedo = static_cast<float>(o.albedo);
  h.coefficients = TransferCoefficients(o);
  h.vertex_count = static_cast<int64_t>(mesh.positions.size());
  h.mesh_hash = MeshHash(mesh);
  stats->vertices = h.vertex_count;
  const std::vector<Eigen::Vector3d> normals = TransferNormals(mesh, stats);
  const Quadrature q = MakeQuadrature(o);
  const int C = h.coefficients;
  const size_t V = static_cast<size_t>(h.vertex_count);
  const bool streaming = sink && o.bounces == 0;
  if (!streaming) out.data.assign(V * static_cast<size_t>(C), 0.0f);
  if (V == 0) return out;

  EmbreeScene scene;
  scene.AddMesh(mesh, false);
  scene.Commit();
  const auto bounds = mesh.Bounds();
  const double diag = static_cast<double>((bounds.max() - bounds.min()).norm());
  const double offset = std::max(1e-6, 1e-5 * diag);

  // Rays of vertex v: the quadrature directions above its tangent plane.
  auto rays_of = [&](size_t v, std::vector<Ray>* rays, std::vector<int>* dirs) {
    rays->clear();
    dirs->clear();
    const Eigen::Vector3d& n = normals[v];
    if (n.squaredNorm() == 0 || (needed && !(*needed)[v])) return;
    const Eigen::Vector3d origin = mesh.positions[v].cast<double>() + offset * n;
    for (size_t d = 0; d < q.dir.size(); ++d) {
      bool above = false;  // any part of the sub-cell above the horizon
      for (const auto& c : q.corners[d]) above = above || c.dot(n) > 0;
      if (!above) continue;
      Ray r;
      r.origin = origin.cast<float>();
      r.direction = q.dir[d].cast<float>();
      rays->push_back(r);
      dirs->push_back(static_cast<int>(d));
    }
  };
  auto add = [&](double* acc, int d, double w) {
    if (o.basis == TransferBasis::kCube) {
      acc[q.cell[static_cast<size_t>(d)]] += w;
    } else {
      const double* y = &q.sh[static_cast<size_t>(d) * C];
      for (int k = 0; k < C; ++k) acc[k] += w * y[k];
    }
  };

  // Bounce 0: direct transfer, one occlusion ray per quadrature direction,
  // for vertices [v0, v1) into dst.
  std::atomic<int64_t> rays_total{0}, occluded_all{0};
  auto direct = [&](int64_t v0, int64_t v1, float* dst_base) {
    ParallelForChunks(v0, v1, 64, [&](int64_t begin, int64_t end) {
      std::vector<Ray> rays;
      std::vector<int> dirs;
      std::vector<char> occ;
      std::vector<double> acc(static_cast<size_t>(C));
      for (int64_t v = begin; v < end; ++v) {
        rays_of(static_cast<size_t>(v), &rays, &dirs);
        if (rays.empty()) continue;
        occ.assign(rays.size(), 0);
        if (o.ray_log) o.ray_log->insert(o.ray_log->end(), rays.begin(), rays.end());
        scene.Occluded(rays, occ);
        rays_total += static_cast<int64_t>(rays.size());
        std::fill(acc.begin(), acc.end(), 0.0);
        bool any = false;
        const Eigen::Vector3d& n = normals[static_cast<size_t>(v)];
        for (size_t r = 0; r < rays.size(); ++r) {
          if (occ[r]) continue;
          any = true;
          const int d = dirs[r];
          add(acc.data(), d, CosineWeightedSolidAngle(q, static_cast<size_t>(d), n));
        }
        if (!any) ++occluded_all;
        float* dst = dst_base + static_cast<size_t>(v - v0) * C;
        for (int k = 0; k < C; ++k) dst[k] = static_cast<float>(acc[static_cast<size_t>(k)]);
      }
    });
  };
  if (streaming) {
    std::vector<float> buf;
    const int64_t chunk = std::max<int64_t>(1, o.chunk);
    for (int64_t v0 = 0; v0 < static_cast<int64_t>(V); v0 += chunk) {
      const int64_t v1 = std::min<int64_t>(static_cast<int64_t>(V), v0 + chunk);
      buf.assign(static_cast<size_t>(v1 - v0) * C, 0.0f);
      direct(v0, v1, buf.data());
      (*sink)(buf.data(), v1 - v0);
    }
  } else {
    direct(0, static_cast<int64_t>(V), out.data.data());
  }
  stats->rays += rays_total.load();
  stats->fully_occluded = occluded_all.load();
  if (needed)
    for (char c : *needed) stats->skipped_vertices += !c;

  // Bounces: T_b(v) = T_0(v) + albedo sum over rays that hit the object's
  // outside of (cos dw / pi) T_{b-1}(hit), interpolated at the hit.
  if (o.bounces > 0) {
    const std::vector<float> direct_transfer = out.data;
    std::vector<float> prev = out.data;
    for (int b = 0; b < o.bounces; ++b) {
      std::atomic<int64_t> brays{0};
      ParallelForChunks(0, static_cast<int64_t>(V), 64, [&](int64_t begin, int64_t end) {
        std::vector<Ray> rays;
        std::vector<int> dirs;
        std::vector<Hit> hits;
        std::vector<double> acc(static_cast<size_t>(C));
        for (int64_t v = begin; v < end; ++v) {
          rays_of(static_cast<size_t>(v), &rays, &dirs);
          if (rays.empty()) continue;
          hits.assign(rays.size(), Hit());
          scene.Intersect(rays, hits);
          brays += static_cast<int64_t>(rays.size());
          std::fill(acc.begin(), acc.end(), 0.0);
          const Eigen::Vector3d& n = normals[static_cast<size_t>(v)];
          for (size_t r = 0; r < rays.size(); ++r) {
            if (!hits[r].valid()) continue;
            const auto& t = mesh.triangles[hits[r].primitive_id];
            const double u = hits[r].uv.x(), w = hits[r].uv.y(), a = 1 - u - w;
            const Eigen::Vector3d nq = a * normals[static_cast<size_t>(t[0])] + u * normals[static_cast<size_t>(t[1])] +
                                       w * normals[static_cast<size_t>(t[2])];
            const int d = dirs[r];
            if (nq.dot(q.dir[static_cast<size_t>(d)]) >= 0) continue;  // the inside of the object: no light
            const double f = o.albedo * CosineWeightedSolidAngle(q, static_cast<size_t>(d), n);
            const float* p0 = prev.data() + static_cast<size_t>(t[0]) * C;
            const float* p1 = prev.data() + static_cast<size_t>(t[1]) * C;
            const float* p2 = prev.data() + static_cast<size_t>(t[2]) * C;
            for (int k = 0; k < C; ++k) acc[static_cast<size_t>(k)] += f * (a * p0[k] + u * p1[k] + w * p2[k]);
          }
          float* dst = out.data.data() + static_cast<size_t>(v) * C;
          const float* d0 = direct_transfer.data() + static_cast<size_t>(v) * C;
          for (int k = 0; k < C; ++k) dst[k] = static_cast<float>(d0[k] + acc[static_cast<size_t>(k)]);
        }
      });
      stats->rays += brays.load();
      prev = out.data;
    }
  }
  return out;
}

}  // namespace

VertexTransfer ComputeTransfer(const Mesh& mesh, const TransferOptions& options, TransferStats* stats,
                               const std::vector<char>* needed) {
  return ComputeTransferImpl(mesh, options, stats, needed, nullptr);
}

namespace {
constexpr char kMagic[8] = {'M', 'R', '-', 'F', 'F', 'C', '\r', '\n'};
constexpr uint32_t kVersion = 1;
constexpr size_t kHeaderSize = 64;

template <class T>
void Put(std::vector<char>* b, size_t at, T v) {
  std::memcpy(b->data() + at, &v, sizeof v);
}
template <class T>
T Get(const char* b, size_t at) {
  T v;
  std::memcpy(&v, b + at, sizeof v);
  return v;
}
}  // namespace

namespace {
std::vector<char> EncodeHeader(const TransferHeader& h) {
  std::vector<char> head(kHeaderSize, 0);
  std::memcpy(head.data(), kMagic, 8);
  Put<uint32_t>(&head, 8, kVersion);
  Put<uint32_t>(&head, 12, static_cast<uint32_t>(h.basis));
  Put<uint32_t>(&head, 16, static_cast<uint32_t>(h.resolution));
  Put<uint32_t>(&head, 20, static_cast<uint32_t>(h.order));
  Put<uint32_t>(&head, 24, static_cast<uint32_t>(h.supersample));
  Put<uint32_t>(&head, 28, static_cast<uint32_t>(h.bounces));
  Put<float>(&head, 32, h.albedo);
  Put<uint32_t>(&head, 36, static_cast<uint32_t>(h.coefficients));
  Put<uint64_t>(&head, 40, static_cast<uint64_t>(h.vertex_count));
  Put<uint64_t>(&head, 48, h.mesh_hash);
  Put<uint32_t>(&head, 56, static_cast<uint32_t>(h.valid_spp));
  return head;
}
}  // namespace

void WriteTransfer(const fs::path& path, const VertexTransfer& t) {
  const TransferHeader& h = t.header;
  MR_CHECK(static_cast<int64_t>(t.data.size()) == h.vertex_count * h.coefficients);
  const std::vector<char> head = EncodeHeader(h);
  WriteAtomically(path, [&](const fs::path& tmp) {
    OutputFile f(tmp, path.string());
    f.Write(head.data(), head.size());
    f.Write(t.data.data(), t.data.size() * sizeof(float));
    f.Close();
  });
}

TransferHeader ComputeTransferToFile(const Mesh& mesh, const TransferOptions& options, const fs::path& path,
                                     TransferStats* stats, const std::vector<char>* needed, int valid_spp) {
  TransferHeader header;
  WriteAtomically(path, [&](const fs::path& tmp) {
    OutputFile f(tmp, path.string());
    f.Write(std::vector<char>(kHeaderSize, 0).data(), kHeaderSize);  // the header once its fields are known
    const ChunkSink sink = [&](const float* data, int64_t vertices) {
      f.Write(data, static_cast<size_t>(vertices * TransferCoefficients(options)) * sizeof(float));
    };
    VertexTransfer t = ComputeTransferImpl(mesh, options, stats, needed, &sink);
    t.header.valid_spp = valid_spp;
    header = t.header;
    if (!t.data.empty()) f.Write(t.data.data(), t.data.size() * sizeof(float));  // not streamed (bounces)
    const std::vector<char> head = EncodeHeader(header);
    f.WriteAt(0, head.data(), head.size());
    f.Close();
  });
  return header;
}

VertexTransfer ReadTransfer(const fs::path& path) {
  RequireFile(path, "form-factor file");
  const FileLoc loc{path.string()};
  std::ifstream f(path, std::ios::binary);
  std::vector<char> head(kHeaderSize);
  if (!f.read(head.data(), kHeaderSize)) ThrowErrorAt(loc, "too short for an .ffc header ({} bytes)", kHeaderSize);
  if (std::memcmp(head.data(), kMagic, 8) != 0) ThrowErrorAt(loc, "not an .ffc file (bad magic)");
  const uint32_t version = Get<uint32_t>(head.data(), 8);
  if (version != kVersion) ThrowErrorAt(loc, ".ffc version {} (this mr reads version {})", version, kVersion);
  VertexTransfer t;
  TransferHeader& h = t.header;
  const uint32_t basis = Get<uint32_t>(head.data(), 12);
  if (basis > 1) ThrowErrorAt(loc, "unknown basis {}", basis);
  h.basis = static_cast<TransferBasis>(basis);
  h.resolution = static_cast<int>(Get<uint32_t>(head.data(), 16));
  h.order = static_cast<int>(Get<uint32_t>(head.data(), 20));
  h.supersample = static_cast<int>(Get<uint32_t>(head.data(), 24));
  h.bounces = static_cast<int>(Get<uint32_t>(head.data(), 28));
  h.albedo = Get<float>(head.data(), 32);
  h.coefficients = static_cast<int>(Get<uint32_t>(head.data(), 36));
  h.vertex_count = static_cast<int64_t>(Get<uint64_t>(head.data(), 40));
  h.mesh_hash = Get<uint64_t>(head.data(), 48);
  h.valid_spp = static_cast<int>(Get<uint32_t>(head.data(), 56));
  // Ranges first: the coefficient count is computed only from values that cannot overflow it.
  const bool in_range = h.resolution >= 1 && h.resolution <= 256 &&
                        (h.basis != TransferBasis::kSh || (h.order >= 1 && h.order <= kMaxShOrder));
  const int expected = !in_range                         ? -1
                       : h.basis == TransferBasis::kCube ? 6 * h.resolution * h.resolution
                                                         : h.order * h.order;
  if (!in_range || h.coefficients != expected)
    ThrowErrorAt(loc, "inconsistent header: basis {}, resolution {}, order {}, {} coefficients per vertex",
                 h.basis == TransferBasis::kCube ? "cube" : "sh", h.resolution, h.order, h.coefficients);
  const auto size = fs::file_size(path);
  const uint64_t want = kHeaderSize + static_cast<uint64_t>(h.vertex_count) * static_cast<uint64_t>(h.coefficients) * 4;
  if (h.vertex_count < 0 || h.vertex_count > (int64_t{1} << 40) || size != want)
    ThrowErrorAt(loc, "file is {} bytes; the header ({} vertices x {} coefficients) says {}", size, h.vertex_count,
                 h.coefficients, want);
  t.data.resize(static_cast<size_t>(h.vertex_count) * static_cast<size_t>(h.coefficients));
  f.read(reinterpret_cast<char*>(t.data.data()), static_cast<std::streamsize>(t.data.size() * sizeof(float)));
  if (!f) ThrowErrorAt(loc, "read failed");
  for (size_t i = 0; i < t.data.size(); ++i)
    if (!std::isfinite(t.data[i]))
      ThrowErrorAt(loc, "vertex {} coefficient {} is not finite", i / static_cast<size_t>(h.coefficients),
                   i % static_cast<size_t>(h.coefficients));
  return t;
}

void CheckTransferMatches(const VertexTransfer& t, const Mesh& mesh, const std::string& ffc_name,
                          const std::string& mesh_name) {
  if (t.header.mesh_hash != MeshHash(mesh) || t.header.vertex_count != static_cast<int64_t>(mesh.positions.size()))
    ThrowErrorAt(FileLoc{ffc_name},
                 "was computed for another mesh ({} vertices, hash {:016x}); {} has {} vertices, hash {:016x}: "
                 "run mr-formfactor on it again",
                 t.header.vertex_count, t.header.mesh_hash, mesh_name, mesh.positions.size(), MeshHash(mesh));
}

EnvironmentCoefficients ProjectEnvironment(const Image& env, const std::string& env_name, const TransferHeader& h,
                                           const Eigen::Matrix3d& object_from_world, double scale, bool window) {
  EnvironmentMap check(env, env_name, scale);  // refuses NaN/Inf/negative pixels, naming file and pixel
  (void)check;
  const int r = env.ChannelIndex("R"), g = env.ChannelIndex("G"), b = env.ChannelIndex("B");
  EnvironmentCoefficients out;
  out.rgb.assign(static_cast<size_t>(h.coefficients), Eigen::Vector3d::Zero());
  const int W = env.width(), H = env.height();
  // Every map pixel is split into k x k sub-pixels, k chosen so that a cube
  // cell holds at least ~16 of them: each cell's mean radiance is then its
  // binned power over its binned solid angle, exact for a constant map and
  // within a few percent of the power of a one-pixel sun.
  const int n = h.resolution;
  const int k = std::max(1, static_cast<int>(std::ceil(8.0 * n / (H - 1))));
  std::vector<double> cell_weight(h.basis == TransferBasis::kCube ? out.rgb.size() : 0, 0.0);
  std::vector<double> y(static_cast<size_t>(h.coefficients));
  for (int py = 0; py < H; ++py)
    for (int px = 0; px < W; ++px) {
      const double omega = LatLongPixelSolidAngle(px, py, W, H) / (k * k);
      if (omega <= 0) continue;
      const Eigen::Vector3d L(env.at(px, py, r) * scale, env.at(px, py, g) * scale, env.at(px, py, b) * scale);
      for (int sy = 0; sy < k; ++sy)
        for (int sx = 0; sx < k; ++sx) {
          const Eigen::Vector2d sub(px - 0.5 + (sx + 0.5) / k, py - 0.5 + (sy + 0.5) / k);
          const Eigen::Vector3d d = (object_from_world * LatLongPixelToDirection(sub, W, H)).normalized();
          if (h.basis == TransferBasis::kCube) {
            const size_t c = static_cast<size_t>(CubeCell(d, n));
            out.rgb[c] += L * omega;
            cell_weight[c] += omega;
          } else {
            ShEvaluate(d, h.order, y.data());
            for (size_t q = 0; q < y.size(); ++q) out.rgb[q] += L * (omega * y[q]);
          }
        }
    }
  if (h.basis == TransferBasis::kCube) {
    for (size_t c = 0; c < out.rgb.size(); ++c)
      if (cell_weight[c] > 0) out.rgb[c] /= cell_weight[c];
  } else if (window) {
    for (int l = 0; l < h.order; ++l)
      for (int m = -l; m <= l; ++m) out.rgb[static_cast<size_t>(l * (l + 1) + m)] *= ShLanczosWindow(l, h.order);
  }
  return out;
}

int EffectiveShOrder(const EnvironmentCoefficients& env, int order, double tolerance) {
  std::vector<double> band(static_cast<size_t>(order), 0.0);
  double total = 0;
  for (int l = 0; l < order; ++l)
    for (int m = -l; m <= l; ++m)
      band[static_cast<size_t>(l)] += env.rgb.at(static_cast<size_t>(l * (l + 1) + m)).squaredNorm();
  for (double b : band) total += b;
  int keep = order;
  double tail = 0;
  while (keep > 1 && tail + band[static_cast<size_t>(keep - 1)] <= tolerance * total)
    tail += band[static_cast<size_t>(--keep)];
  return keep;
}

std::vector<Eigen::Vector3d> ShadeVertices(const VertexTransfer& t, const EnvironmentCoefficients& env,
                                           const Eigen::Vector3d& albedo, int64_t* clamped, double* most_negative,
                                           const std::vector<Eigen::Vector3f>* vertex_albedo) {
  MR_CHECK(!vertex_albedo || static_cast<int64_t>(vertex_albedo->size()) == t.header.vertex_count);
  MR_CHECK(static_cast<int>(env.rgb.size()) <= t.header.coefficients);  // fewer: a truncated SH order
  const int used = static_cast<int>(env.rgb.size());
  std::vector<Eigen::Vector3d> out(static_cast<size_t>(t.header.vertex_count));
  std::atomic<int64_t> neg{0};
  std::vector<double> lowest(out.size(), 0.0);
  ParallelFor(0, t.header.vertex_count, [&](int64_t v) {
    const float* c = t.vertex(v);
    Eigen::Vector3d s = Eigen::Vector3d::Zero();
    for (int k = 0; k < used; ++k) s += env.rgb[static_cast<size_t>(k)] * static_cast<double>(c[k]);
    s = s.cwiseProduct(vertex_albedo ? (*vertex_albedo)[static_cast<size_t>(v)].cast<double>() : albedo);
    lowest[static_cast<size_t>(v)] = std::min(0.0, s.minCoeff());
    for (int k = 0; k < 3; ++k)
      if (s[k] < 0) {
        s[k] = 0;
        ++neg;
      }
    out[static_cast<size_t>(v)] = s;
  });
  if (clamped) *clamped = neg.load();
  if (most_negative) *most_negative = lowest.empty() ? 0.0 : *std::min_element(lowest.begin(), lowest.end());
  return out;
}

double ColorVerticesByRadiance(const std::vector<Eigen::Vector3d>& radiance, Mesh* mesh) {
  std::vector<double> lum;
  for (const auto& r : radiance) lum.push_back(Luminance(r));
  std::sort(lum.begin(), lum.end());
  const double p99 = lum.empty() ? 1.0 : lum[lum.size() * 99 / 100];
  const double exposure = p99 > 0 ? 1.0 / p99 : 1.0;
  mesh->colors.resize(mesh->positions.size());
  for (size_t v = 0; v < radiance.size(); ++v)
    mesh->colors[v] = (radiance[v] * exposure).cwiseMin(1.0).cwiseMax(0.0).cast<float>();
  return exposure;
}

}  // namespace mr
