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

// Ray origins are offset along the normal by 64 float ulps of the hit
// position: local, so the offset (and every path) does not depend on what
// else is in the scene.
double OffsetScale(const Eigen::Vector3d& p) {
  return 64.0 * std::numeric_limits<float>::epsilon() * std::max(p.cwiseAbs().maxCoeff(), 1e-3);
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
  Frame frame{Eigen::Vector3d::UnitZ()};
  const Bsdf* bsdf = nullptr;
  const Material* material = nullptr;
};

Vertex MakeVertex(const RenderScene& scene, const Ray& ray, const Hit& hit) {
  Vertex v;
  const Eigen::Vector3d d = ray.direction.cast<double>().normalized();
  v.p = ray.origin.cast<double>() + static_cast<double>(hit.t) * ray.direction.cast<double>();
  Eigen::Vector3d n = scene.WorldNormal(hit);
  if (n.dot(d) > 0) n = -n;  // two-sided: face the incoming ray
  v.frame = Frame(n);
  v.wo_world = -d;
  v.bsdf = &scene.bsdf(hit.geometry_id);
  v.material = &scene.material(hit.geometry_id);
  return v;
}

// One environment next-event estimate at `v`.  Returns the unoccluded
// contribution (times beta) and the shadow ray to test.
bool EnvironmentNee(const RenderScene& scene, const Vertex& v, Pcg32& rng, Eigen::Vector3d* contrib, Ray* shadow) {
  const EnvironmentMap& env = scene.environment();
  const double u0 = rng.NextDouble(), u1 = rng.NextDouble(), u2 = rng.NextDouble();
  if (env.empty()) return false;
  Eigen::Vector3d wi;
  double pdf_light = 0;
  Eigen::Vector3d le = env.Sample(u0, u1, u2, &wi, &pdf_light);
  if (pdf_light <= 0) return false;
  const Eigen::Vector3d wo_l = v.frame.ToLocal(v.wo_world), wi_l = v.frame.ToLocal(wi);
  if (wi_l.z() <= 0) return false;
  Eigen::Vector3d f = v.bsdf->Eval(wo_l, wi_l);
  if (f.maxCoeff() <= 0) return false;
  const double w = PowerHeuristic(pdf_light, v.bsdf->Pdf(wo_l, wi_l));
  *contrib = f.cwiseProduct(le) * (wi_l.z() * w / pdf_light);
  *shadow = MakeRay(v.p + v.frame.n * OffsetScale(v.p), wi, kMaskAll);
  return true;
}

}  // namespace

Eigen::Vector3d DifferentialPathTracer::TraceSingle(Ray ray, uint32_t mask, Eigen::Vector3d beta, double prev_pdf,
                                                    int depth, Pcg32& rng, int* rays) const {
  Eigen::Vector3d L = Eigen::Vector3d::Zero();
  ray.mask = mask;
  for (;; ++depth) {
    Hit hit;
    ++*rays;
    if (!Intersect(ray, &hit)) {
      const Eigen::Vector3d d = ray.direction.cast<double>().normalized();
      const double w = prev_pdf > 0 ? PowerHeuristic(prev_pdf, scene_.environment().Pdf(d)) : 1.0;
      L += beta.cwiseProduct(scene_.environment().Eval(d)) * w;
      break;
    }
    Vertex v = MakeVertex(scene_, ray, hit);
    L += beta.cwiseProduct(v.material->emission);
    if (depth >= settings_.max_depth || v.bsdf->IsBlack()) break;
    Eigen::Vector3d c;
    Ray shadow;
    if (EnvironmentNee(scene_, v, rng, &c, &shadow)) {
      shadow.mask = mask;
      ++*rays;
      if (!Occluded(shadow)) L += beta.cwiseProduct(c);
    }
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
    ray = MakeRay(v.p + v.frame.n * OffsetScale(v.p), v.frame.ToWorld(s.wi), mask);
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
      const Eigen::Vector3d d = ray.direction.cast<double>().normalized();
      const double w = prev_pdf > 0 ? PowerHeuristic(prev_pdf, scene_.environment().Pdf(d)) : 1.0;
      const Eigen::Vector3d c = beta.cwiseProduct(scene_.environment().Eval(d)) * w;
      out.mixed += c;
      out.real += c;
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
    Eigen::Vector3d c;
    Ray shadow;
    if (EnvironmentNee(scene_, v, rng, &c, &shadow)) {
      shadow.mask = kMaskReal;
      ++out.rays;
      if (!Occluded(shadow)) {             // st_r
        out.real += beta.cwiseProduct(c);
        shadow.mask = kMaskVirtual;
        ++out.rays;
        if (!Occluded(shadow)) out.mixed += beta.cwiseProduct(c);  // st_rv = min(st_r, st_v)
      }
    }
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
    ray = MakeRay(v.p + v.frame.n * OffsetScale(v.p), v.frame.ToWorld(s.wi), kMaskAll);
  }
}

FrameRenderer::FrameRenderer(const RenderScene& scene, const CameraModel& camera, const Rigid3& world_from_cam,
                             const PathTracerSettings& settings)
    : scene_(scene),
      tracer_(scene, settings),
      width_(camera.width()),
      height_(camera.height()),
      world_from_cam_(world_from_cam) {
  const size_t n = static_cast<size_t>(width_) * height_;
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
  frame_seed_ = HashCombine(settings.seed, static_cast<uint64_t>(settings.frame));
  sum_m_.assign(n, Eigen::Vector3d::Zero());
  sum_r_.assign(n, Eigen::Vector3d::Zero());
  sum_d_.assign(n, 0);
  sum_d2_.assign(n, 0);
  coverage_.assign(n, 0);
}

void FrameRenderer::RenderPass(int spp) {
  std::atomic<int64_t> nonfinite{0}, rays{0};
  const Eigen::Matrix3d R = world_from_cam_.rotation.toRotationMatrix();
  const Eigen::Vector3d origin = world_from_cam_.translation;
  ParallelFor(0, height_, [&](int64_t y) {
    int64_t row_rays = 0;
    for (int x = 0; x < width_; ++x) {
      const size_t i = static_cast<size_t>(y) * width_ + x;
      const size_t c00 = static_cast<size_t>(y) * (width_ + 1) + x, c10 = c00 + 1, c01 = c00 + width_ + 1,
                   c11 = c01 + 1;
      if (!(corner_ok_[c00] && corner_ok_[c10] && corner_ok_[c01] && corner_ok_[c11])) continue;  // outside the lens
      for (int s = 0; s < spp; ++s) {
        // One generator per (pixel, sample index): samples are independent
        // of each other, of the thread count and of how passes split them.
        Pcg32 rng(HashCombine(frame_seed_, static_cast<uint64_t>(spp_ + s)), i);
        const double fx = rng.NextDouble(), fy = rng.NextDouble();
        Eigen::Vector3d d = (1 - fy) * ((1 - fx) * corner_dirs_[c00] + fx * corner_dirs_[c10]) +
                            fy * ((1 - fx) * corner_dirs_[c01] + fx * corner_dirs_[c11]);
        Ray ray = MakeRay(origin, (R * d).normalized(), kMaskAll);
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
Image MeanImage(const std::vector<Eigen::Vector3d>& sum, int w, int h, int spp) {
  Image img = Image::Rgb(w, h);
  const double inv = spp > 0 ? 1.0 / spp : 0.0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        img.at(x, y, c) = static_cast<float>(sum[static_cast<size_t>(y) * w + x][c] * inv);
  return img;
}
}  // namespace

Image FrameRenderer::Mixed() const { return MeanImage(sum_m_, width_, height_, spp_); }
Image FrameRenderer::Real() const { return MeanImage(sum_r_, width_, height_, spp_); }

Image FrameRenderer::Mask() const {
  Image img = Image::Gray(width_, height_);
  for (size_t i = 0; i < coverage_.size(); ++i) img.values()[i] = spp_ > 0 ? static_cast<float>(coverage_[i] / spp_) : 0.f;
  return img;
}

Image FrameRenderer::DifferenceVariance() const {
  Image img = Image::Gray(width_, height_);
  if (spp_ < 2) return img;
  for (size_t i = 0; i < sum_d_.size(); ++i) {
    const double mean = sum_d_[i] / spp_;
    const double var = std::max(0.0, (sum_d2_[i] / spp_ - mean * mean)) * spp_ / (spp_ - 1);
    img.values()[i] = static_cast<float>(var / spp_);  // variance of the mean
  }
  return img;
}

}  // namespace mr
