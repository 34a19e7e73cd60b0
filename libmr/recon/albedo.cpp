#include "recon/albedo.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>

#include <ceres/ceres.h>
#include <fmt/format.h>

#include "core/error.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "geometry/embree_scene.h"
#include "light/environment.h"
#include "light/light_source.h"
#include "light/lights_file.h"

namespace mr {

namespace {

constexpr int kMaxObs = 8;
constexpr float kSaturated = 254.5f / 255.0f;  // of an 8-bit code, linear or not

struct Obs {
  int frame = -1;
  float w = 0;
  Eigen::Vector3f c = Eigen::Vector3f::Zero();
};

// Whether p lies on area light l's surface (within 5 cm of its plane and
// of its outline): a lamp's own patch of the room's mesh.
bool OnAreaLight(const Light& l, const Eigen::Vector3d& p) {
  if (l.type != LightType::kArea) return false;
  const double m = 0.05;
  const Eigen::Vector3d n = l.direction.normalized();
  const Eigen::Vector3d d = p - l.position;
  if (std::abs(d.dot(n)) > m) return false;
  if (l.shape == AreaShape::kDisc) return (d - d.dot(n) * n).norm() <= 0.5 * l.width + m;
  const Eigen::Vector3d u = (l.axis - l.axis.dot(n) * n).normalized(), w = n.cross(u);
  return std::abs(d.dot(u)) <= 0.5 * l.width + m && std::abs(d.dot(w)) <= 0.5 * l.height + m;
}

struct VertexObs {
  Obs obs[kMaxObs];
  int n = 0;
  void Add(const Obs& o) {
    if (n < kMaxObs) {
      obs[n++] = o;
      return;
    }
    int worst = 0;
    for (int i = 1; i < kMaxObs; ++i)
      if (obs[i].w < obs[worst].w) worst = i;
    if (o.w > obs[worst].w) obs[worst] = o;
  }
};

struct ShadingResidual {
  ShadingResidual(const Eigen::Vector3d& e_over_pi, const Eigen::Vector3d& obs, double sqrt_w)
      : e(e_over_pi), i(obs), s(sqrt_w) {}
  template <typename T>
  bool operator()(const T* gain, const T* rho, T* r) const {
    for (int k = 0; k < 3; ++k) r[k] = T(s) * (gain[0] * rho[k] * T(e[k]) - T(i[k]));
    return true;
  }
  Eigen::Vector3d e, i;
  double s;
};

}  // namespace

int64_t FillFromNeighbours(const std::vector<Eigen::Vector3i>& triangles, const std::vector<bool>& known,
                           const Eigen::Vector3d& fallback, std::vector<Eigen::Vector3d>* values, int64_t* isolated) {
  const size_t nv = values->size();
  std::vector<std::vector<int>> adjacent(nv);
  for (const Eigen::Vector3i& t : triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      if (a < 0 || b < 0 || static_cast<size_t>(a) >= nv || static_cast<size_t>(b) >= nv) continue;
      adjacent[static_cast<size_t>(a)].push_back(b);
      adjacent[static_cast<size_t>(b)].push_back(a);
    }
  std::vector<bool> have = known;
  int64_t filled = 0;
  std::vector<size_t> ring;
  for (;;) {
    // The next ring: unknown vertices with a known neighbour, all computed
    // from the values before this ring (so the result does not depend on
    // the vertices' order).
    ring.clear();
    for (size_t v = 0; v < nv; ++v)
      if (!have[v])
        for (int u : adjacent[v])
          if (have[static_cast<size_t>(u)]) {
            ring.push_back(v);
            break;
          }
    if (ring.empty()) break;
    std::vector<Eigen::Vector3d> next(ring.size(), Eigen::Vector3d::Zero());
    for (size_t i = 0; i < ring.size(); ++i) {
      int n = 0;
      for (int u : adjacent[ring[i]])
        if (have[static_cast<size_t>(u)]) {
          next[i] += (*values)[static_cast<size_t>(u)];
          ++n;
        }
      next[i] /= n;
    }
    for (size_t i = 0; i < ring.size(); ++i) {
      (*values)[ring[i]] = next[i];
      have[ring[i]] = true;
    }
    filled += static_cast<int64_t>(ring.size());
  }
  int64_t alone = 0;
  for (size_t v = 0; v < nv; ++v)
    if (!have[v]) {
      (*values)[v] = fallback;
      ++alone;
    }
  if (isolated) *isolated = alone;
  return filled;
}

AlbedoStats ComputeAlbedo(const RgbdSequence& seq, const FuseResult& fused, double max_depth,
                          const AlbedoOptions& options, Mesh* mesh, Report* report) {
  AlbedoStats st;
  const size_t nv = mesh->positions.size();
  const PinholeIntrinsics& K = seq.K;
  // Frames: every stride-th tracked one.
  std::map<double, const RgbdFrame*> by_time;
  for (const RgbdFrame& f : seq.frames) by_time[f.timestamp] = &f;
  std::vector<std::pair<const RgbdFrame*, Rigid3>> frames;
  for (size_t i = 0; i < fused.trajectory.poses.size(); i += static_cast<size_t>(std::max(1, options.frame_stride))) {
    const TimedPose& tp = fused.trajectory.poses[i];
    auto it = by_time.find(tp.timestamp);
    if (it != by_time.end() && !it->second->color.empty()) frames.emplace_back(it->second, tp.world_from_cam);
  }
  st.frames_used = static_cast<int>(frames.size());
  std::vector<Eigen::Vector3d> sum(nv, Eigen::Vector3d::Zero());
  std::vector<double> wsum(nv, 0.0);
  std::vector<VertexObs> obs(nv);
  std::vector<std::atomic<int>> clipped_views(nv);  // views in which the vertex was clipped
  DepthReadOptions dopt;
  dopt.scale = seq.depth_scale;
  dopt.max_m = max_depth;
  const float cos_max = static_cast<float>(std::cos(options.max_angle_deg * kDegToRad));
  for (size_t fi = 0; fi < frames.size(); ++fi) {
    const auto& [frame, world_from_cam] = frames[fi];
    const DepthMap depth = ReadDepth(frame->depth, dopt, K.width, K.height);
    const Image color = ReadColor(frame->color, K.width, K.height);
    const Rigid3 cam_from_world = world_from_cam.Inverse();
    const Eigen::Matrix3f R = cam_from_world.rotation.toRotationMatrix().cast<float>();
    const Eigen::Vector3f t = cam_from_world.translation.cast<float>();
    const float tol = static_cast<float>(options.depth_tolerance);
    ParallelFor(0, static_cast<int64_t>(nv), [&](int64_t vi) {
      const size_t v = static_cast<size_t>(vi);
      const Eigen::Vector3f pc = R * mesh->positions[v] + t;
      if (pc.z() <= 0.05f) return;
      const int u = static_cast<int>(std::lround(K.fx * pc.x() / pc.z() + K.cx));
      const int y = static_cast<int>(std::lround(K.fy * pc.y() / pc.z() + K.cy));
      if (u < 0 || y < 0 || u >= K.width || y >= K.height) return;
      const float d = depth.at(u, y);
      if (!(d > 0) || std::abs(d - pc.z()) > tol) return;
      const float c = (R * mesh->normals[v]).dot(-pc.normalized());
      if (c < cos_max) return;
      Eigen::Vector3f col(color.at(u, y, 0), color.at(u, y, 1), color.at(u, y, 2));
      // Saturated pixels say only "at least": left out (counted).
      if (col.allFinite() && col.maxCoeff() >= kSaturated) ++clipped_views[v];
      if (!col.allFinite() || col.maxCoeff() >= kSaturated) return;
      col /= static_cast<float>(options.camera_scale);  // to the lighting's radiance unit
      sum[v] += c * col.cast<double>();
      wsum[v] += c;
      obs[v].Add({static_cast<int>(fi), c, col});
    });
  }
  std::vector<Eigen::Vector3d> observed(nv, Eigen::Vector3d::Zero());
  for (size_t v = 0; v < nv; ++v) {
    if (wsum[v] > 0) {
      observed[v] = sum[v] / wsum[v];
      ++st.vertices_observed;
    } else {
      // The fused voxel colour, in the camera's units like the observations.
      observed[v] = mesh->colors.empty() ? Eigen::Vector3d::Zero().eval()
                                         : (mesh->colors[v].cast<double>() / options.camera_scale).eval();
      ++st.vertices_unobserved;
    }
  }
  std::vector<Eigen::Vector3d> albedo = observed;

  if (!options.lights.empty() || !options.env.empty()) {
    st.delit = true;
    std::vector<LightSource> lights;
    if (!options.lights.empty())
      for (const Light& l : ReadLights(options.lights)) lights.emplace_back(l);
    EnvironmentMap env;
    if (!options.env.empty()) env = EnvironmentMap(ReadImage(options.env), options.env);
    // A lamp the camera clipped in every view: its light is a light of
    // lights.json (placed where it is: mr-lights --room), not the clipped
    // colour the room's rays would take from it a second time.
    for (size_t v = 0; v < nv; ++v)
      if (wsum[v] <= 0 && clipped_views[v] > 0)
        for (const LightSource& ls : lights)
          if (OnAreaLight(ls.light(), mesh->positions[v].cast<double>())) {
            observed[v].setZero();
            ++st.vertices_on_lights;
            break;
          }
    EmbreeScene scene;
    scene.AddMesh(*mesh, false);
    scene.Commit();
    const double eps = 1e-3;
    std::vector<Eigen::Vector3d> E(nv, Eigen::Vector3d::Zero());
    const int rays = std::max(1, options.rays);
    ParallelFor(0, static_cast<int64_t>(nv), [&](int64_t vi) {
      const size_t v = static_cast<size_t>(vi);
      const Eigen::Vector3d n = mesh->normals[v].cast<double>().normalized();
      const Eigen::Vector3d p = mesh->positions[v].cast<double>() + eps * n;
      Pcg32 rng(options.seed, static_cast<uint64_t>(v));
      Eigen::Vector3d e = Eigen::Vector3d::Zero();
      for (const LightSource& ls : lights) {
        const int samples = ls.light().IsDelta() ? 1 : 16;
        for (int s = 0; s < samples; ++s) {
          LightSample smp;
          if (!ls.Sample(p, rng.NextDouble(), rng.NextDouble(), &smp)) continue;
          const double c = n.dot(smp.wi);
          if (c <= 0) continue;
          Ray r;
          r.origin = p.cast<float>();
          r.direction = smp.wi.cast<float>();
          r.tfar = std::isfinite(smp.distance) ? static_cast<float>(smp.distance * (1 - 1e-4)) : r.tfar;
          if (scene.Occluded(r)) continue;
          e += smp.li * c / smp.pdf / samples;
        }
      }
      // The room's observed radiance where cosine-distributed rays hit it (every
      // bounce at once); the map where rays escape, by multiple importance
      // sampling of the cosine and the map's own distribution (balance
      // heuristic), so that a sun of a few pixels is found as reliably as a sky.
      Eigen::Vector3d tan = std::abs(n.x()) < 0.9 ? n.cross(Eigen::Vector3d::UnitX()).normalized()
                                                  : n.cross(Eigen::Vector3d::UnitY()).normalized();
      const Eigen::Vector3d bit = n.cross(tan);
      Eigen::Vector3d room = Eigen::Vector3d::Zero(), sky = Eigen::Vector3d::Zero();
      for (int s = 0; s < rays; ++s) {
        const auto u = Sobol2D(static_cast<uint32_t>(s), static_cast<uint32_t>(v), true);
        const auto d = SampleCosineHemisphere(u[0], u[1]);
        const Eigen::Vector3d dir = d[0] * tan + d[1] * bit + d[2] * n;
        Ray r;
        r.origin = p.cast<float>();
        r.direction = dir.cast<float>();
        Hit h;
        if (scene.Intersect(r, &h)) {
          const Eigen::Vector3i& tri = mesh->triangles[h.primitive_id];
          const double b1 = h.uv.x(), b2 = h.uv.y(), b0 = 1 - b1 - b2;
          room += b0 * observed[static_cast<size_t>(tri[0])] + b1 * observed[static_cast<size_t>(tri[1])] +
                  b2 * observed[static_cast<size_t>(tri[2])];
        } else if (!env.empty()) {
          double pdf_env = 0;
          const Eigen::Vector3d L = env.EvalWithPdf(dir, &pdf_env);
          const double c = d[2];
          sky += L * c / (c / kPi + pdf_env);
        }
        if (env.empty()) continue;
        Eigen::Vector3d dl;
        double pdf_env = 0;
        const double e0 = rng.NextDouble(), e1 = rng.NextDouble();  // in this order
        const Eigen::Vector3d L = env.Sample(e0, e1, &dl, &pdf_env);
        const double c = n.dot(dl);
        if (c <= 0 || !(pdf_env > 0)) continue;
        Ray sr;
        sr.origin = p.cast<float>();
        sr.direction = dl.cast<float>();
        if (scene.Occluded(sr)) continue;
        sky += L * c / (c / kPi + pdf_env);
      }
      E[v] = e + room * (kPi / rays) + sky / rays;
    });
    // Joint solve of gains and a subset's albedo.
    std::vector<size_t> subset;
    std::vector<size_t> candidates;
    for (size_t v = 0; v < nv; ++v)
      if (obs[v].n >= 3 && E[v].minCoeff() > 0) candidates.push_back(v);
    const size_t step =
        std::max<size_t>(1, candidates.size() / static_cast<size_t>(std::max(1, options.solve_vertices)));
    for (size_t i = 0; i < candidates.size(); i += step) subset.push_back(candidates[i]);
    std::vector<double> gain(frames.size(), 1.0);
    if (!subset.empty()) {
      ceres::Problem problem;
      std::vector<Eigen::Vector3d> rho(subset.size());
      std::vector<int> per_frame(frames.size(), 0);
      for (size_t si = 0; si < subset.size(); ++si) {
        const size_t v = subset[si];
        rho[si] = (observed[v].array() / (E[v].array() / kPi)).matrix();
        for (int k = 0; k < obs[v].n; ++k) {
          const Obs& o = obs[v].obs[k];
          problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ShadingResidual, 3, 1, 3>(
                                       new ShadingResidual(E[v] / kPi, o.c.cast<double>(), std::sqrt(o.w))),
                                   new ceres::HuberLoss(options.huber), &gain[static_cast<size_t>(o.frame)],
                                   rho[si].data());
          ++per_frame[static_cast<size_t>(o.frame)];
        }
        for (int k = 0; k < 3; ++k) problem.SetParameterLowerBound(rho[si].data(), k, 0.0);
      }
      const size_t ref = static_cast<size_t>(std::max_element(per_frame.begin(), per_frame.end()) - per_frame.begin());
      problem.SetParameterBlockConstant(&gain[ref]);
      for (size_t f = 0; f < frames.size(); ++f)
        if (per_frame[f] > 0) problem.SetParameterLowerBound(&gain[f], 0, 0.01);
      ceres::Solver::Options so;
      so.linear_solver_type = ceres::SPARSE_SCHUR;
      so.max_num_iterations = 50;
      so.num_threads = ThreadCount();
      ceres::Solver::Summary summary;
      ceres::Solve(so, &problem, &summary);
      if (report) report->SetMetric("albedo.solve", summary.BriefReport());
    }
    // Every vertex: IRLS (Huber) with the gains fixed.
    double esum = 0;
    int64_t en = 0;
    for (size_t v = 0; v < nv; ++v) {
      if (obs[v].n == 0 || !(E[v].minCoeff() > 0)) continue;
      esum += E[v].mean();
      ++en;
      Eigen::Vector3d r = (observed[v].array() / (E[v].array() / kPi)).matrix();
      for (int it = 0; it < 5; ++it) {
        Eigen::Vector3d num = Eigen::Vector3d::Zero(), den = Eigen::Vector3d::Zero();
        for (int k = 0; k < obs[v].n; ++k) {
          const Obs& o = obs[v].obs[k];
          for (int c = 0; c < 3; ++c) {
            const double a = gain[static_cast<size_t>(o.frame)] * E[v][c] / kPi;
            const double res = a * r[c] - o.c[c];
            const double hw = std::abs(res) <= options.huber ? 1.0 : options.huber / std::abs(res);
            num[c] += o.w * hw * a * o.c[c];
            den[c] += o.w * hw * a * a;
          }
        }
        for (int c = 0; c < 3; ++c)
          if (den[c] > 0) r[c] = num[c] / den[c];
      }
      albedo[v] = r;
    }
    st.mean_irradiance = en ? esum / static_cast<double>(en) : 0;
    for (size_t f = 0; f < gain.size(); ++f) {
      st.gain_min = std::min(st.gain_min, gain[f]);
      st.gain_max = std::max(st.gain_max, gain[f]);
    }
  }
  // Vertices no frame saw: the albedo of the surface around them (the
  // fused voxel colour is a raw colour in the camera's units, not an albedo).
  if (st.vertices_unobserved > 0) {
    std::vector<bool> known(nv);
    for (size_t v = 0; v < nv; ++v) known[v] = wsum[v] > 0;
    st.vertices_from_neighbours =
        FillFromNeighbours(mesh->triangles, known, Eigen::Vector3d::Constant(0.5), &albedo, &st.vertices_isolated);
  }
  Mesh::Scalar ar{"albedo_r", {}}, ag{"albedo_g", {}}, ab{"albedo_b", {}}, orr{"observed_r", {}}, og{"observed_g", {}},
      ob{"observed_b", {}};
  mesh->colors.resize(nv);
  for (size_t v = 0; v < nv; ++v) {
    ar.values.push_back(static_cast<float>(albedo[v].x()));
    ag.values.push_back(static_cast<float>(albedo[v].y()));
    ab.values.push_back(static_cast<float>(albedo[v].z()));
    orr.values.push_back(static_cast<float>(observed[v].x()));
    og.values.push_back(static_cast<float>(observed[v].y()));
    ob.values.push_back(static_cast<float>(observed[v].z()));
    if (albedo[v].maxCoeff() > 1) ++st.albedo_clamped;
    mesh->colors[v] = albedo[v].cwiseMax(0.0).cwiseMin(1.0).cast<float>();
  }
  for (auto* s : {&ar, &ag, &ab, &orr, &og, &ob}) mesh->scalars.push_back(std::move(*s));
  if (report) {
    report->SetMetric("albedo.frames_used", st.frames_used);
    report->SetMetric("albedo.vertices_observed", st.vertices_observed);
    report->SetMetric("albedo.vertices_unobserved", st.vertices_unobserved);
    report->SetMetric("albedo.delit", st.delit);
    report->SetMetric("albedo.albedo_above_1", st.albedo_clamped);
    report->SetMetric("albedo.vertices_on_lights", st.vertices_on_lights);
    if (st.delit) {
      report->SetMetric("albedo.gain_range", {st.gain_min, st.gain_max});
      report->SetMetric("albedo.mean_irradiance", st.mean_irradiance);
    } else {
      report->Skip("de-lit albedo", "no --lights or --env: albedo is the viewing-angle-weighted mean colour");
    }
    report->SetMetric("albedo.vertices_from_neighbours", st.vertices_from_neighbours);
    report->SetMetric("albedo.vertices_isolated", st.vertices_isolated);
    if (st.vertices_unobserved)
      report->Warn(
          fmt::format("{} vertices are seen in no albedo frame: {} take the albedo of the surface around "
                      "them, {} (with nothing seen connected to them) albedo 0.5",
                      st.vertices_unobserved, st.vertices_from_neighbours, st.vertices_isolated));
  }
  return st;
}

}  // namespace mr
