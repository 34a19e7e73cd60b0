#include "render/prt.h"

#include <Eigen/SVD>

#include <algorithm>
#include <atomic>
#include "core/error.h"
#include "core/parallel.h"
#include "core/sh.h"
#include "core/spherical.h"
#include "geometry/mesh.h"
#include "render/render_scene.h"
#include "scene/frames.h"
#include "transfer/formfactor.h"

namespace mr {

Image AddLightsSeenFrom(const Image& env, const std::vector<LightSource>& lights, const Eigen::Vector3d& centre,
                        const Eigen::Matrix3d& world_from_env, double scale, int strata) {
  Image out = env;
  const int r = out.ChannelIndex("R"), g = out.ChannelIndex("G"), b = out.ChannelIndex("B");
  const int W = out.width(), H = out.height();
  for (const LightSource& l : lights) {
    const int n = l.light().IsDelta() ? 1 : strata;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        LightSample s;
        if (!l.Sample(centre, (i + 0.5) / n, (j + 0.5) / n, &s) || !(s.pdf > 0)) continue;
        // li / pdf: a delta light's irradiance (pdf 1), else radiance over
        // the solid-angle pdf; either way this sample's share of the
        // irradiance integral, as a radiance over its pixel's solid angle.
        const Eigen::Vector3d e = s.li / (s.pdf * n * n);
        const Eigen::Vector2d px = DirectionToLatLongPixel(world_from_env.transpose() * s.wi, W, H);
        const int x = std::clamp(static_cast<int>(std::lround(px.x())), 0, W - 1) % W;
        const int y = std::clamp(static_cast<int>(std::lround(px.y())), 0, H - 1);
        const double omega = LatLongPixelSolidAngle(x, y, W, H) * scale;
        out.at(x, y, r) += static_cast<float>(e.x() / omega);
        out.at(x, y, g) += static_cast<float>(e.y() / omega);
        out.at(x, y, b) += static_cast<float>(e.z() / omega);
      }
  }
  return out;
}

std::map<uint32_t, PrtObject> PreparePrt(const Scene& scene, const RenderScene& rs, int spp, Report* report,
                                         int frame) {
  if (!scene.lighting.environment)
    throw UsageError(
        "method prt shades objects by the environment map, and the scene names none (lighting.environment)");
  std::string env_name;
  const Image env = EnvironmentImageAt(scene, frame, &env_name);  // this frame's map, non-finite pixels kept:
                                                                  // ProjectEnvironment names a bad one itself
  std::map<uint32_t, PrtObject> out;
  for (size_t i = 0; i < scene.virtuals.size(); ++i) {
    const SceneVirtual& v = scene.virtuals[i];
    if (!v.formfactors)
      throw UsageError(
          fmt::format("method prt needs form factors for virtual object \"{}\": run mr-formfactor on {} and "
                      "name the .ffc in virtual[{}].formfactors",
                      v.name, v.mesh.string(), i));
    const Mesh mesh = ReadVirtualMesh(v);
    const VertexTransfer t = ReadTransfer(*v.formfactors);
    CheckTransferMatches(t, mesh, v.formfactors->string(), v.mesh.string());
    if (t.header.valid_spp > 0 && spp > t.header.valid_spp)
      ThrowErrorAt(FileLoc{v.formfactors->string()},
                   "holds only the vertices a render of up to {} samples per pixel sees, and this render takes {}: "
                   "run mr-formfactor --scene with --spp {} or more, or without --scene",
                   t.header.valid_spp, spp, spp);
    // The environment in the object's frame: the rotation of the object's
    // transform (its polar factor), so that a scaled object sees the same sky.
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(v.WorldFromObjectAt(frame).linear(),
                                          Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d world_from_object_rot = svd.matrixU() * svd.matrixV().transpose();
    if (world_from_object_rot.determinant() < 0) world_from_object_rot = -world_from_object_rot;
    const Eigen::Vector3d sv = svd.singularValues();
    if (sv.maxCoeff() > sv.minCoeff() * (1 + 1e-6))
      report->Warn(
          fmt::format("virtual object \"{}\" is scaled non-uniformly: its form factors were computed for the "
                      "unscaled mesh",
                      v.name));
    const Eigen::Matrix3d object_from_env = world_from_object_rot.transpose() * scene.lighting.world_from_env;
    // The lights as the object's centre sees them (the classic PRT
    // approximation: lighting the same over the object), in the map.
    Eigen::Vector3d lo = Eigen::Vector3d::Zero();
    if (!mesh.positions.empty()) lo = mesh.positions[0].cast<double>();
    Eigen::Vector3d hi = lo;
    for (const auto& p : mesh.positions) {
      lo = lo.cwiseMin(p.cast<double>());
      hi = hi.cwiseMax(p.cast<double>());
    }
    const Eigen::Vector3d centre = v.WorldFromObjectAt(frame) * (0.5 * (lo + hi));
    const Image lit = rs.lights().empty() ? Image()
                                          : AddLightsSeenFrom(env, rs.lights(), centre, scene.lighting.world_from_env,
                                                              scene.lighting.environment_scale);
    EnvironmentCoefficients ec = ProjectEnvironment(rs.lights().empty() ? env : lit, env_name, t.header,
                                                    object_from_env, scene.lighting.environment_scale);
    if (t.header.basis == TransferBasis::kSh) {
      // Bands that hold (almost) none of the environment's energy change nothing: dropped.
      // The dropped bands change a vertex by at most sqrt(1e-5) |T| |L| (Cauchy-Schwarz): 0.3%.
      const int keep = EffectiveShOrder(ec, t.header.order, 1e-5);
      if (keep < t.header.order) {
        ec.rgb.resize(static_cast<size_t>(ShCount(keep)));
        report->Skip(fmt::format("SH bands {}..{} of \"{}\"", keep, t.header.order - 1, v.name),
                     "the environment holds less than 1e-5 of its energy there (a change of at most 0.3%): shaded at "
                     "order " +
                         std::to_string(keep));
      }
    }
    int64_t clamped = 0;
    PrtObject po;
    if (v.material.albedo_from_vertex_colors && mesh.colors.size() != mesh.positions.size())
      ThrowErrorAt(FileLoc{v.mesh.string()},
                   "material.albedo_from_vertex_colors is set but the mesh has no vertex colours");
    // A texture is sampled at each vertex's uv: prt shades per vertex.
    std::vector<Eigen::Vector3f> texels;
    if (v.file_materials) {  // an asset: its own materials' albedo at each vertex
      texels = AssetVertexAlbedo(ReadAsset(v.mesh), v.mesh.string());
    } else if (!v.material.albedo_texture.empty()) {
      if (mesh.uvs.size() != mesh.positions.size())
        ThrowErrorAt(FileLoc{v.mesh.string()},
                     "material.albedo_texture is set but the mesh has no texture coordinates");
      const Image tex = ReadAlbedoTexture(v.material.albedo_texture);
      for (const Eigen::Vector2f& uv : mesh.uvs)
        texels.push_back(RenderScene::SampleTexture(tex, uv.cast<double>()).cast<float>());
    }
    po.vertex_radiance = ShadeVertices(t, ec, v.material.albedo, &clamped, nullptr,
                                       v.material.albedo_from_vertex_colors ? &mesh.colors
                                       : texels.empty()                     ? nullptr
                                                                            : &texels);
    po.triangles = mesh.triangles;
    po.emission = v.material.emission;
    if (clamped > 0)
      report->Warn(
          fmt::format("virtual object \"{}\": {} negative vertex values (SH ringing) clamped to 0", v.name, clamped));
    out[rs.virtual_ids().at(i)] = std::move(po);
  }
  report->Skip("relighting of the real scene",
               "method prt shades the virtual objects only (no shadows or light on the "
               "room); pt renders their effect on the room");
  if (!rs.lights().empty())
    report->Skip(fmt::format("the {} lights' variation over each object", rs.lights().size()),
                 "method prt takes the lights as each object's centre sees them (in its environment, "
                 "docs/methods.md), unoccluded by the room");
  return out;
}

std::vector<char> VerticesSeenByCamera(const Scene& scene, const std::string& object, int spp, int64_t* frames_seen) {
  size_t index = scene.virtuals.size();
  for (size_t i = 0; i < scene.virtuals.size(); ++i)
    if (scene.virtuals[i].name == object) index = i;
  if (index == scene.virtuals.size())
    throw UsageError(fmt::format("{}: no virtual object is named \"{}\"", scene.file.string(), object));
  RenderScene rs;
  LoadRenderScene(scene, &rs);
  const uint32_t id = rs.virtual_ids().at(index);
  const Mesh mesh = ReadVirtualMesh(scene.virtuals[index]);
  const CameraModel camera = CameraModel::Read(scene.camera.model);
  const std::vector<Rigid3> poses = LoadScenePoses(scene);
  const int end = scene.render.frame_end < 0 ? static_cast<int>(poses.size())
                                             : std::min<int>(scene.render.frame_end, static_cast<int>(poses.size()));
  std::vector<std::atomic<char>> seen(mesh.positions.size());
  *frames_seen = 0;
  for (int f = scene.render.frame_begin; f < end; ++f) {
    CameraSampler sampler(camera, poses[static_cast<size_t>(f)], scene.render.seed, f);
    std::atomic<bool> any{false};
    ParallelFor(0, sampler.height(), [&](int64_t y) {
      for (int x = 0; x < sampler.width(); ++x) {
        if (!sampler.PixelValid(x, static_cast<int>(y))) continue;
        for (int s = 0; s < spp; ++s) {
          Ray ray;
          sampler.Sample(x, static_cast<int>(y), s, &ray);
          Hit hit;
          if (!rs.embree().Intersect(ray, &hit) || hit.geometry_id != id) continue;
          any = true;
          for (int k = 0; k < 3; ++k) seen[static_cast<size_t>(mesh.triangles[hit.primitive_id][k])] = 1;
        }
      }
    });
    *frames_seen += any.load();
  }
  std::vector<char> out(seen.size());
  for (size_t i = 0; i < seen.size(); ++i) out[i] = seen[i].load();
  return out;
}

PrtFrameRenderer::PrtFrameRenderer(const RenderScene& scene, const std::map<uint32_t, PrtObject>& objects,
                                   const CameraModel& camera, const Rigid3& world_from_cam, uint64_t seed, int frame,
                                   const Image* background, const CameraExposure& exposure)
    : scene_(scene),
      objects_(objects),
      sampler_(camera, world_from_cam, seed, frame, exposure),
      width_(camera.width()),
      height_(camera.height()),
      background_(background ? *background : Image::Rgb(camera.width(), camera.height())) {
  const size_t n = static_cast<size_t>(width_) * height_;
  sum_object_.assign(n, Eigen::Vector3d::Zero());
  count_.assign(n, 0);
  coverage_.assign(n, 0);
}

void PrtFrameRenderer::RenderPass(int spp) {
  ParallelFor(0, height_, [&](int64_t y) {
    for (int x = 0; x < width_; ++x) {
      if (!sampler_.PixelValid(x, static_cast<int>(y))) continue;
      const size_t i = static_cast<size_t>(y) * width_ + x;
      count_[i] += spp;
      for (int s = 0; s < spp; ++s) {
        Ray ray;
        sampler_.Sample(x, static_cast<int>(y), spp_ + s, &ray);
        Hit hit;
        if (!scene_.embree().Intersect(ray, &hit) || !hit.is_virtual) continue;
        const auto it = objects_.find(hit.geometry_id);
        if (it == objects_.end()) continue;
        const PrtObject& o = it->second;
        const Eigen::Vector3i& t = o.triangles[hit.primitive_id];
        const double u = hit.uv.x(), v = hit.uv.y();
        sum_object_[i] += (1 - u - v) * o.vertex_radiance[static_cast<size_t>(t[0])] +
                          u * o.vertex_radiance[static_cast<size_t>(t[1])] +
                          v * o.vertex_radiance[static_cast<size_t>(t[2])] + o.emission;
        ++coverage_[i];
      }
    }
  });
  spp_ += spp;
}

Image PrtFrameRenderer::Mixed() const {
  Image img = Image::Rgb(width_, height_);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      const size_t i = static_cast<size_t>(y) * width_ + x;
      const double n = count_[i];
      for (int c = 0; c < 3; ++c)
        img.at(x, y, c) =
            n > 0 ? static_cast<float>((sum_object_[i][c] + (n - coverage_[i]) * background_.at(x, y, c)) / n)
                  : background_.at(x, y, c);
    }
  return img;
}

Image PrtFrameRenderer::Real() const { return background_; }

Image PrtFrameRenderer::Mask() const {
  Image img = Image::Gray(width_, height_);
  for (size_t i = 0; i < count_.size(); ++i)
    img.values()[i] = count_[i] > 0 ? static_cast<float>(static_cast<double>(coverage_[i]) / count_[i]) : 0.0f;
  return img;
}

Image PrtFrameRenderer::DifferenceVariance() const { return Image::Gray(width_, height_); }

Image PrtFrameRenderer::SampleCount() const {
  Image img = Image::Gray(width_, height_);
  for (size_t i = 0; i < count_.size(); ++i) img.values()[i] = static_cast<float>(count_[i]);
  return img;
}

namespace {

class PrtMethod : public RenderMethod {
 public:
  void Prepare(const JobContext& job) override {
    objects_ = PreparePrt(job.scene, job.rs, job.spp, job.report, job.frame);
    if (!job.photograph)
      job.report->Skip("background", "the scene names no camera frames: prt composites the objects over black");
  }
  std::vector<std::string> WorldChanged(const JobContext& job, const WorldChange&) override {
    Prepare(job);  // the environment's projection into each object's frame, and its vertex shading
    return {"vertex shading"};
  }
  std::unique_ptr<FrameMethod> NewFrame(const FrameContext& f) override {
    return std::make_unique<PrtFrameRenderer>(f.rs, objects_, f.camera, f.world_from_cam, f.seed, f.frame,
                                              f.photo_radiance, f.exposure);
  }

 private:
  std::map<uint32_t, PrtObject> objects_;
};

}  // namespace

std::unique_ptr<RenderMethod> MakePrtMethod(JsonSettings&, const Scene&) { return std::make_unique<PrtMethod>(); }

}  // namespace mr
