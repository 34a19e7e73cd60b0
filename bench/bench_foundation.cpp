// Foundation benchmarks: ray queries of the Embree scene (single rays,
// streams, packets; real-only and mixed masks) and the samplers.
// Results with machine and date go into docs/benchmarks.md.
#include <benchmark/benchmark.h>

#include <filesystem>

#include "core/sampling.h"
#include "core/spherical.h"
#include "geometry/embree_scene.h"
#include "geometry/mesh.h"

namespace {

// The Stanford bunny (res2, 16k triangles) from ../shared/data when present,
// otherwise a procedural sphere of similar size.
mr::Mesh BenchMesh() {
  std::filesystem::path bunny = std::filesystem::path(MR_SHARED_DATA) / "meshes" / "bun_zipper_res2.ply";
  if (std::filesystem::exists(bunny)) return mr::ReadMesh(bunny);
  mr::Mesh m;
  const int n = 90;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      double th = M_PI * i / n, ph = 2 * M_PI * j / n;
      m.positions.emplace_back(0.08f * std::sin(th) * std::cos(ph), 0.1f + 0.08f * std::cos(th),
                               0.08f * std::sin(th) * std::sin(ph));
    }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      int a = i * (n + 1) + j, b = a + n + 1;
      m.triangles.push_back({a, b, a + 1});
      m.triangles.push_back({a + 1, b, b + 1});
    }
  return m;
}

struct Fixture {
  mr::EmbreeScene scene;
  std::vector<mr::Ray> rays;
  Fixture() {
    mr::Mesh room;  // a floor under the object (real)
    room.positions = {{-1, 0.03f, -1}, {1, 0.03f, -1}, {1, 0.03f, 1}, {-1, 0.03f, 1}};
    room.triangles = {{0, 2, 1}, {0, 3, 2}};
    scene.AddMesh(room, false);
    scene.AddMesh(BenchMesh(), true);
    scene.Commit();
    // Rays from a camera 0.4 m away towards the object, jittered per index.
    for (uint32_t i = 0; i < 65536; ++i) {
      auto u = mr::Sobol2D(i, 7, true);
      mr::Ray r;
      r.origin = {0, 0.1f, -0.4f};
      r.direction = Eigen::Vector3f(0.25f * (u[0] - 0.5f), 0.25f * (u[1] - 0.5f), 1.0f).normalized();
      rays.push_back(r);
    }
  }
};

Fixture& F() {
  static Fixture f;
  return f;
}

void BM_IntersectSingle(benchmark::State& state) {
  auto& f = F();
  const uint32_t mask = static_cast<uint32_t>(state.range(0));
  size_t i = 0, hits = 0;
  for (auto _ : state) {
    mr::Ray r = f.rays[i++ & 65535];
    r.mask = mask;
    mr::Hit h;
    hits += f.scene.Intersect(r, &h);
  }
  benchmark::DoNotOptimize(hits);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_IntersectSingle)->Arg(mr::kMaskAll)->Arg(mr::kMaskReal);

void BM_IntersectStream(benchmark::State& state) {
  auto& f = F();
  std::vector<mr::Hit> hits(f.rays.size());
  for (auto _ : state) f.scene.Intersect(f.rays, hits);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * f.rays.size()));
}
BENCHMARK(BM_IntersectStream);

void BM_IntersectPacket8(benchmark::State& state) {
  auto& f = F();
  std::vector<mr::Hit> hits(8);
  size_t i = 0;
  for (auto _ : state) {
    f.scene.IntersectPacket8(std::span<const mr::Ray>(f.rays).subspan(i, 8), hits);
    i = (i + 8) & 65535;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * 8));
}
BENCHMARK(BM_IntersectPacket8);

void BM_OccludedStream(benchmark::State& state) {
  auto& f = F();
  std::vector<char> occ(f.rays.size());
  for (auto _ : state) f.scene.Occluded(f.rays, occ);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * f.rays.size()));
}
BENCHMARK(BM_OccludedStream);

void BM_Pcg32(benchmark::State& state) {
  mr::Pcg32 rng(1, 2);
  float s = 0;
  for (auto _ : state) s += rng.NextFloat();
  benchmark::DoNotOptimize(s);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_Pcg32);

void BM_Sobol2DScrambled(benchmark::State& state) {
  uint32_t i = 0;
  float s = 0;
  for (auto _ : state) s += mr::Sobol2D(i++, 5, true)[1];
  benchmark::DoNotOptimize(s);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_Sobol2DScrambled);

void BM_LatLongPixelToDirection(benchmark::State& state) {
  double s = 0;
  int i = 0;
  for (auto _ : state) {
    s += mr::LatLongPixelToDirection({i % 512, (i / 512) % 256}, 512, 256).x();
    ++i;
  }
  benchmark::DoNotOptimize(s);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_LatLongPixelToDirection);

}  // namespace

BENCHMARK_MAIN();
