// Every options struct a tool fills checks itself (Check()): a bad flag is a
// UsageError (exit 2) naming the flag, raised before any file is read; the
// defaults with the required fields given pass.
#include <gtest/gtest.h>

#include <string>

#include "calib/calibrate_job.h"
#include "camera/register.h"
#include "core/error.h"
#include "eval/plate_check.h"
#include "eval/shards.h"
#include "eval/sweep.h"
#include "jobs/eval_jobs.h"
#include "jobs/formfactor_job.h"
#include "jobs/probe_job.h"
#include "jobs/register_job.h"
#include "render/render_job.h"
#include "synth/synth.h"
#include "transfer/formfactor.h"

namespace mr {
namespace {

// Runs `check`, expecting a UsageError whose message holds `flag`.
template <class F>
void ExpectUsageError(F check, const std::string& flag) {
  try {
    check();
    ADD_FAILURE() << "no UsageError for " << flag;
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find(flag), std::string::npos) << e.what();
  }
}

TEST(OptionsCheck, RenderOptions) {
  RenderOptions o;
  EXPECT_NO_THROW(o.Check());
  o.method = "raytrace";
  ExpectUsageError([&] { o.Check(); }, "raytrace");
  o.method = "ic";
  o.frame_begin = 4, o.frame_end = 2;
  ExpectUsageError([&] { o.Check(); }, "--frames");
}

TEST(OptionsCheck, SynthOptions) {
  SynthOptions o;
  o.out = "capture";
  EXPECT_NO_THROW(o.Check());
  o.lens = "fisheye";
  ExpectUsageError([&] { o.Check(); }, "lens");
  o.lens = "pinhole";
  o.truth_spp = 15, o.truth_region_spp = 64;  // the truth's halves need even counts
  ExpectUsageError([&] { o.Check(); }, "--truth-region-spp");
  o.truth_spp = 128;
  ExpectUsageError([&] { o.Check(); }, "--truth-region-spp");  // below the truth's
  o.out.clear();
  o.truth_region_spp = 0;
  ExpectUsageError([&] { o.Check(); }, "--out");
}

TEST(OptionsCheck, TransferAndFormfactorJob) {
  TransferOptions t;
  EXPECT_NO_THROW(t.Check());
  t.order = 9;
  ExpectUsageError([&] { t.Check(); }, "--order");
  FormfactorJobOptions f;
  f.mesh = "object.ply", f.out = "object.ffc";
  EXPECT_NO_THROW(f.Check());
  f.shade = "env.exr";
  ExpectUsageError([&] { f.Check(); }, "--ffc");
  f.shade.clear();
  f.scene = "scene.json";
  ExpectUsageError([&] { f.Check(); }, "--object");
}

TEST(OptionsCheck, RegistrationAndColmap) {
  RegisterOptions r;
  EXPECT_NO_THROW(r.Check());
  r.mesh = Mesh{};
  ExpectUsageError([&] { r.Check(); }, "--initial");
  ColmapRunOptions c;
  EXPECT_NO_THROW(c.Check());
  c.matcher = "vocabulary";
  ExpectUsageError([&] { c.Check(); }, "vocabulary");
  RegisterJobOptions j;
  j.model_dir = "sparse", j.out = "poses.txt";
  EXPECT_NO_THROW(j.Check());
  j.initial = std::vector<double>(16, 0.0);  // not a similarity
  ExpectUsageError([&] { j.Check(); }, "--initial");
}

TEST(OptionsCheck, CalibrationJobs) {
  CalibrationOptions c;
  EXPECT_NO_THROW(c.Check());
  c.lensmodel = "LENSMODEL_NONE";
  ExpectUsageError([&] { c.Check(); }, "LENSMODEL_NONE");
  RigJob rig;
  rig.cameras = {"a=left/*.png", "a=right/*.png"};
  ExpectUsageError([&] { rig.Check(); }, "given twice");
  SphereJob sphere;
  sphere.images = {"sphere.exr"};
  sphere.options.radius_m = 0.05;
  EXPECT_NO_THROW(sphere.Check());
  sphere.world_board = "board.png";
  ExpectUsageError([&] { sphere.Check(); }, "--board");
}

TEST(OptionsCheck, ProbeJob) {
  ProbeJobOptions o;
  o.photos = {"probe.exr"};
  o.probes = {"probe.json"};
  o.out = "env.exr";
  EXPECT_NO_THROW(o.Check());
  o.fisheye = "light.cameramodel";
  ExpectUsageError([&] { o.Check(); }, "--fisheye");
  o.fisheye.clear();
  o.sequence.light = "lightcam/frames.txt";
  ExpectUsageError([&] { o.Check(); }, "contradict");
}

TEST(OptionsCheck, EvalJobs) {
  PlateCheckOptions p;
  p.out = "plate";
  EXPECT_NO_THROW(p.Check());
  p.smoothing.jump_ratio = 1;
  ExpectUsageError([&] { p.Check(); }, "--jump-ratio");
  SweepJobOptions s;
  s.sweep.out = "sweep";
  s.methods = "pt,vct";
  EXPECT_NO_THROW(s.Check());
  s.frames = "x:y";
  ExpectUsageError([&] { s.Check(); }, "--frames");
  ShardMergeOptions m;
  ExpectUsageError([&] { m.Check(); }, "no shard reports");
}

}  // namespace
}  // namespace mr
