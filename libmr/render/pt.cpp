#include "render/pt.h"

#include <algorithm>
#include <cmath>

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
    : PixelLoopMethod(camera, world_from_cam, settings.seed, settings.frame, exposure),
      tracer_(scene, settings),
      batch_(std::max(0, settings.batch)) {
  const size_t n = static_cast<size_t>(width()) * height();
  // Pixels whose camera rays provably meet no geometry see only the
  // environment, identically in I_m and I_r: their difference is exactly
  // zero, and after the first pass they are not sampled further.
  bool virtual_disc = false;  // a virtual sun seen directly differs between I_m and I_r
  for (const LightSource& l : scene.lights()) virtual_disc = virtual_disc || (l.is_virtual() && !l.light().IsDelta());
  // (One apex and fixed corners: not with a moving camera or a lens.)
  skip_possible_ = settings.skip_environment_pixels && scene.has_virtual() && !virtual_disc && !exposure.any();
  if (!skip_possible_) return;
  eye_ = world_from_cam.translation;
  for (const auto& b : scene.geometry_bounds())
    for (int k = 0; k < 8; ++k)
      far_ = std::max(far_, (b.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)) - eye_).norm());
  far_ = 2 * far_ + 1;  // the hull of the apex and the far corners covers the pyramid out to far/2
  escaped_.assign(n, 0);
  skip_.assign(n, kUntested);
}

bool PtFrameRenderer::ProvablyEnvironment(size_t pixel) const {
  const int x = static_cast<int>(pixel % static_cast<size_t>(width())), y = static_cast<int>(pixel / width());
  const CameraSampler& cs = sampler();
  if (!cs.PixelValid(x, y)) return false;
  Eigen::Vector3d c[4];
  cs.CornerDirections(x, y, c);
  const Eigen::Vector3d axis = (c[0] + c[1] + c[2] + c[3]).normalized();
  for (const auto& ci : c)
    if (!(ci.dot(axis) > 0.9)) return false;  // too wide for the pyramid's proof
  for (const auto& b : tracer_.scene().geometry_bounds())
    if (!PyramidMissesBox(eye_, c, far_, b)) return false;
  return true;
}

bool PtFrameRenderer::PixelDone(size_t pixel) const {
  if (!only_.empty() && !only_[pixel]) return true;
  if (!skip_possible_ || !escaped_[pixel] || accumulator().count(pixel) == 0) return false;
  if (skip_[pixel] == kUntested) skip_[pixel] = ProvablyEnvironment(pixel) ? kSkip : kKeep;
  return skip_[pixel] == kSkip;
}

int64_t PtFrameRenderer::skipped_pixels() const {
  return std::count(skip_.begin(), skip_.end(), static_cast<char>(kSkip));
}

void PtFrameRenderer::Shade(const Ray& ray, Sampler& rng, int64_t, size_t pixel, int sample, PathSample* out) {
  *out = tracer_.Trace(ray, rng);
  if (sample == 0 && skip_possible_) escaped_[pixel] = !std::isfinite(out->first_t);
}

void PtFrameRenderer::ShadeBatch(Batch& b, int64_t row) {
  if (batch_ == 0) return PixelLoopMethod::ShadeBatch(b, row);
  tracer_.TraceBatch(b.rays, b.rngs, b.out);
  if (skip_possible_)
    for (size_t k = 0; k < b.out.size(); ++k)
      if (b.samples[k] == 0) escaped_[b.pixels[k]] = !std::isfinite(b.out[k].first_t);
}

namespace {

PathTracerSettings ParsePtSettings(JsonSettings& s, const Scene& scene) {
  PathTracerSettings st;
  s.Bool("skip_environment_pixels", &st.skip_environment_pixels);
  s.Bool("plate_reflections", &st.plate_reflections);
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

std::unique_ptr<RenderMethod> MakePtMethod(JsonSettings& block, const Scene& scene) {
  return std::make_unique<PtMethod>(ParsePtSettings(block, scene));
}

}  // namespace mr
