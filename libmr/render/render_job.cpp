#include "render/render_job.h"
#include "core/check.h"

#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <set>

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
#include "render/swim.h"
#include "render/world.h"
#include "scene/frames.h"

namespace mr {

namespace {

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

// The content of everything a scene's frames are made from that is not per
// frame (see RunRenderJob's provenance).
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
  for (const SceneLighting::Probe& pr : scene.lighting.probes)  // their centres: in the scene file
    if (!pr.map_per_frame) add(pr.map);
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
  report->SetMetric("camera_poses", ScenePoseSource(scene));
  const int n_frames = static_cast<int>(in.poses.size());
  int begin = frame_begin >= 0 ? frame_begin : scene.render.frame_begin;
  {
    ScopedTimer t(report, "load");
    LoadRenderScene(scene, rs, std::min(begin, std::max(0, n_frames - 1)));  // the world of the first frame
  }
  {
    // What the lights are: placed in the room, at infinity, points.
    int area = 0, distant = 0, point = 0, bounded = 0;
    for (const LightSource& l : rs->lights()) {
      area += l.light().type == LightType::kArea;
      distant += l.light().type == LightType::kDistant;
      point += l.light().type == LightType::kPoint || l.light().type == LightType::kSpot;
      bounded += !l.light().strength_note.empty();
    }
    if (!rs->lights().empty())
      report->SetMetric("lights",
                        {{"area", area}, {"distant", distant}, {"point_or_spot", point}, {"lower_bounds", bounded}});
  }
  for (const LightSource& l : rs->lights())
    if (!l.light().strength_note.empty())
      report->Warn(fmt::format("light {}'s strength is {}: what it lights is too dark by what the clip hid",
                               l.light().name, l.light().strength_note));
  int end = frame_end >= 0 ? frame_end : scene.render.frame_end;
  if (begin >= n_frames)
    throw UsageError(fmt::format("frame range {}:{} is empty (the scene has {} frames)", begin, end, n_frames));
  {
    // Every input of every frame to render, checked before the first frame.
    ScopedTimer t(report, "check inputs");
    for (const std::string& w : CheckSceneInputs(scene, in.camera.width(), in.camera.height(), begin, end).warnings) {
      report->Warn(w);
    }
  }
  if (end < 0 || end > n_frames) end = n_frames;
  if (begin >= end)
    throw UsageError(fmt::format("frame range {}:{} is empty (the scene has {} frames)", begin, end, n_frames));
  MR_CHECK(0 <= begin && begin < end && end <= n_frames);
  in.begin = begin;
  in.end = end;
  return in;
}

namespace {

// One mr-render job: the state its frames share, and its steps in the order
// RunRenderJob takes them.  Each step is one part of the job a maintainer
// can read on its own; what a step decides for the later ones is a member.
class RenderJob {
 public:
  RenderJob(const Scene& scene, const RenderOptions& o, Report* report);
  void FindResumedFrames();
  void EstimateGrain();
  void OpenVideo();
  void PrepareWorldAndMethod();
  void SetUpNeighbourPlates();
  void ReplayResumedFrames();
  void RenderFrames() {
    for (int f = resumed_end_; f < in_.end; ++f) RenderFrame(f);
  }
  void Summarize();

 private:
  // A frame's error against the reference and its flicker.
  struct PreviousFrame {
    int frame;
    Image composite, reference;
    std::optional<Image> region;
  };
  // What one frame is rendered from and what its passes made.
  struct Frame {
    int f = 0;
    bool copy = false;  // copied through: nothing rendered
    PhotoEncoding encoding;
    std::optional<Image> photo, ref, region;
    // The plate's code values as read, where a colour space decodes them:
    // an unchanged pixel writes them back (PhotoEncoding, KeepPlateCodes).
    std::optional<Image> codes;
    std::optional<DecodedPlate> plate;  // prt's background; pt's and ic's reflections
    PlateViews plates;
    double seconds = 0;       // the method's own time on the frame
    int done = 0;             // samples per pixel rendered
    std::string review_note;  // on the review sheet: the objects' swim
  };
  // The images a frame writes.
  struct FrameImages {
    CompositeResult cr;
    Image mixed, real, mask, variance, samples;
    int64_t clipped_kept = 0, clipped_changed = 0;
  };

  JobContext JobAt(int f) const {
    return JobContext{scene_, rs_, in_.camera, spp_, resumed_end_, decoding_.photograph, report_, f};
  }
  uint64_t InputsKey(int f) const;
  std::string Provenance(int f) const;
  void CheckCrossings(int f, const std::vector<std::string>* moved);
  void ReportAssetApproximations();
  FrameError Measure(int f, const Image& composite, const Image& ref, const std::optional<Image>& region, Json* fj);
  void CheckMaskAgainstReference(int f, const Image& mask, const Image& ref, const Image& photo, Json* fj);
  template <class Work>
  void Timed(Frame* fr, Work&& work) {
    const auto start = std::chrono::steady_clock::now();
    work();
    fr->seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  void RenderFrame(int f);
  Json AdvanceWorld(Frame* fr);
  void LoadPlates(Frame* fr);
  void AddNeighbourPlates(Frame* fr);
  void LoadProbes();
  const EnvironmentMap& ProbeMap(const fs::path& file);
  void AddProbes(Frame* fr);
  std::unique_ptr<FrameMethod> RunPasses(Frame* fr, const FrameContext& fc, const FrameDecoding& dec);
  FrameImages Compose(const Frame& fr, FrameMethod* fm, const FrameDecoding& dec);
  void WriteFrame(const Frame& fr, FrameImages* im);

  const Scene& scene_;
  const RenderOptions& o_;
  Report* report_;
  std::string method_name_;
  const MethodInfo& info_;
  std::unique_ptr<RenderMethod> method_;
  int spp_ = 0;
  double budget_ = 0;
  fs::path out_dir_;
  RenderScene rs_;
  JobInputs in_;
  int n_frames_ = 0;
  FrameDecoding decoding_;
  std::optional<fs::path> reference_;
  bool shard_ = false;
  std::string frame_provenance_;
  uint64_t global_key_ = 0;
  int resumed_end_ = 0;
  std::optional<FrameReader> frames_;
  std::optional<NoiseProfile> grain_;
  std::unique_ptr<VideoWriter> video_out_;
  fs::path video_path_;
  std::optional<WorldTracker> world_;
  std::optional<SwimMeter> swim_;  // with a plate and virtual objects
  bool copy_through_ = false;
  int world_kept_ = 0, world_changed_ = 0;
  // Neighbouring frames' plates for reflections the frame's own does not see.
  int neighbours_ = 0, step_ = 0;
  bool use_neighbours_ = false;
  std::optional<FrameReader> neighbour_frames_;
  std::map<int, DecodedPlate> neighbour_plates_;
  int64_t neighbours_still_ = 0, neighbours_without_gain_ = 0;
  // lighting.probes' own maps by file (a probe without one takes the environment's).
  std::map<std::string, EnvironmentMap> probe_maps_;
  int still_frames_ = 0;  // with a shutter, over which the camera does not move
  Json frames_json_ = Json::array();
  fs::path review_sheet_;  // the last one written
  ErrorCurve errors_;
  std::optional<PreviousFrame> previous_;  // for the flicker
  double flicker_sum_ = 0;
  int flicker_frames_ = 0;
  int64_t clamped_ = 0, nonfinite_ = 0;
};

// The method, the inputs (checked), the frames' decoding and the output
// folder, in that order: a refused run leaves nothing behind.
RenderJob::RenderJob(const Scene& scene, const RenderOptions& o, Report* report)
    : scene_(scene),
      o_(o),
      report_(report),
      method_name_(o.method.empty() ? scene.render.method : o.method),
      info_(FindRenderMethod(method_name_)) {
  method_ = CreateRenderMethod(scene, method_name_);
  spp_ = o.spp > 0 ? o.spp : scene.render.spp;
  budget_ = o.time_budget_s >= 0 ? o.time_budget_s : scene.render.time_budget_s;
  out_dir_ = o.out_dir.empty() ? scene.output.dir : o.out_dir;
  in_ = LoadJobInputs(scene, o.frame_begin, o.frame_end, &rs_, report);
  n_frames_ = static_cast<int>(in_.poses.size());
  decoding_ = FrameDecoding::FromScene(scene, report);
  for (int f = in_.begin; f < in_.end; ++f) (void)decoding_.ForFrame(f);  // a gain for every frame, before the first
  LoadProbes();
  // The output folder only once every input is known to be sound: a refused
  // run leaves nothing behind, not even an empty folder.
  std::error_code ec;
  fs::create_directories(out_dir_, ec);
  if (!fs::is_directory(out_dir_))
    ThrowErrorAt(FileLoc{out_dir_.string()}, "cannot create the output folder{}", ec ? ": " + ec.message() : "");
  reference_ = o.reference ? o.reference : scene.reference;
  shard_ = in_.begin > 0 || in_.end < n_frames_;
  report->SetMetric("shard", Json{{"begin", in_.begin}, {"end", in_.end}, {"scene_frames", n_frames_}});
  frame_provenance_ = fmt::format("scene {} method {} spp {} time_budget {} seed {}", scene.file.filename().string(),
                                  method_name_, spp_, budget_, scene.render.seed);
  // Both folders a run writes: the frames, and the inputs keys under .mr-render/.
  if (const int stale = RemoveStaleTemporaries(out_dir_) + RemoveStaleTemporaries(out_dir_ / ".mr-render"); stale > 0)
    report->Warn(fmt::format("removed {} temporary files that killed runs left in {}", stale, out_dir_.string()));
  global_key_ = SceneInputsKey(scene);
  resumed_end_ = in_.begin;
}

// A frame's inputs key: what it is made from, by content: the scene file,
// the camera model, poses, response, gains, meshes and textures
// (SceneInputsKey), and the frame's own photograph, environment map and
// lights file.  --resume keeps frames from the first on while theirs match,
// so a changed input re-renders its frame and every frame after it (which
// may carry over state from it: ic's records, vct's grid).  The key does not
// depend on where a shard begins: shards write the frames one run writes.
uint64_t RenderJob::InputsKey(int f) const {
  uint64_t k = global_key_;
  if (scene_.camera.frames && !scene_.camera.frames_are_video) {
    const fs::path photo = FramePath(*scene_.camera.frames, f);
    k = HashCombine(k, fs::exists(photo) ? ContentHash(photo) : 0);
  }
  k = HashCombine(k, EnvironmentKey(scene_, f));
  const std::optional<fs::path> lights = LightsAt(scene_, f);
  k = HashCombine(k, lights ? ContentHash(*lights) : 0);
  for (const SceneLighting::Probe& pr : scene_.lighting.probes)
    if (pr.map_per_frame) {
      const std::optional<fs::path> p = PerFrameFile(*pr.map, f, nullptr);
      k = HashCombine(k, p ? ContentHash(*p) : 0);
    }
  return k;
}

// A frame's provenance: the job's settings, the frame and its plate gain (a
// refitted gains file re-renders the frames whose gain changed).
std::string RenderJob::Provenance(int f) const {
  std::string p = frame_provenance_ + fmt::format(" frame {}", f);
  if (scene_.output.grain != "off") p += " grain " + scene_.output.grain;
  if (scene_.render.adaptive_threshold > 0)
    p += fmt::format(" adaptive {:.9g} min_spp {}", scene_.render.adaptive_threshold, scene_.render.adaptive_min_spp);
  if (!decoding_.frame_gains.empty()) {
    const Rgb g = decoding_.ForFrame(f).gain;
    p += fmt::format(" gain {:.9g},{:.9g},{:.9g}", g[0], g[1], g[2]);
  }
  return p;
}

// --resume: frames an earlier run of the same settings completed are kept,
// and rendering starts at the first missing one (as a shard starting there
// would: byte-identical frames).
void RenderJob::FindResumedFrames() {
  if (!o_.resume) return;
  while (resumed_end_ < in_.end && FrameComplete(out_dir_, resumed_end_, scene_.output, Provenance(resumed_end_)) &&
         InputsKeyOf(out_dir_, resumed_end_) == fmt::format("{:016x}", InputsKey(resumed_end_)))
    ++resumed_end_;
  if (resumed_end_ > in_.begin)
    report_->Skip(fmt::format("frames {}:{}", in_.begin, resumed_end_),
                  "--resume: complete in the output folder from an earlier run with the same settings");
}

// The plate's grain, measured on up to 8 frames spread over the whole scene
// (not the shard: every shard adds the same grain).
void RenderJob::EstimateGrain() {
  frames_.emplace(scene_, in_.camera, decoding_);
  if (scene_.output.grain == "off") {
    report_->Skip("grain", "output.grain is \"off\"");
    return;
  }
  if (!decoding_.photograph) {
    report_->Skip("grain", "no plate: a synthetic composite has no sensor noise to match");
    return;
  }
  if (!rs_.has_virtual()) {
    report_->Skip("grain", "no virtual object: nothing rendered shows in the composite");
    return;
  }
  ScopedTimer t(report_, "grain estimate");
  FrameReader sample_frames(scene_, in_.camera, decoding_);
  std::vector<Image> codes;
  bool has_codes = true;
  const int n = std::min(8, n_frames_);
  for (int k = 0; k < n && has_codes; ++k) {
    const int f = static_cast<int>(static_cast<int64_t>(k) * n_frames_ / n);
    PhotoEncoding enc;
    const Image photo = *sample_frames.Photo(f, &enc);
    has_codes = enc.has_codes;
    codes.push_back(decoding_.ToCodes(decoding_.ToRadiance(photo), enc));
  }
  if (!has_codes && scene_.output.grain == "auto") {
    report_->Skip("grain",
                  "output.grain is \"auto\" and the plate is float (no code values, no sensor noise to "
                  "match); \"on\" measures it anyway");
    return;
  }
  grain_ = EstimateNoise(codes);
  report_->SetMetric("grain", grain_->ToJson());
  report_->SetMetric("grain.frames", n);
  spdlog::info("grain: plate noise {:.2f}/255 at mid-grey (G), from {} patches of {} frames", 255 * grain_->At(1, 0.5),
               grain_->patches_used, n);
}

// A video plate's composite video: the input's frame rate and size, a frame
// per frame rendered (8-bit sRGB code values, as FrameReader reads them).
void RenderJob::OpenVideo() {
  video_path_ = out_dir_ / ("composite." + scene_.output.video);
  if (frames_->is_video() && scene_.output.video == "none") {
    report_->Skip("composite video", "output.video is \"none\"");
  } else if (frames_->is_video() && shard_) {
    report_->Skip("composite video", fmt::format("frames {}:{} are a shard of {}: `mr-eval merge` writes the video "
                                                 "from every shard's frames",
                                                 in_.begin, in_.end, n_frames_));
  } else if (frames_->is_video()) {
    video_out_ = std::make_unique<VideoWriter>(video_path_, in_.camera.width(), in_.camera.height(), frames_->fps());
  }
  if (frames_->is_video()) report_->SetMetric("plate_fps", frames_->fps());  // mr-eval merge's video
  if (!decoding_.photograph)
    report_->Skip("photograph",
                  "the scene names no camera frames: I_c is the rendered real scene I_r (synthetic composite)");
}

// The world where it changes during the video (render/world.h), brought to
// the first frame rendered, and the method's view-independent work.  With no
// virtual object nothing can differ from the photograph: frames are copied
// through without rendering (I_m - I_r = 0 exactly; tested).
void RenderJob::PrepareWorldAndMethod() {
  world_.emplace(scene_, rs_, in_.begin);
  if (resumed_end_ > in_.begin && resumed_end_ < in_.end) world_->Advance(resumed_end_, &rs_);
  copy_through_ = !world_->dynamic() && !rs_.has_virtual() && decoding_.photograph;
  if (!world_->dynamic() && !rs_.has_virtual())
    report_->Skip("virtual objects", "the scene has none: the composite is the photograph");
  ReportAssetApproximations();
  if (copy_through_) {
    report_->Skip("rendering",
                  "no virtual object can change any frame: frames are copied through from the photographs");
    return;
  }
  // Only over several frames of a plate: one frame has no motion to swim against.
  if (decoding_.photograph && !scene_.virtuals.empty()) {
    if (in_.end - resumed_end_ > 1)
      swim_.emplace(scene_, in_.camera);
    else
      report_->Skip("the objects' swim against the plate", "one frame rendered: no motion between frames to measure");
  }
  const JobContext job = JobAt(resumed_end_);
  if (info_.prepare_timing.empty()) {
    method_->Prepare(job);
  } else {
    ScopedTimer t(report_, info_.prepare_timing);
    method_->Prepare(job);
  }
  CheckCrossings(resumed_end_, nullptr);
}

// What an asset's materials bring that this method does not render yet
// (issue 38), per object.
void RenderJob::ReportAssetApproximations() {
  for (size_t i = 0; i < scene_.virtuals.size(); ++i) {
    const SceneVirtual& v = scene_.virtuals[i];
    if (!v.file_materials) continue;
    const uint32_t id = rs_.virtual_ids().at(i);
    report_->SetMetric("assets." + v.name + ".textures", rs_.asset_textures(id));
    report_->SetMetric("assets." + v.name + ".texture_bytes", rs_.asset_texture_bytes(id));
    report_->Skip(fmt::format("virtual object \"{}\": its occlusion textures", v.name),
                  "occlusion textures are baked ambient occlusion, which a path tracer computes");
    if (scene_.render.method != "pt")
      report_->Skip(fmt::format("virtual object \"{}\": its materials' lobes apart", v.name),
                    fmt::format("method {} takes their diffuse albedo per point and the object's mean metallic lobe "
                                "where it treats the lobes apart, and its cached or gathered diffuse light ignores "
                                "transmission (pt renders them whole)",
                                scene_.render.method));
  }
}

// An object passing through a real surface renders, but is rarely meant.
void RenderJob::CheckCrossings(int f, const std::vector<std::string>* moved) {
  for (size_t i = 0; i < scene_.virtuals.size(); ++i) {
    const std::string& name = scene_.virtuals[i].name;
    if (moved && std::find(moved->begin(), moved->end(), name) == moved->end()) continue;
    if (const int64_t n = rs_.RealCrossings(i); n > 0) {
      const std::string w = fmt::format(
          "frame {}: virtual object \"{}\" passes through real geometry ({} of its edges cross a real surface)", f,
          name, n);
      report_->Warn(w);
    }
  }
}

// Neighbouring frames' plates for reflections the frame's own does not see
// (the frames f +- k step), read in increasing order by their own reader and
// kept while in reach; and what the camera's shutter and lens leave out.
void RenderJob::SetUpNeighbourPlates() {
  neighbours_ = scene_.render.plate_neighbours;
  step_ = scene_.render.plate_neighbour_step;
  const bool takes = !copy_through_ && decoding_.photograph && method_->TakesPlateReflections();
  use_neighbours_ = takes && neighbours_ > 0 && n_frames_ > 1;
  if (takes && !use_neighbours_)
    report_->Skip("plate neighbours", neighbours_ == 0 ? "render.plate_neighbours is 0: reflections take the frame's "
                                                         "own plate only"
                                                       : "the scene has one frame");
  if (use_neighbours_) neighbour_frames_.emplace(scene_, in_.camera, decoding_);
  if (scene_.camera.shutter <= 0) report_->Skip("motion blur", "camera.shutter is 0 (or not given)");
  if (scene_.camera.aperture_radius <= 0) report_->Skip("depth of field", "camera.lens is not given: a pinhole");
}

// Where the objects cover the frame, a reference made with the same objects
// differs from the plate by more than the light they send the room (which
// changes the whole room a little): the share of the mask where a channel
// of the reference differs from the plate's by over 10 %, and a warning
// below one half (the objects moved, or were rescaled, since the reference
// was made; its error figures then compare two different scenes).
void RenderJob::CheckMaskAgainstReference(int f, const Image& mask, const Image& ref, const Image& photo, Json* fj) {
  int64_t covered = 0, inside = 0, changed_pixels = 0;
  for (int y = 0; y < mask.height(); ++y)
    for (int x = 0; x < mask.width(); ++x) {
      bool c = false;
      for (int k = 0; k < 3; ++k)
        c = c || std::abs(ref.at(x, y, k) - photo.at(x, y, k)) > 0.1f * (std::abs(photo.at(x, y, k)) + 1e-3f);
      changed_pixels += c;
      if (!(mask.at(x, y, 0) > 0)) continue;
      ++covered;
      inside += c;
    }
  if (covered == 0) return;
  const double share = static_cast<double>(inside) / static_cast<double>(covered);
  (*fj)["mask_in_reference_change"] = share;
  if (share < 0.5)
    report_->Warn(fmt::format(
        "frame {}: only {:.0f} % of the objects' mask ({} pixels) lies where the reference differs from the plate "
        "by over 10 % ({} pixels): the objects are not where they were when the reference was made (moved or "
        "rescaled?), so its "
        "error figures compare two different scenes",
        f, 100 * share, covered, changed_pixels));
}

// A frame's error against the reference (over the region the objects
// change, where the plate is known) and its flicker against the frame
// before, into fj.
FrameError RenderJob::Measure(int f, const Image& composite, const Image& ref, const std::optional<Image>& region,
                              Json* fj) {
  const FrameError e = MeasureFrame(composite, ref, region ? &*region : nullptr);
  (*fj)["rmse"] = e.rmse;
  (*fj)["relmse"] = e.relmse;
  (*fj)["region_relmse"] = e.region_relmse;
  if (previous_ && previous_->frame == f - 1) {
    std::optional<Image> both;
    if (region && previous_->region) {
      both = *region;
      for (size_t i = 0; i < both->values().size(); ++i)
        both->values()[i] = std::max(both->values()[i], previous_->region->values()[i]);
    }
    const double flicker =
        MeasureFlicker(composite, previous_->composite, ref, previous_->reference, both ? &*both : nullptr);
    (*fj)["flicker"] = flicker;
    flicker_sum_ += flicker;
    ++flicker_frames_;
  }
  previous_ = PreviousFrame{f, composite, ref, region};
  return e;
}

// The frames --resume kept: into the video and the error figures as if
// rendered now.
void RenderJob::ReplayResumedFrames() {
  const PhotoEncoding video_encoding{true, Transfer::kSrgb, PixelType::kUint8};
  for (int f = in_.begin; f < resumed_end_; ++f) {
    Json fj = {{"frame", f}, {"resumed", true}};
    if (video_out_ || reference_) {
      const Image composite = ReadImage(out_dir_ / fmt::format("{:05d}.exr", f)).Layer("composite");
      if (video_out_) video_out_->WriteCodes(decoding_.ToCodes(composite, video_encoding));
      if (reference_) {
        const Image ref = ReadReferenceFrame(FramePath(*reference_, f), in_.camera.width(), in_.camera.height());
        // The plate, read in order (a video reads forwards), for the region.
        PhotoEncoding encoding;
        const std::optional<Image> photo = frames_->Photo(f, &encoding);
        std::optional<Image> region;
        if (photo) region = ChangedRegion(ref, *photo);
        Measure(f, composite, ref, region, &fj);
      }
    }
    frames_json_.push_back(fj);
  }
}

// The frame's world (light and objects) and what the method rebuilt for it;
// JSON null when the world never changes.
Json RenderJob::AdvanceWorld(Frame* fr) {
  if (!world_->dynamic()) return Json();
  const int f = fr->f;
  const WorldChange wc = world_->Advance(f, &rs_);
  std::vector<std::string> rebuilt;
  if (wc.any() && f > resumed_end_) {
    ScopedTimer t(report_, "world update");
    Timed(fr, [&] {
      if (scene_.render.world_update == "rebuild") {
        method_->Prepare(JobAt(f));
        rebuilt = {"everything (render.world_update is rebuild)"};
      } else {
        rebuilt = method_->WorldChanged(JobAt(f), wc);
      }
    });
    spdlog::info("frame {}: {} changed: {}", f, wc.Describe(),
                 rebuilt.empty() ? std::string("nothing to rebuild") : fmt::format("{}", fmt::join(rebuilt, ", ")));
  }
  (wc.any() ? world_changed_ : world_kept_) += f > resumed_end_;
  if (!wc.moved.empty() && f > resumed_end_) CheckCrossings(f, &wc.moved);
  Json world_json = wc.ToJson();
  world_json["rebuilt"] = rebuilt;
  for (const std::string& n : wc.notes) report_->Warn(n);
  return world_json;
}

// The frame's photograph, reference and changed region, and the plates its
// reflections take the room from.
void RenderJob::LoadPlates(Frame* fr) {
  const int f = fr->f;
  Image codes;
  fr->photo = frames_->Photo(f, &fr->encoding, decoding_.ocio_decode ? &codes : nullptr);
  if (decoding_.ocio_decode && fr->photo) fr->codes = std::move(codes);
  if (reference_) fr->ref = ReadReferenceFrame(FramePath(*reference_, f), in_.camera.width(), in_.camera.height());
  if (fr->photo && !fr->copy) fr->plate = DecodePlate(decoding_.ForFrame(f), *fr->photo, fr->encoding);
  if (fr->plate && method_->TakesPlateReflections())
    fr->plates.push_back(ViewOf(*fr->plate, in_.camera, in_.poses[static_cast<size_t>(f)]));
  if (fr->plate && use_neighbours_) AddNeighbourPlates(fr);
  if (fr->ref && fr->photo) fr->region = ChangedRegion(*fr->ref, *fr->photo);
  AddProbes(fr);
}

// lighting.probes' own maps (one file each: read and checked before
// anything is written; patterns: per frame), and what the method does with
// them.
void RenderJob::LoadProbes() {
  const std::vector<SceneLighting::Probe>& probes = scene_.lighting.probes;
  for (const SceneLighting::Probe& pr : probes)
    if (pr.map && !pr.map_per_frame) (void)ProbeMap(*pr.map);
  if (probes.empty()) return;
  report_->SetMetric("probes", static_cast<int64_t>(probes.size()));
  const std::string m = method_name_;
  if (m == "vpl")
    report_->Skip("the probes' radiance on vpl's diffuse light",
                  "vpl takes the room's radiance from the probes on the glossy rays it traces from virtual surfaces; "
                  "its diffuse light renders the room (pt and ic take the room's own light everywhere)");
  else if (m != "pt" && m != "ic")
    report_->Skip("the probes' radiance", m + " renders the room's light; pt, ic and vpl take it from the probes");
}

// A probe's map, read once (kept while frames use it).
const EnvironmentMap& RenderJob::ProbeMap(const fs::path& file) {
  auto it = probe_maps_.find(file.string());
  if (it != probe_maps_.end()) return it->second;
  ImageReadOptions opt;
  opt.nonfinite = NonFinite::kAllow;  // EnvironmentMap names the first bad pixel itself
  return probe_maps_
      .emplace(file.string(), EnvironmentMap(ReadImage(file, opt), file.string(), scene_.lighting.environment_scale,
                                             scene_.lighting.world_from_env))
      .first->second;
}

// The probes where the light was captured: the room's own light
// (PlateView::probe), after the plates.
void RenderJob::AddProbes(Frame* fr) {
  const std::vector<SceneLighting::Probe>& probes = scene_.lighting.probes;
  MR_CHECK(fr->plates.size() + probes.size() <= kMaxPlateViews);
  std::set<std::string> used;
  for (const SceneLighting::Probe& pr : probes) {
    PlateView v;
    v.probe = &rs_.environment();
    if (pr.map) {
      fs::path file = *pr.map;
      if (pr.map_per_frame) {
        const std::optional<fs::path> p = PerFrameFile(*pr.map, fr->f, nullptr);
        if (!p) ThrowErrorAt(FileLoc{pr.map->string()}, "no probe map for frame {} or any frame before it", fr->f);
        file = *p;
      }
      v.probe = &ProbeMap(file);
      used.insert(file.string());
    }
    v.probe_centre = pr.at;
    fr->plates.push_back(v);
  }
  std::erase_if(probe_maps_, [&](const auto& kv) { return !used.count(kv.first); });
}

// The neighbours' plates, nearest first; a camera that did not move sees
// nothing new, and a plate without a gain has unknown units.
void RenderJob::AddNeighbourPlates(Frame* fr) {
  const int f = fr->f;
  const Rigid3& pose = in_.poses[static_cast<size_t>(f)];
  std::vector<int> wanted;
  for (int k = 1; k <= neighbours_; ++k)
    for (const int g : {f + k * step_, f - k * step_}) {
      if (g < 0 || g >= n_frames_) continue;
      if (SamePose(in_.poses[static_cast<size_t>(g)], pose)) {
        ++neighbours_still_;
        continue;
      }
      if (!decoding_.HasGain(g)) {
        ++neighbours_without_gain_;
        continue;
      }
      wanted.push_back(g);
    }
  std::erase_if(neighbour_plates_, [&](const auto& kv) { return kv.first < f - neighbours_ * step_; });
  std::vector<int> missing;
  for (int g : wanted)
    if (!neighbour_plates_.count(g)) missing.push_back(g);
  std::sort(missing.begin(), missing.end());  // a video reads forwards
  for (int g : missing) {
    PhotoEncoding e;
    const std::optional<Image> p = neighbour_frames_->Photo(g, &e);
    neighbour_plates_.emplace(g, DecodePlate(decoding_.ForFrame(g), *p, e));
  }
  for (int g : wanted)
    fr->plates.push_back(ViewOf(neighbour_plates_.at(g), in_.camera, in_.poses[static_cast<size_t>(g)]));
}

// The frame's renderer and its passes: all samples in one (one_pass), or 1,
// 1, 2, 4, ... with an error checkpoint after each, until spp or the time
// budget.  Null when the frame is copied through.
std::unique_ptr<FrameMethod> RenderJob::RunPasses(Frame* fr, const FrameContext& fc, const FrameDecoding& dec) {
  std::unique_ptr<FrameMethod> fm;
  if (!fr->copy) {
    ScopedTimer t(report_, "render");
    Timed(fr, [&] { fm = method_->NewFrame(fc); });
  }
  const AdaptiveSampling adaptive{scene_.render.adaptive_threshold, scene_.render.adaptive_min_spp};
  if (fm && adaptive.on() && !fm->SetAdaptive(adaptive) && fr->f == resumed_end_)
    report_->Skip("adaptive sampling",
                  fmt::format("render.method {} has no per-pixel sample loop to stop", scene_.render.method));
  const Image* photo_ptr = fr->photo ? &*fr->photo : nullptr;
  Progress progress(fmt::format("frame {}", fr->f), spp_);
  double seconds = 0;
  while (fm && fr->done < spp_) {
    const int n = info_.one_pass ? spp_ : std::min(fr->done == 0 ? 1 : fr->done, spp_ - fr->done);
    {
      ScopedTimer t(report_, "render");
      Timed(fr, [&] { fm->RenderPass(n); });
    }
    fr->done += n;
    progress.Update(fr->done);
    seconds = fr->seconds;
    if (fr->ref)
      errors_.Checkpoint(
          seconds, fr->done,
          MeasureFrame(dec.Compose(*fm, photo_ptr).composite, *fr->ref, fr->region ? &*fr->region : nullptr));
    if (budget_ > 0 && seconds >= budget_) {
      report_->Warn(fmt::format("frame {}: time budget {} s reached at {} spp", fr->f, budget_, fr->done));
      break;
    }
  }
  progress.Done();
  fr->seconds = seconds;  // the method's time up to its last pass
  return fm;
}

// The composite and the layers beside it; a copied frame's are the
// photograph's.
RenderJob::FrameImages RenderJob::Compose(const Frame& fr, FrameMethod* fm, const FrameDecoding& dec) {
  FrameImages im;
  if (!fm) {
    im.cr.composite = decoding_.ToRadiance(*fr.photo);
    im.cr.difference = Image::Rgb(in_.camera.width(), in_.camera.height());
    im.cr.objects = Image::Rgba(in_.camera.width(), in_.camera.height());
    im.mixed = im.real = *fr.photo;
    im.mask = im.variance = im.samples = Image::Gray(in_.camera.width(), in_.camera.height());
    return im;
  }
  ScopedTimer t(report_, "composite");
  im.cr = dec.Compose(*fm, fr.photo ? &*fr.photo : nullptr);
  im.mixed = fm->Mixed();
  im.real = fm->Real();
  im.mask = fm->Mask();
  if (fr.plate && fr.plate->clipped_rgb) {
    // Clipped plate channels keep their codes under a change their unknown
    // excess hides (composite.h).
    const ClippedChannels k =
        KeepClippedChannels(dec.ToRadiance(*fr.photo), *fr.plate->clipped_rgb, im.mask, &im.cr.composite);
    im.clipped_kept = k.kept;
    im.clipped_changed = k.changed;
  }
  im.variance = fm->DifferenceVariance();
  im.samples = fm->SampleCount();
  if (grain_) {
    // The plate's noise where the composite shows the render, added to the
    // codes and brought back to radiance: pixels the object does not cover
    // keep their values exactly.
    const Image codes0 = dec.ToCodes(im.cr.composite, fr.encoding);
    Image noisy = codes0;
    AddGrain(*grain_, im.mask, scene_.render.seed, fr.f, &noisy);
    const Image r0 = dec.FromCodes(codes0, fr.encoding), r1 = dec.FromCodes(noisy, fr.encoding);
    for (int y = 0; y < im.mask.height(); ++y)
      for (int x = 0; x < im.mask.width(); ++x)
        if (im.mask.at(x, y, 0) > 0)
          for (int c = 0; c < 3; ++c)
            im.cr.composite.at(x, y, c) = std::max(0.0f, im.cr.composite.at(x, y, c) + r1.at(x, y, c) - r0.at(x, y, c));
  }
  return im;
}

// The frame's files, its inputs key, its video frame and review sheet.  The
// 8-bit outputs go through the inverse of the frames' decoding: a pixel the
// object does not change keeps the plate's code value.
void RenderJob::WriteFrame(const Frame& fr, FrameImages* im) {
  ScopedTimer t(report_, "write");
  Image codes = decoding_.ToCodes(im->cr.composite, fr.encoding);
  if (fr.codes) KeepPlateCodes(*fr.photo, im->cr.composite, *fr.codes, &codes);
  const Image* photo_ptr = fr.photo ? &*fr.photo : nullptr;
  FrameLayers layers{&im->cr.composite,  &codes,        &im->mixed,   &im->real, &im->mask,
                     &im->cr.difference, &im->variance, &im->samples, photo_ptr, &im->cr.objects};
  WriteFrameFiles(out_dir_, fr.f, layers, fr.encoding, decoding_.CodesColorSpace(fr.encoding), scene_.output, o_.tool,
                  Provenance(fr.f), report_);
  // The frame's inputs key beside it (not in it: inputs that differ only in
  // their comments or paths still give the same frame's bytes).
  std::error_code key_ec;
  fs::create_directories(out_dir_ / ".mr-render", key_ec);
  WriteTextFile(out_dir_ / ".mr-render" / fmt::format("{:05d}.inputs", fr.f),
                fmt::format("{:016x}\n", InputsKey(fr.f)));
  if (video_out_) video_out_->WriteCodes(codes);
  if (scene_.output.review) {
    const Image plate_codes = decoding_.ToCodes(fr.photo ? decoding_.ToRadiance(*fr.photo) : im->real, fr.encoding);
    review_sheet_ = WriteReviewSheet(out_dir_, fr.f, plate_codes, codes, im->mask, fr.photo.has_value(), o_.tool,
                                     report_, fr.review_note);
  }
}

// One frame: its world, its plates, the passes, the composite, its figures
// and its files.  A frame whose objects cannot show (none, or enclosed away
// from the camera) is the photograph, copied through.
void RenderJob::RenderFrame(int f) {
  Frame fr;
  fr.f = f;
  const Rigid3& pose = in_.poses[static_cast<size_t>(f)];
  const Json world_json = AdvanceWorld(&fr);
  std::string enclosed;
  const bool no_virtual = !rs_.has_virtual();
  fr.copy = copy_through_ ||
            (decoding_.photograph && (no_virtual || rs_.VirtualEnclosedAwayFrom(pose.translation, &enclosed)));
  if (fr.copy && !copy_through_)
    report_->Skip(fmt::format("rendering frame {}", f),
                  (no_virtual ? std::string("no virtual object or light in this frame's world") : enclosed) +
                      ": I_m - I_r = 0 exactly, the photograph is copied through");
  const FrameDecoding dec = decoding_.ForFrame(f);
  LoadPlates(&fr);
  const CameraExposure exposure = FrameExposure(scene_, in_.poses, f);
  if (scene_.camera.shutter > 0 && !exposure.moves && !fr.copy) ++still_frames_;
  const FrameContext fc{.rs = rs_,
                        .camera = in_.camera,
                        .world_from_cam = pose,
                        .seed = scene_.render.seed,
                        .frame = f,
                        .photo_radiance = fr.plate ? &fr.plate->radiance : nullptr,
                        .photo_clipped = fr.plate && fr.plate->clipped ? &*fr.plate->clipped : nullptr,
                        .exposure = exposure,
                        .plates = fr.plates};
  std::unique_ptr<FrameMethod> fm = RunPasses(&fr, fc, dec);
  FrameImages im = Compose(fr, fm.get(), dec);
  clamped_ += im.cr.clamped_negative;
  const int64_t frame_nonfinite = fm ? fm->nonfinite_samples() : 0;
  nonfinite_ += frame_nonfinite;
  const int64_t env_pixels = fm ? fm->skipped_pixels() : 0;
  Json fj = {{"frame", f},
             {"gain", dec.gain},
             {"spp", fr.done},
             {"seconds", fr.seconds},
             {"clamped_negative", im.cr.clamped_negative},
             {"clipped_kept", im.clipped_kept},
             {"clipped_changed", im.clipped_changed},
             {"nonfinite_samples", frame_nonfinite},
             {"copied_through", !fm},
             {"environment_pixels_sampled_once", env_pixels}};
  if (!world_json.is_null()) fj["world"] = world_json;
  if (swim_ && fr.plate)
    if (Json sw = swim_->Frame(f, pose, fr.plate->radiance); !sw.is_null()) {
      for (const auto& [name, px] : sw.items())
        fr.review_note +=
            fmt::format("{}swim {} {:.1f} px", fr.review_note.empty() ? "" : ", ", name, px.get<double>());
      fj["swim_px"] = std::move(sw);
    }
  if (fm && scene_.render.adaptive_threshold > 0) {
    double total = 0;
    for (float c : im.samples.values()) total += c;
    fj["adaptive"] = {{"stopped_pixels", fm->adaptive_stopped()},
                      {"mean_spp", total / std::max<size_t>(1, im.samples.values().size())}};
  }
  if (env_pixels > 0 && fr.done > 1)
    report_->Skip(fmt::format("frame {}: {} pixels after the first sample", f, env_pixels),
                  "their camera rays provably meet no geometry (environment only): I_m - I_r = 0 exactly");
  if (fr.ref) fj["curve"] = errors_.EndFrame(Measure(f, im.cr.composite, *fr.ref, fr.region, &fj));
  if (fr.ref && fr.photo) CheckMaskAgainstReference(f, im.mask, *fr.ref, *fr.photo, &fj);
  if (fm) method_->FrameDone(*fm, fc, report_, &fj);
  frames_json_.push_back(fj);
  WriteFrame(fr, &im);
  spdlog::info("frame {}: {} spp in {:.2f} s{}", f, fr.done, fr.seconds,
               fr.ref ? fmt::format(", relMSE {:.3g}", fj["relmse"].get<double>()) : std::string());
}

// What the job skipped over all frames, the method's own summary, and the
// job's figures.
void RenderJob::Summarize() {
  if (swim_) {
    const Json sw = swim_->Summary();
    if (!sw.empty()) {
      report_->SetMetric("swim", sw);
      for (const auto& [name, v] : sw.items())
        spdlog::info("swim of \"{}\" against the plate: {:.2f} px RMS, {:.2f} px at most, over {} frame steps", name,
                     v["rms_px"].get<double>(), v["max_px"].get<double>(), v["frames"].get<int>());
    }
  }
  if (still_frames_ > 0)
    report_->Skip(fmt::format("motion blur in {} frames", still_frames_),
                  "the camera does not move over their shutter intervals: the blur is exactly none");
  if (world_->dynamic()) {
    report_->SetMetric("world", Json{{"frames_changed", world_changed_}, {"frames_kept", world_kept_}});
    if (world_kept_ > 0)
      report_->Skip(fmt::format("rebuilding in {} frames", world_kept_),
                    "their light (by content) and objects are the previous frame's: every cache, volume and VPL set "
                    "kept");
  }
  if (use_neighbours_) {
    report_->SetMetric("plate_neighbours", Json{{"count", neighbours_}, {"step", step_}});
    if (neighbours_still_ > 0)
      report_->Skip(fmt::format("{} neighbouring plates", neighbours_still_),
                    "taken from the frame's own pose: they see nothing the frame's plate does not");
    if (neighbours_without_gain_ > 0)
      report_->Skip(fmt::format("{} neighbouring plates without a gain", neighbours_without_gain_),
                    "camera.gains has no entry for them: their units are unknown");
  }
  method_->Finish(report_);
  if (video_out_) {
    video_out_->Close();
    report_->AddOutput(video_path_.string());
  }
  if (!review_sheet_.empty()) {
    report_->SetMetric("review_sheet", review_sheet_.string());
    spdlog::info("review sheet: {}", review_sheet_.string());
  }
  report_->SetMetric("method", method_name_);
  report_->SetMetric("frames", frames_json_);
  report_->SetMetric("clamped_negative", clamped_);
  report_->SetMetric("nonfinite_samples", nonfinite_);
  if (clamped_ > 0) report_->Warn(fmt::format("{} negative composite values clamped to 0", clamped_));
  if (errors_.frames() > 0) {
    report_->SetMetric("rmse", errors_.mean_rmse());
    report_->SetMetric("relmse", errors_.mean_relmse());
    report_->SetMetric("region_relmse", errors_.mean_region_relmse());
    report_->SetMetric("curve", errors_.MeanCurve());
  }
  if (flicker_frames_ > 0) report_->SetMetric("flicker", flicker_sum_ / flicker_frames_);  // kept frames too
}

}  // namespace

void RenderOptions::Check() const {
  if (!method.empty()) FindRenderMethod(method);
  if (spp < 0) throw UsageError(fmt::format("--spp {} must be positive", spp));
  if (frame_begin < -1 || frame_end < -1 || (frame_begin >= 0 && frame_end >= 0 && frame_begin >= frame_end))
    throw UsageError("--frames must be A:B with 0 <= A < B");
}

void RunRenderJob(const Scene& scene, const RenderOptions& o, Report* report) {
  o.Check();
  RenderJob job(scene, o, report);
  job.FindResumedFrames();
  job.EstimateGrain();
  job.OpenVideo();
  job.PrepareWorldAndMethod();
  job.SetUpNeighbourPlates();
  job.ReplayResumedFrames();
  job.RenderFrames();
  job.Summarize();
}

}  // namespace mr
