#include "eval/transfer_reference.h"

#include <algorithm>
#include <cmath>

#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "core/spherical.h"
#include "light/environment.h"
#include "render/path_tracer.h"
#include "render/render_scene.h"
#include "transfer/formfactor.h"

namespace mr {

std::vector<Eigen::Vector3d> ReferenceVertexRadiance(const Mesh& mesh, const Image& env, const std::string& env_name,
                                                     const Eigen::Matrix3d& world_from_object, double albedo,
                                                     int bounces, int rays, uint64_t seed) {
  TransferStats stats;
  const std::vector<Eigen::Vector3d> normals = TransferNormals(mesh, &stats);
  RenderScene scene;
  Material m;
  m.albedo = Eigen::Vector3d::Constant(albedo);
  Mesh world = mesh;
  for (auto& p : world.positions) p = (world_from_object * p.cast<double>()).cast<float>();
  world.normals.clear();
  scene.AddReal(world, m);
  scene.SetEnvironment(EnvironmentMap(env, env_name));
  scene.Commit();
  PathTracerSettings st;
  st.max_depth = bounces;
  st.seed = seed;
  DifferentialPathTracer tracer(scene, st);
  const EnvironmentMap& em = scene.environment();
  const auto bounds = world.Bounds();
  const double offset = std::max(1e-6, 1e-5 * static_cast<double>((bounds.max() - bounds.min()).norm()));
  std::vector<Eigen::Vector3d> out(mesh.positions.size(), Eigen::Vector3d::Zero());
  ParallelFor(0, static_cast<int64_t>(mesh.positions.size()), [&](int64_t v) {
    const Eigen::Vector3d n = (world_from_object * normals[static_cast<size_t>(v)]).normalized();
    if (!n.allFinite() || normals[static_cast<size_t>(v)].squaredNorm() == 0) return;
    const Eigen::Vector3d p = world.positions[static_cast<size_t>(v)].cast<double>() + offset * n;
    Eigen::Vector3d t, b;
    CoordinateSystem(n, &t, &b);
    Eigen::Vector3d e = Eigen::Vector3d::Zero();  // estimate of irradiance E
    for (int s = 0; s < rays; ++s) {
      // Sample s of the vertex's stratified sequence.
      Sampler rng = Sampler::Stratified(HashCombine(seed, static_cast<uint64_t>(v)), static_cast<uint32_t>(s));
      // Environment sample, MIS against cosine sampling.
      Eigen::Vector3d wi;
      double pdf_l = 0;
      const auto [e0, e1] = rng.Next2D();
      const Eigen::Vector3d le = em.Sample(e0, e1, &wi, &pdf_l);
      const double cos_l = wi.dot(n);
      if (pdf_l > 0 && cos_l > 0) {
        Ray r;
        r.origin = p.cast<float>();
        r.direction = wi.cast<float>();
        if (!scene.embree().Occluded(r)) {
          const double pb = cos_l / kPi;
          e += le * (cos_l / pdf_l * pdf_l * pdf_l / (pdf_l * pdf_l + pb * pb));
        }
      }
      // Cosine sample: the path tracer weighs an escape against the
      // environment pdf, and follows hits on the object for `bounces`.
      const auto [c0, c1] = rng.Next2D();
      const auto c = SampleCosineHemisphere(c0, c1);
      const Eigen::Vector3d d = c[0] * t + c[1] * b + c[2] * n;
      if (c[2] <= 0) continue;
      Ray r;
      r.origin = p.cast<float>();
      r.direction = d.cast<float>();
      e += kPi * tracer.Radiance(r, c[2] / kPi, rng);
    }
    out[static_cast<size_t>(v)] = albedo / kPi * e / rays;
  });
  return out;
}

VertexError CompareVertexRadiance(const std::vector<Eigen::Vector3d>& radiance,
                                  const std::vector<Eigen::Vector3d>& reference) {
  double num = 0, den = 0, rel = 0;
  for (size_t v = 0; v < reference.size(); ++v) {
    const Eigen::Vector3d& r = reference[v];
    num += (radiance[v] - r).squaredNorm();
    den += r.squaredNorm();
    for (int c = 0; c < 3; ++c) rel += (radiance[v][c] - r[c]) * (radiance[v][c] - r[c]) / (r[c] * r[c] + 0.01);
  }
  VertexError e;
  e.relative_rms = std::sqrt(num / std::max(den, 1e-300));
  e.relmse = rel / (3.0 * static_cast<double>(std::max<size_t>(1, reference.size())));
  return e;
}

}  // namespace mr
