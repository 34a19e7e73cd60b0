#include "render/pt.h"

#include <algorithm>

#include <spdlog/spdlog.h>

#include "core/parallel.h"
#include "render/render_scene.h"

namespace mr {

namespace {

// Whether the pyramid from `o` through the unit corner directions c[0..3]
// (in order around the pixel), up to distance `far`, provably misses `box`:
// a separating axis among the pyramid's side normals, the box's axes and
// their edge cross products.  Testing only some axes can miss a separation
// but never invent one, so a "true" is a proof.
bool PyramidMissesBox(const Eigen::Vector3d& o, const Eigen::Vector3d c[4], double far,
                      const Eigen::AlignedBox3d& box) {
  if (box.contains(o)) return false;
  const Eigen::Vector3d centre = box.center(), half = 0.5 * box.sizes();
  Eigen::Vector3d pts[5] = {o, o + far * c[0], o + far * c[1], o + far * c[2], o + far * c[3]};
  const double margin = 1e-5 * far;  // float rays deviate from these directions by ~1e-7
  auto separated = [&](const Eigen::Vector3d& a) {
    const double n = a.norm();
    if (!(n > 1e-12)) return false;
    double lo = INFINITY, hi = -INFINITY;
    for (const auto& p : pts) {
      const double d = p.dot(a);
      lo = std::min(lo, d);
      hi = std::max(hi, d);
    }
    const double bc = centre.dot(a), br = half.dot(a.cwiseAbs());
    return lo > bc + br + margin * n || hi < bc - br - margin * n;
  };
  for (int i = 0; i < 4; ++i)
    if (separated(c[i].cross(c[(i + 1) % 4]))) return true;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(k);
    if (separated(e)) return true;
    for (int i = 0; i < 4; ++i)
      if (separated(e.cross(c[i])) || separated(e.cross(c[(i + 1) % 4] - c[i]))) return true;
  }
  return false;
}

}  // namespace

PtFrameRenderer::PtFrameRenderer(const RenderScene& scene, const CameraModel& camera, const Rigid3& world_from_cam,
                                 const PathTracerSettings& settings, const CameraExposure& exposure)
    : PixelLoopMethod(camera, world_from_cam, settings.seed, settings.frame, exposure), tracer_(scene, settings) {
  const size_t n = static_cast<size_t>(width()) * height();
  const CameraSampler& cs = sampler();
  // Pixels whose camera rays provably meet no geometry see only the
  // environment, identically in I_m and I_r: their difference is exactly
  // zero, and after the first pass they are not sampled further.
  skip_.assign(n, 0);
  bool virtual_disc = false;  // a virtual sun seen directly differs between I_m and I_r
  for (const LightSource& l : scene.lights()) virtual_disc = virtual_disc || (l.is_virtual() && !l.light().IsDelta());
  // (One apex and fixed corners: not with a moving camera or a lens.)
  if (settings.skip_environment_pixels && scene.has_virtual() && !virtual_disc && !exposure.any()) {
    const Eigen::Vector3d o = world_from_cam.translation;
    double far = 1;
    for (const auto& b : scene.geometry_bounds())
      for (int k = 0; k < 8; ++k)
        far = std::max(far, (b.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)) - o).norm());
    far = 2 * far + 1;  // the hull of the apex and the far corners covers the pyramid out to far/2
    ParallelFor(0, height(), [&](int64_t y) {
      for (int x = 0; x < width(); ++x) {
        if (!cs.PixelValid(x, static_cast<int>(y))) continue;
        Eigen::Vector3d c[4];
        cs.CornerDirections(x, static_cast<int>(y), c);
        const Eigen::Vector3d axis = (c[0] + c[1] + c[2] + c[3]).normalized();
        bool narrow = true;
        for (const auto& ci : c) narrow = narrow && ci.dot(axis) > 0.9;
        if (!narrow) continue;
        bool misses = true;
        for (const auto& b : scene.geometry_bounds()) misses = misses && PyramidMissesBox(o, c, far, b);
        skip_[static_cast<size_t>(y) * width() + x] = misses;
      }
    });
    for (char k : skip_) skipped_pixels_ += k;
  }
}

void PtFrameRenderer::Shade(const Ray& ray, Sampler& rng, int64_t, size_t, int, PathSample* out) {
  *out = tracer_.Trace(ray, rng);
}

namespace {

PathTracerSettings ParsePtSettings(const JsonNode& block, const Scene& scene) {
  block.RequireObject({"skip_environment_pixels", "plate_reflections"});
  PathTracerSettings st;
  if (block.Has("skip_environment_pixels")) st.skip_environment_pixels = block.Child("skip_environment_pixels").Bool();
  if (block.Has("plate_reflections")) st.plate_reflections = block.Child("plate_reflections").Bool();
  return WithSceneRender(st, scene);
}

class PtMethod : public SettingsMethod<PathTracerSettings> {
 public:
  using SettingsMethod::SettingsMethod;
  std::unique_ptr<FrameMethod> NewFrame(const FrameContext& f) override {
    PathTracerSettings st = st_;
    st.seed = f.seed;
    st.frame = f.frame;
    st.plates = f.plates;
    return std::make_unique<PtFrameRenderer>(f.rs, f.camera, f.world_from_cam, st, f.exposure);
  }
  // Nothing of pt's outlives a frame: a changed world costs nothing.
  std::vector<std::string> WorldChanged(const JobContext&, const WorldChange&) override { return {}; }
  void Prepare(const JobContext& job) override {
    if (!st_.plate_reflections)
      job.report->Skip("plate reflections",
                       "render.pt.plate_reflections is false: virtual objects reflect the "
                       "rendered room");
    else if (!job.photograph)
      job.report->Skip("plate reflections", "no plate: virtual objects reflect the rendered room");
  }
  void FrameDone(const FrameMethod& fm, const FrameContext& f, Report* report, Json* frame_json) override {
    const auto& fr = static_cast<const PtFrameRenderer&>(fm);
    Json c = PlateCountersJson(fr.plate_counters());
    if (!c.is_null()) (*frame_json)["plate_reflections"] = std::move(c);
    (*frame_json)["rays"] = fr.rays_traced();
    (*frame_json)["virtual_shadow_tests_skipped"] = fr.virtual_tests_skipped();
    if (fr.virtual_tests_skipped() > 0)
      report->Skip(fmt::format("frame {}: {} virtual shadow tests", f.frame, fr.virtual_tests_skipped()),
                   "their shadow segments meet no virtual object's bounding box: no virtual object can block them");
  }
  bool TakesPlateReflections() const override { return st_.plate_reflections; }
};

}  // namespace

std::unique_ptr<RenderMethod> MakePtMethod(const JsonNode& block, const Scene& scene) {
  return std::make_unique<PtMethod>(ParsePtSettings(block, scene));
}

}  // namespace mr
