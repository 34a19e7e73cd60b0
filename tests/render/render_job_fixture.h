// The helpers and the shared synthetic capture of the render job's tests
// (render_job_test.cpp, render_job_plate_test.cpp, render_job_camera_test.cpp,
// render_job_world_test.cpp).
#pragma once

#include <gtest/gtest.h>
#include "render/render_job.h"

#include <algorithm>
#include <fstream>

#include "camera/camera_model.h"
#include "core/error.h"
#include "core/image.h"
#include "core/image_metrics.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "core/video.h"
#include "eval/plate_check.h"
#include "geometry/mesh.h"
#include "hdr/response.h"
#include "light/lights_file.h"
#include "render/composite.h"
#include "render/error_curve.h"
#include "render/frame_io.h"
#include "render/grain.h"
#include "render/prt.h"
#include "render/pt.h"
#include "render/render_scene.h"
#include "scene/frames.h"
#include "synth/synth.h"
#include "test_util.h"
#include "transfer/formfactor.h"

namespace mr::render_job_test {

inline double MeanOfValues(const Image& img) {
  double s = 0;
  for (float v : img.values()) s += v;
  return s / static_cast<double>(img.values().size());
}

inline std::string Bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Integer code values of an 8-bit image (PNG) or video frame.
inline std::vector<int> Codes(const Image& raw, double max = 255) {
  std::vector<int> c(raw.values().size());
  for (size_t i = 0; i < c.size(); ++i) c[i] = static_cast<int>(std::lround(raw.values()[i] * max));
  return c;
}
inline std::vector<int> PngCodes(const fs::path& p, double max = 255) {
  return Codes(ReadRgbForComparison(p, Transfer::kLinear, true), max);
}
inline std::vector<int> VideoCodes(const fs::path& p, int f) {
  Image img = VideoReader(p).Frame(f);
  for (float& v : img.values()) v = LinearToSrgb(v);
  return Codes(img);
}

// Of the channel values the object leaves untouched (difference 0, mask 0),
// how many there are and how many of them differ between the input and
// output code values.
inline std::pair<int64_t, int64_t> UntouchedCodes(const Image& diff, const Image& mask, const std::vector<int>& in,
                                                  const std::vector<int>& out) {
  int64_t kept = 0, moved = 0;
  for (int y = 0; y < diff.height(); ++y)
    for (int x = 0; x < diff.width(); ++x)
      for (int c = 0; c < 3; ++c)
        if (diff.at(x, y, c) == 0.0f && mask.at(x, y, 0) == 0.0f) {
          const size_t i = static_cast<size_t>((y * diff.width() + x) * 3 + c);
          ++kept;
          moved += in[i] != out[i];
        }
  return {kept, moved};
}

// One small synthetic capture shared by the tests of this file.
class Capture : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    // Made once for all of this file's test processes, then copied: the
    // tests write scene variants into their copy.
    const fs::path made = test::SharedFixture("render-job-capture", [](const fs::path& out) {
      SynthOptions o;
      o.out = out;
      o.truth_spp = 1024;  // truth noise is 1/128 of the 8-spp estimate's: negligible below
      Report r("mr-synth", "test");
      RunSynth(o, &r);
    });
    fs::copy(made, dir_->path() / "cap", fs::copy_options::recursive);
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path Cap() { return dir_->path() / "cap"; }
  inline static test::TempDir* dir_ = nullptr;

  // Scene variant `j` written as Cap()/NAME.json and rendered with `o` into
  // the temporary folder's NAME-METHOD (o.out_dir set); `r` receives the report.
  static fs::path RenderVariant(const Json& j, const std::string& name, RenderOptions o, Report* r) {
    WriteTextFile(Cap() / (name + ".json"), j.dump(2));
    o.out_dir = dir_->path() / (name + "-" + (o.method.empty() ? std::string("scene") : o.method));
    RunRenderJob(ReadScene(Cap() / (name + ".json")), o, r);
    return o.out_dir;
  }

  // Frame 0 of `s` at `spp` samples per pixel into the temporary folder's
  // NAME; `r` receives the report. Returns the frame's EXR (every layer).
  static Image RenderFirstFrame(const Scene& s, int spp, const std::string& name, Report* r) {
    RenderOptions o;
    o.spp = spp;
    o.frame_end = 1;
    o.out_dir = dir_->path() / name;
    RunRenderJob(s, o, r);
    return ReadImage(o.out_dir / "00000.exr");
  }

  Report Render(int spp, const fs::path& out, int threads = 0) {
    Scene s = ReadScene(Cap() / "scene.json");
    RenderOptions o;
    o.spp = spp;
    o.frame_begin = 0;
    o.frame_end = 1;
    o.out_dir = out;
    Report r("mr-render", "test");
    SetThreadCount(threads);
    RunRenderJob(s, o, &r);
    SetThreadCount(0);
    return r;
  }
};

// The small capture with a diffuse table top (no caustic paths), one frame,
// truth at 256 spp: made once for all of this file's test processes.
inline fs::path DiffuseTableCapture() {
  return test::SharedFixture("render-job-capture-diffuse-table", [](const fs::path& out) {
    SynthOptions o;
    o.out = out;
    o.frames = 1;
    o.truth_spp = 256;
    o.table_top = "diffuse";
    o.probe = false;
    Report r("mr-synth", "test");
    RunSynth(o, &r);
  });
}

// Unbiased: the composite's relMSE against the truth falls as 1/spp.  Over
// three doublings (1 -> 8 spp) the ideal ratio is 8; 5 leaves room for noise
// in the estimate of the error itself and the truth's own noise (at 256 spp,
// 1/32 of the 8-spp estimate's).  On the capture with a diffuse table top:
// the glossy one's caustic paths (the sun reflected by the table onto the
// room) are rare samples thousands of times a pixel's mean, and one drawn
// between 2 and 8 spp made the error rise (issue 22, docs/methods.md).
}  // namespace mr::render_job_test
