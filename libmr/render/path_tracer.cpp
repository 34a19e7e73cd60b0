#include "render/path_tracer.h"

#include "render/path_common.h"

#include <atomic>
#include <cmath>

#include "core/math.h"
#include "core/parallel.h"
#include "core/spherical.h"

namespace mr {

Eigen::Vector3d DifferentialPathTracer::TraceSingle(Ray ray, uint32_t mask, Eigen::Vector3d beta, double prev_pdf,
                                                    int depth, Pcg32& rng, int* rays, int escape_from_depth) const {
  Eigen::Vector3d L = Eigen::Vector3d::Zero();
  ray.mask = mask;
  const unsigned lights = mask == kMaskReal ? kRealLights : kAllLights;  // a real path sees no virtual light
  for (;; ++depth) {
    Hit hit;
    ++*rays;
    if (!Intersect(ray, &hit)) {
      if (depth >= escape_from_depth) L += beta.cwiseProduct(Escaped(scene_, ray, prev_pdf, lights));
      break;
    }
    PathVertex v = MakeVertex(scene_, ray, hit);
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

PathSample DifferentialPathTracer::TraceFrom(const Ray& start, Eigen::Vector3d beta, double prev_pdf, int start_depth,
                                             Pcg32& rng, int escape_from_depth) const {
  PathSample out;
  int* rays = &out.rays;
  Ray ray = start;
  ray.mask = kMaskAll;
  for (int depth = start_depth;; ++depth) {
    Hit hit;
    ++*rays;
    const bool found = Intersect(ray, &hit);
    if (depth == start_depth) out.first_t = hit.t;
    if (!found) {
      if (depth < escape_from_depth) return out;
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
      out.real += TraceSingle(ray, kMaskReal, beta, prev_pdf, depth, real_rng, &out.rays, escape_from_depth);
      out.mixed += TraceSingle(ray, kMaskAll, beta, prev_pdf, depth, rng, &out.rays, escape_from_depth);
      return out;
    }
    // A real vertex shared by both paths.
    PathVertex v = MakeVertex(scene_, ray, hit);
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
      height_(camera.height()),
      acc_(width_, height_) {
  const size_t n = static_cast<size_t>(width_) * height_;
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
}

void FrameRenderer::RenderPass(int spp) {
  std::atomic<int64_t> nonfinite{0}, rays{0};
  ParallelFor(0, height_, [&](int64_t y) {
    int64_t row_rays = 0;
    for (int x = 0; x < width_; ++x) {
      const size_t i = static_cast<size_t>(y) * width_ + x;
      if (!sampler_.PixelValid(x, static_cast<int>(y))) continue;  // outside the lens
      if (skip_[i] && acc_.count(i) > 0) continue;  // provably no difference: sampled once is enough
      acc_.Count(i, spp);
      for (int s = 0; s < spp; ++s) {
        Ray ray;
        Pcg32 rng = sampler_.Sample(x, static_cast<int>(y), spp_ + s, &ray);
        PathSample ps = tracer_.Trace(ray, rng);
        row_rays += ps.rays;
        if (!ps.mixed.allFinite() || !ps.real.allFinite()) {
          ++nonfinite;  // dropped and counted: never NaN in the image
          continue;
        }
        acc_.Add(i, ps.mixed, ps.real, ps.primary_virtual);
      }
    }
    rays += row_rays;
  });
  spp_ += spp;
  nonfinite_ += nonfinite.load();
  rays_ += rays.load();
}

Image FrameRenderer::Mixed() const { return acc_.Mixed(); }
Image FrameRenderer::Real() const { return acc_.Real(); }
Image FrameRenderer::Mask() const { return acc_.Mask(); }
Image FrameRenderer::DifferenceVariance() const { return acc_.DifferenceVariance(); }
Image FrameRenderer::SampleCount() const { return acc_.SampleCount(); }

}  // namespace mr
