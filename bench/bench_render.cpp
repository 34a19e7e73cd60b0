// Renderer benchmarks: samples and rays per second of `pt` on mr-synth's
// presets, against a bare Embree closest-hit loop over the same scene (the
// efficiency ratio).  Results go into docs/benchmarks.md.
#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>
#include <span>

#include "camera/camera_model.h"
#include "camera/trajectory.h"
#include "core/parallel.h"
#include "core/report.h"
#include "core/sampling.h"
#include "core/spherical.h"
#include "geometry/primitives.h"
#include "render/camera_sampler.h"
#include "render/path_common.h"
#include "render/path_tracer.h"
#include "render/pt.h"
#include "render/render_scene.h"
#include "scene/scene.h"
#include "synth/synth.h"

namespace {

struct Capture {
  mr::RenderScene scene;
  mr::CameraModel camera;
  mr::Rigid3 pose;
  explicit Capture(const std::string& preset) {
    const auto dir = std::filesystem::temp_directory_path() / ("mr-bench-" + preset);
    if (!std::filesystem::exists(dir / "scene.json")) {
      mr::SynthOptions o;
      o.preset = preset;
      o.out = dir;
      o.truth_spp = 1;
      mr::Report r("bench", "bench");
      mr::RunSynth(o, &r);
    }
    mr::Scene s = mr::ReadScene(dir / "scene.json");
    mr::LoadRenderScene(s, &scene);
    camera = mr::CameraModel::Read(s.camera.model);
    pose = mr::ReadTum(*s.camera.poses).poses[0].world_from_cam;
  }
};

Capture& Get(const std::string& preset) {
  static Capture small("small"), room("room");
  return preset == "small" ? small : room;
}

void BM_RenderPt(benchmark::State& state, const std::string& preset) {
  Capture& c = Get(preset);
  mr::PathTracerSettings st;
  st.max_depth = 8;
  int64_t samples = 0;
  mr::PtFrameRenderer fr(c.scene, c.camera, c.pose, st);  // camera rays are set up once per frame
  for (auto _ : state) {
    fr.RenderPass(1);
    samples += static_cast<int64_t>(c.camera.width()) * c.camera.height();
  }
  const int64_t rays = fr.rays_traced();
  state.counters["samples_per_s"] = benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsRate);
  state.counters["rays_per_s"] = benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(BM_RenderPt, small, std::string("small"))->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_RenderPt, room, std::string("room"))->Unit(benchmark::kMillisecond)->Iterations(4)->UseRealTime();

// Thread scaling of pt's pass on the room preset, its paths one by one
// (batch 0) and in batches (PathTracerSettings::batch): arguments
// {threads, batch}.  The same bytes in every case (tests).
void BM_PtThreads(benchmark::State& state) {
  Capture& c = Get("room");
  mr::SetThreadCount(static_cast<int>(state.range(0)));
  mr::PathTracerSettings st;
  st.max_depth = 8;
  st.batch = static_cast<int>(state.range(1));
  mr::PtFrameRenderer fr(c.scene, c.camera, c.pose, st);
  for (auto _ : state) fr.RenderPass(1);
  mr::SetThreadCount(0);
  state.counters["rays_per_s"] = benchmark::Counter(static_cast<double>(fr.rays_traced()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_PtThreads)
    ->ArgsProduct({{1, 2}, {0, 256}})
    ->ArgNames({"threads", "batch"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(4)
    ->UseRealTime();

// A frame's camera rays set up: every pixel corner unprojected (the room
// preset's lens is OpenCV8, which libmrcal unprojects by an iterative solve).
void BM_CameraSetup(benchmark::State& state, const std::string& preset) {
  Capture& c = Get(preset);
  for (auto _ : state) {
    mr::CameraSampler sampler(c.camera, c.pose, 1, 0);
    benchmark::DoNotOptimize(sampler.PixelValid(0, 0));
  }
}
BENCHMARK_CAPTURE(BM_CameraSetup, room, std::string("room"))->Unit(benchmark::kMillisecond)->UseRealTime();

// The bare loop: rtcIntersect1 through EmbreeScene::Intersect over random
// rays from the camera position, on all threads like the renderer.
void BM_BareIntersect(benchmark::State& state, const std::string& preset) {
  Capture& c = Get(preset);
  const int64_t n = 1 << 18;
  int64_t rays = 0;
  for (auto _ : state) {
    std::atomic<int64_t> hits{0};
    mr::ParallelForChunks(0, n, 4096, [&](int64_t i0, int64_t i1) {
      int64_t h = 0;
      for (int64_t i = i0; i < i1; ++i) {
        mr::Pcg32 rng(7, static_cast<uint64_t>(i));
        auto d = mr::SampleUniformSphere(rng.NextDouble(), rng.NextDouble());
        mr::Ray r;
        r.origin = c.pose.translation.cast<float>();
        r.direction = Eigen::Vector3f(static_cast<float>(d[0]), static_cast<float>(d[1]), static_cast<float>(d[2]));
        mr::Hit hit;
        h += c.scene.embree().Intersect(r, &hit);
      }
      hits += h;
    });
    rays += n;
    benchmark::DoNotOptimize(hits.load());
  }
  state.counters["rays_per_s"] = benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(BM_BareIntersect, small, std::string("small"))->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_BareIntersect, room, std::string("room"))->Unit(benchmark::kMillisecond)->UseRealTime();

// The efficiency ratio over the same rays: one single-threaded pass of `pt`
// records every ray it traces; the bare loop replays them through
// rtcIntersect1 / rtcOccluded1 on one thread.
// Replays logged rays one by one through rtcIntersect1 / rtcOccluded1 (the
// bare loop of the efficiency ratios); returns the hits, to be kept.
int64_t ReplaySingle(const mr::EmbreeScene& embree, const std::vector<mr::Ray>& closest,
                     const std::vector<mr::Ray>& occlusion) {
  int64_t hits = 0;
  for (const auto& r : closest) {
    mr::Hit h;
    hits += embree.Intersect(r, &h);
  }
  for (const auto& r : occlusion) hits += embree.Occluded(r);
  return hits;
}

// `batch`: PathTracerSettings::batch (0: one path at a time).
void BM_EfficiencyRatio(benchmark::State& state, const std::string& preset, int batch) {
  Capture& c = Get(preset);
  mr::SetThreadCount(1);
  mr::RayLog log;
  int64_t traced = 0;
  mr::PathTracerSettings st;
  st.max_depth = 8;
  st.batch = batch;
  st.skip_environment_pixels = false;  // every pass traces the rays of the recorded one
  {
    st.ray_log = &log;
    mr::PtFrameRenderer fr(c.scene, c.camera, c.pose, st);
    fr.RenderPass(1);
    traced = fr.rays_traced();
  }
  st.ray_log = nullptr;
  mr::PtFrameRenderer fr(c.scene, c.camera, c.pose, st);
  double render_s = 0, bare_s = 0;
  int64_t hits = 0;
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    fr.RenderPass(1);
    auto t1 = std::chrono::steady_clock::now();
    hits += ReplaySingle(c.scene.embree(), log.closest, log.occlusion);
    auto t2 = std::chrono::steady_clock::now();
    render_s += std::chrono::duration<double>(t1 - t0).count();
    bare_s += std::chrono::duration<double>(t2 - t1).count();
  }
  benchmark::DoNotOptimize(hits);
  mr::SetThreadCount(0);
  const double n =
      static_cast<double>(log.closest.size() + log.occlusion.size()) * static_cast<double>(state.iterations());
  state.counters["render_rays_per_s"] = n / render_s;
  state.counters["bare_rays_per_s"] = n / bare_s;
  state.counters["efficiency"] = bare_s / render_s;
  // Every query the pass counts must be in the log, or the ratio flatters the bare loop.
  state.counters["logged_of_traced"] =
      static_cast<double>(log.closest.size() + log.occlusion.size()) / static_cast<double>(traced);
  state.counters["occlusion_share"] =
      static_cast<double>(log.occlusion.size()) / static_cast<double>(log.closest.size() + log.occlusion.size());
}
BENCHMARK_CAPTURE(BM_EfficiencyRatio, small, std::string("small"), 256)->Unit(benchmark::kMillisecond)->Iterations(20);
BENCHMARK_CAPTURE(BM_EfficiencyRatio, room, std::string("room"), 256)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK_CAPTURE(BM_EfficiencyRatio, small_one_by_one, std::string("small"), 0)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(20);
BENCHMARK_CAPTURE(BM_EfficiencyRatio, room_one_by_one, std::string("room"), 0)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

// The ceiling of the ratio for any scalar path tracer over single rays: the
// least a bounce can do.  Camera rays as pt's (CameraSampler); at each hit
// the scene's normal, a shading frame, one cosine-weighted direction from a
// PCG32 stream, the albedo into the throughput, Russian roulette from the
// third bounce; an escaped ray adds a constant.  No light sampling, no MIS,
// no environment lookups, no second solution.  Its rays are logged and
// replayed like pt's.  Whatever pt does beyond this lowers its ratio
// further; the figure says how far a reorganisation of the same scalar work
// could go on this machine.
void BM_MinimalTracerEfficiency(benchmark::State& state, const std::string& preset) {
  Capture& c = Get(preset);
  const mr::CameraSampler cs(c.camera, c.pose, 1, 0);
  const mr::EmbreeScene& embree = c.scene.embree();
  std::vector<mr::Ray> log;
  auto pass = [&](std::vector<mr::Ray>* record) {
    double sum = 0;
    for (int y = 0; y < cs.height(); ++y)
      for (int x = 0; x < cs.width(); ++x) {
        if (!cs.PixelValid(x, y)) continue;
        mr::Ray ray;
        cs.Sample(x, y, 0, &ray);
        mr::Pcg32 rng(1, static_cast<uint64_t>(y) * cs.width() + x);
        Eigen::Vector3d beta = Eigen::Vector3d::Ones();
        for (int depth = 0; depth < 8; ++depth) {
          if (record) record->push_back(ray);
          mr::Hit hit;
          if (!embree.Intersect(ray, &hit)) {
            sum += beta.sum();
            break;
          }
          const Eigen::Vector3d d = ray.direction.cast<double>();
          Eigen::Vector3d n = c.scene.WorldNormal(hit);
          if (n.dot(d) > 0) n = -n;
          Eigen::Vector3d t, b;
          mr::CoordinateSystem(n, &t, &b);
          const auto w = mr::SampleCosineHemisphere(rng.NextDouble(), rng.NextDouble());
          beta = beta.cwiseProduct(c.scene.material(hit.geometry_id).albedo);
          if (depth >= 3) {
            const double q = std::min(1.0, beta.maxCoeff());
            if (rng.NextDouble() >= q) break;
            beta /= q;
          }
          const Eigen::Vector3d p = ray.origin.cast<double>() + static_cast<double>(hit.t) * d;
          ray.origin = (p + 1e-4 * n).cast<float>();
          ray.direction = (w[0] * t + w[1] * b + w[2] * n).cast<float>();
          ray.tfar = INFINITY;
        }
      }
    return sum;
  };
  mr::SetThreadCount(1);
  pass(&log);
  double render_s = 0, bare_s = 0, sum = 0;
  int64_t hits = 0;
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    sum += pass(nullptr);
    auto t1 = std::chrono::steady_clock::now();
    hits += ReplaySingle(embree, log, {});
    auto t2 = std::chrono::steady_clock::now();
    render_s += std::chrono::duration<double>(t1 - t0).count();
    bare_s += std::chrono::duration<double>(t2 - t1).count();
  }
  benchmark::DoNotOptimize(hits);
  benchmark::DoNotOptimize(sum);
  mr::SetThreadCount(0);
  const double n = static_cast<double>(log.size()) * static_cast<double>(state.iterations());
  state.counters["render_rays_per_s"] = n / render_s;
  state.counters["bare_rays_per_s"] = n / bare_s;
  state.counters["efficiency"] = bare_s / render_s;
}
BENCHMARK_CAPTURE(BM_MinimalTracerEfficiency, small, std::string("small"))
    ->Unit(benchmark::kMillisecond)
    ->Iterations(20);
BENCHMARK_CAPTURE(BM_MinimalTracerEfficiency, room, std::string("room"))->Unit(benchmark::kMillisecond)->Iterations(3);

// Embree's stream entry point over the same logged rays: rtcIntersect1M /
// rtcOccluded1M in batches of 256 (RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT),
// against rtcIntersect1 / rtcOccluded1 one by one.  A wavefront renderer's
// gain on the Embree side is this ratio.
void BM_StreamReplay(benchmark::State& state, const std::string& preset) {
  Capture& c = Get(preset);
  mr::SetThreadCount(1);
  mr::RayLog log;
  mr::PathTracerSettings st;
  st.max_depth = 8;
  st.skip_environment_pixels = false;
  st.ray_log = &log;
  {
    mr::PtFrameRenderer fr(c.scene, c.camera, c.pose, st);
    fr.RenderPass(1);
  }
  const mr::EmbreeScene& embree = c.scene.embree();
  constexpr size_t kBatch = 256;
  std::vector<mr::Hit> hits(kBatch);
  std::vector<char> occ(kBatch);
  double single_s = 0, stream_s = 0;
  int64_t found = 0;
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    found += ReplaySingle(embree, log.closest, log.occlusion);
    auto t1 = std::chrono::steady_clock::now();
    for (size_t i = 0; i < log.closest.size(); i += kBatch) {
      const size_t m = std::min(kBatch, log.closest.size() - i);
      embree.Intersect(std::span<const mr::Ray>(log.closest.data() + i, m), std::span<mr::Hit>(hits.data(), m));
      found += hits[0].valid();
    }
    for (size_t i = 0; i < log.occlusion.size(); i += kBatch) {
      const size_t m = std::min(kBatch, log.occlusion.size() - i);
      embree.Occluded(std::span<const mr::Ray>(log.occlusion.data() + i, m), std::span<char>(occ.data(), m));
      found += occ[0];
    }
    auto t2 = std::chrono::steady_clock::now();
    single_s += std::chrono::duration<double>(t1 - t0).count();
    stream_s += std::chrono::duration<double>(t2 - t1).count();
  }
  benchmark::DoNotOptimize(found);
  mr::SetThreadCount(0);
  state.counters["stream_over_single_speed"] = single_s / stream_s;
}
BENCHMARK_CAPTURE(BM_StreamReplay, room, std::string("room"))->Unit(benchmark::kMillisecond)->Iterations(3);

// A fused room's geometry: a closed box of 4 m x 4 m x 3 m whose six walls
// are grids of 2 x 240 x 240 triangles (691 200 in all), each vertex pushed
// off its wall by up to a millimetre (as a TSDF mesh's facets), and a sphere
// prototype of 2 112 triangles instanced in it as the virtual object.
struct RoughRoom {
  mr::EmbreeScene embree;
  uint32_t object = 0;
  RoughRoom() {
    constexpr int n = 240;
    mr::Mesh room;
    mr::Pcg32 rng(3, 3);
    const Eigen::Vector3f lo(-2, -2, 0), size(4, 4, 3);
    for (int axis = 0; axis < 3; ++axis)
      for (int side = 0; side < 2; ++side) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3, first = static_cast<int>(room.positions.size());
        for (int y = 0; y <= n; ++y)
          for (int x = 0; x <= n; ++x) {
            Eigen::Vector3f p = lo;
            p[axis] += side * size[axis] + 1e-3f * rng.NextFloat();
            p[u] += size[u] * static_cast<float>(x) / n;
            p[v] += size[v] * static_cast<float>(y) / n;
            room.positions.push_back(p);
          }
        for (int y = 0; y < n; ++y)
          for (int x = 0; x < n; ++x) {
            const int i = first + y * (n + 1) + x;
            room.triangles.push_back({i, i + 1, i + n + 2});
            room.triangles.push_back({i, i + n + 2, i + n + 1});
          }
      }
    embree.AddMesh(room, false);
    object = embree.AddInstance(embree.AddPrototype(mr::UvSphere(0.3f, 32)), Placed(0));
    embree.Commit();
  }
  static Eigen::Affine3f Placed(int step) {
    Eigen::Affine3f a = Eigen::Affine3f::Identity();
    a.translate(Eigen::Vector3f(0.01f * static_cast<float>(step % 2), 0, 1.5f));
    return a;
  }
};

// `moved`: the object moved once since the first commit (a dynamic
// capture's room: EmbreeScene has dropped its tree of both kinds).
RoughRoom& Room(bool moved = false) {
  static RoughRoom still;
  static RoughRoom& once_moved = []() -> RoughRoom& {
    static RoughRoom room;
    room.embree.SetInstanceTransform(room.object, RoughRoom::Placed(1));
    room.embree.Commit();
    return room;
  }();
  return moved ? once_moved : still;
}

// A frame's world update when the object moves: the transform and Commit().
void BM_MovedObjectCommit(benchmark::State& state) {
  RoughRoom& r = Room(true);
  mr::SetThreadCount(static_cast<int>(state.range(0)));
  int step = 0;
  for (auto _ : state) {
    r.embree.SetInstanceTransform(r.object, RoughRoom::Placed(++step));
    r.embree.Commit();
  }
  mr::SetThreadCount(0);
}
BENCHMARK(BM_MovedObjectCommit)->Arg(2)->ArgName("threads")->Unit(benchmark::kMillisecond)->UseRealTime();

// Shadow rays from the floor towards the object's bounding sphere, one by
// one on one thread (a virtual blocker test's directions: about half meet
// the sphere, the rest go on to the walls): a virtual blocker test
// (kMaskVirtual), the real one (kMaskReal) and both (kMaskAll).  Arguments:
// the mask, and whether the object has moved (Room).
void BM_RoughRoomShadowRays(benchmark::State& state) {
  RoughRoom& r = Room(state.range(1) != 0);
  const auto mask = static_cast<uint32_t>(state.range(0));
  std::vector<mr::Ray> rays(1 << 16);
  mr::Pcg32 rng(5, 5);
  for (mr::Ray& ray : rays) {
    ray.origin = Eigen::Vector3f(3.6f * rng.NextFloat() - 1.8f, 3.6f * rng.NextFloat() - 1.8f, 0.01f);
    const Eigen::Vector3f aim(0.8f * rng.NextFloat() - 0.4f, 0.8f * rng.NextFloat() - 0.4f,
                              1.5f + 0.8f * rng.NextFloat() - 0.4f);
    ray.direction = aim - ray.origin;
    ray.mask = mask;
  }
  int64_t blocked = 0, traced = 0;
  for (auto _ : state) {
    for (const mr::Ray& ray : rays) blocked += r.embree.Occluded(ray);
    traced += static_cast<int64_t>(rays.size());
  }
  benchmark::DoNotOptimize(blocked);
  state.counters["rays_per_s"] = benchmark::Counter(static_cast<double>(traced), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RoughRoomShadowRays)
    ->ArgsProduct({{mr::kMaskVirtual, mr::kMaskReal, mr::kMaskAll}, {0, 1}})
    ->ArgNames({"mask", "moved"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The shared differential direct light at real points (DirectDiffuse with
// shadow_samples 4, ic's default: the objects' sky shadow by
// EnvironmentDifference, the lights' by shadow rays), one thread: a 10-m
// floor, a 0.1-m virtual sphere 0.1 m above it, and a sky with a sun of
// 1e4 x its radiance in a 128 x 64 map.  Points on a grid 0.05 to 5 m from
// the sphere, as a frame's real pixels lie (most far from the object).
void BM_SharedDirectLight(benchmark::State& state) {
  static const auto scene = [] {
    auto s = std::make_unique<mr::RenderScene>();
    mr::Material floor, ball;
    floor.albedo = Eigen::Vector3d::Constant(0.6);
    ball.albedo = Eigen::Vector3d::Constant(0.8);
    s->AddReal(mr::Quad({-5, 0, -5}, {5, 0, -5}, {5, 0, 5}, {-5, 0, 5}), floor);
    Eigen::Affine3d t = Eigen::Affine3d::Identity();
    t.translate(Eigen::Vector3d(0, 0.2, 0));
    s->AddVirtual(mr::UvSphere(0.1f, 48), t, ball);
    mr::Image sky = mr::Image::Rgb(128, 64, 1.0f);
    for (int c = 0; c < 3; ++c) sky.at(40, 20, c) = 1e4f;
    s->SetEnvironment(mr::EnvironmentMap(sky, "sky"));
    s->Commit();
    return s;
  }();
  std::vector<mr::PathVertex> points;
  for (int i = 0; i < 64; ++i) {
    const double r = 0.05 * std::pow(100.0, i / 63.0), phi = 2.4 * i;  // 0.05 to 5 m, spiralling
    const Eigen::Vector3d at(r * std::cos(phi), 0, r * std::sin(phi)), eye = at + Eigen::Vector3d(0.3, 1, 0.2);
    const mr::Ray ray = mr::MakeRay(eye, (at - eye).normalized(), mr::kMaskReal);
    mr::Hit hit;
    if (!scene->embree().Intersect(ray, &hit)) continue;
    mr::PathVertex v = mr::MakeVertex(*scene, ray, hit);
    v.bsdf = mr::DiffuseLobe(*scene, v);
    points.push_back(v);
  }
  uint32_t index = 0;
  int64_t rays = 0, calls = 0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (auto _ : state) {
    for (const mr::PathVertex& v : points) {
      mr::Sampler g = mr::Sampler::Stratified(7, index++);
      Eigen::Vector3d m = Eigen::Vector3d::Zero(), r = Eigen::Vector3d::Zero();
      rays += mr::DirectDiffuse(
          *scene, v, v.albedo, false, true, true, g, &m, &r,
          [&](mr::Ray sr) { return mr::TestVirtualBlockers(*scene, sr) == mr::VirtualTest::kBlocked ? 0.0 : 1.0; }, 4);
      sum += m - r;
    }
    calls += static_cast<int64_t>(points.size());
  }
  benchmark::DoNotOptimize(sum);
  state.counters["seconds_per_point"] =
      benchmark::Counter(static_cast<double>(calls), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["rays_per_point"] = static_cast<double>(rays) / static_cast<double>(std::max<int64_t>(1, calls));
}
BENCHMARK(BM_SharedDirectLight)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
