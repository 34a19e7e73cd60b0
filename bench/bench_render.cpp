// Renderer benchmarks: samples and rays per second of `pt` on mr-synth's
// presets, against a bare Embree closest-hit loop over the same scene (the
// efficiency ratio).  Results go into docs/benchmarks.md.
#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>

#include "camera/camera_model.h"
#include "camera/trajectory.h"
#include "core/parallel.h"
#include "core/report.h"
#include "core/sampling.h"
#include "render/camera_sampler.h"
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
void BM_EfficiencyRatio(benchmark::State& state, const std::string& preset) {
  Capture& c = Get(preset);
  mr::SetThreadCount(1);
  mr::RayLog log;
  mr::PathTracerSettings st;
  st.max_depth = 8;
  st.skip_environment_pixels = false;  // every pass traces the rays of the recorded one
  {
    st.ray_log = &log;
    mr::PtFrameRenderer fr(c.scene, c.camera, c.pose, st);
    fr.RenderPass(1);
  }
  st.ray_log = nullptr;
  mr::PtFrameRenderer fr(c.scene, c.camera, c.pose, st);
  double render_s = 0, bare_s = 0;
  int64_t hits = 0;
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    fr.RenderPass(1);
    auto t1 = std::chrono::steady_clock::now();
    for (const auto& r : log.closest) {
      mr::Hit h;
      hits += c.scene.embree().Intersect(r, &h);
    }
    for (const auto& r : log.occlusion) hits += c.scene.embree().Occluded(r);
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
  state.counters["occlusion_share"] =
      static_cast<double>(log.occlusion.size()) / static_cast<double>(log.closest.size() + log.occlusion.size());
}
BENCHMARK_CAPTURE(BM_EfficiencyRatio, small, std::string("small"))->Unit(benchmark::kMillisecond)->Iterations(20);
BENCHMARK_CAPTURE(BM_EfficiencyRatio, room, std::string("room"))->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
