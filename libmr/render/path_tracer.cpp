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
    if (depth >= settings_.max_depth || v.bsdf.IsBlack()) break;
    NextEvent(scene_, v, rng, [&](const Eigen::Vector3d& c, Ray shadow, bool virtual_light) {
      if (virtual_light && !(lights & kVirtualLights)) return;
      shadow.mask = mask;
      ++*rays;
      if (!Occluded(shadow)) L += beta.cwiseProduct(c);
    });
    BsdfSample s;
    const double ul = rng.NextDouble(), u0 = rng.NextDouble(), u1 = rng.NextDouble();
    if (!v.bsdf.Sample(v.frame.ToLocal(v.wo_world), ul, u0, u1, &s)) break;
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
    if (depth >= settings_.max_depth || v.bsdf.IsBlack()) return out;
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
    if (!v.bsdf.Sample(v.frame.ToLocal(v.wo_world), ul, u0, u1, &s)) return out;
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

}  // namespace mr
