#include "render/render_job.h"

#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <map>

#include "core/error.h"
#include "core/file.h"
#include "core/hash.h"
#include "core/image.h"
#include "core/json.h"
#include "core/progress.h"
#include "core/video.h"
#include "render/composite.h"
#include "render/error_curve.h"
#include "render/frame_io.h"
#include "render/grain.h"
#include "render/method.h"
#include "render/render_scene.h"
#include "render/world.h"
#include "scene/frames.h"

namespace mr {

namespace {

// The content of everything a scene's frames are made from that is not per
// frame (see RunRenderJob's provenance).
// A JSON file as parsed, its comment left out (tools write their command
// line there: two runs of one scene from different folders are the same
// frames).
uint64_t JsonContentKey(const fs::path& path) {
  Json j = ReadJsonFile(path);
  if (j.is_object()) j.erase("comment");
  return HashString(j.dump());
}

// The inputs key an earlier run left beside frame f ("" when none).
std::string InputsKeyOf(const fs::path& out_dir, int f) {
  const fs::path p = out_dir / ".mr-render" / fmt::format("{:05d}.inputs", f);
  std::error_code ec;
  if (!fs::is_regular_file(p, ec)) return "";
  std::string t = ReadTextFile(p);
  while (!t.empty() && (t.back() == '\n' || t.back() == ' ')) t.pop_back();
  return t;
}

uint64_t SceneInputsKey(const Scene& scene) {
  uint64_t k = JsonContentKey(scene.file);
  auto add = [&](const std::optional<fs::path>& p) {
    k = HashCombine(k, p && !p->empty() && fs::exists(*p) ? ContentHash(*p) : 0);
  };
  add(scene.camera.model);
  add(scene.camera.poses);
  add(scene.camera.response);
  if (scene.camera.gains) k = HashCombine(k, JsonContentKey(*scene.camera.gains));
  if (scene.camera.frames_are_video) add(scene.camera.frames);
  for (const SceneReal& r : scene.reals) {
    add(r.mesh);
    add(r.material.albedo_texture);
  }
  for (const SceneVirtual& v : scene.virtuals) {
    add(v.mesh);
    add(v.material.albedo_texture);
    add(v.formfactors);
  }
  return k;
}

// A frame's plate as reflections look it up: radiance in the render's units
// at the frame's gain, and where it clipped (codes only).
struct DecodedPlate {
  Image radiance;
  std::optional<Image> clipped;      // one channel: any channel clipped
  std::optional<Image> clipped_rgb;  // per channel
};

DecodedPlate DecodePlate(const FrameDecoding& dec, const Image& photo, const PhotoEncoding& encoding) {
  DecodedPlate d{dec.ToRenderUnits(photo), std::nullopt, std::nullopt};
  if (encoding.has_codes) {  // a code at the top of its range
    const Image codes = dec.ToCodes(dec.ToRadiance(photo), encoding);
    d.clipped = Image::Gray(codes.width(), codes.height());
    d.clipped_rgb = Image::Rgb(codes.width(), codes.height());
    for (int y = 0; y < codes.height(); ++y)
      for (int x = 0; x < codes.width(); ++x)
        for (int c = 0; c < 3; ++c)
          if (codes.at(x, y, c) >= 254.5f / 255) d.clipped->at(x, y, 0) = d.clipped_rgb->at(x, y, c) = 1;
  }
  return d;
}

PlateView ViewOf(const DecodedPlate& d, const CameraModel& camera, const Rigid3& pose) {
  return PlateView{&d.radiance, d.clipped ? &*d.clipped : nullptr, &camera, pose};
}

bool SamePose(const Rigid3& a, const Rigid3& b) {
  return (a.translation - b.translation).norm() <= 1e-9 && a.rotation.angularDistance(b.rotation) <= 1e-9;
}

}  // namespace

JobInputs LoadJobInputs(const Scene& scene, int frame_begin, int frame_end, RenderScene* rs, Report* report) {
  JobInputs in;
  {
    ScopedTimer t(report, "load");
    in.camera = CameraModel::Read(scene.camera.model);
    in.poses = LoadScenePoses(scene);
  }
  report->AddInput(scene.file.string());
  const int n_frames = static_cast<int>(in.poses.size());
  int begin = frame_begin >= 0 ? frame_begin : scene.render.frame_begin;
  {
    ScopedTimer t(report, "load");
    LoadRenderScene(scene, rs, std::min(begin, std::max(0, n_frames - 1)));  // the world of the first frame
  }
  int end = frame_end >= 0 ? frame_end : scene.render.frame_end;
  if (begin >= n_frames)
    throw UsageError(fmt::format("frame range {}:{} is empty (the scene has {} frames)", begin, end, n_frames));
  {
    // Every input of every frame to render, checked before the first frame.
    ScopedTimer t(report, "check inputs");
    for (const std::string& w : CheckSceneInputs(scene, in.camera.width(), in.camera.height(), begin, end).warnings) {
      spdlog::warn("{}", w);
      report->Warn(w);
    }
  }
  if (end < 0 || end > n_frames) end = n_frames;
  if (begin >= end)
    throw UsageError(fmt::format("frame range {}:{} is empty (the scene has {} frames)", begin, end, n_frames));
  in.begin = begin;
  in.end = end;
  return in;
}

void RunRenderJob(const Scene& scene, const RenderOptions& o, Report* report) {
  const std::string method_name = o.method.empty() ? scene.render.method : o.method;
  const MethodInfo& info = FindRenderMethod(method_name);
  std::unique_ptr<RenderMethod> method = CreateRenderMethod(scene, method_name);
  const int spp = o.spp > 0 ? o.spp : scene.render.spp;
  const double budget = o.time_budget_s >= 0 ? o.time_budget_s : scene.render.time_budget_s;
  const fs::path out_dir = o.out_dir.empty() ? scene.output.dir : o.out_dir;

  RenderScene rs;
  const JobInputs in = LoadJobInputs(scene, o.frame_begin, o.frame_end, &rs, report);
  const CameraModel& camera = in.camera;
  const std::vector<Rigid3>& poses = in.poses;
  const int n_frames = static_cast<int>(poses.size());
  const int begin = in.begin, end = in.end;
  const FrameDecoding decoding = FrameDecoding::FromScene(scene, report);
  for (int f = begin; f < end; ++f) (void)decoding.ForFrame(f);  // a gain for every frame, before the first
  // The output folder only once every input is known to be sound: a refused
  // run leaves nothing behind, not even an empty folder.
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (!fs::is_directory(out_dir))
    ThrowErrorAt(FileLoc{out_dir.string()}, "cannot create the output folder{}", ec ? ": " + ec.message() : "");
  const std::optional<fs::path> reference = o.reference ? o.reference : scene.reference;
  const bool shard = begin > 0 || end < n_frames;
  report->SetMetric("shard", Json{{"begin", begin}, {"end", end}, {"scene_frames", n_frames}});
  const std::string frame_provenance =
      fmt::format("scene {} method {} spp {} time_budget {} seed {}", scene.file.filename().string(), method_name, spp,
                  budget, scene.render.seed);
  if (const int stale = RemoveStaleTemporaries(out_dir); stale > 0)
    report->Warn(fmt::format("removed {} temporary files that killed runs left in {}", stale, out_dir.string()));
  // --resume: frames an earlier run of the same settings completed are kept,
  // and rendering starts at the first missing one (as a shard starting
  // there would: byte-identical frames).
  // A frame's provenance: the job's settings, the frame and its plate gain
  // (a refitted gains file re-renders the frames whose gain changed).
  // And what it is made from, by content: the scene file, the camera
  // model, poses, response, gains, meshes and textures, and the frame's
  // own photograph, environment map and lights file.  --resume keeps frames
  // from the first on while theirs match, so a changed input re-renders its
  // frame and every frame after it (which may carry over state from it:
  // ic's records, vct's grid).  The key does not depend on where a shard
  // begins: shards write the frames one run writes.
  const uint64_t global_key = SceneInputsKey(scene);
  auto inputs_key = [&](int f) {
    uint64_t k = global_key;
    if (scene.camera.frames && !scene.camera.frames_are_video) {
      const fs::path photo = FramePath(*scene.camera.frames, f);
      k = HashCombine(k, fs::exists(photo) ? ContentHash(photo) : 0);
    }
    k = HashCombine(k, EnvironmentKey(scene, f));
    const std::optional<fs::path> lights = LightsAt(scene, f);
    k = HashCombine(k, lights ? ContentHash(*lights) : 0);
    return k;
  };
  auto provenance = [&](int f) {
    std::string p = frame_provenance + fmt::format(" frame {}", f);
    if (scene.output.grain != "off") p += " grain " + scene.output.grain;
    if (scene.render.adaptive_threshold > 0)
      p += fmt::format(" adaptive {:.9g} min_spp {}", scene.render.adaptive_threshold, scene.render.adaptive_min_spp);
    if (!decoding.frame_gains.empty()) {
      const Rgb g = decoding.ForFrame(f).gain;
      p += fmt::format(" gain {:.9g},{:.9g},{:.9g}", g[0], g[1], g[2]);
    }
    return p;
  };
  int resumed_end = begin;
  if (o.resume) {
    while (resumed_end < end && FrameComplete(out_dir, resumed_end, scene.output, provenance(resumed_end)) &&
           InputsKeyOf(out_dir, resumed_end) == fmt::format("{:016x}", inputs_key(resumed_end)))
      ++resumed_end;
    if (resumed_end > begin)
      report->Skip(fmt::format("frames {}:{}", begin, resumed_end),
                   "--resume: complete in the output folder from an earlier run with the same settings");
  }
  FrameReader frames(scene, camera, decoding);
  // The plate's grain, measured on up to 8 frames spread over the whole
  // scene (not the shard: every shard adds the same grain).
  std::optional<NoiseProfile> grain;
  if (scene.output.grain == "off") {
    report->Skip("grain", "output.grain is \"off\"");
  } else if (!decoding.photograph) {
    report->Skip("grain", "no plate: a synthetic composite has no sensor noise to match");
  } else if (!rs.has_virtual()) {
    report->Skip("grain", "no virtual object: nothing rendered shows in the composite");
  } else {
    ScopedTimer t(report, "grain estimate");
    FrameReader sample_frames(scene, camera, decoding);
    std::vector<Image> codes;
    bool has_codes = true;
    const int n = std::min(8, n_frames);
    for (int k = 0; k < n && has_codes; ++k) {
      const int f = static_cast<int>(static_cast<int64_t>(k) * n_frames / n);
      PhotoEncoding enc;
      const Image photo = *sample_frames.Photo(f, &enc);
      has_codes = enc.has_codes;
      codes.push_back(decoding.ToCodes(decoding.ToRadiance(photo), enc));
    }
    if (!has_codes && scene.output.grain == "auto") {
      report->Skip("grain",
                   "output.grain is \"auto\" and the plate is float (no code values, no sensor noise to "
                   "match); \"on\" measures it anyway");
    } else {
      grain = EstimateNoise(codes);
      report->SetMetric("grain", grain->ToJson());
      report->SetMetric("grain.frames", n);
      spdlog::info("grain: plate noise {:.2f}/255 at mid-grey (G), from {} patches of {} frames",
                   255 * grain->At(1, 0.5), grain->patches_used, n);
    }
  }
  std::unique_ptr<VideoWriter> video_out;
  const fs::path video_path = out_dir / ("composite." + scene.output.video);
  // A video's frames are 8-bit sRGB code values (FrameReader).
  const PhotoEncoding video_encoding{true, Transfer::kSrgb, PixelType::kUint8};
  if (frames.is_video() && scene.output.video == "none") {
    report->Skip("composite video", "output.video is \"none\"");
  } else if (frames.is_video() && shard) {
    report->Skip("composite video", fmt::format("frames {}:{} are a shard of {}: `mr-eval merge` writes the video "
                                                "from every shard's frames",
                                                begin, end, n_frames));
  } else if (frames.is_video()) {
    // The input's frame rate and size; a frame per frame rendered.
    video_out = std::make_unique<VideoWriter>(video_path, camera.width(), camera.height(), frames.fps());
  }
  if (frames.is_video()) report->SetMetric("plate_fps", frames.fps());  // mr-eval merge's video
  if (!decoding.photograph)
    report->Skip("photograph",
                 "the scene names no camera frames: I_c is the rendered real scene I_r (synthetic composite)");
  // With no virtual object nothing can differ from the photograph: frames are
  // copied through without rendering (I_m - I_r = 0 exactly; tested).
  // The world where it changes during the video (render/world.h): brought
  // to the first frame rendered.
  WorldTracker world(scene, rs, begin);
  if (resumed_end > begin && resumed_end < end) world.Advance(resumed_end, &rs);
  const bool copy_through = !world.dynamic() && !rs.has_virtual() && decoding.photograph;
  if (!world.dynamic() && !rs.has_virtual())
    report->Skip("virtual objects", "the scene has none: the composite is the photograph");
  if (copy_through)
    report->Skip("rendering", "no virtual object can change any frame: frames are copied through from the photographs");
  auto job_at = [&](int f) { return JobContext{scene, rs, camera, spp, resumed_end, decoding.photograph, report, f}; };
  if (!copy_through) {
    const JobContext job = job_at(resumed_end);
    if (info.prepare_timing.empty()) {
      method->Prepare(job);
    } else {
      ScopedTimer t(report, info.prepare_timing);
      method->Prepare(job);
    }
  }
  int world_kept = 0, world_changed = 0;
  // An object passing through a real surface renders, but is rarely meant.
  auto check_crossings = [&](int f, const std::vector<std::string>* moved) {
    for (size_t i = 0; i < scene.virtuals.size(); ++i) {
      const std::string& name = scene.virtuals[i].name;
      if (moved && std::find(moved->begin(), moved->end(), name) == moved->end()) continue;
      if (const int64_t n = rs.RealCrossings(i); n > 0) {
        const std::string w = fmt::format(
            "frame {}: virtual object \"{}\" passes through real geometry ({} of its edges cross a real surface)", f,
            name, n);
        spdlog::warn("{}", w);
        report->Warn(w);
      }
    }
  };
  if (!copy_through) check_crossings(resumed_end, nullptr);

  // Neighbouring frames' plates for reflections the frame's own does not
  // see (the frames f +- k step), read in increasing order by their own
  // reader and kept while in reach.
  const int neighbours = scene.render.plate_neighbours, step = scene.render.plate_neighbour_step;
  const bool use_neighbours =
      !copy_through && decoding.photograph && method->TakesPlateReflections() && neighbours > 0 && n_frames > 1;
  if (!copy_through && decoding.photograph && method->TakesPlateReflections() && !use_neighbours)
    report->Skip("plate neighbours", neighbours == 0 ? "render.plate_neighbours is 0: reflections take the frame's "
                                                       "own plate only"
                                                     : "the scene has one frame");
  std::optional<FrameReader> neighbour_frames;
  if (use_neighbours) neighbour_frames.emplace(scene, camera, decoding);
  std::map<int, DecodedPlate> neighbour_plates;
  int64_t neighbours_still = 0, neighbours_without_gain = 0;
  if (scene.camera.shutter <= 0) report->Skip("motion blur", "camera.shutter is 0 (or not given)");
  if (scene.camera.aperture_radius <= 0) report->Skip("depth of field", "camera.lens is not given: a pinhole");
  int still_frames = 0;  // with a shutter, over which the camera does not move
  Json frames_json = Json::array();
  fs::path review_sheet;  // the last one written
  ErrorCurve errors;
  struct PreviousFrame {
    int frame;
    Image composite, reference;
    std::optional<Image> region;
  };
  std::optional<PreviousFrame> previous;  // for the flicker
  double flicker_sum = 0;
  int flicker_frames = 0;
  int64_t clamped = 0, nonfinite = 0;
  // A frame's error against the reference (over the region the objects
  // change, where the plate is known) and its flicker against the frame
  // before, into fj.
  auto measure = [&](int f, const Image& composite, const Image& ref, const std::optional<Image>& region, Json* fj) {
    const FrameError e = MeasureFrame(composite, ref, region ? &*region : nullptr);
    (*fj)["rmse"] = e.rmse;
    (*fj)["relmse"] = e.relmse;
    (*fj)["region_relmse"] = e.region_relmse;
    if (previous && previous->frame == f - 1) {
      std::optional<Image> both;
      if (region && previous->region) {
        both = *region;
        for (size_t i = 0; i < both->values().size(); ++i)
          both->values()[i] = std::max(both->values()[i], previous->region->values()[i]);
      }
      const double flicker =
          MeasureFlicker(composite, previous->composite, ref, previous->reference, both ? &*both : nullptr);
      (*fj)["flicker"] = flicker;
      flicker_sum += flicker;
      ++flicker_frames;
    }
    previous = PreviousFrame{f, composite, ref, region};
    return e;
  };
  for (int f = begin; f < resumed_end; ++f) {  // kept by --resume
    Json fj = {{"frame", f}, {"resumed", true}};
    if (video_out || reference) {
      const Image composite = ReadImage(out_dir / fmt::format("{:05d}.exr", f)).Layer("composite");
      if (video_out) video_out->WriteCodes(decoding.ToCodes(composite, video_encoding));
      if (reference) {
        const Image ref = ReadReferenceFrame(FramePath(*reference, f), camera.width(), camera.height());
        // The plate, read in order (a video reads forwards), for the region.
        PhotoEncoding encoding;
        const std::optional<Image> photo = frames.Photo(f, &encoding);
        std::optional<Image> region;
        if (photo) region = ChangedRegion(ref, *photo);
        measure(f, composite, ref, region, &fj);
      }
    }
    frames_json.push_back(fj);
  }
  for (int f = resumed_end; f < end; ++f) {
    const Rigid3& pose = poses[static_cast<size_t>(f)];
    // The method's own time on this frame: its world update, its frame
    // renderer's set-up and its passes; not loading, the error checkpoints,
    // compositing or writing (the frame's `seconds`, its error curve's).
    double method_seconds = 0;
    auto timed = [&method_seconds](auto&& work) {
      const auto start = std::chrono::steady_clock::now();
      work();
      method_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    Json world_json;
    if (world.dynamic()) {
      const WorldChange wc = world.Advance(f, &rs);
      std::vector<std::string> rebuilt;
      if (wc.any() && f > resumed_end) {
        ScopedTimer t(report, "world update");
        timed([&] {
          if (scene.render.world_update == "rebuild") {
            method->Prepare(job_at(f));
            rebuilt = {"everything (render.world_update is rebuild)"};
          } else {
            rebuilt = method->WorldChanged(job_at(f), wc);
          }
        });
        spdlog::info("frame {}: {} changed: {}", f, wc.Describe(),
                     rebuilt.empty() ? std::string("nothing to rebuild") : fmt::format("{}", fmt::join(rebuilt, ", ")));
      }
      (wc.any() ? world_changed : world_kept) += f > resumed_end;
      if (!wc.moved.empty() && f > resumed_end) check_crossings(f, &wc.moved);
      world_json = wc.ToJson();
      world_json["rebuilt"] = rebuilt;
      for (const std::string& n : wc.notes) report->Warn(n);
    }
    std::string enclosed;
    const bool no_virtual = !rs.has_virtual();
    const bool frame_copy = copy_through || (decoding.photograph &&
                                             (no_virtual || rs.VirtualEnclosedAwayFrom(pose.translation, &enclosed)));
    if (frame_copy && !copy_through)
      report->Skip(fmt::format("rendering frame {}", f),
                   (no_virtual ? std::string("no virtual object or light in this frame's world") : enclosed) +
                       ": I_m - I_r = 0 exactly, the photograph is copied through");
    const FrameDecoding dec = decoding.ForFrame(f);
    PhotoEncoding encoding;
    const std::optional<Image> photo = frames.Photo(f, &encoding);
    std::optional<Image> ref;
    if (reference) ref = ReadReferenceFrame(FramePath(*reference, f), camera.width(), camera.height());
    std::optional<DecodedPlate> plate;  // prt's background; pt's and ic's reflections
    if (photo && !frame_copy) plate = DecodePlate(dec, *photo, encoding);
    PlateViews plates;
    if (plate && method->TakesPlateReflections()) plates.push_back(ViewOf(*plate, camera, pose));
    if (plate && use_neighbours) {
      std::vector<int> wanted;  // nearest first; a camera that did not move sees nothing new
      for (int k = 1; k <= neighbours; ++k)
        for (const int g : {f + k * step, f - k * step}) {
          if (g < 0 || g >= n_frames) continue;
          if (SamePose(poses[static_cast<size_t>(g)], pose)) {
            ++neighbours_still;
            continue;
          }
          if (!decoding.HasGain(g)) {
            ++neighbours_without_gain;  // its units are unknown
            continue;
          }
          wanted.push_back(g);
        }
      std::erase_if(neighbour_plates, [&](const auto& kv) { return kv.first < f - neighbours * step; });
      std::vector<int> missing;
      for (int g : wanted)
        if (!neighbour_plates.count(g)) missing.push_back(g);
      std::sort(missing.begin(), missing.end());  // a video reads forwards
      for (int g : missing) {
        PhotoEncoding e;
        const std::optional<Image> p = neighbour_frames->Photo(g, &e);
        neighbour_plates.emplace(g, DecodePlate(decoding.ForFrame(g), *p, e));
      }
      for (int g : wanted) plates.push_back(ViewOf(neighbour_plates.at(g), camera, poses[static_cast<size_t>(g)]));
    }
    const CameraExposure exposure = FrameExposure(scene, poses, f);
    if (scene.camera.shutter > 0 && !exposure.moves && !frame_copy) ++still_frames;
    const FrameContext fc{rs,
                          camera,
                          pose,
                          scene.render.seed,
                          f,
                          plate ? &plate->radiance : nullptr,
                          plate && plate->clipped ? &*plate->clipped : nullptr,
                          exposure,
                          plates};
    std::unique_ptr<FrameMethod> fr;
    if (!frame_copy) {
      ScopedTimer t(report, "render");
      timed([&] { fr = method->NewFrame(fc); });
    }
    const AdaptiveSampling adaptive{scene.render.adaptive_threshold, scene.render.adaptive_min_spp};
    if (fr && adaptive.on() && !fr->SetAdaptive(adaptive) && f == resumed_end)
      report->Skip("adaptive sampling",
                   fmt::format("render.method {} has no per-pixel sample loop to stop", scene.render.method));
    std::optional<Image> region;
    if (ref && photo) region = ChangedRegion(*ref, *photo);
    const Image* photo_ptr = photo ? &*photo : nullptr;
    Progress progress(fmt::format("frame {}", f), spp);
    int done = 0;
    double seconds = 0;
    while (fr && done < spp) {
      const int n = info.one_pass ? spp : std::min(done == 0 ? 1 : done, spp - done);
      {
        ScopedTimer t(report, "render");
        timed([&] { fr->RenderPass(n); });
      }
      done += n;
      progress.Update(done);
      seconds = method_seconds;
      if (ref)
        errors.Checkpoint(seconds, done,
                          MeasureFrame(dec.Compose(*fr, photo_ptr).composite, *ref, region ? &*region : nullptr));
      if (budget > 0 && seconds >= budget) {
        report->Warn(fmt::format("frame {}: time budget {} s reached at {} spp", f, budget, done));
        break;
      }
    }
    progress.Done();
    CompositeResult cr;
    Image mixed, real, mask, variance, samples;
    int64_t clipped_kept = 0, clipped_changed = 0;
    if (fr) {
      ScopedTimer t(report, "composite");
      cr = dec.Compose(*fr, photo_ptr);
      mixed = fr->Mixed();
      real = fr->Real();
      mask = fr->Mask();
      if (plate && plate->clipped_rgb) {
        // Clipped plate channels keep their codes under a change their
        // unknown excess hides (composite.h).
        const ClippedChannels k = KeepClippedChannels(dec.ToRadiance(*photo), *plate->clipped_rgb, mask, &cr.composite);
        clipped_kept = k.kept;
        clipped_changed = k.changed;
      }
      variance = fr->DifferenceVariance();
      samples = fr->SampleCount();
      if (grain) {
        // The plate's noise where the composite shows the render, added to
        // the codes and brought back to radiance: pixels the object does not
        // cover keep their values exactly.
        const Image codes0 = dec.ToCodes(cr.composite, encoding);
        Image noisy = codes0;
        AddGrain(*grain, mask, scene.render.seed, f, &noisy);
        const Image r0 = dec.FromCodes(codes0, encoding), r1 = dec.FromCodes(noisy, encoding);
        for (int y = 0; y < mask.height(); ++y)
          for (int x = 0; x < mask.width(); ++x)
            if (mask.at(x, y, 0) > 0)
              for (int c = 0; c < 3; ++c)
                cr.composite.at(x, y, c) = std::max(0.0f, cr.composite.at(x, y, c) + r1.at(x, y, c) - r0.at(x, y, c));
      }
    } else {  // copied through
      cr.composite = decoding.ToRadiance(*photo);
      cr.difference = Image::Rgb(camera.width(), camera.height());
      mixed = real = *photo;
      mask = variance = samples = Image::Gray(camera.width(), camera.height());
    }
    clamped += cr.clamped_negative;
    const int64_t frame_nonfinite = fr ? fr->nonfinite_samples() : 0;
    nonfinite += frame_nonfinite;
    const int64_t env_pixels = fr ? fr->skipped_pixels() : 0;
    Json fj = {{"frame", f},
               {"gain", dec.gain},
               {"spp", done},
               {"seconds", seconds},
               {"clamped_negative", cr.clamped_negative},
               {"clipped_kept", clipped_kept},
               {"clipped_changed", clipped_changed},
               {"nonfinite_samples", frame_nonfinite},
               {"copied_through", !fr},
               {"environment_pixels_sampled_once", env_pixels}};
    if (!world_json.is_null()) fj["world"] = world_json;
    if (fr && adaptive.on()) {
      double total = 0;
      for (float c : samples.values()) total += c;
      fj["adaptive"] = {{"stopped_pixels", fr->adaptive_stopped()},
                        {"mean_spp", total / std::max<size_t>(1, samples.values().size())}};
    }
    if (env_pixels > 0 && done > 1)
      report->Skip(fmt::format("frame {}: {} pixels after the first sample", f, env_pixels),
                   "their camera rays provably meet no geometry (environment only): I_m - I_r = 0 exactly");
    if (ref) fj["curve"] = errors.EndFrame(measure(f, cr.composite, *ref, region, &fj));
    if (fr) method->FrameDone(*fr, fc, report, &fj);
    frames_json.push_back(fj);
    {
      ScopedTimer t(report, "write");
      // The 8-bit outputs through the inverse of the frames' decoding: a
      // pixel the object does not change keeps the plate's code value.
      const Image codes = decoding.ToCodes(cr.composite, encoding);
      FrameLayers layers{&cr.composite, &codes, &mixed, &real, &mask, &cr.difference, &variance, &samples, photo_ptr};
      WriteFrameFiles(out_dir, f, layers, encoding, decoding.CodesColorSpace(encoding), scene.output, o.tool,
                      provenance(f), report);
      // The frame's inputs key beside it (not in it: inputs that differ
      // only in their comments or paths still give the same frame's bytes).
      std::error_code key_ec;
      fs::create_directories(out_dir / ".mr-render", key_ec);
      WriteTextFile(out_dir / ".mr-render" / fmt::format("{:05d}.inputs", f), fmt::format("{:016x}\n", inputs_key(f)));
      if (video_out) video_out->WriteCodes(codes);
      if (scene.output.review) {
        const Image plate_codes = decoding.ToCodes(photo ? decoding.ToRadiance(*photo) : real, encoding);
        review_sheet = WriteReviewSheet(out_dir, f, plate_codes, codes, mask, photo.has_value(), o.tool, report);
      }
    }
    spdlog::info("frame {}: {} spp in {:.2f} s{}", f, done, seconds,
                 ref ? fmt::format(", relMSE {:.3g}", fj["relmse"].get<double>()) : std::string());
  }
  if (still_frames > 0)
    report->Skip(fmt::format("motion blur in {} frames", still_frames),
                 "the camera does not move over their shutter intervals: the blur is exactly none");
  if (world.dynamic()) {
    report->SetMetric("world", Json{{"frames_changed", world_changed}, {"frames_kept", world_kept}});
    if (world_kept > 0)
      report->Skip(fmt::format("rebuilding in {} frames", world_kept),
                   "their light (by content) and objects are the previous frame's: every cache, volume and VPL set "
                   "kept");
  }
  if (use_neighbours) {
    report->SetMetric("plate_neighbours", Json{{"count", neighbours}, {"step", step}});
    if (neighbours_still > 0)
      report->Skip(fmt::format("{} neighbouring plates", neighbours_still),
                   "taken from the frame's own pose: they see nothing the frame's plate does not");
    if (neighbours_without_gain > 0)
      report->Skip(fmt::format("{} neighbouring plates without a gain", neighbours_without_gain),
                   "camera.gains has no entry for them: their units are unknown");
  }
  method->Finish(report);
  if (video_out) {
    video_out->Close();
    report->AddOutput(video_path.string());
  }
  if (!review_sheet.empty()) {
    report->SetMetric("review_sheet", review_sheet.string());
    spdlog::info("review sheet: {}", review_sheet.string());
  }
  report->SetMetric("method", method_name);
  report->SetMetric("frames", frames_json);
  report->SetMetric("clamped_negative", clamped);
  report->SetMetric("nonfinite_samples", nonfinite);
  if (clamped > 0) report->Warn(fmt::format("{} negative composite values clamped to 0", clamped));
  if (errors.frames() > 0) {
    report->SetMetric("rmse", errors.mean_rmse());
    report->SetMetric("relmse", errors.mean_relmse());
    report->SetMetric("region_relmse", errors.mean_region_relmse());
    report->SetMetric("curve", errors.MeanCurve());
  }
  if (flicker_frames > 0) report->SetMetric("flicker", flicker_sum / flicker_frames);  // kept frames too
}

}  // namespace mr
