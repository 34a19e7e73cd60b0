// The interface every rendering method implements, and the registry that is
// the one list of methods (docs/architecture.md, "How to add a render method").
//
// A method has two parts:
//  - RenderMethod, one per job: parses its settings from the scene's
//    render.<name> block, does the view-independent work once (Prepare:
//    VPLs, volumes, a cache, vertex shading), makes a FrameMethod per frame
//    and reports what each frame did;
//  - FrameMethod, one per frame: renders I_m, I_r and the mask M
//    progressively (RenderPass adds samples to every pixel).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/image.h"
#include "core/json.h"
#include "core/json_node.h"
#include "core/json_settings.h"
#include "core/report.h"
#include "render/camera_sampler.h"
#include "render/pixel_accumulator.h"
#include "render/plate_view.h"
#include "scene/scene.h"

namespace mr {

class RenderScene;

// What every rendering method produces for a frame, progressively.
class FrameMethod {
 public:
  virtual ~FrameMethod() = default;
  virtual void RenderPass(int spp) = 0;
  virtual Image Mixed() const = 0;               // mean I_m, RGB
  virtual Image Real() const = 0;                // mean I_r, RGB
  virtual Image Mask() const = 0;                // fraction of camera samples whose first hit is virtual, "Y"
  virtual Image DifferenceVariance() const = 0;  // variance of the mean of luminance(I_m - I_r), "Y"
  virtual Image SampleCount() const = 0;         // samples per pixel, "Y"
  virtual int64_t nonfinite_samples() const { return 0; }
  virtual int64_t skipped_pixels() const { return 0; }
  // Adaptive sampling for the passes to come (pixel_accumulator.h); false
  // where the method has no per-pixel loop to stop.
  virtual bool SetAdaptive(const AdaptiveSampling&) { return false; }
  // Pixels adaptive sampling stopped so far.
  virtual int64_t adaptive_stopped() const { return 0; }
};

// What a job knows before its first frame.
struct JobContext {
  const Scene& scene;
  const RenderScene& rs;
  const CameraModel& camera;
  int spp = 0;
  int frame_begin = 0;
  bool photograph = false;  // the scene names camera frames (I_c is given)
  Report* report = nullptr;
  int frame = 0;  // the frame whose world `rs` holds (render/world.h)
};

struct WorldChange;  // render/world.h

// One frame to render.
struct FrameContext {
  const RenderScene& rs;
  const CameraModel& camera;
  const Rigid3& world_from_cam;
  uint64_t seed = 0;
  int frame = 0;
  // The frame's photograph as linear radiance (prt's background); null when
  // the scene names no frames.
  const Image* photo_radiance = nullptr;
  // One channel, > 0 where the photograph clipped (a code at the top of its
  // range); null: none, or float frames.
  const Image* photo_clipped = nullptr;
  // The shutter interval and lens the frame's samples spread over (none by
  // default); every method takes its camera rays from it (CameraSampler).
  CameraExposure exposure = {};
  // The plates reflections may take the room from: this frame's (from
  // photo_radiance and photo_clipped), then its neighbours' nearest first
  // (render.plate_neighbours), each in the render's units at its own gain;
  // empty when the scene names no frames or the method takes no plate.
  PlateViews plates = {};
};

class RenderMethod {
 public:
  virtual ~RenderMethod() = default;
  // View-independent work, once per job, timed as prepare_timing() (never
  // called when no frame is rendered).
  virtual void Prepare(const JobContext& job) { (void)job; }
  virtual std::unique_ptr<FrameMethod> NewFrame(const FrameContext& frame) = 0;
  // After a frame: its counters and skipped parts into the report and the
  // frame's entry of the report's "frames".
  virtual void FrameDone(const FrameMethod& f, const FrameContext& frame, Report* report, Json* frame_json) {
    (void)f, (void)frame, (void)report, (void)frame_json;
  }
  // After the last frame.
  virtual void Finish(Report* report) { (void)report; }
  // The world changed before frame job.frame (the light, or objects
  // moved; `rs` already holds the new one): brings the view-independent
  // work up to date and returns what was rebuilt, for the report.  By
  // default Prepare again.
  virtual std::vector<std::string> WorldChanged(const JobContext& job, const WorldChange& change) {
    (void)change;
    Prepare(job);
    return {"everything Prepare builds"};
  }
  // Whether FrameContext::plates is looked at (the job then reads the
  // neighbouring frames' plates too).
  virtual bool TakesPlateReflections() const { return false; }
};

// A method's settings struct with the scene's generic render settings
// (render.max_depth, render.seed) filled in.
template <class Settings>
Settings WithSceneRender(Settings s, const Scene& scene) {
  s.max_depth = scene.render.max_depth;
  s.seed = scene.render.seed;
  return s;
}

// A RenderMethod that keeps the settings it was made with.
template <class Settings>
class SettingsMethod : public RenderMethod {
 public:
  explicit SettingsMethod(const Settings& settings) : st_(settings) {}

 protected:
  Settings st_;
};

struct MethodInfo {
  std::string name;     // scene.json render.method, mr-render --method
  std::string summary;  // one line, for --help and docs
  // The method shades virtual objects from their precomputed form factors
  // (virtual[i].formfactors): mr-pipeline plans the formfactor stage for it.
  bool uses_formfactors = false;
  // In mr-eval sweep's default --methods (a method that does not render the
  // objects' light on the room is not comparable on the same error).
  bool default_sweep = true;
  // Frames take all their samples in one pass (their per-frame work is not
  // progressive); otherwise passes of 1, 1, 2, 4, ... samples, with an
  // error-curve checkpoint after each.
  bool one_pass = false;
  // The report's timing key of Prepare ("" when the method prepares nothing).
  std::string prepare_timing;
  // mr-eval sweep's default settings: key -> values, the i-th setting taking
  // the i-th value of each (one value: the same for all); "spp" is the
  // render's samples per pixel, other keys are render.<name> keys.
  std::vector<std::pair<std::string, std::vector<Json>>> sweep;
  // Reads the method's settings from `block` (the scene's render.<name>
  // object, or an empty one), each key once (JsonSettings: bad values fail
  // with the key path), and makes the job's method. Called through
  // CreateRenderMethod, which then rejects the keys nothing read.
  std::function<std::unique_ptr<RenderMethod>(JsonSettings& block, const Scene& scene)> create;
};

// Every method, in the order docs and --help list them.
const std::vector<MethodInfo>& RenderMethodRegistry();
// The methods mr-eval sweep renders unless told (MethodInfo::default_sweep).
std::vector<std::string> DefaultSweepMethods();
// "pt, ic, vpl, vct, prt".
std::string RenderMethodNames();
// The method called `name`; a UsageError naming the valid ones otherwise.
const MethodInfo& FindRenderMethod(std::string_view name);
// Checks the scene's render.method and every render.<method> block by
// parsing each with its method: errors name the scene file and key.
void CheckRenderSettings(const Scene& scene);
// The job's method `name` (empty: the scene's), settings from the scene.
std::unique_ptr<RenderMethod> CreateRenderMethod(const Scene& scene, const std::string& name);
// Method `m` with its settings read from `block` (render.<name> of `scene`):
// unknown keys and bad values fail naming the block's file and key path.
std::unique_ptr<RenderMethod> CreateRenderMethod(const MethodInfo& m, const JsonNode& block, const Scene& scene);
// The settings method `m` declares in its render.<name> block, with their
// defaults and ranges, in the order it reads them (docs/formats.md lists them).
std::vector<SettingDecl> RenderMethodSettings(const MethodInfo& m);

}  // namespace mr
