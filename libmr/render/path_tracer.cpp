#include "render/path_tracer.h"

#include <atomic>
#include <cmath>

#include "core/math.h"
#include "core/parallel.h"
#include "core/spherical.h"

namespace mr {

namespace {

double PowerHeuristic(double a, double b) {
  if (std::isinf(a)) return 1;
  const double a2 = a * a, b2 = b * b;
  return a2 + b2 > 0 ? a2 / (a2 + b2) : 0;
}

struct Frame {
  Eigen::Vector3d t, b, n;
  explicit Frame(const Eigen::Vector3d& normal) : n(normal) { CoordinateSystem(n, &t, &b); }
  Eigen::Vector3d ToLocal(const Eigen::Vector3d& v) const { return {v.dot(t), v.dot(b), v.dot(n)}; }
  Eigen::Vector3d ToWorld(const Eigen::Vector3d& v) const { return v.x() * t + v.y() * b + v.z() * n; }
};

// Ray origins are offset along the normal by 64 float ulps of the largest
// magnitude that entered the hit position: the position itself, the ray's
// origin and the distance travelled (Embree's t carries an error relative to
// those, so a hit near the world origin reached from 1 m away is uncertain
// to ~1e-7 m, not to ulps of its own tiny coordinates).  Local, so the
// offset (and every path) does not depend on what else is in the scene.
double OffsetScale(const Eigen::Vector3d& p, const Eigen::Vector3d& origin, double t) {
  const double m = std::max({p.cwiseAbs().maxCoeff(), origin.cwiseAbs().maxCoeff(), t, 1e-3});
  return 64.0 * std::numeric_limits<float>::epsilon() * m;
}

Ray MakeRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, uint32_t mask, double tfar = INFINITY) {
  Ray r;
  r.origin = origin.cast<float>();
  r.direction = dir.cast<float>();
  r.mask = mask;
  r.tfar = static_cast<float>(tfar);
  return r;
}

// A surface vertex: position, shading frame facing the incoming ray, BSDF.
struct Vertex {
  Eigen::Vector3d p, wo_world;
  double offset = 0;  // along the normal, for rays leaving p
  Frame frame{Eigen::Vector3d::UnitZ()};
  const Bsdf* bsdf = nullptr;
  const Material* material = nullptr;
};

Vertex MakeVertex(const RenderScene& scene, const Ray& ray, const Hit& hit) {
  Vertex v;
  const Eigen::Vector3d d = ray.direction.cast<double>().normalized();
  const Eigen::Vector3d o = ray.origin.cast<double>();
  v.p = o + static_cast<double>(hit.t) * ray.direction.cast<double>();
  v.offset = OffsetScale(v.p, o, static_cast<double>(hit.t) * ray.direction.cast<double>().norm());
  Eigen::Vector3d n = scene.WorldNormal(hit);
  if (n.dot(d) > 0) n = -n;  // two-sided: face the incoming ray
  v.frame = Frame(n);
  v.wo_world = -d;
  v.bsdf = &scene.bsdf(hit.geometry_id);
  v.material = &scene.material(hit.geometry_id);
  return v;
}

// Which emitters a path sees: the environment and real lights exist in both
// I_m and I_r, virtual lights only in I_m.
enum LightSet : unsigned { kRealLights = 1, kVirtualLights = 2, kAllLights = 3 };

unsigned LightBit(const LightSource& l) { return l.is_virtual() ? kVirtualLights : kRealLights; }

// Radiance arriving along an escaped ray from the environment and the
// distant disc lights in `which`, each MIS-weighted against the BSDF pdf
// that chose the direction (prev_pdf 0: seen directly by the camera).
Eigen::Vector3d Escaped(const RenderScene& scene, const Ray& ray, double prev_pdf, unsigned which) {
  Eigen::Vector3d L = Eigen::Vector3d::Zero();
  const Eigen::Vector3d d = ray.direction.cast<double>().normalized();
  const EnvironmentMap& env = scene.environment();
  if ((which & kRealLights) && !env.empty()) {
    double pdf = 0;
    const Eigen::Vector3d le = env.EvalWithPdf(d, &pdf);
    L += le * (prev_pdf > 0 ? PowerHeuristic(prev_pdf, pdf) : 1.0);
  }
  if (scene.has_distant_area_light())
    for (const LightSource& l : scene.lights()) {
      if (!(which & LightBit(l))) continue;
      double pdf = 0;
      const Eigen::Vector3d le = l.EvalDistant(d, &pdf);
      if (pdf > 0) L += le * (prev_pdf > 0 ? PowerHeuristic(prev_pdf, pdf) : 1.0);
    }
  return L;
}

// Next-event estimates at `v`: one environment sample and one sample of each
// light.  Calls emit(contribution, shadow ray, is_virtual_light) for each
// unoccluded contribution (times beta: the caller's) still to be tested.  The
// random numbers drawn do not depend on outcomes, so that paths that part at
// a virtual object keep their streams aligned.
template <class Emit>
void NextEvent(const RenderScene& scene, const Vertex& v, Pcg32& rng, Emit&& emit) {
  const Eigen::Vector3d wo_l = v.frame.ToLocal(v.wo_world);
  const Eigen::Vector3d origin = v.p + v.frame.n * v.offset;
  const EnvironmentMap& env = scene.environment();
  {
    const double u0 = rng.NextDouble(), u1 = rng.NextDouble(), u2 = rng.NextDouble();
    Eigen::Vector3d wi;
    double pdf_light = 0;
    if (!env.empty()) {
      const Eigen::Vector3d le = env.Sample(u0, u1, u2, &wi, &pdf_light);
      const Eigen::Vector3d wi_l = v.frame.ToLocal(wi);
      if (pdf_light > 0 && wi_l.z() > 0) {
        const Eigen::Vector3d f = v.bsdf->Eval(wo_l, wi_l);
        if (f.maxCoeff() > 0) {
          const double w = PowerHeuristic(pdf_light, v.bsdf->Pdf(wo_l, wi_l));
          emit(Eigen::Vector3d(f.cwiseProduct(le) * (wi_l.z() * w / pdf_light)), MakeRay(origin, wi, kMaskAll), false);
        }
      }
    }
  }
  for (const LightSource& l : scene.lights()) {
    const double u0 = rng.NextDouble(), u1 = rng.NextDouble();
    LightSample ls;
    if (!l.Sample(v.p, u0, u1, &ls)) continue;
    const Eigen::Vector3d wi_l = v.frame.ToLocal(ls.wi);
    if (wi_l.z() <= 0) continue;
    const Eigen::Vector3d f = v.bsdf->Eval(wo_l, wi_l);
    if (f.maxCoeff() <= 0) continue;
    const double w = ls.delta ? 1.0 : PowerHeuristic(ls.pdf, v.bsdf->Pdf(wo_l, wi_l));
    // A point light's shadow ray stops just short of it.
    const double tfar = std::isinf(ls.distance) ? INFINITY : ls.distance * (1 - 1e-6);
    emit(Eigen::Vector3d(f.cwiseProduct(ls.li) * (wi_l.z() * w / ls.pdf)), MakeRay(origin, ls.wi, kMaskAll, tfar),
         l.is_virtual());
  }
}

}  // namespace

Eigen::Vector3d DifferentialPathTracer::TraceSingle(Ray ray, uint32_t mask, Eigen::Vector3d beta, double prev_pdf,
                                                    int depth, Pcg32& rng, int* rays) const {
  Eigen::Vector3d L = Eigen::Vector3d::Zero();
  ray.mask = mask;
  const unsigned lights = mask == kMaskReal ? kRealLights : kAllLights;  // a real path sees no virtual light
  for (;; ++depth) {
    Hit hit;
    ++*rays;
    if (!Intersect(ray, &hit)) {
      L += beta.cwiseProduct(Escaped(scene_, ray, prev_pdf, lights));
      break;
    }
    Vertex v = MakeVertex(scene_, ray, hit);
    L += beta.cwiseProduct(v.material->emission);
    if (depth >= settings_.max_depth || v.bsdf->IsBlack()) break;
    NextEvent(scene_, v, rng, [&](const Eigen::Vector3d& c, Ray shadow, bool virtual_light) {
      if (virtual_light && !(lights & kVirtualLights)) return;
      shadow.mask = mask;
      ++*rays;
      if (!Occluded(shadow)) L += beta.cwiseProduct(c);
    });
    BsdfSample s;
    const double ul = rng.NextDouble(), u0 = rng.NextDouble(), u1 = rng.NextDouble();
    if (!v.bsdf->Sample(v.frame.ToLocal(v.wo_world), ul, u0, u1, &s)) break;
    beta = beta.cwiseProduct(s.f) * (s.wi.z() / s.pdf);
    prev_pdf = s.pdf;
    if (depth + 1 >= settings_.rr_depth) {
      const double q = std::min(1.0, beta.maxCoeff());
      if (rng.NextDouble() >= q) break;
      beta /= q;
    }
    ray = MakeRay(v.p + v.frame.n * v.offset, v.frame.ToWorld(s.wi), mask);
  }
  return L;
}

PathSample DifferentialPathTracer::Trace(const Ray& primary, Pcg32& rng) const {
  PathSample out;
  int* rays = &out.rays;
  Ray ray = primary;
  ray.mask = kMaskAll;
  Eigen::Vector3d beta = Eigen::Vector3d::Ones();
  double prev_pdf = 0;  // 0: the camera ray, seen directly (no MIS)
  for (int depth = 0;; ++depth) {
    Hit hit;
    ++*rays;
    if (!Intersect(ray, &hit)) {
      const Eigen::Vector3d c = beta.cwiseProduct(Escaped(scene_, ray, prev_pdf, kRealLights));
      out.mixed += c;
      out.real += c;
      if (scene_.has_virtual()) out.mixed += beta.cwiseProduct(Escaped(scene_, ray, prev_pdf, kVirtualLights));
      return out;
    }
    if (hit.is_virtual) {
      // The paths part: the real one continues behind the object with a copy
      // of the random stream, the mixed one goes on from the object.
      if (depth == 0) out.primary_virtual = true;
      Pcg32 real_rng = rng;
      out.real += TraceSingle(ray, kMaskReal, beta, prev_pdf, depth, real_rng, &out.rays);
      out.mixed += TraceSingle(ray, kMaskAll, beta, prev_pdf, depth, rng, &out.rays);
      return out;
    }
    // A real vertex shared by both paths.
    Vertex v = MakeVertex(scene_, ray, hit);
    const Eigen::Vector3d e = beta.cwiseProduct(v.material->emission);
    out.mixed += e;
    out.real += e;
    if (depth >= settings_.max_depth || v.bsdf->IsBlack()) return out;
    const bool virtual_geometry = scene_.has_virtual_geometry();
    NextEvent(scene_, v, rng, [&](const Eigen::Vector3d& c, Ray shadow, bool virtual_light) {
      if (virtual_light) {  // lights I_m only, blocked by anything
        ++out.rays;
        if (!Occluded(shadow)) out.mixed += beta.cwiseProduct(c);
        return;
      }
      shadow.mask = kMaskReal;
      ++out.rays;
      if (Occluded(shadow)) return;  // st_r
      out.real += beta.cwiseProduct(c);
      if (virtual_geometry) {
        shadow.mask = kMaskVirtual;
        ++out.rays;
        if (Occluded(shadow)) return;  // st_rv = min(st_r, st_v)
      }
      out.mixed += beta.cwiseProduct(c);
    });
    BsdfSample s;
    const double ul = rng.NextDouble(), u0 = rng.NextDouble(), u1 = rng.NextDouble();
    if (!v.bsdf->Sample(v.frame.ToLocal(v.wo_world), ul, u0, u1, &s)) return out;
    beta = beta.cwiseProduct(s.f) * (s.wi.z() / s.pdf);
    prev_pdf = s.pdf;
    if (depth + 1 >= settings_.rr_depth) {
      const double q = std::min(1.0, beta.maxCoeff());
      if (rng.NextDouble() >= q) return out;
      beta /= q;
    }
    ray = MakeRay(v.p + v.frame.n * v.offset, v.frame.ToWorld(s.wi), kMaskAll);
  }
}

namespace {

// Whether the pyramid from `o` through the unit corner directions c[0..3]
// (in order around the pixel), up to distance `far`, provably misses `box`:
// a separating axis among the pyramid's side normals, the box's axes and
// their edge cross products.  Testing only some axes can miss a separation
// but never invent one, so a "true" is a proof.
bool PyramidMissesBox(const Eigen::Vector3d& o, const Eigen::Vector3d c[4], double far, const Eigen::AlignedBox3d& box) {
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

CameraSampler::CameraSampler(const CameraModel& camera, const Rigid3& world_from_cam, uint64_t seed, int frame)
    : width_(camera.width()),
      height_(camera.height()),
      world_from_cam_(world_from_cam),
      R_(world_from_cam.rotation.toRotationMatrix()) {
  corner_dirs_.resize(static_cast<size_t>(width_ + 1) * (height_ + 1));
  corner_ok_.resize(corner_dirs_.size());
  ParallelFor(0, height_ + 1, [&](int64_t y) {
    for (int x = 0; x <= width_; ++x) {
      const size_t i = static_cast<size_t>(y) * (width_ + 1) + x;
      Eigen::Vector3d d;
      corner_ok_[i] = camera.Unproject(Eigen::Vector2d(x - 0.5, static_cast<double>(y) - 0.5), &d);
      corner_dirs_[i] = corner_ok_[i] ? d : Eigen::Vector3d::UnitZ();
    }
  });
  frame_seed_ = HashCombine(seed, static_cast<uint64_t>(frame));
}

bool CameraSampler::PixelValid(int x, int y) const {
  const size_t c00 = static_cast<size_t>(y) * (width_ + 1) + x, c10 = c00 + 1, c01 = c00 + width_ + 1, c11 = c01 + 1;
  return corner_ok_[c00] && corner_ok_[c10] && corner_ok_[c01] && corner_ok_[c11];
}

Pcg32 CameraSampler::Sample(int x, int y, int s, Ray* ray) const {
  const size_t i = static_cast<size_t>(y) * width_ + x;
  const size_t c00 = static_cast<size_t>(y) * (width_ + 1) + x, c10 = c00 + 1, c01 = c00 + width_ + 1, c11 = c01 + 1;
  // One generator per (pixel, sample index): samples are independent of
  // each other, of the thread count and of how passes split them.
  Pcg32 rng(HashCombine(frame_seed_, static_cast<uint64_t>(s)), i);
  const double fx = rng.NextDouble(), fy = rng.NextDouble();
  const Eigen::Vector3d d = (1 - fy) * ((1 - fx) * corner_dirs_[c00] + fx * corner_dirs_[c10]) +
                            fy * ((1 - fx) * corner_dirs_[c01] + fx * corner_dirs_[c11]);
  *ray = MakeRay(world_from_cam_.translation, (R_ * d).normalized(), kMaskAll);
  return rng;
}

void CameraSampler::CornerDirections(int x, int y, Eigen::Vector3d c[4]) const {
  const size_t c00 = static_cast<size_t>(y) * (width_ + 1) + x, c10 = c00 + 1, c01 = c00 + width_ + 1, c11 = c01 + 1;
  c[0] = (R_ * corner_dirs_[c00]).normalized();
  c[1] = (R_ * corner_dirs_[c10]).normalized();
  c[2] = (R_ * corner_dirs_[c11]).normalized();
  c[3] = (R_ * corner_dirs_[c01]).normalized();
}

FrameRenderer::FrameRenderer(const RenderScene& scene, const CameraModel& camera, const Rigid3& world_from_cam,
                             const PathTracerSettings& settings)
    : scene_(scene),
      tracer_(scene, settings),
      sampler_(camera, world_from_cam, settings.seed, settings.frame),
      width_(camera.width()),
      height_(camera.height()) {
  const size_t n = static_cast<size_t>(width_) * height_;
  count_.assign(n, 0);
  // Pixels whose camera rays provably meet no geometry see only the
  // environment, identically in I_m and I_r: their difference is exactly
  // zero, and after the first pass they are not sampled further.
  skip_.assign(n, 0);
  bool virtual_disc = false;  // a virtual sun seen directly differs between I_m and I_r
  for (const LightSource& l : scene.lights()) virtual_disc = virtual_disc || (l.is_virtual() && !l.light().IsDelta());
  if (settings.skip_environment_pixels && scene.has_virtual() && !virtual_disc) {
    const Eigen::Vector3d o = world_from_cam.translation;
    double far = 1;
    for (const auto& b : scene.geometry_bounds())
      for (int k = 0; k < 8; ++k)
        far = std::max(far, (b.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)) - o).norm());
    far = 2 * far + 1;  // the hull of the apex and the far corners covers the pyramid out to far/2
    ParallelFor(0, height_, [&](int64_t y) {
      for (int x = 0; x < width_; ++x) {
        if (!sampler_.PixelValid(x, static_cast<int>(y))) continue;
        Eigen::Vector3d c[4];
        sampler_.CornerDirections(x, static_cast<int>(y), c);
        const Eigen::Vector3d axis = (c[0] + c[1] + c[2] + c[3]).normalized();
        bool narrow = true;
        for (const auto& ci : c) narrow = narrow && ci.dot(axis) > 0.9;
        if (!narrow) continue;
        bool misses = true;
        for (const auto& b : scene.geometry_bounds()) misses = misses && PyramidMissesBox(o, c, far, b);
        skip_[static_cast<size_t>(y) * width_ + x] = misses;
      }
    });
    for (char k : skip_) skipped_pixels_ += k;
  }
  sum_m_.assign(n, Eigen::Vector3d::Zero());
  sum_r_.assign(n, Eigen::Vector3d::Zero());
  sum_d_.assign(n, 0);
  sum_d2_.assign(n, 0);
  coverage_.assign(n, 0);
}

void FrameRenderer::RenderPass(int spp) {
  std::atomic<int64_t> nonfinite{0}, rays{0};
  ParallelFor(0, height_, [&](int64_t y) {
    int64_t row_rays = 0;
    for (int x = 0; x < width_; ++x) {
      const size_t i = static_cast<size_t>(y) * width_ + x;
      if (!sampler_.PixelValid(x, static_cast<int>(y))) continue;  // outside the lens
      if (skip_[i] && count_[i] > 0) continue;  // provably no difference: sampled once is enough
      count_[i] += spp;
      for (int s = 0; s < spp; ++s) {
        Ray ray;
        Pcg32 rng = sampler_.Sample(x, static_cast<int>(y), spp_ + s, &ray);
        PathSample ps = tracer_.Trace(ray, rng);
        row_rays += ps.rays;
        if (!ps.mixed.allFinite() || !ps.real.allFinite()) {
          ++nonfinite;  // dropped and counted: never NaN in the image
          continue;
        }
        sum_m_[i] += ps.mixed;
        sum_r_[i] += ps.real;
        const double dl = Luminance(ps.mixed - ps.real);
        sum_d_[i] += dl;
        sum_d2_[i] += dl * dl;
        coverage_[i] += ps.primary_virtual ? 1 : 0;
      }
    }
    rays += row_rays;
  });
  spp_ += spp;
  nonfinite_ += nonfinite.load();
  rays_ += rays.load();
}

namespace {
Image MeanImage(const std::vector<Eigen::Vector3d>& sum, int w, int h, const std::vector<int>& count) {
  Image img = Image::Rgb(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const double inv = count[i] > 0 ? 1.0 / count[i] : 0.0;
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = static_cast<float>(sum[i][c] * inv);
    }
  return img;
}
}  // namespace

Image FrameRenderer::Mixed() const { return MeanImage(sum_m_, width_, height_, count_); }
Image FrameRenderer::Real() const { return MeanImage(sum_r_, width_, height_, count_); }

Image FrameRenderer::Mask() const {
  Image img = Image::Gray(width_, height_);
  for (size_t i = 0; i < coverage_.size(); ++i) img.values()[i] = count_[i] > 0 ? static_cast<float>(coverage_[i] / count_[i]) : 0.f;
  return img;
}

Image FrameRenderer::DifferenceVariance() const {
  Image img = Image::Gray(width_, height_);
  for (size_t i = 0; i < sum_d_.size(); ++i) {
    const double n = count_[i];
    if (n < 2) continue;
    const double mean = sum_d_[i] / n;
    const double var = std::max(0.0, (sum_d2_[i] / n - mean * mean)) * n / (n - 1);
    img.values()[i] = static_cast<float>(var / n);  // variance of the mean
  }
  return img;
}

Image FrameRenderer::SampleCount() const {
  Image img = Image::Gray(width_, height_);
  for (size_t i = 0; i < count_.size(); ++i) img.values()[i] = static_cast<float>(count_[i]);
  return img;
}

}  // namespace mr
