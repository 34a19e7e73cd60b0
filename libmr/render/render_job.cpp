#include "render/render_job.h"

#include <algorithm>

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>

#include "camera/camera_model.h"
#include "camera/colmap_text.h"
#include "camera/trajectory.h"
#include "core/error.h"
#include "core/image.h"
#include "core/math.h"
#include "core/progress.h"
#include "core/video.h"
#include "eval/metrics.h"
#include "hdr/response.h"
#include "render/composite.h"
#include "render/path_tracer.h"
#include "render/prt.h"
#include "render/vct.h"
#include "render/vpl.h"
#include "render/irradiance_cache.h"
#include "render/render_scene.h"

namespace mr {

fs::path FramePath(const fs::path& pattern, int i) {
  const std::string p = pattern.string();
  if (p.find('%') == std::string::npos) return pattern;
  std::vector<char> buf(p.size() + 32);
  std::snprintf(buf.data(), buf.size(), p.c_str(), i);
  return fs::path(buf.data());
}

std::vector<Rigid3> LoadScenePoses(const Scene& s) {
  std::vector<Rigid3> world_from_cam;
  if (!s.camera.poses) return {Rigid3()};
  switch (s.camera.pose_format) {
    case PoseFormat::kTum:
      for (const auto& p : ReadTum(*s.camera.poses).poses) world_from_cam.push_back(p.world_from_cam);
      break;
    case PoseFormat::k7Scenes:
      for (const auto& p : Read7ScenesFolder(*s.camera.poses).poses) world_from_cam.push_back(p.world_from_cam);
      break;
    case PoseFormat::kColmap: {
      ColmapModel m = ReadColmapText(*s.camera.poses);
      std::vector<std::pair<std::string, Rigid3>> byname;
      for (const auto& [id, im] : m.images) byname.emplace_back(im.name, im.cam_from_world.Inverse());
      std::sort(byname.begin(), byname.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      for (auto& [n, p] : byname) world_from_cam.push_back(p);
      break;
    }
  }
  return world_from_cam;
}

namespace {

// The photograph or reference of frame `path`, checked against the camera's size.
Image ReadRgb(const fs::path& path, int w, int h, const Transfer transfer, bool raw = false) {
  Image img = ReadRgbForComparison(path, transfer, raw);
  if (img.width() != w || img.height() != h)
    ThrowErrorAt(FileLoc{path.string()}, "image is {}x{}, the camera model says {}x{}", img.width(), img.height(), w, h);
  return img;
}

}  // namespace

// ic's temporal stability on a static scene: each pixel's world point
// (`positions`) is projected into the previous frame; where it lands on a
// pixel that interpolated irradiance at the same point, the relative mean absolute change of
// the interpolated irradiance, sum |E_f - E_f-1| / sum |E_f|.  NaN: no
// overlap.
double TemporalChange(const CameraModel& camera, const Rigid3& prev_pose, const std::vector<float>& prev,
                      const std::vector<Eigen::Vector3f>& prev_positions, const std::vector<Eigen::Vector3f>& positions,
                      const std::vector<float>& now) {
  double diff = 0, sum = 0;
  const int w = camera.width(), h = camera.height();
  for (size_t i = 0; i < now.size(); ++i) {
    if (!std::isfinite(now[i]) || !positions[i].allFinite()) continue;
    const Eigen::Vector3d pc = prev_pose.rotation.conjugate() * (positions[i].cast<double>() - prev_pose.translation);
    Eigen::Vector2d q;
    if (!camera.Project(pc, &q) || !q.allFinite()) continue;
    if (!(q.x() > -0.5 && q.y() > -0.5 && q.x() < w - 0.5 && q.y() < h - 0.5)) continue;
    const long x = std::lround(q.x()), y = std::lround(q.y());
    if (x < 0 || y < 0 || x >= w || y >= h) continue;
    const size_t j = static_cast<size_t>(y) * w + x;
    const float p = prev[j];
    // The same surface (not one hidden in the previous frame): within 1% of the distance.
    if (!std::isfinite(p) || !((prev_positions[j] - positions[i]).norm() < 0.01 * pc.norm())) continue;
    diff += std::abs(now[i] - p);
    sum += std::abs(now[i]);
  }
  return sum > 0 ? diff / sum : NAN;
}

void RunRenderJob(const Scene& scene, const RenderOptions& o, Report* report) {
  const std::string method = o.method.empty() ? scene.render.method : o.method;
  if (std::find(RenderMethods().begin(), RenderMethods().end(), method) == RenderMethods().end())
    throw UsageError(fmt::format("unknown method \"{}\" (pt, ic, vpl, vct, prt)", method));
  const int spp = o.spp > 0 ? o.spp : scene.render.spp;
  const double budget = o.time_budget_s >= 0 ? o.time_budget_s : scene.render.time_budget_s;
  const fs::path out_dir = o.out_dir.empty() ? scene.output.dir : o.out_dir;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (!fs::is_directory(out_dir)) ThrowErrorAt(FileLoc{out_dir.string()}, "cannot create the output folder");

  RenderScene rs;
  CameraModel camera;
  std::vector<Rigid3> poses;
  {
    ScopedTimer t(report, "load");
    camera = CameraModel::Read(scene.camera.model);
    poses = LoadScenePoses(scene);
    LoadRenderScene(scene, &rs);
  }
  report->AddInput(scene.file.string());
  const int n_frames = static_cast<int>(poses.size());
  int begin = o.frame_begin >= 0 ? o.frame_begin : scene.render.frame_begin;
  int end = o.frame_end >= 0 ? o.frame_end : scene.render.frame_end;
  if (end < 0 || end > n_frames) end = n_frames;
  if (begin >= end) throw UsageError(fmt::format("frame range {}:{} is empty (the scene has {} frames)", begin, end, n_frames));
  const std::optional<fs::path> reference = o.reference ? o.reference : scene.reference;
  const bool shard = begin > 0 || end < n_frames;
  report->SetMetric("shard", Json{{"begin", begin}, {"end", end}, {"scene_frames", n_frames}});
  const std::string frame_provenance =
      fmt::format("scene {} method {} spp {} time_budget {} seed {}", scene.file.filename().string(), method, spp,
                  budget, scene.render.seed);
  // "display": the camera response is unknown, so the photograph stays in
  // display values and the renders are brought to display space by the tone
  // map TM(L) = sRGB(clamp(exposure L)); the composite is
  // M TM(I_m) + (1 - M)(I_c + TM(I_m) - TM(I_r)), stored back as radiance.
  const bool display_space = scene.camera.frames && scene.camera.frames_transfer == "display";
  const Transfer photo_transfer =
      scene.camera.frames_transfer == "srgb" ? Transfer::kSrgb : Transfer::kLinear;  // display, response: raw code values
  // "response": raw codes through the camera's response (mr-hdr), over the
  // frames' exposure time.
  std::optional<CameraResponse> response;
  if (scene.camera.frames && scene.camera.frames_transfer == "response") {
    response = ReadResponse(*scene.camera.response);
    report->AddInput(scene.camera.response->string());
  }
  const bool raw_codes = display_space || response.has_value();
  if (scene.camera.frames)
    report->SetMetric("compositing", display_space ? "display space (camera response unknown)"
                                     : response    ? "linear radiance (frames through the camera's response)"
                                                   : "linear radiance");
  std::unique_ptr<VideoReader> video_in;
  std::unique_ptr<VideoWriter> video_out;
  if (scene.camera.frames && scene.camera.frames_are_video) {
    video_in = std::make_unique<VideoReader>(*scene.camera.frames);
    if (video_in->width() != camera.width() || video_in->height() != camera.height())
      ThrowErrorAt(FileLoc{scene.camera.frames->string()}, "video is {}x{}, the camera model says {}x{}",
                   video_in->width(), video_in->height(), camera.width(), camera.height());
  }
  if (video_in && shard) {
    report->Skip("composite video", fmt::format("frames {}:{} are a shard of {}: `mr-eval merge` writes the video "
                                                "from every shard's frames", begin, end, n_frames));
  } else if (video_in) {
    const fs::path vpath = out_dir / "composite.mp4";
    video_out = std::make_unique<VideoWriter>(vpath, camera.width(), camera.height(),
                                              video_in->fps() > 0 ? video_in->fps() : 30.0);
  }
  if (!scene.camera.frames)
    report->Skip("photograph", "the scene names no camera frames: I_c is the rendered real scene I_r (synthetic composite)");
  // With no virtual object nothing can differ from the photograph: frames are
  // copied through without rendering (I_m - I_r = 0 exactly; tested).
  const bool copy_through = !rs.has_virtual() && scene.camera.frames.has_value();
  if (!rs.has_virtual())
    report->Skip("virtual objects", "the scene has none: the composite is the photograph");
  if (copy_through)
    report->Skip("rendering", "no virtual object can change any frame: frames are copied through from the photographs");

  if (method == "pt") {
    bool vertex_albedo = false;
    for (const auto& r : scene.reals) vertex_albedo = vertex_albedo || r.material.albedo_from_vertex_colors;
    for (const auto& v : scene.virtuals) vertex_albedo = vertex_albedo || v.material.albedo_from_vertex_colors;
    if (vertex_albedo)
      report->Warn("material.albedo_from_vertex_colors is not used by pt yet: the materials' albedo is used instead");
  }
  std::map<uint32_t, PrtObject> prt_objects;
  if (method == "prt" && !copy_through) {
    ScopedTimer t(report, "prepare prt");
    prt_objects = PreparePrt(scene, rs, spp, report);
    if (!scene.camera.frames)
      report->Skip("background", "the scene names no camera frames: prt composites the objects over black");
  }
  bool has_emissive = false;  // vpl and vct take no light from emissive surfaces
  for (const auto& r : scene.reals) has_emissive = has_emissive || r.material.IsEmissive();
  for (const auto& v : scene.virtuals) has_emissive = has_emissive || v.material.IsEmissive();
  std::shared_ptr<const VplSet> vpls;
  if (method == "vpl" && !copy_through) {
    ScopedTimer t(report, "build vpls");
    VplSettings vs;
    vs.paths = scene.render.vpl.paths;
    vs.directions = scene.render.vpl.directions;
    vs.glossy_depth = scene.render.vpl.glossy_depth;
    vs.clamp_distance = scene.render.vpl.clamp_distance;
    vs.drop_threshold = scene.render.vpl.drop_threshold;
    vs.compensate = scene.render.vpl.compensate;
    vs.max_depth = scene.render.max_depth;
    vs.seed = scene.render.seed;
    vpls = VplSet::Build(rs, vs);
    vpls->Describe(report);
    if (has_emissive)
      report->Warn("vpl: emissive surfaces are seen but light nothing (VPLs leave the environment and lights.json's lights only)");
  }
  std::shared_ptr<const VctVolumes> vct_volumes;
  if (method == "vct" && !copy_through) {
    ScopedTimer t(report, "build volumes");
    VctSettings vs;
    const SceneVctSettings& vo = scene.render.vct;
    vs.resolution = vo.resolution;
    vs.directions = vo.directions;
    vs.injection_spacing = vo.injection_spacing;
    vs.shadow_aperture_deg = vo.shadow_aperture_deg;
    vs.min_specular_aperture_deg = vo.min_specular_aperture_deg;
    vs.cone_offset = vo.cone_offset;
    vs.paper_accumulation = vo.accumulation == "paper";
    vs.split_relighting = vo.relight == "split";
    vs.far_field_width = vo.far_field_width;
    vs.far_field_samples = vo.far_field_samples;
    vs.max_depth = scene.render.max_depth;
    vs.seed = scene.render.seed;
    vct_volumes = VctVolumes::Build(rs, vs);
    vct_volumes->Describe(report);
    if (has_emissive)
      report->Warn("vct: emissive surfaces are seen and lit but inject no light into the volumes");
  }
  std::unique_ptr<IrradianceCache> ic_cache;
  if (method == "ic" && !copy_through) {
    IcSettings is;
    const SceneIcSettings& o = scene.render.ic;
    is.rays = o.rays;
    is.accuracy = o.accuracy;
    is.min_spacing_px = o.min_spacing_px;
    is.max_spacing_px = o.max_spacing_px;
    is.t_max = o.t_max;
    is.tile = o.tile;
    is.influence_threshold = o.influence_threshold;
    is.photograph = scene.camera.frames.has_value();
    is.max_depth = scene.render.max_depth;
    is.seed = scene.render.seed;
    ic_cache = std::make_unique<IrradianceCache>(rs, is);
    if (begin > 0)
      report->Warn(fmt::format("ic: the cache starts empty at frame {} (records carry over between frames), so frames of "
                               "this shard differ from an unsharded run within ic's accuracy", begin));
  }
  // ic's temporal figure: the previous frame's interpolated irradiance.
  std::vector<float> prev_irradiance;
  std::vector<Eigen::Vector3f> prev_positions;
  Rigid3 prev_pose;
  PathTracerSettings st;
  st.max_depth = scene.render.max_depth;
  st.seed = scene.render.seed;
  Json frames_json = Json::array();
  std::vector<Json> curve_sum;
  int64_t clamped = 0, nonfinite = 0;
  double sum_rmse = 0, sum_relmse = 0, sum_region = 0;
  int n_ref = 0;
  for (int f = begin; f < end; ++f) {
    st.frame = f;
    const auto t0 = std::chrono::steady_clock::now();
    std::unique_ptr<FrameMethod> fr;
    std::string enclosed;
    const bool frame_copy =
        copy_through || (scene.camera.frames && rs.VirtualEnclosedAwayFrom(poses[static_cast<size_t>(f)].translation, &enclosed));
    if (frame_copy && !copy_through)
      report->Skip(fmt::format("rendering frame {}", f), enclosed + ": I_m - I_r = 0 exactly, the photograph is copied through");
    std::optional<Image> photo, ref;
    if (video_in) {
      photo = video_in->Frame(f);  // decoded through sRGB
      if (raw_codes)
        for (float& v : photo->values()) v = LinearToSrgb(v);  // back to code values
    } else if (scene.camera.frames) {
      photo = ReadRgb(FramePath(*scene.camera.frames, f), camera.width(), camera.height(), photo_transfer, raw_codes);
    }
    if (photo && response) {
      *photo = Linearise(*photo, *response);
      for (float& v : photo->values()) v /= static_cast<float>(scene.camera.exposure);
    }
    if (reference) ref = ReadRgb(FramePath(*reference, f), camera.width(), camera.height(), Transfer::kLinear);
    if (!frame_copy) {
      if (method == "prt") {
        std::optional<Image> background;  // the photograph as radiance
        if (photo) {
          background = *photo;
          if (display_space)
            for (float& v : background->values())
              v = SrgbToLinear(Clamp(v, 0.0f, 1.0f)) / static_cast<float>(scene.camera.exposure);
        }
        fr = std::make_unique<PrtFrameRenderer>(rs, prt_objects, camera, poses[static_cast<size_t>(f)], st.seed, f,
                                                background ? &*background : nullptr);
      } else if (method == "ic") {
        fr = std::make_unique<IcFrameRenderer>(rs, ic_cache.get(), camera, poses[static_cast<size_t>(f)], st.seed, f);
      } else if (method == "vct") {
        fr = std::make_unique<VctFrameRenderer>(rs, vct_volumes, camera, poses[static_cast<size_t>(f)], st.seed, f);
      } else if (method == "vpl") {
        fr = std::make_unique<VplFrameRenderer>(rs, vpls, camera, poses[static_cast<size_t>(f)], st.seed, f);
      } else {
        fr = std::make_unique<FrameRenderer>(rs, camera, poses[static_cast<size_t>(f)], st);
      }
    }
    // The region the object changes: where the reference differs from the photograph.
    std::optional<Image> region;
    if (ref && photo) {
      region = Image::Gray(camera.width(), camera.height());
      for (int y = 0; y < camera.height(); ++y)
        for (int x = 0; x < camera.width(); ++x)
          for (int c = 0; c < 3; ++c)
            if (ref->at(x, y, c) != photo->at(x, y, c)) region->at(x, y, 0) = 1;
    }
    auto composite_now = [&]() {
      Image real = fr->Real(), mixed = fr->Mixed();
      if (!display_space) return Composite(photo ? *photo : real, mixed, real, fr->Mask());
      const float e = static_cast<float>(scene.camera.exposure);
      auto tm = [e](Image img) {
        for (float& v : img.values()) v = LinearToSrgb(Clamp(v * e, 0.0f, 1.0f));
        return img;
      };
      CompositeResult r = Composite(*photo, tm(mixed), tm(real), fr->Mask());
      for (float& v : r.composite.values()) v = SrgbToLinear(Clamp(v, 0.0f, 1.0f)) / e;
      return r;
    };
    Json curve = Json::array();
    Progress progress(fmt::format("frame {}", f), spp);
    int done = 0;
    double seconds = 0;
    while (fr && done < spp) {
      // pt, prt: checkpoints at 1, 2, 4, 8, ... spp; vpl and ic in one pass.
      const int n = method == "vpl" || method == "ic" || method == "vct" ? spp : std::min(done == 0 ? 1 : done, spp - done);
      {
        ScopedTimer t(report, "render");
        fr->RenderPass(n);
      }
      done += n;
      progress.Update(done);
      seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (ref) {
        CompositeResult cr = composite_now();
        ImageMetrics m = CompareImages(cr.composite, *ref);
        double region_relmse = region ? CompareImages(cr.composite, *ref, &*region).relmse : m.relmse;
        curve.push_back({{"seconds", seconds}, {"spp", done}, {"relmse", m.relmse}, {"region_relmse", region_relmse}});
      }
      if (budget > 0 && seconds >= budget) {
        report->Warn(fmt::format("frame {}: time budget {} s reached at {} spp", f, budget, done));
        break;
      }
    }
    progress.Done();
    CompositeResult cr;
    Image mixed, real, mask, variance;
    if (fr) {
      ScopedTimer t(report, "composite");
      cr = composite_now();
      mixed = fr->Mixed();
      real = fr->Real();
      mask = fr->Mask();
      variance = fr->DifferenceVariance();
    } else {  // copied through
      cr.composite = *photo;
      if (display_space)
        for (float& v : cr.composite.values()) v = SrgbToLinear(Clamp(v, 0.0f, 1.0f)) / static_cast<float>(scene.camera.exposure);
      cr.difference = Image::Rgb(camera.width(), camera.height());
      mixed = real = *photo;
      mask = variance = Image::Gray(camera.width(), camera.height());
    }
    clamped += cr.clamped_negative;
    const int64_t frame_nonfinite = fr ? fr->nonfinite_samples() : 0;
    nonfinite += frame_nonfinite;
    const int64_t env_pixels = fr ? fr->skipped_pixels() : 0;
    Json fj = {{"frame", f}, {"spp", done}, {"seconds", seconds}, {"clamped_negative", cr.clamped_negative},
               {"nonfinite_samples", frame_nonfinite}, {"copied_through", !fr}, {"environment_pixels_sampled_once", env_pixels}};
    if (env_pixels > 0 && done > 1)
      report->Skip(fmt::format("frame {}: {} pixels after the first sample", f, env_pixels),
                   "their camera rays provably meet no geometry (environment only): I_m - I_r = 0 exactly");
    if (ref) {
      ImageMetrics m = CompareImages(cr.composite, *ref);
      const double region_relmse = region ? CompareImages(cr.composite, *ref, &*region).relmse : m.relmse;
      fj["rmse"] = m.rmse;
      fj["relmse"] = m.relmse;
      fj["region_relmse"] = region_relmse;
      fj["curve"] = curve;
      sum_rmse += m.rmse;
      sum_relmse += m.relmse;
      sum_region += region_relmse;
      ++n_ref;
      for (size_t k = 0; k < curve.size(); ++k) {
        if (curve_sum.size() <= k) curve_sum.push_back({{"seconds", 0.0}, {"spp", curve[k]["spp"]}, {"relmse", 0.0}, {"region_relmse", 0.0}, {"frames", 0}});
        for (const char* key : {"seconds", "relmse", "region_relmse"})
          curve_sum[k][key] = curve_sum[k][key].get<double>() + curve[k][key].get<double>();
        curve_sum[k]["frames"] = curve_sum[k]["frames"].get<int>() + 1;
      }
    }
    if (auto* v = dynamic_cast<VplFrameRenderer*>(fr.get())) {
      v->Describe(report, f);
      fj["clamp_bias_mixed"] = v->clamp_bias_mixed();
      fj["clamp_bias_real"] = v->clamp_bias_real();
    }
    if (auto* v = dynamic_cast<VctFrameRenderer*>(fr.get())) v->Describe(report, f);
    if (auto* ic = dynamic_cast<IcFrameRenderer*>(fr.get())) {
      ic->Describe(report, f);
      if (!prev_irradiance.empty()) {
        const double change = TemporalChange(camera, prev_pose, prev_irradiance, prev_positions, ic->positions(), ic->interpolated());
        fj["temporal_change"] = change;
        report->SetMetric(fmt::format("ic.frames.{}.temporal_change", f), change);
      }
      prev_irradiance = ic->interpolated();
      prev_positions = ic->positions();
      prev_pose = poses[static_cast<size_t>(f)];
    }
    frames_json.push_back(fj);
    {
      ScopedTimer t(report, "write");
      Image layers;
      layers.AppendLayer("composite", cr.composite);
      layers.AppendLayer("mixed", mixed);
      layers.AppendLayer("real", real);
      layers.AppendLayer("mask", mask);
      layers.AppendLayer("difference", cr.difference);
      layers.AppendLayer("variance", variance);
      layers.AppendLayer("samples", fr ? fr->SampleCount() : Image::Gray(camera.width(), camera.height()));
      if (photo) layers.AppendLayer("photo", *photo);
      ImageWriteOptions wo;
      wo.tool = o.tool;
      // A frame's provenance is what decides its pixels, not how the job
      // was split: no command line (it names --frames), so that a frame
      // rendered in a shard is byte-identical to the same frame rendered
      // in one run (docs/cluster.md).  The report keeps the command line.
      wo.attributes["mr:render"] = frame_provenance + fmt::format(" frame {}", f);
      wo.pixel_type = scene.output.half ? PixelType::kHalf : PixelType::kFloat;
      const fs::path exr = out_dir / fmt::format("{:05d}.exr", f);
      WriteImage(exr, layers, wo);
      report->AddOutput(exr.string());
      if (video_out) video_out->Write(cr.composite);
      if (scene.output.png) {
        const fs::path png = out_dir / fmt::format("{:05d}.png", f);
        ImageWriteOptions po = wo;
        po.pixel_type = PixelType::kUint8;
        WriteImage(png, cr.composite, po);
        report->AddOutput(png.string());
      }
    }
    spdlog::info("frame {}: {} spp in {:.2f} s{}", f, done, seconds,
                 ref ? fmt::format(", relMSE {:.3g}", fj["relmse"].get<double>()) : std::string());
  }
  if (ic_cache) ic_cache->Describe(report);
  if (video_out) {
    video_out->Close();
    report->AddOutput((out_dir / "composite.mp4").string());
  }
  report->SetMetric("method", method);
  report->SetMetric("frames", frames_json);
  report->SetMetric("clamped_negative", clamped);
  report->SetMetric("nonfinite_samples", nonfinite);
  if (clamped > 0) report->Warn(fmt::format("{} negative composite values clamped to 0", clamped));
  if (n_ref > 0) {
    report->SetMetric("rmse", sum_rmse / n_ref);
    report->SetMetric("relmse", sum_relmse / n_ref);
    report->SetMetric("region_relmse", sum_region / n_ref);
    Json curve = Json::array();
    for (auto& c : curve_sum) {
      const int nf = c["frames"].get<int>();
      curve.push_back({{"seconds", c["seconds"].get<double>() / nf}, {"spp", c["spp"]},
                       {"relmse", c["relmse"].get<double>() / nf}, {"region_relmse", c["region_relmse"].get<double>() / nf}});
    }
    report->SetMetric("curve", curve);
  }
}

}  // namespace mr
