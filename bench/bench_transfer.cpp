// Form-factor transfer benchmarks (issue: mr-formfactor): the paper's
// setting (8 x 8 cells x 6 faces per vertex) on the Stanford dragon and on a
// 30k-vertex procedural mesh, and the ray rate against a bare Embree
// occlusion loop over the same rays.  Results go into docs/benchmarks.md.
#include <benchmark/benchmark.h>

#include <chrono>

#include "core/math.h"
#include "core/parallel.h"
#include "geometry/embree_scene.h"
#include "geometry/primitives.h"
#include "transfer/formfactor.h"

namespace {

const mr::Mesh& Dragon() {
  static const mr::Mesh m = mr::ReadMesh(std::string(MR_SHARED_DATA) + "/meshes/dragon_vrip_res3.ply");
  return m;
}
const mr::Mesh& Bumpy30k() {
  static const mr::Mesh m = mr::BumpySphere(122);  // 123 x 244 = 30 012 vertices
  return m;
}

void BM_Transfer(benchmark::State& state, const mr::Mesh& (*mesh)(), int supersample) {
  mr::TransferOptions o;
  o.resolution = 8;
  o.supersample = supersample;
  int64_t rays = 0;
  for (auto _ : state) {
    mr::TransferStats st;
    benchmark::DoNotOptimize(mr::ComputeTransfer(mesh(), o, &st).data.data());
    rays += st.rays;
  }
  state.counters["vertices"] = static_cast<double>(mesh().positions.size());
  state.counters["rays_per_s"] = benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(BM_Transfer, dragon_8x8x6, &Dragon, 1)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);
BENCHMARK_CAPTURE(BM_Transfer, dragon_8x8x6_ss2, &Dragon, 2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_Transfer, bumpy30k_8x8x6, &Bumpy30k, 1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);

// The same rays, one thread: the transfer's rate against rtcOccluded1M over
// the rays it traced, in the same chunks of one vertex's hemisphere.
void BM_TransferEfficiency(benchmark::State& state, const mr::Mesh& (*mesh)()) {
  mr::SetThreadCount(1);
  std::vector<mr::Ray> log;
  mr::TransferOptions o;
  o.resolution = 8;
  o.supersample = 1;
  o.ray_log = &log;
  {
    mr::TransferStats st;
    mr::ComputeTransfer(mesh(), o, &st);
  }
  o.ray_log = nullptr;
  mr::EmbreeScene scene;
  scene.AddMesh(mesh(), false);
  scene.Commit();
  const size_t per_batch = log.size() / mesh().positions.size();
  double t_transfer = 0, t_bare = 0;
  int64_t hits = 0;
  std::vector<char> occ(per_batch + 1);
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    mr::TransferStats st;
    benchmark::DoNotOptimize(mr::ComputeTransfer(mesh(), o, &st).data.data());
    auto t1 = std::chrono::steady_clock::now();
    for (size_t b = 0; b < log.size(); b += per_batch) {
      const size_t n = std::min(per_batch, log.size() - b);
      scene.Occluded(std::span<const mr::Ray>(log.data() + b, n), std::span<char>(occ.data(), n));
      hits += occ[0];
    }
    auto t2 = std::chrono::steady_clock::now();
    t_transfer += std::chrono::duration<double>(t1 - t0).count();
    t_bare += std::chrono::duration<double>(t2 - t1).count();
  }
  benchmark::DoNotOptimize(hits);
  mr::SetThreadCount(0);
  const double n = static_cast<double>(log.size()) * static_cast<double>(state.iterations());
  state.counters["transfer_rays_per_s"] = n / t_transfer;
  state.counters["bare_rays_per_s"] = n / t_bare;
  state.counters["efficiency"] = t_bare / t_transfer;
}
BENCHMARK_CAPTURE(BM_TransferEfficiency, dragon, &Dragon)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
