#include "render/render_job.h"

#include <gtest/gtest.h>

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

namespace mr {
namespace {

double MeanOfValues(const Image& img) {
  double s = 0;
  for (float v : img.values()) s += v;
  return s / static_cast<double>(img.values().size());
}

std::string Bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Integer code values of an 8-bit image (PNG) or video frame.
std::vector<int> Codes(const Image& raw, double max = 255) {
  std::vector<int> c(raw.values().size());
  for (size_t i = 0; i < c.size(); ++i) c[i] = static_cast<int>(std::lround(raw.values()[i] * max));
  return c;
}
std::vector<int> PngCodes(const fs::path& p, double max = 255) {
  return Codes(ReadRgbForComparison(p, Transfer::kLinear, true), max);
}
std::vector<int> VideoCodes(const fs::path& p, int f) {
  Image img = VideoReader(p).Frame(f);
  for (float& v : img.values()) v = LinearToSrgb(v);
  return Codes(img);
}

// Of the channel values the object leaves untouched (difference 0, mask 0),
// how many there are and how many of them differ between the input and
// output code values.
std::pair<int64_t, int64_t> UntouchedCodes(const Image& diff, const Image& mask, const std::vector<int>& in,
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
  static test::TempDir* dir_;

  // Scene variant `j` written as Cap()/NAME.json and rendered with `o` into
  // the temporary folder's NAME-METHOD (o.out_dir set); `r` receives the report.
  static fs::path RenderVariant(const Json& j, const std::string& name, RenderOptions o, Report* r) {
    WriteTextFile(Cap() / (name + ".json"), j.dump(2));
    o.out_dir = dir_->path() / (name + "-" + (o.method.empty() ? std::string("scene") : o.method));
    RunRenderJob(ReadScene(Cap() / (name + ".json")), o, r);
    return o.out_dir;
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
test::TempDir* Capture::dir_ = nullptr;

// The small capture with a diffuse table top (no caustic paths), one frame,
// truth at 256 spp: made once for all of this file's test processes.
fs::path DiffuseTableCapture() {
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
TEST_F(Capture, RelativeErrorFallsAsOneOverSpp) {
  const fs::path made = DiffuseTableCapture();
  RenderOptions o;
  o.spp = 8;
  o.out_dir = dir_->path() / "r8";
  Report r("mr-render", "test");
  RunRenderJob(ReadScene(made / "scene.json"), o, &r);
  const Json& curve = r.metrics()["curve"];
  ASSERT_EQ(curve.size(), 4u);  // checkpoints at 1, 2, 4, 8 spp
  for (size_t k = 0; k < 4; ++k) EXPECT_EQ(curve[k]["spp"], 1 << k);
  const double r1 = curve[0]["relmse"], r8 = curve[3]["relmse"];
  EXPECT_GT(r1 / r8, 5.0) << r1 << " " << r8;
  EXPECT_LT(r1 / r8, 12.0) << r1 << " " << r8;
  for (size_t k = 1; k < 4; ++k) EXPECT_LT(curve[k]["relmse"].get<double>(), curve[k - 1]["relmse"].get<double>());
  EXPECT_GT(r.metrics()["region_relmse"].get<double>(), 0.0);
}

// Adaptive sampling stops pixels without losing the object's change: on
// the diffuse-table capture (pt, 32 spp, threshold 3e-3 from 8 spp) the
// object's total change over the image (composite - plate, summed) is the
// uniform render's within 1% (stopping pixels whose differences were all
// zero by chance lost 6% on the medium capture, docs/methods.md), and the
// report says how many pixels stopped and the mean samples they took.
TEST_F(Capture, AdaptiveSamplingKeepsTheObjectsTotalChange) {
  const fs::path made = DiffuseTableCapture();
  const fs::path cap = dir_->path() / "adaptive-cap";
  fs::copy(made, cap, fs::copy_options::recursive);
  const Json j = Json::parse(ReadTextFile(cap / "scene.json"));
  const Image photo = ReadImage(cap / "photos" / "00000.exr");
  auto total_change = [&](const std::string& name, bool adaptive, Report* r) {
    Json v = j;
    v["render"]["spp"] = 32;
    if (adaptive) v["render"]["adaptive"] = {{"threshold", 3e-3}, {"min_spp", 8}};
    WriteTextFile(cap / (name + ".json"), v.dump(2));
    RenderOptions o;
    o.out_dir = dir_->path() / name;
    RunRenderJob(ReadScene(cap / (name + ".json")), o, r);
    const Image c = ReadImage(o.out_dir / "00000.exr").Layer("composite");
    double sum = 0;
    for (size_t i = 0; i < c.values().size(); ++i) sum += c.values()[i] - photo.values()[i];
    return sum;
  };
  Report ru("mr-render", "test"), ra("mr-render", "test");
  const double uniform = total_change("uniform", false, &ru), adaptive = total_change("adaptive", true, &ra);
  const Json& a = ra.metrics()["frames"][0]["adaptive"];
  ASSERT_TRUE(a.is_object());
  EXPECT_LE(a["mean_spp"].get<double>(), 32.0);
  EXPECT_GE(a["stopped_pixels"].get<int64_t>(), 0);
  EXPECT_FALSE(ru.metrics()["frames"][0].contains("adaptive"));
  ASSERT_GT(std::abs(uniform), 1.0);
  EXPECT_NEAR(adaptive / uniform, 1.0, 0.01) << adaptive << " against " << uniform << "; " << a.dump();
}

TEST_F(Capture, SameCommandSameBytesForAnyThreadCount) {
  Render(4, dir_->path() / "a", 1);
  Render(4, dir_->path() / "b", 2);
  Render(4, dir_->path() / "c", 2);
  const std::string a = Bytes(dir_->path() / "a" / "00000.exr");
  ASSERT_FALSE(a.empty());
  // EXPECT_TRUE, not EXPECT_EQ: gtest would print a quarter megabyte of bytes.
  EXPECT_TRUE(a == Bytes(dir_->path() / "b" / "00000.exr"));
  EXPECT_TRUE(a == Bytes(dir_->path() / "c" / "00000.exr"));
  EXPECT_TRUE(Bytes(dir_->path() / "a" / "00000.png") == Bytes(dir_->path() / "b" / "00000.png"));
}

TEST_F(Capture, TruthDiffersFromThePhotographOnlyWhereTheObjectActs) {
  Image photo = ReadImage(Cap() / "photos" / "00000.exr"), truth = ReadImage(Cap() / "truth" / "00000.exr");
  int64_t changed = 0;
  for (size_t i = 0; i < photo.values().size(); ++i) changed += photo.values()[i] != truth.values()[i];
  // The object, its shadow and its interreflections change pixels; every
  // path that meets the object diverges, so many pixels change a little.
  EXPECT_GT(changed, 30);
}

// Without virtual objects the composite is the photograph, bit for bit.
TEST_F(Capture, NoVirtualObjectsGiveThePhotographExactly) {
  Json j = ReadJsonFile(Cap() / "scene.json");
  j.erase("virtual");
  WriteTextFile(Cap() / "empty.json", j.dump());
  Scene s = ReadScene(Cap() / "empty.json");
  RenderOptions o;
  o.spp = 2;
  o.frame_end = 1;
  o.out_dir = dir_->path() / "empty";
  Report r("mr-render", "test");
  RunRenderJob(s, o, &r);
  Image out = ReadImage(dir_->path() / "empty" / "00000.exr");
  Image photo = ReadImage(Cap() / "photos" / "00000.exr");
  EXPECT_EQ(out.Layer("composite").values(), photo.values());
  bool skipped = false;
  for (const auto& sk : r.skipped()) skipped = skipped || sk["what"] == "rendering";
  EXPECT_TRUE(skipped);
  EXPECT_FALSE(r.ToJson()["timings"].contains("render"));  // nothing was rendered
  EXPECT_EQ(r.metrics()["frames"][0]["copied_through"], true);
}

// output.layers decides which layers a frame's EXR holds (it was validated
// and documented, but every layer was always written); by default all.
TEST_F(Capture, OutputLayersDecideWhatIsWritten) {
  Scene s = ReadScene(Cap() / "scene.json");
  EXPECT_EQ(s.output.layers, OutputLayers());
  RenderOptions o;
  o.spp = 1;
  o.frame_end = 1;
  for (const auto& [name, layers] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"all", OutputLayers()}, {"two", {"mask", "composite"}}}) {
    s.output.layers = layers;
    o.out_dir = dir_->path() / ("layers-" + name);
    Report r("mr-render", "test");
    RunRenderJob(s, o, &r);
    std::vector<std::string> got = ReadImage(o.out_dir / "00000.exr").LayerNames(), want = layers;
    std::sort(got.begin(), got.end());  // EXR keeps channels sorted by name
    std::sort(want.begin(), want.end());
    EXPECT_EQ(got, want);  // "all": the scene names photographs, so "photo" too
  }
}

// The object shut in a closed real cupboard: no path from the camera can
// reach it, so each frame is the photograph, copied through and reported.
TEST_F(Capture, ObjectInAClosedCupboardLeavesThePhotograph) {
  Mesh cupboard;
  const Eigen::Vector3f lo(-0.35f, 0.6f, -0.45f), hi(0.55f, 1.35f, 0.45f);
  for (int i = 0; i < 8; ++i)
    cupboard.positions.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  cupboard.triangles = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                        {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  WritePly(Cap() / "meshes" / "cupboard.ply", cupboard);
  Json j = ReadJsonFile(Cap() / "scene.json");
  j["real"].push_back({{"mesh", "meshes/cupboard.ply"}});
  WriteTextFile(Cap() / "cupboard.json", j.dump());
  RenderOptions o;
  o.spp = 2;
  o.frame_end = 1;
  o.out_dir = dir_->path() / "cupboard";
  Report r("mr-render", "test");
  RunRenderJob(ReadScene(Cap() / "cupboard.json"), o, &r);
  bool skipped = false;
  for (const auto& sk : r.skipped()) skipped = skipped || sk["what"] == "rendering frame 0";
  EXPECT_TRUE(skipped) << r.ToJson().dump();
  EXPECT_EQ(r.metrics()["frames"][0]["copied_through"], true);
  // The photograph here is of the room without the cupboard; what matters is
  // that it is passed through untouched.
  EXPECT_EQ(ReadImage(o.out_dir / "00000.exr").Layer("composite").values(),
            ReadImage(Cap() / "photos" / "00000.exr").values());
}

// prt: the object shaded from its transfer; outside the object the
// composite is the photograph, bit for bit (prt does not relight the room,
// and says so).
TEST_F(Capture, PrtShadesTheObjectAndLeavesTheRoom) {
  const Mesh object = ReadMesh(Cap() / "meshes" / "object.ply");
  TransferOptions to;
  TransferStats ts;
  WriteTransfer(Cap() / "object.ffc", ComputeTransfer(object, to, &ts));
  Json j = ReadJsonFile(Cap() / "scene.json");
  j["virtual"][0]["formfactors"] = "object.ffc";
  WriteTextFile(Cap() / "prt.json", j.dump());
  RenderOptions o;
  o.method = "prt";
  o.spp = 4;
  o.frame_end = 1;
  o.out_dir = dir_->path() / "prt";
  Report r("mr-render", "test");
  RunRenderJob(ReadScene(Cap() / "prt.json"), o, &r);
  const Image out = ReadImage(o.out_dir / "00000.exr");
  const Image photo = ReadImage(Cap() / "photos" / "00000.exr");
  const Image comp = out.Layer("composite"), mask = out.Layer("mask");
  int object_pixels = 0;
  for (int y = 0; y < photo.height(); ++y)
    for (int x = 0; x < photo.width(); ++x) {
      if (mask.at(x, y, 0) == 0) {
        for (int c = 0; c < 3; ++c) ASSERT_EQ(comp.at(x, y, c), photo.at(x, y, c));
      } else {
        ++object_pixels;
        EXPECT_GT(comp.at(x, y, 1), 0.0f);
      }
    }
  EXPECT_GT(object_pixels, 10);
  bool said = false;
  for (const auto& sk : r.skipped()) said = said || sk["what"] == "relighting of the real scene";
  EXPECT_TRUE(said);
  // Against the truth (which has the object's shadow on the table) prt is
  // worse than pt in the region the object changes, but not wildly so.
  EXPECT_LT(r.metrics()["region_relmse"].get<double>(), 0.5);

  // Without form factors: a usage error naming the object.
  j["virtual"][0].erase("formfactors");
  WriteTextFile(Cap() / "prt-none.json", j.dump());
  Report r2("mr-render", "test");
  try {
    RunRenderJob(ReadScene(Cap() / "prt-none.json"), o, &r2);
    ADD_FAILURE() << "prt without form factors was accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("needs form factors for virtual object \"object\""), std::string::npos)
        << e.what();
  }
}

// mr-formfactor --scene: vertices no camera sample sees are left out, and
// the prt render is bit-identical to one with every vertex computed.  A
// render that takes more samples than the .ffc was made for is refused.
TEST_F(Capture, PrtVertexSkippingChangesNothing) {
  const Mesh object = ReadMesh(Cap() / "meshes" / "object.ply");
  Json j = ReadJsonFile(Cap() / "scene.json");
  j["virtual"][0]["formfactors"] = "object-seen.ffc";
  j["render"]["frames"] = "0:1";
  WriteTextFile(Cap() / "prt-seen.json", j.dump());
  const Scene scene = ReadScene(Cap() / "prt-seen.json", false);
  int64_t frames = 0;
  const std::vector<char> seen = VerticesSeenByCamera(scene, "object", 4, &frames);
  EXPECT_EQ(frames, 1);
  int64_t n_seen = 0;
  for (char c : seen) n_seen += c;
  EXPECT_GT(n_seen, 10);
  EXPECT_LT(n_seen, static_cast<int64_t>(seen.size()) * 3 / 4);  // the far side is hidden
  TransferOptions to;
  TransferStats ts;
  VertexTransfer part = ComputeTransfer(object, to, &ts, &seen);
  EXPECT_EQ(ts.skipped_vertices, static_cast<int64_t>(seen.size()) - n_seen);
  part.header.valid_spp = 4;
  WriteTransfer(Cap() / "object-seen.ffc", part);
  WriteTransfer(Cap() / "object-all.ffc", ComputeTransfer(object, to, &ts));
  auto render = [&](const std::string& ffc, int spp, const std::string& out) {
    Json k = j;
    k["virtual"][0]["formfactors"] = ffc;
    WriteTextFile(Cap() / "prt-k.json", k.dump());
    RenderOptions o;
    o.method = "prt";
    o.spp = spp;
    o.out_dir = dir_->path() / out;
    Report r("mr-render", "test");
    RunRenderJob(ReadScene(Cap() / "prt-k.json"), o, &r);
    return ReadImage(o.out_dir / "00000.exr").Layer("composite").values();
  };
  EXPECT_EQ(render("object-seen.ffc", 4, "seen"), render("object-all.ffc", 4, "all"));
  EXPECT_THROW(render("object-seen.ffc", 8, "more"), Error);
}

TEST_F(Capture, NanInTheEnvironmentMapIsAClearError) {
  Image env = ReadImage(Cap() / "env.exr");
  env.at(7, 3, 2) = std::numeric_limits<float>::quiet_NaN();
  test::TempDir d;
  fs::copy(Cap(), d.path() / "cap", fs::copy_options::recursive);
  WriteImage(d.path() / "cap" / "env.exr", env);
  Scene s = ReadScene(d.path() / "cap" / "scene.json");
  RenderOptions o;
  o.spp = 1;
  o.out_dir = d.path() / "out";
  Report r("mr-render", "test");
  try {
    RunRenderJob(s, o, &r);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("env.exr: pixel (7, 3) has non-finite radiance nan in channel B"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(d.path() / "out" / "00000.exr"));
}

// A video input gives a video output; frames decode from the mp4 mr-synth wrote.
TEST_F(Capture, VideoInVideoOut) {
  Json j = ReadJsonFile(Cap() / "scene.json");
  j["camera"]["frames"] = "photos.mp4";
  j["camera"]["frames_transfer"] = "srgb";
  WriteTextFile(Cap() / "video.json", j.dump());
  Scene s = ReadScene(Cap() / "video.json");
  RenderOptions o;
  o.spp = 1;
  o.out_dir = dir_->path() / "video";
  Report r("mr-render", "test");
  RunRenderJob(s, o, &r);
  ASSERT_TRUE(fs::exists(dir_->path() / "video" / "composite.mp4"));
  VideoReader v(dir_->path() / "video" / "composite.mp4");
  EXPECT_EQ(v.width(), 64);
  EXPECT_EQ(v.height(), 48);
  Image last = v.Frame(1);  // both frames are there
  EXPECT_GT(MeanOfValues(last), 0.01);
  // The photograph decoded from the mp4 is close to the PNG (lossy codec).
  Image photo = ReadImage(dir_->path() / "video" / "00000.exr").Layer("photo");
  Image png = ReadImage(Cap() / "photos" / "00000.png");
  EXPECT_NEAR(MeanOfValues(photo), MeanOfValues(png), 0.02);
}

// The 8-bit photographs with the response unknown: display-space compositing.
// Where the object changes nothing the composite is the photograph (within
// float round trips); overall it approaches the truth up to the 8-bit
// photograph's quantisation, noise and clipping.
TEST_F(Capture, DisplaySpaceCompositingOfEightBitPhotographs) {
  Scene s = ReadScene(Cap() / "scene-ldr.json");
  EXPECT_EQ(s.camera.frames_transfer, "display");
  RenderOptions o;
  o.spp = 8;
  o.frame_end = 1;
  o.out_dir = dir_->path() / "ldr";
  Report r("mr-render", "test");
  RunRenderJob(s, o, &r);
  EXPECT_EQ(r.metrics()["compositing"], "display space (camera response unknown)");
  Image out = ReadImage(dir_->path() / "ldr" / "00000.exr");
  Image comp = out.Layer("composite"), diff = out.Layer("difference"), photo = out.Layer("photo");
  const float e = static_cast<float>(s.camera.exposure);
  int64_t unchanged = 0, bad = 0;
  for (int y = 0; y < comp.height(); ++y)
    for (int x = 0; x < comp.width(); ++x)
      for (int c = 0; c < 3; ++c)
        if (diff.at(x, y, c) == 0.0f) {
          ++unchanged;
          const float expected = SrgbToLinear(photo.at(x, y, c)) / e;
          bad += std::abs(comp.at(x, y, c) - expected) > 1e-5f * (1 + expected);
        }
  EXPECT_GT(unchanged, 0);
  EXPECT_EQ(bad, 0);
  EXPECT_LT(r.metrics()["relmse"].get<double>(), 0.1);
  // With the object in view: every pixel it does not change (difference 0,
  // mask 0) keeps the photograph's code value in the PNG, at exposure != 1.
  const std::vector<int> in = PngCodes(Cap() / "photos" / "00000.png"), png = PngCodes(o.out_dir / "00000.png");
  const Image mask = out.Layer("mask");
  const auto [kept, moved] = UntouchedCodes(diff, mask, in, png);
  EXPECT_GT(kept, 100);
  EXPECT_EQ(moved, 0);
}

// The 8-bit display-space plate without its exposure: mr-eval plate fits
// the render-to-plate gain from the room (true geometry and albedo here)
// and recovers the exposure the plate was made with (one number for all
// three channels: the capture has no white balance); rendering with the
// fitted gains then composites as well as the hand-set exposure did, and
// keeps every untouched pixel's code.  Tolerance 2%: the 32-spp render's
// noise averages out over ~2700 room pixels (the jackknife's sigma is
// ~0.3%), and the plate's noise (1/255 in code values, before
// quantisation) biases the sRGB-decoded values by under 1% above code 4.
// The re-rendering error is the render's noise (relMSE 0.072 at 8 spp,
// 0.0125 at 64: it falls as 1/spp) and the plate's: bounded at 32 spp by
// 0.04, twice the expected 0.02.
TEST_F(Capture, PlateFitRecoversTheExposureAndReplacesIt) {
  Json j = ReadJsonFile(Cap() / "scene-ldr.json");
  const double exposure = j["camera"]["exposure"].get<double>();
  j["camera"].erase("exposure");
  j["output"]["dir"] = "render-fit";
  WriteTextFile(Cap() / "scene-fit.json", j.dump(2));
  PlateCheckOptions po;
  po.out = dir_->path() / "plate";
  po.spp = 32;
  po.frame_end = 1;
  Report pr("mr-eval", "test");
  RunPlateCheck(ReadScene(Cap() / "scene-fit.json"), po, &pr);
  const std::vector<FrameGain> gains = ReadPlateGains(po.out / "gains.json");
  ASSERT_EQ(gains.size(), 1u);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(gains[0].gain[c] / exposure, 1, 0.02) << "channel " << c;
    EXPECT_GT(gains[0].sigma[c], 0);
    EXPECT_LT(gains[0].sigma[c] / gains[0].gain[c], 0.01);
  }
  const Json& f0 = pr.metrics()["frames"][0];
  EXPECT_GT(f0["pixels"].get<int64_t>(), 2000);  // of 64 x 48
  EXPECT_LT(pr.metrics()["relmse"].get<double>(), 0.04);
  EXPECT_TRUE(pr.metrics().contains("region_relmse"));

  // Rendered with the fitted gains (exposure 1: the composite layer is in the
  // plate's display-linear units, the truth times the exposure).
  j["camera"]["gains"] = "../plate/gains.json";
  WriteTextFile(Cap() / "scene-fit.json", j.dump(2));
  RenderOptions o;
  o.spp = 8;
  o.frame_end = 1;
  o.out_dir = dir_->path() / "fit";
  Report r("mr-render", "test");
  RunRenderJob(ReadScene(Cap() / "scene-fit.json"), o, &r);
  EXPECT_EQ(r.metrics()["frames"][0]["gain"][1].get<double>(), gains[0].gain[1]);
  const Image out = ReadImage(o.out_dir / "00000.exr");
  Image comp = out.Layer("composite");
  for (float& v : comp.values()) v /= static_cast<float>(exposure);
  const Image truth = ReadImage(Cap() / "truth" / "00000.exr");
  EXPECT_LT(CompareImages(comp, truth).relmse, 0.1);
  const std::vector<int> in = PngCodes(Cap() / "photos" / "00000.png"), png = PngCodes(o.out_dir / "00000.png");
  const Image diff = out.Layer("difference"), mask = out.Layer("mask");
  const auto [kept, moved] = UntouchedCodes(diff, mask, in, png);
  EXPECT_GT(kept, 100);
  EXPECT_EQ(moved, 0);

  // gains_scale "room": the gains correct the room's part (its albedo's
  // scale), and the object's own pixels are the render's, unscaled: where
  // the mask is 1 the composite equals the gain-less render's bit for bit.
  {
    Json k = j;
    k["camera"]["gains_scale"] = "room";
    WriteTextFile(Cap() / "scene-room.json", k.dump(2));
    k["camera"].erase("gains");
    k["camera"].erase("gains_scale");
    WriteTextFile(Cap() / "scene-nogain.json", k.dump(2));
    Image comp_room, comp_none, m;
    for (const char* name : {"room", "nogain"}) {
      RenderOptions ro = o;
      ro.out_dir = dir_->path() / (std::string("scale-") + name);
      Report rr("mr-render", "test");
      RunRenderJob(ReadScene(Cap() / (std::string("scene-") + name + ".json")), ro, &rr);
      const Image e = ReadImage(ro.out_dir / "00000.exr");
      (name[0] == 'r' ? comp_room : comp_none) = e.Layer("composite");
      m = e.Layer("mask");
    }
    int64_t full = 0, differ = 0;
    for (int y = 0; y < m.height(); ++y)
      for (int x = 0; x < m.width(); ++x)
        if (m.at(x, y, 0) == 1.0f) {
          ++full;
          for (int c = 0; c < 3; ++c) differ += comp_room.at(x, y, c) != comp_none.at(x, y, c);
        }
    EXPECT_GT(full, 10);
    EXPECT_EQ(differ, 0);
    EXPECT_NE(comp_room.values(), comp_none.values());  // the room's part is scaled
  }

  // A gains file without the frame, or with a bad gain: refused before the
  // first frame, naming the file, nothing written.
  WriteTextFile(dir_->path() / "plate" / "short.json",
                R"({"version": 1, "kind": "mr-plate-gains", "frames": [{"frame": 5, "gain": [1, 1, 1]}]})");
  j["camera"]["gains"] = "../plate/short.json";
  j["output"]["dir"] = "render-short";
  WriteTextFile(Cap() / "scene-short.json", j.dump(2));
  o.out_dir = dir_->path() / "short";
  try {
    Report r2("mr-render", "test");
    RunRenderJob(ReadScene(Cap() / "scene-short.json"), o, &r2);
    ADD_FAILURE() << "rendered without a gain for frame 0";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("short.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("frame 0"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(o.out_dir));
  // With a hand-set exposure too: ambiguous in display mode, refused.
  j["camera"]["exposure"] = exposure;
  WriteTextFile(Cap() / "scene-short.json", j.dump(2));
  EXPECT_THROW(ReadScene(Cap() / "scene-short.json"), Error);
}

// Grain: the 8-bit plate's noise is measured from the frames (the report
// gives the profile; the estimator's accuracy on known noise is tested in
// grain_test.cpp; this plate's noise is its 1/255 sensor noise plus the
// truth render's Monte Carlo noise) and added where the object shows: the
// same job with output.grain "off" differs from it only there, and by
// noise of the profile's sigma at each pixel's code (the normalised
// differences' RMS within 25% of 1: ~100 fully covered channel values of
// the 64x48 capture give it to ~7%, 1 sigma).  Float (EXR) plates have no
// code values: "auto" leaves grain out and says why.
TEST_F(Capture, GrainMatchesThePlateWhereTheObjectShows) {
  Json j = ReadJsonFile(Cap() / "scene-ldr.json");
  const double e = j["camera"]["exposure"].get<double>();
  Image comp[2], mask;
  NoiseProfile profile;
  for (int on = 0; on < 2; ++on) {
    j["output"]["grain"] = on ? "on" : "off";
    WriteTextFile(Cap() / "scene-grain.json", j.dump(2));
    RenderOptions o;
    o.spp = 4;
    o.frame_end = 1;
    o.out_dir = dir_->path() / (on ? "grain-on" : "grain-off");
    Report r("mr-render", "test");
    RunRenderJob(ReadScene(Cap() / "scene-grain.json"), o, &r);
    EXPECT_EQ(r.metrics().contains("grain"), on == 1);
    if (on)
      for (int b = 0; b < NoiseProfile::kBins; ++b)
        for (int c = 0; c < 3; ++c)
          profile.sigma[static_cast<size_t>(c)][static_cast<size_t>(b)] =
              r.metrics()["grain"]["bins"][static_cast<size_t>(b)]["sigma"][static_cast<size_t>(c)].get<double>();
    const Image out = ReadImage(o.out_dir / "00000.exr");
    comp[on] = out.Layer("composite");
    mask = out.Layer("mask");
  }
  double sum2 = 0;
  int64_t n = 0, outside_changed = 0;
  for (int y = 0; y < mask.height(); ++y)
    for (int x = 0; x < mask.width(); ++x)
      for (int c = 0; c < 3; ++c) {
        const float a = comp[0].at(x, y, c), b = comp[1].at(x, y, c);
        if (mask.at(x, y, 0) == 0.0f) {
          outside_changed += a != b;
        } else if (mask.at(x, y, 0) == 1.0f) {
          const double ca = LinearToSrgb(std::min(1.0f, a * static_cast<float>(e)));
          const double cb = LinearToSrgb(std::min(1.0f, b * static_cast<float>(e)));
          if (ca > 0.02 && ca < 0.98) sum2 += std::pow((cb - ca) / profile.At(c, ca), 2), ++n;
        }
      }
  EXPECT_EQ(outside_changed, 0);
  ASSERT_GT(n, 60);
  EXPECT_NEAR(std::sqrt(sum2 / n), 1, 0.25) << n << " samples";
  // The float plate: left out, reported.
  Report r("mr-render", "test");
  RenderOptions o;
  o.spp = 1;
  o.frame_end = 1;
  o.out_dir = dir_->path() / "grain-exr";
  RunRenderJob(ReadScene(Cap() / "scene.json"), o, &r);
  EXPECT_FALSE(r.metrics().contains("grain"));
  EXPECT_NE(r.ToJson().dump().find("no sensor noise to match"), std::string::npos);
}

// A plate whose exposure jumps between its two frames (frame 1 made at 1.6x
// frame 0's exposure, 8-bit): mr-eval plate finds the jump, keeps the
// smoothing from blending across it, and recovers both exposures (2%, as
// above).
TEST_F(Capture, PlateFitKeepsAnExposureJump) {
  Json j = ReadJsonFile(Cap() / "scene-ldr.json");
  const double e = j["camera"]["exposure"].get<double>();
  fs::create_directories(Cap() / "photos-jump");
  for (int f = 0; f < 2; ++f) {
    Image photo = ReadImage(Cap() / "photos" / fmt::format("{:05d}.exr", f));
    const double scale = f == 0 ? e : 1.6 * e;
    for (float& v : photo.values()) v = Clamp(static_cast<float>(v * scale), 0.0f, 1.0f);
    WriteImage(Cap() / "photos-jump" / fmt::format("{:05d}.png", f), photo);  // sRGB-encoded 8-bit
  }
  j["camera"].erase("exposure");
  j["camera"]["frames"] = "photos-jump/%05d.png";
  WriteTextFile(Cap() / "scene-jump.json", j.dump(2));
  PlateCheckOptions po;
  po.out = dir_->path() / "plate-jump";
  po.spp = 32;
  Report r("mr-eval", "test");
  RunPlateCheck(ReadScene(Cap() / "scene-jump.json"), po, &r);
  const std::vector<FrameGain> g = ReadPlateGains(po.out / "gains.json");
  ASSERT_EQ(g.size(), 2u);
  EXPECT_FALSE(g[0].jump_before);
  EXPECT_TRUE(g[1].jump_before);
  EXPECT_EQ(r.metrics()["exposure_jumps"], 1);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(g[0].gain[c] / e, 1, 0.02) << c;
    EXPECT_NEAR(g[1].gain[c] / (1.6 * e), 1, 0.02) << c;
  }
}

// The plate in reflections through mr-render: the capture's object made a
// mirror on its glossy table.  A glossy real surface sends other light
// towards the object than towards the plate's camera, so the table is
// rendered, not taken from the plate; the mirror's pixels then agree with
// pt reflecting the rendered room (1024 spp) as well as pt at 64 spp does
// (1.5x + 0.002).  The frame's report gives the share from the plate;
// render.pt.plate_reflections false turns it off, said in the report.
// (The diffuse case, where the plate is used: plate_reflection_test.cpp.)
TEST_F(Capture, MirrorOnAGlossyTableReflectsItRendered) {
  Json j = ReadJsonFile(Cap() / "scene.json");
  for (auto& v : j["virtual"])
    v["material"] = {{"albedo", {0, 0, 0}}, {"specular", {0.9, 0.9, 0.9}}, {"roughness", 0.02}};
  auto render = [&](bool plate, int spp, int seed, Report* r) {
    Json k = j;
    k["render"]["seed"] = seed;
    k["render"]["pt"] = {{"plate_reflections", plate}};
    k["render"]["plate_neighbour_step"] = 1;  // frame 1's plate for what frame 0's does not see
    WriteTextFile(Cap() / "scene-mirror.json", k.dump(2));
    RenderOptions o;
    o.method = "pt";
    o.spp = spp;
    o.frame_end = 1;
    o.out_dir = dir_->path() / fmt::format("mirror-{}-{}-{}", plate, spp, seed);
    RunRenderJob(ReadScene(Cap() / "scene-mirror.json"), o, r);
    return ReadImage(o.out_dir / "00000.exr");
  };
  Report r_ref("mr-render", "test"), r_plate("mr-render", "test"), r_render("mr-render", "test");
  const Image ref = render(false, 1024, 7, &r_ref);
  const Image with_plate = render(true, 64, 1, &r_plate), rendered = render(false, 64, 1, &r_render);
  Image mask = ref.Layer("mask");
  for (float& m : mask.values()) m = m > 0.99f ? 1.0f : 0.0f;
  const double err_plate = CompareImages(with_plate.Layer("composite"), ref.Layer("composite"), &mask).relmse;
  const double err_render = CompareImages(rendered.Layer("composite"), ref.Layer("composite"), &mask).relmse;
  EXPECT_LT(err_plate, 1.5 * err_render + 0.002) << err_plate << " with the plate, " << err_render << " rendered";
  const Json& pr = r_plate.metrics()["frames"][0];
  ASSERT_TRUE(pr.contains("plate_reflections"));
  EXPECT_GT(pr["plate_reflections"]["rendered"].get<int64_t>(), pr["plate_reflections"]["from_plate"].get<int64_t>());
  EXPECT_LE(pr["plate_reflections"]["from_other_frames"].get<int64_t>(),
            pr["plate_reflections"]["from_plate"].get<int64_t>());
  EXPECT_EQ(r_plate.metrics()["plate_neighbours"]["step"], 1);
  EXPECT_FALSE(r_render.metrics()["frames"][0].contains("plate_reflections"));
  EXPECT_FALSE(r_render.metrics().contains("plate_neighbours"));  // nothing reflects the plate: none read
  EXPECT_NE(r_render.ToJson().dump().find("plate_reflections is false"), std::string::npos);
}

// Motion blur: the capture's camera moves 0.8 m and turns between its two
// frames.  With a full shutter (1: the whole frame interval) frame 0 is
// the mean of the renders over its interval (the first frame blurs over
// the half interval it has, towards frame 1): the blurred pt render at 512
// spp is compared with the mean of 16 sharp renders at poses spread over
// the interval (32 spp each); its error (the two estimates' noise) is a
// small fraction (< 0.35) of the sharp frame's against the same mean (the
// noise and what the blur changes).  Then every
// method with the blur against pt with it: no worse than 1.5x its error
// without blur (+0.005 for noise).
TEST_F(Capture, MotionBlurIsTheMeanOverTheShutterInterval) {
  Json j = ReadJsonFile(Cap() / "scene.json");
  j["camera"]["shutter"] = 1.0;
  WriteTextFile(Cap() / "scene-blur.json", j.dump(2));
  const Scene s = ReadScene(Cap() / "scene-blur.json");
  const std::vector<Rigid3> poses = LoadScenePoses(s);
  const CameraModel camera = CameraModel::Read(s.camera.model);
  RenderScene rs;
  LoadRenderScene(s, &rs);
  const CameraExposure e = FrameExposure(s, poses, 0);
  ASSERT_TRUE(e.moves);
  PathTracerSettings st;
  st.max_depth = s.render.max_depth;
  PtFrameRenderer blurred(rs, camera, poses[0], st, e), sharp(rs, camera, poses[0], st);
  blurred.RenderPass(512);
  sharp.RenderPass(512);
  Image mean = Image::Rgb(camera.width(), camera.height());
  constexpr int kPoses = 16;
  for (int k = 0; k < kPoses; ++k) {
    const double t = (k + 0.5) / kPoses;
    const Rigid3 pose =
        t < 0.5 ? InterpolatePose(e.open, poses[0], 2 * t) : InterpolatePose(poses[0], e.close, 2 * t - 1);
    PathTracerSettings sk = st;
    sk.seed = 100 + k;
    PtFrameRenderer r(rs, camera, pose, sk);
    r.RenderPass(32);
    const Image m = r.Mixed();
    for (size_t i = 0; i < mean.values().size(); ++i) mean.values()[i] += m.values()[i] / kPoses;
  }
  const double err_blur = CompareImages(blurred.Mixed(), mean).relmse;
  const double err_sharp = CompareImages(sharp.Mixed(), mean).relmse;
  EXPECT_LT(err_blur, 0.35 * err_sharp) << err_blur << " against " << err_sharp;
  std::printf("motion blur: relMSE %.5f blurred, %.5f sharp, against the mean over the interval\n", err_blur,
              err_sharp);

  // Every method, blurred and not, against pt the same way.
  auto render = [&](const std::string& method, bool blur, int spp) {
    Json k = j;
    k["camera"]["shutter"] = blur ? 1.0 : 0.0;
    WriteTextFile(Cap() / "scene-blur.json", k.dump(2));
    RenderOptions o;
    o.method = method;
    o.spp = spp;
    o.frame_end = 1;
    o.out_dir = dir_->path() / ("blur-" + method + (blur ? "-on" : "-off"));
    Report r("mr-render", "test");
    RunRenderJob(ReadScene(Cap() / "scene-blur.json"), o, &r);
    return ReadImage(o.out_dir / "00000.exr").Layer("composite");
  };
  const Image pt_on = render("pt", true, 64), pt_off = render("pt", false, 64);
  for (const std::string m : {"ic", "vpl", "vct"}) {
    const double on = CompareImages(render(m, true, 8), pt_on).relmse;
    const double off = CompareImages(render(m, false, 8), pt_off).relmse;
    EXPECT_LT(on, 1.5 * off + 0.005) << m << ": " << on << " blurred, " << off << " sharp";
  }
}

// Depth of field: a thin lens (aperture radius 10 cm, focused at 1 m, in
// front of the room: everything is out of focus) changes pt's frame by
// more than twice what another seed changes (the ray geometry itself is
// tested exactly in exposure_test.cpp), and every method with the lens is
// as close to pt with it as without (1.5x + 0.005 for noise).
TEST_F(Capture, DepthOfFieldAgainstPt) {
  Json j = ReadJsonFile(Cap() / "scene.json");
  auto render = [&](const std::string& method, bool lens, int spp, int seed = 1) {
    Json k = j;
    k["render"]["seed"] = seed;
    if (lens) k["camera"]["lens"] = {{"aperture_radius", 0.1}, {"focus_distance", 1.0}};
    WriteTextFile(Cap() / "scene-lens.json", k.dump(2));
    RenderOptions o;
    o.method = method;
    o.spp = spp;
    o.frame_end = 1;
    o.out_dir = dir_->path() / ("lens-" + method + (lens ? "-on" : "-off") + std::to_string(seed));
    Report r("mr-render", "test");
    RunRenderJob(ReadScene(Cap() / "scene-lens.json"), o, &r);
    return ReadImage(o.out_dir / "00000.exr").Layer("composite");
  };
  const Image pt_on = render("pt", true, 128), pt_off = render("pt", false, 128);
  const double noise = CompareImages(render("pt", false, 128, 2), pt_off).relmse;
  EXPECT_GT(CompareImages(pt_on, pt_off).relmse, 2 * noise);
  for (const std::string m : {"ic", "vpl", "vct"}) {
    const double on = CompareImages(render(m, true, 8), pt_on).relmse;
    const double off = CompareImages(render(m, false, 8), pt_off).relmse;
    EXPECT_LT(on, 1.5 * off + 0.005) << m << ": " << on << " with the lens, " << off << " without";
  }
}

// A camera that does not move over the shutter: the blur is left out,
// reported, and the frame is the sharp one, byte for byte.  Without a lens
// the report says depth of field was left out.
TEST_F(Capture, StillCameraAndPinholeLeaveTheFrameUnchanged) {
  std::string first;
  {
    std::ifstream in(Cap() / "trajectory.txt");
    for (std::string line; std::getline(in, line);)
      if (!line.empty() && line[0] != '#') {
        first = line.substr(line.find(' '));
        break;
      }
  }
  WriteTextFile(Cap() / "still.txt", "0" + first + "\n0.0333" + first + "\n");
  Json j = ReadJsonFile(Cap() / "scene.json");
  j["camera"]["poses"]["path"] = "still.txt";
  std::vector<float> composite[2];
  for (int blur = 0; blur < 2; ++blur) {
    j["camera"]["shutter"] = blur ? 0.5 : 0.0;
    WriteTextFile(Cap() / "scene-still.json", j.dump(2));
    RenderOptions o;
    o.spp = 2;
    o.frame_end = 1;
    o.out_dir = dir_->path() / ("still" + std::to_string(blur));
    Report r("mr-render", "test");
    RunRenderJob(ReadScene(Cap() / "scene-still.json"), o, &r);
    composite[blur] = ReadImage(o.out_dir / "00000.exr").Layer("composite").values();
    const std::string rep = r.ToJson().dump();
    EXPECT_NE(rep.find(blur ? "the camera does not move" : "camera.shutter is 0"), std::string::npos);
    EXPECT_NE(rep.find("camera.lens is not given"), std::string::npos);
  }
  EXPECT_EQ(composite[0], composite[1]);
}

// The same 8-bit photographs through a known camera response (mr-hdr's
// response.json; here the sRGB curve the photographs were made with) and
// their exposure: composited in linear radiance.  Where the object changes
// nothing the composite is the linearised photograph; overall it
// approaches the truth as the display-space composite does.
TEST_F(Capture, FramesThroughTheCameraResponse) {
  CameraResponse srgb;
  srgb.method = "debevec";
  srgb.channels = {"R", "G", "B"};
  std::vector<double> g(256);
  for (int k = 0; k < 256; ++k) g[static_cast<size_t>(k)] = std::log(std::max(SrgbToLinear(k / 255.0f), 1e-7f));
  srgb.log_exposure = {g, g, g};
  WriteResponse(Cap() / "response.json", srgb);
  Json j = ReadJsonFile(Cap() / "scene-ldr.json");
  j["camera"]["frames_transfer"] = "response";
  j["camera"]["response"] = "response.json";
  WriteTextFile(Cap() / "scene-response.json", j.dump(2));
  Scene s = ReadScene(Cap() / "scene-response.json");
  RenderOptions o;
  o.spp = 8;
  o.frame_end = 1;
  o.out_dir = dir_->path() / "resp";
  Report r("mr-render", "test");
  RunRenderJob(s, o, &r);
  EXPECT_EQ(r.metrics()["compositing"], "linear radiance (frames through the camera's response)");
  Image out = ReadImage(dir_->path() / "resp" / "00000.exr");
  Image comp = out.Layer("composite"), diff = out.Layer("difference"), photo = out.Layer("photo");
  int64_t unchanged = 0, bad = 0;
  for (int y = 0; y < comp.height(); ++y)
    for (int x = 0; x < comp.width(); ++x)
      for (int c = 0; c < 3; ++c)
        if (diff.at(x, y, c) == 0.0f) {
          ++unchanged;
          bad += std::abs(comp.at(x, y, c) - photo.at(x, y, c)) > 1e-6f * (1 + photo.at(x, y, c));
        }
  EXPECT_GT(unchanged, 0);
  EXPECT_EQ(bad, 0);
  EXPECT_LT(r.metrics()["relmse"].get<double>(), 0.1);
  // frames_transfer "response" without a response file is refused.
  j["camera"].erase("response");
  EXPECT_THROW(ParseScene(j, Cap(), "scene.json", false), Error);
}

// Section 1 of the real-plate work: the 8-bit outputs are encoded through
// the inverse of exactly the decoding the frames went through, so that with
// the virtual object far outside the view the PNG output equals the input
// frame code for code, for every frames_transfer mode, for 8-bit PNG plates
// with clipped highlights, 16-bit PNG plates (a 16-bit PNG out) and videos.  (Before, "display" at exposure != 1 and
// "response" wrote sRGB(radiance): every untouched pixel came out brighter or darker.)
TEST_F(Capture, EightBitOutputsKeepThePlatesCodeValues) {
  // A response that is neither sRGB nor linear (a 2.2 power with a toe).
  CameraResponse resp;
  resp.method = "debevec";
  resp.channels = {"R", "G", "B"};
  std::vector<double> g(256);
  for (int k = 0; k < 256; ++k) g[static_cast<size_t>(k)] = std::log((1e-3 + std::pow(k / 255.0, 2.2)) / (1 + 1e-3));
  resp.log_exposure = {g, g, g};
  WriteResponse(Cap() / "response-toe.json", resp);
  // The plates as 8-bit PNGs with clipped highlights (a 12x8 block at code
  // 255: clipped pixels keep their code value), and as 16-bit PNGs (the
  // output PNG keeps 16 bits).
  fs::create_directories(Cap() / "clipped");
  fs::create_directories(Cap() / "deep");
  for (int f = 0; f < 2; ++f) {
    Image codes = ReadRgbForComparison(Cap() / "photos" / fmt::format("{:05d}.png", f), Transfer::kLinear, true);
    for (int y = 4; y < 12; ++y)
      for (int x = 40; x < 52; ++x)
        for (int c = 0; c < 3; ++c) codes.at(x, y, c) = 1.0f;
    ImageWriteOptions wo;
    wo.ldr_transfer = Transfer::kLinear;  // the values are codes already
    wo.attributes["oiio:ColorSpace"] = "sRGB";
    wo.pixel_type = PixelType::kUint8;
    WriteImage(Cap() / "clipped" / fmt::format("{:05d}.png", f), codes, wo);
    for (float& v : codes.values()) v = std::min(1.0f, v + 37.0f / 65535.0f);  // codes between the 8-bit ones
    wo.pixel_type = PixelType::kUint16;
    WriteImage(Cap() / "deep" / fmt::format("{:05d}.png", f), codes, wo);
  }
  for (const std::string mode : {"srgb", "linear", "display", "response"})
    for (const std::string plate : {"clipped", "deep", "video"}) {
      const bool video = plate == "video", deep = plate == "deep";
      const double max = deep ? 65535 : 255;
      SCOPED_TRACE(mode + " " + plate);
      Json j = ReadJsonFile(Cap() / "scene.json");
      j["camera"]["frames"] = video ? "photos.mp4" : plate + "/%05d.png";
      j["camera"]["frames_transfer"] = mode;
      j["camera"]["exposure"] = 0.37;  // != 1: display and response divide by it
      if (mode == "response") j["camera"]["response"] = "response-toe.json";
      j["virtual"][0]["transform"] = {{"translation", {0, -1000, 0}}};  // far outside the view, below the floor
      j["output"]["video"] = "mkv";
      j.erase("reference");
      WriteTextFile(Cap() / "codes.json", j.dump());
      RenderOptions o;
      o.spp = 1;
      o.frame_end = 2;
      o.out_dir = dir_->path() / ("codes-" + mode + "-" + plate);
      Report r("mr-render", "test");
      RunRenderJob(ReadScene(Cap() / "codes.json"), o, &r);
      for (int f = 0; f < 2; ++f) {
        const std::vector<int> in =
            video ? VideoCodes(Cap() / "photos.mp4", f) : PngCodes(Cap() / plate / fmt::format("{:05d}.png", f), max);
        const std::vector<int> out = PngCodes(o.out_dir / fmt::format("{:05d}.png", f), max);
        int width = 0;
        EXPECT_EQ(ReadImageHeader(o.out_dir / fmt::format("{:05d}.png", f), &width, nullptr, nullptr).pixel_type,
                  deep ? "uint16" : "uint8");
        if (plate == "clipped") {
          EXPECT_EQ(out[(8 * 64 + 45) * 3], 255);
        }
        ASSERT_EQ(in.size(), out.size());
        int64_t differ = 0;
        for (size_t i = 0; i < in.size(); ++i) differ += in[i] != out[i];
        EXPECT_EQ(differ, 0) << "frame " << f;
        // FFV1 is lossless: the output video holds the same codes.
        if (video) {
          EXPECT_TRUE(VideoCodes(o.out_dir / "composite.mkv", f) == in) << "frame " << f;
        }
      }
    }
}

// The composite video keeps the plate's frame rate (29.97 here, not a
// round number), its size and a frame per frame rendered; mp4 is lossy, so
// its codes match the plate's within the codec's loss (measured: see below).
TEST_F(Capture, OutputVideoKeepsThePlatesRateCountAndSize) {
  const double fps = 30000.0 / 1001.0;
  {
    VideoWriter w(Cap() / "photos-ntsc.mp4", 64, 48, fps);
    for (int f = 0; f < 2; ++f) w.Write(ReadImage(Cap() / "photos" / fmt::format("{:05d}.png", f)));
    w.Close();
  }
  Json j = ReadJsonFile(Cap() / "scene.json");
  j["camera"]["frames"] = "photos-ntsc.mp4";
  j["camera"]["frames_transfer"] = "srgb";
  j["virtual"][0]["transform"] = {{"translation", {0, -1000, 0}}};
  j["output"]["review"] = true;
  WriteTextFile(Cap() / "ntsc.json", j.dump());
  RenderOptions o;
  o.spp = 1;
  o.out_dir = dir_->path() / "ntsc";
  Report r("mr-render", "test");
  RunRenderJob(ReadScene(Cap() / "ntsc.json"), o, &r);
  VideoReader in(Cap() / "photos-ntsc.mp4"), out(o.out_dir / "composite.mp4");
  EXPECT_EQ(out.width(), in.width());
  EXPECT_EQ(out.height(), in.height());
  EXPECT_EQ(out.frame_count(), 2);
  EXPECT_NEAR(out.fps(), in.fps(), 1e-6);
  EXPECT_NEAR(out.fps(), fps, 1e-3);
  EXPECT_NEAR(r.metrics()["plate_fps"].get<double>(), fps, 1e-3);
  for (int f = 0; f < 2; ++f) {
    const std::vector<int> a = VideoCodes(Cap() / "photos-ntsc.mp4", f), b = VideoCodes(o.out_dir / "composite.mp4", f);
    double sum = 0;
    int worst = 0;
    for (size_t i = 0; i < a.size(); ++i) {
      sum += std::abs(a[i] - b[i]);
      worst = std::max(worst, std::abs(a[i] - b[i]));
    }
    const double mean = sum / static_cast<double>(a.size());
    // MPEG-4 part 2 re-encoding of an already MPEG-4-coded noisy 64x48
    // frame: measured mean 1.7 and 1.9, worst 6 and 9 code values (2026-12);
    // the bounds leave twice that for other FFmpeg builds.  Exactness is
    // output.video "mkv"'s (EightBitOutputsKeepThePlatesCodeValues).
    EXPECT_LT(mean, 4.0) << "frame " << f;
    EXPECT_LE(worst, 24) << "frame " << f;
    std::cerr << "frame " << f << ": mp4 round trip mean " << mean << " worst " << worst << " code values\n";
    // The review sheet: plate | composite | difference | mask, 2x2.
    const Image sheet = ReadImage(o.out_dir / fmt::format("{:05d}-review.png", f));
    EXPECT_GE(sheet.width(), 2 * 64);
    EXPECT_GE(sheet.height(), 2 * 48);
  }
  EXPECT_EQ(r.metrics()["review_sheet"], (o.out_dir / "00001-review.png").string());
}

// A world that changes during the video (render/world.h).  The capture's
// object given a trajectory that moves and turns it between its two
// frames: frame 1 of the dynamic job is, byte for byte, frame 1 of the
// static scene with the object where the trajectory puts it, for pt (nothing
// to rebuild) and vpl (its VPL set rebuilt, as the report says).  A
// trajectory that holds the object still, with a per-frame environment whose
// frame 1 is a copy of frame 0's, changes nothing and rebuilds nothing
// (kept by content, reported), and its frames are the static scene's.
TEST_F(Capture, ChangingWorldRendersEachFrameAsItsStaticScene) {
  const Json base = ReadJsonFile(Cap() / "scene.json");
  auto run = [&](const Json& j, const std::string& name, const std::string& method, int b, int e, Report* r) {
    RenderOptions o;
    o.method = method;
    o.spp = 2;
    o.frame_begin = b;
    o.frame_end = e;
    return RenderVariant(j, name, o, r);
  };
  Json moving = base;
  moving["virtual"][0].erase("transform");
  moving["virtual"][0]["trajectory"] = Json::parse(R"([
    {"frame": 0, "translation": [0.1, 0.9, 0], "rotation_deg": [0, 28.6479, 0]},
    {"frame": 1, "translation": [0.3, 0.9, 0.1], "rotation_deg": [0, 70, 0], "scale": 1.2}])");
  WriteTextFile(Cap() / "moving.json", moving.dump(2));
  const Eigen::Affine3d at1 = ReadScene(Cap() / "moving.json").virtuals[0].WorldFromObjectAt(1);
  Json still = base;
  std::vector<double> m(16);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[static_cast<size_t>(4 * r + c)] = at1.matrix()(r, c);
  still["virtual"][0]["transform"] = {{"matrix", m}};
  for (const std::string method : {"pt", "vpl"}) {
    SCOPED_TRACE(method);
    Report rd("mr-render", "test"), rs("mr-render", "test");
    const fs::path dyn = run(moving, "moving", method, 0, 2, &rd);
    const fs::path stat = run(still, "still", method, 1, 2, &rs);
    EXPECT_EQ(ReadImage(dyn / "00001.exr").Layer("composite").values(),
              ReadImage(stat / "00001.exr").Layer("composite").values());
    const Json& w = rd.metrics()["frames"][1]["world"];
    EXPECT_EQ(w["moved"], Json::array({"object"}));
    EXPECT_EQ(w["rebuilt"].size(), method == "pt" ? 0u : 1u) << w.dump();
    EXPECT_EQ(rd.metrics()["world"]["frames_changed"], 1);
  }

  // Held still, the light per frame with frame 1 a copy of frame 0's.
  fs::create_directories(Cap() / "envs");
  fs::copy_file(Cap() / "env.exr", Cap() / "envs" / "00000.exr", fs::copy_options::overwrite_existing);
  fs::copy_file(Cap() / "env.exr", Cap() / "envs" / "00001.exr", fs::copy_options::overwrite_existing);
  Json held = base;
  held["lighting"]["environment"] = "envs/%05d.exr";
  held["virtual"][0].erase("transform");
  held["virtual"][0]["trajectory"] =
      Json::array({moving["virtual"][0]["trajectory"][0], moving["virtual"][0]["trajectory"][0]});
  held["virtual"][0]["trajectory"][1]["frame"] = 1;
  WriteTextFile(Cap() / "held.json", held.dump(2));
  const Eigen::Affine3d at0 = ReadScene(Cap() / "held.json").virtuals[0].WorldFromObjectAt(0);
  Json fixed = base;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[static_cast<size_t>(4 * r + c)] = at0.matrix()(r, c);
  fixed["virtual"][0]["transform"] = {{"matrix", m}};
  Report rh("mr-render", "test"), rb("mr-render", "test");
  const fs::path h = run(held, "held", "vpl", 0, 2, &rh);
  const fs::path b = run(fixed, "fixed", "vpl", 0, 2, &rb);
  EXPECT_EQ(rh.metrics()["world"]["frames_kept"], 1);
  EXPECT_EQ(rh.metrics()["frames"][1]["world"]["rebuilt"].size(), 0u);
  EXPECT_NE(rh.ToJson().dump().find("every cache, volume and VPL set kept"), std::string::npos);
  EXPECT_FALSE(rb.metrics().contains("world"));  // a static scene has nothing to track
  for (int f = 0; f < 2; ++f)
    EXPECT_EQ(ReadImage(h / fmt::format("{:05d}.exr", f)).Layer("composite").values(),
              ReadImage(b / fmt::format("{:05d}.exr", f)).Layer("composite").values())
        << f;
}

// The light per frame: a frame without a map of its own takes the last
// earlier one's (said in the report, nothing rebuilt), a changed map is
// loaded and the frame renders as the static scene under it; an object
// scaled to nothing leaves the frame's plate exactly, copied through; a
// first frame with no map at or before it is an error naming the pattern.
TEST_F(Capture, PerFrameLightAndAnObjectScaledToNothing) {
  const Json base = ReadJsonFile(Cap() / "scene.json");
  fs::create_directories(Cap() / "envs2");
  fs::copy_file(Cap() / "env.exr", Cap() / "envs2" / "00000.exr", fs::copy_options::overwrite_existing);
  Json j = base;
  j["lighting"]["environment"] = "envs2/%05d.exr";
  RenderOptions o;
  o.spp = 2;
  o.frame_end = 2;
  Report ra("mr-render", "test");
  RenderVariant(j, "envs2-a", o, &ra);
  EXPECT_NE(ra.ToJson().dump().find("frame 1 has no environment map of its own: frame 0's"), std::string::npos);
  EXPECT_EQ(ra.metrics()["world"]["frames_kept"], 1);

  // Frame 1's map four times brighter: loaded, and frame 1 is the static scene under it.
  Image env = ReadImage(Cap() / "env.exr");
  for (float& v : env.values()) v *= 4;
  WriteImage(Cap() / "envs2" / "00001.exr", env);
  Report rb("mr-render", "test");
  const fs::path dyn = RenderVariant(j, "envs2-b", o, &rb);
  EXPECT_TRUE(rb.metrics()["frames"][1]["world"]["environment"].get<bool>());
  Json k = base;
  k["lighting"]["environment"] = "envs2/00001.exr";
  RenderOptions os = o;
  os.frame_begin = 1;
  Report rs("mr-render", "test");
  const fs::path stat = RenderVariant(k, "envs2-static", os, &rs);
  EXPECT_EQ(ReadImage(dyn / "00001.exr").Layer("composite").values(),
            ReadImage(stat / "00001.exr").Layer("composite").values());

  // The object shrinks to nothing at frame 1: that frame is the plate.
  Json z = base;
  z["virtual"][0].erase("transform");
  z["virtual"][0]["trajectory"] = Json::parse(R"([{"frame": 0, "translation": [0.1, 0.9, 0]},
                                                   {"frame": 1, "translation": [0.1, 0.9, 0], "scale": 0}])");
  Report rz("mr-render", "test");
  const fs::path vanish = RenderVariant(z, "vanish", o, &rz);
  EXPECT_TRUE(rz.metrics()["frames"][1]["copied_through"].get<bool>());
  const Image out1 = ReadImage(vanish / "00001.exr");
  EXPECT_EQ(out1.Layer("composite").values(), ReadImage(Cap() / "photos" / "00001.exr").values());
  EXPECT_FALSE(rz.metrics()["frames"][0]["copied_through"].get<bool>());

  // Sunk into the table at frame 1: rendered, and reported (resting on it at
  // frame 0 is not).
  Json sunk = base;
  sunk["virtual"][0].erase("transform");
  sunk["virtual"][0]["trajectory"] = Json::parse(R"([{"frame": 0, "translation": [0.1, 0.9, 0]},
                                                      {"frame": 1, "translation": [0.1, 0.8, 0]}])");
  Report rk("mr-render", "test");
  RenderVariant(sunk, "sunk", o, &rk);
  const std::string warnings = rk.ToJson()["warnings"].dump();
  EXPECT_NE(warnings.find("frame 1: virtual object"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("passes through real geometry"), std::string::npos) << warnings;
  EXPECT_EQ(warnings.find("frame 0: virtual object"), std::string::npos) << warnings;

  // No map at or before the first frame.
  Json none = base;
  none["lighting"]["environment"] = "envs2/missing%05d.exr";
  Report rn("mr-render", "test");
  try {
    RenderVariant(none, "envs-none", o, &rn);
    ADD_FAILURE() << "rendered";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no environment map for frame 0"), std::string::npos) << e.what();
  }
}

// The environment as a video (an LDR 360-degree camera's): plate frame f is
// lit by the video's frame f, decoded through sRGB and scaled by
// environment_scale, and renders as the static scene under that decoded map
// (written as a float EXR: bit for bit); two equal frames are no change
// (the world kept); past the video's end its last frame is reused, and the
// report says so.  FFV1 (.mkv) is lossless, so frames keep their codes.
TEST_F(Capture, EnvironmentVideoLightsEachFrameByItsFrame) {
  const Json base = ReadJsonFile(Cap() / "scene.json");
  const Image sky = ReadImage(Cap() / "env.exr");
  const double scale = 4.0;  // the sky's 1/4 is code 255; the sun clips, as an LDR camera's would
  auto frame = [&](double gain) {
    Image f = Image::Rgb(sky.width(), sky.height());
    for (int y = 0; y < sky.height(); ++y)
      for (int x = 0; x < sky.width(); ++x)
        for (int c = 0; c < 3; ++c) f.at(x, y, c) = static_cast<float>(sky.at(x, y, c) * gain / scale);
    return f;
  };
  auto write_video = [&](const fs::path& p, const std::vector<double>& gains) {
    VideoWriter w(p, sky.width(), sky.height(), 30);
    for (double g : gains) w.Write(frame(g));
    w.Close();
  };
  write_video(Cap() / "env-ab.mkv", {1.0, 0.5});
  write_video(Cap() / "env-aa.mkv", {1.0, 1.0});
  write_video(Cap() / "env-a.mkv", {1.0});
  RenderOptions o;
  o.spp = 2;
  o.frame_end = 2;
  auto with_env = [&](const std::string& env) {
    Json j = base;
    j["lighting"]["environment"] = env;
    j["lighting"]["environment_scale"] = scale;
    return j;
  };
  Report rv("mr-render", "test");
  const fs::path dyn = RenderVariant(with_env("env-ab.mkv"), "env-video", o, &rv);
  EXPECT_TRUE(rv.metrics()["frames"][1]["world"]["environment"].get<bool>()) << rv.metrics()["frames"][1].dump();
  for (int f = 0; f < 2; ++f) {
    SCOPED_TRACE(f);
    WriteImage(Cap() / fmt::format("env-video-{}.exr", f), VideoReader(Cap() / "env-ab.mkv").Frame(f));
    RenderOptions os = o;
    os.frame_begin = f;
    os.frame_end = f + 1;
    Report rs("mr-render", "test");
    const fs::path stat =
        RenderVariant(with_env(fmt::format("env-video-{}.exr", f)), fmt::format("env-video-static-{}", f), os, &rs);
    const auto name = fmt::format("{:05d}.exr", f);
    EXPECT_EQ(ReadImage(dyn / name).Layer("composite").values(), ReadImage(stat / name).Layer("composite").values());
  }
  // The decoded frame is the written one through 8 bits: its mean within
  // half a code of the sky's (clipped) mean.
  {
    const Image decoded = VideoReader(Cap() / "env-ab.mkv").Frame(0);
    const Image written = frame(1.0);
    double d = 0, w = 0;
    for (size_t i = 0; i < decoded.values().size(); ++i) {
      d += decoded.values()[i];
      w += std::min(1.0f, written.values()[i]);
    }
    EXPECT_NEAR(d / w, 1.0, 0.01);
  }
  Report ra("mr-render", "test");
  RenderVariant(with_env("env-aa.mkv"), "env-video-aa", o, &ra);
  EXPECT_EQ(ra.metrics()["world"]["frames_kept"], 1) << ra.metrics()["world"].dump();
  Report r1("mr-render", "test");
  const fs::path a = RenderVariant(with_env("env-a.mkv"), "env-video-a", o, &r1);
  EXPECT_NE(r1.ToJson().dump().find("frame 1 has no environment map of its own: the video's last, frame 0's"),
            std::string::npos)
      << r1.ToJson().dump();
  EXPECT_EQ(r1.metrics()["world"]["frames_kept"], 1);
  // The same file rewritten with another light: read again, not the
  // frame this process decoded before.
  write_video(Cap() / "env-a.mkv", {0.5});
  Report r2("mr-render", "test");
  const fs::path a2 = RenderVariant(with_env("env-a.mkv"), "env-video-a2", o, &r2);
  EXPECT_NE(ReadImage(a / "00000.exr").Layer("composite").values(),
            ReadImage(a2 / "00000.exr").Layer("composite").values());
}

// A virtual torch (a spot light in the `virtual` list) that moves between
// the two frames: frame 1 of the dynamic job is, byte for byte (pt), the
// static scene with the torch where its trajectory puts it; the report
// says the torch moved and the lights changed; vct, with nothing but a
// light moved, injects again and keeps its whole voxelisation.
TEST_F(Capture, AVirtualLightFollowsItsTrajectory) {
  const Json base = ReadJsonFile(Cap() / "scene.json");
  const Json torch = Json::parse(R"({"type": "spot", "position": [0, 0, 0], "direction": [0, -1, 0],
                                     "intensity": [3, 3, 2], "cone_deg": 30})");
  Json moving = base;
  moving["virtual"].push_back(
      {{"name", "torch"}, {"light", torch}, {"trajectory", Json::parse(R"([{"frame": 0, "translation": [-0.4, 1.6, 0]},
                                  {"frame": 1, "translation": [0.4, 1.5, 0.2], "rotation_deg": [20, 0, 0]}])")}});
  Json still = base;
  still["virtual"].push_back(
      {{"name", "torch"},
       {"light", torch},
       {"transform", Json::parse(R"({"translation": [0.4, 1.5, 0.2], "rotation_deg": [20, 0, 0]})")}});
  RenderOptions o;
  o.method = "pt";
  o.spp = 2;
  o.frame_end = 2;
  Report rd("mr-render", "test"), rs("mr-render", "test");
  const fs::path dyn = RenderVariant(moving, "torch-moving", o, &rd);
  o.frame_begin = 1;
  const fs::path stat = RenderVariant(still, "torch-still", o, &rs);
  EXPECT_EQ(ReadImage(dyn / "00001.exr").Layer("composite").values(),
            ReadImage(stat / "00001.exr").Layer("composite").values());
  const Json& w = rd.metrics()["frames"][1]["world"];
  EXPECT_EQ(w["moved_lights"], Json::array({"torch"}));
  EXPECT_TRUE(w["lights"].get<bool>());
  EXPECT_EQ(w["moved"].size(), 0u);
  o.method = "vct";
  o.frame_begin = 0;
  Report rv("mr-render", "test");
  RenderVariant(moving, "torch-moving", o, &rv);
  EXPECT_EQ(rv.metrics()["vct"]["frames"]["1"]["voxelised"], "kept") << rv.metrics()["frames"][1]["world"].dump();
}

// An object that leaves the view and comes back (frame 1: 40 m away,
// behind the camera; frames 0 and 2 on the table): frame 1's composite is
// the plate, but for the object's far-away light (mean |difference| under
// 1e-3 of the mean plate); frame 2 is, byte
// for byte (pt), the static scene at frame 2's pose; ic, whose records on
// the object were dropped when it left, makes them again when it returns.
TEST_F(Capture, AnObjectLeavesTheViewAndComesBack) {
  // Three frames: the capture's two, and the second again a frame later.
  Json base = ReadJsonFile(Cap() / "scene.json");
  fs::create_directories(Cap() / "photos3");
  for (int f = 0; f < 3; ++f)
    fs::copy_file(Cap() / "photos" / fmt::format("{:05d}.exr", std::min(f, 1)),
                  Cap() / "photos3" / fmt::format("{:05d}.exr", f), fs::copy_options::overwrite_existing);
  Trajectory t = ReadTum(Cap() / "trajectory.txt");
  t.poses.push_back({t.poses.back().timestamp + 1 / 30.0, t.poses.back().world_from_cam});
  WriteTum(Cap() / "trajectory3.txt", t);
  base["camera"]["frames"] = "photos3/%05d.exr";
  base["camera"]["poses"]["path"] = "trajectory3.txt";
  base.erase("reference");
  Json j = base;
  j["virtual"][0].erase("transform");
  j["virtual"][0]["trajectory"] = Json::parse(R"([
    {"frame": 0, "translation": [0.1, 0.9, 0]},
    {"frame": 1, "translation": [0.1, 0.9, -40]},
    {"frame": 2, "translation": [0.12, 0.9, 0.02]}])");
  Json still = base;
  still["virtual"][0]["transform"] = {{"translation", {0.12, 0.9, 0.02}}};
  RenderOptions o;
  o.method = "pt";
  o.spp = 2;
  o.frame_end = 3;
  Report rd("mr-render", "test"), rs("mr-render", "test"), ri("mr-render", "test");
  const fs::path dyn = RenderVariant(j, "away", o, &rd);
  const Image away = ReadImage(dyn / "00001.exr");
  Image diff = away.Layer("difference");
  for (float& v : diff.values()) v = std::abs(v);
  EXPECT_LT(MeanOfValues(diff), 1e-3 * MeanOfValues(away.Layer("photo")));
  o.frame_begin = 2;
  const fs::path stat = RenderVariant(still, "back", o, &rs);
  EXPECT_EQ(ReadImage(dyn / "00002.exr").Layer("composite").values(),
            ReadImage(stat / "00002.exr").Layer("composite").values());
  o.method = "ic";
  o.frame_begin = 0;
  RenderVariant(j, "away", o, &ri);
  const Json& ic = ri.metrics()["ic"]["frames"];
  EXPECT_GT(ic["2"]["records_created"].get<int64_t>(), 0);
  for (int f = 0; f < 3; ++f) {
    const Image frame = ReadImage(dir_->path() / "away-ic" / fmt::format("{:05d}.exr", f));
    for (float v : frame.values()) ASSERT_TRUE(std::isfinite(v)) << f;
  }
}

// A lamp switched from nothing to 1e4 W/sr between two frames (lights per
// frame): ic's records, made under the dark frame, are all re-evaluated at
// once, not kept until they age out (the paper's t_max is no answer to a
// lamp switched on); they keep their places, so the interpolation does not
// jump.  Every value is finite.
TEST_F(Capture, LampSwitchedOnReevaluatesTheWholeCache) {
  const Json base = ReadJsonFile(Cap() / "scene.json");
  fs::create_directories(Cap() / "lamps");
  Light lamp;
  lamp.name = "lamp";
  lamp.type = LightType::kPoint;
  lamp.position = Eigen::Vector3d(0.6, 1.6, -0.4);
  lamp.intensity = Eigen::Vector3d::Constant(1e4);
  WriteTextFile(Cap() / "lamps" / "00000.json", LightsToJson({}).dump(2));
  WriteTextFile(Cap() / "lamps" / "00001.json", LightsToJson({lamp}).dump(2));
  Json j = base;
  j["lighting"]["lights"] = "lamps/%05d.json";
  Json k = base;
  k["lighting"]["lights"] = "lamps/00001.json";
  RenderOptions o;
  o.method = "ic";
  o.spp = 2;
  o.frame_end = 2;
  Report rd("mr-render", "test");
  const fs::path dir = RenderVariant(j, "lamps", o, &rd);
  EXPECT_TRUE(rd.metrics()["frames"][1]["world"]["lights"].get<bool>());
  // Every record of frame 0 is re-evaluated under the new light at frame 1
  // (not when it is t_max frames old), in place.
  const Json& ic = rd.metrics()["ic"]["frames"];
  const int64_t records0 = ic["0"]["records"].get<int64_t>();
  EXPECT_GT(records0, 0);
  EXPECT_EQ(ic["1"]["records_reevaluated"].get<int64_t>(), records0);
  EXPECT_EQ(rd.metrics()["frames"][1]["world"]["rebuilt"],
            Json::array({fmt::format("irradiance cache: the {} records re-evaluated in place (new light)", records0)}));
  // The frame is lit as the same frame rendered with the lamp on from the
  // start: each layer's mean within 1% (ic's records differ in place, not
  // in what they integrate; measured 0.1%).
  o.frame_begin = 1;
  Report rs("mr-render", "test");
  const fs::path alone = RenderVariant(k, "lamp-on", o, &rs);
  const Image frame1 = ReadImage(dir / "00001.exr"), still = ReadImage(alone / "00001.exr");
  for (const char* layer : {"mixed", "real"})
    EXPECT_NEAR(MeanOfValues(frame1.Layer(layer)) / MeanOfValues(still.Layer(layer)), 1.0, 0.01) << layer;
  const Image dyn = frame1.Layer("composite");
  for (float v : dyn.values()) ASSERT_TRUE(std::isfinite(v));
  EXPECT_GT(MeanOfValues(dyn), 2 * MeanOfValues(ReadImage(dir / "00000.exr").Layer("composite")));
}

// mr-synth --dynamic (3 frames): the sun moves, the spot lamp switches on at
// the middle frame, the object slides across the table and turns; the truth is
// rendered per frame in that frame's world.  Each method renders it; each
// frame's report says what changed (the map and the object every frame,
// the lights once), what the method rebuilt, and the error and flicker.
// Rendered as the world stands (pt, 64 spp), every later frame is at least
// 3x closer to its truth, in the object's region, than the same render
// with the world of frame 0 held (the light and the object left where they
// were; the truth at 256 spp and pt's own noise limit the ratio); the
// other methods (ic at 8 spp, vpl 2, vct 4) stay within 10x pt's error on
// every frame (their static figures are 1-5x: docs/benchmarks.md).  (The
// truth's own noise, with the sun's fireflies, is why the check is against
// a stale world and not pt's fall with spp: issue 22.  Sample counts are
// low so that the sanitizer suite runs it in minutes.)
TEST(DynamicCapture, EveryMethodFollowsTheChangingWorld) {
  test::TempDir dir;
  SynthOptions so;
  so.out = dir.path() / "cap";
  so.dynamic = true;
  so.frames = 3;
  so.truth_spp = 256;
  so.probe = false;
  Report rsyn("mr-synth", "test");
  RunSynth(so, &rsyn);
  const Scene scene = ReadScene(so.out / "scene.json");
  ASSERT_TRUE(scene.lighting.environment_per_frame);
  ASSERT_EQ(scene.virtuals[0].keyframes.size(), 2u);
  Json stale = ReadJsonFile(so.out / "scene.json");  // frame 0's world held
  stale["lighting"] = {{"environment", "env/00000.exr"}, {"lights", "lights/00000.json"}};
  stale["virtual"][0]["trajectory"].erase(1);
  WriteTextFile(so.out / "stale.json", stale.dump(2));
  auto render = [&](const Scene& sc, const std::string& method, int spp) {
    RenderOptions o;
    o.method = method;
    o.spp = spp;
    o.out_dir = dir.path() / fmt::format("{}-{}-{}", sc.file.stem().string(), method, spp);
    Report r("mr-render", "test");
    RunRenderJob(sc, o, &r);
    return r.metrics();
  };
  const Json pt = render(scene, "pt", 64), held = render(ReadScene(so.out / "stale.json"), "pt", 64);
  for (int f = 1; f < 3; ++f) {
    const Json& b = pt["frames"][f];
    EXPECT_LT(3 * b["region_relmse"].get<double>(), held["frames"][f]["region_relmse"].get<double>()) << f;
    EXPECT_TRUE(b["world"]["environment"].get<bool>()) << f;
    EXPECT_EQ(b["world"]["moved"], Json::array({"object"})) << f;
    EXPECT_EQ(b["world"]["lights"].get<bool>(), f == 1) << f;  // the lamp switches on at frame 3 / 2
    EXPECT_EQ(b["world"]["rebuilt"].size(), 0u) << f;          // pt keeps nothing between frames
    EXPECT_GE(b["flicker"].get<double>(), 0.0);
  }
  std::printf("pt: region relMSE %.4g (the world of frame 0 held: %.4g), flicker %.4g\n",
              pt["region_relmse"].get<double>(), held["region_relmse"].get<double>(), pt["flicker"].get<double>());
  for (const std::string method : {"ic", "vpl", "vct"}) {
    const Json m = render(scene, method, method == "vpl" ? 2 : method == "ic" ? 8 : 4);
    for (int f = 0; f < 3; ++f)
      EXPECT_LT(m["frames"][f]["region_relmse"].get<double>(),
                10 * pt["frames"][f]["region_relmse"].get<double>() + 1e-3)
          << method << " frame " << f;
    EXPECT_EQ(m["frames"][1]["world"]["rebuilt"].size(), 1u) << method;
    std::printf("%s: region relMSE %.4g, flicker %.4g\n", method.c_str(), m["region_relmse"].get<double>(),
                m["flicker"].get<double>());
  }
}

TEST(Composite, DifferentialFormulaAndNegativeClamp) {
  Image photo = Image::Rgb(2, 1, 0.5f), mixed = Image::Rgb(2, 1, 0.2f), real = Image::Rgb(2, 1, 0.4f);
  Image mask = Image::Gray(2, 1, 0.0f);
  mask.at(0, 0, 0) = 0.25f;
  mixed.at(1, 0, 0) = 0.0f;
  real.at(1, 0, 0) = 1.0f;  // a shadow deeper than the photograph allows
  CompositeResult c = Composite(photo, mixed, real, mask);
  EXPECT_FLOAT_EQ(c.composite.at(0, 0, 1), 0.25f * 0.2f + 0.75f * (0.5f + 0.2f - 0.4f));
  EXPECT_EQ(c.composite.at(1, 0, 0), 0.0f);
  EXPECT_EQ(c.clamped_negative, 1);
  EXPECT_FLOAT_EQ(c.difference.at(1, 0, 0), -1.0f);
}

// A clipped plate channel holds a lower bound: a change smaller than a
// tenth of it is hidden by the unknown excess and the plate's value kept; a
// larger one (a deep shadow across a blown-out wall) is composited and
// counted; pixels the object covers and channels that did not clip are
// never touched.
TEST(Composite, ClippedChannelsKeepTheirCodeUnderSmallChanges) {
  const Image photo = Image::Rgb(4, 1, 2.0f);
  Image clipped = Image::Rgb(4, 1, 0.0f), mask = Image::Gray(4, 1, 0.0f), comp = Image::Rgb(4, 1, 2.0f);
  for (int x = 0; x < 4; ++x) clipped.at(x, 0, 0) = 1;  // red clipped everywhere
  comp.at(0, 0, 0) = 1.9f;                              // a 5% shadow: hidden
  comp.at(1, 0, 0) = 1.0f;                              // a 50% shadow: shown
  comp.at(2, 0, 0) = 1.9f;                              // under the object
  mask.at(2, 0, 0) = 0.5f;
  comp.at(3, 0, 1) = 1.9f;  // green did not clip: composited as it is
  const ClippedChannels k = KeepClippedChannels(photo, clipped, mask, &comp);
  EXPECT_EQ(comp.at(0, 0, 0), 2.0f);
  EXPECT_EQ(comp.at(1, 0, 0), 1.0f);
  EXPECT_EQ(comp.at(2, 0, 0), 1.9f);
  EXPECT_EQ(comp.at(3, 0, 1), 1.9f);
  EXPECT_EQ(k.kept, 1);
  EXPECT_EQ(k.changed, 1);
}

TEST(Metrics, KnownValues) {
  Image a = Image::Rgb(8, 8, 0.5f), b = Image::Rgb(8, 8, 0.5f);
  ImageMetrics same = CompareImages(a, b);
  EXPECT_EQ(same.rmse, 0.0);
  EXPECT_NEAR(same.ssim, 1.0, 1e-12);
  a.at(2, 3, 1) = 0.6f;  // one value off by 0.1 out of 192
  ImageMetrics m = CompareImages(a, b);
  EXPECT_NEAR(m.rmse, std::sqrt(0.01 / 192), 1e-7);
  EXPECT_NEAR(m.relmse, 0.01 / (0.25 + kRelMseEpsilon) / 192, 1e-8);
  EXPECT_NEAR(m.psnr, 10 * std::log10(1.0 / (0.01 / 192)), 1e-4);
  EXPECT_LT(m.ssim, 1.0);
  Image region = Image::Gray(8, 8, 0.0f);
  region.at(2, 3, 0) = 1;
  EXPECT_NEAR(CompareImages(a, b, &region).rmse, std::sqrt(0.01 / 3), 1e-7);
  EXPECT_THROW(CompareImages(a, Image::Rgb(4, 4)), Error);
}

// EstimateTruthNoise from a render stopped part-way: per pixel a true
// difference d and samples d + sigma g (g standard normal); the means of
// the first n1 and of all n samples.  The truth's variance is sigma^2 / n, so
// the estimate must be the mean of sigma^2 / n / (T^2 + 0.01).  30 000
// values: the estimate's own relative spread is about sqrt(2 / 30000) =
// 0.8%; 5% is six of those.  Equal and unequal parts.
TEST(TruthNoise, EstimateIsTheVarianceOfTheMeanOfAllSamples) {
  for (const auto& [n1, n] : {std::pair{32, 64}, std::pair{3, 10}}) {
    Pcg32 rng(7, static_cast<uint64_t>(n1));
    auto gauss = [&] {
      const double u1 = std::max(1e-12, rng.NextDouble()), u2 = rng.NextDouble();
      return std::sqrt(-2 * std::log(u1)) * std::cos(kTwoPi * u2);
    };
    const int w = 100, h = 100;
    Image real = Image::Rgb(w, h), mixed = Image::Rgb(w, h), real_half = Image::Rgb(w, h),
          mixed_half = Image::Rgb(w, h);
    double expected = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          const double photo = 0.2 + 0.01 * c, d = -0.1 + 0.002 * x, sigma = 0.05 + 0.001 * y;
          // The mean of n1 samples and of the other n - n1, drawn as their sums.
          const double a = d + sigma * gauss() / std::sqrt(n1), b = d + sigma * gauss() / std::sqrt(n - n1);
          const double t = (n1 * a + (n - n1) * b) / n;
          real.at(x, y, c) = real_half.at(x, y, c) = static_cast<float>(photo);
          mixed_half.at(x, y, c) = static_cast<float>(photo + a);
          mixed.at(x, y, c) = static_cast<float>(photo + t);
          expected += sigma * sigma / n / ((photo + t) * (photo + t) + kRelMseEpsilon);
        }
    expected /= 3.0 * w * h;
    const TruthNoise noise = EstimateTruthNoise(mixed_half, real_half, mixed, real, n1, n);
    EXPECT_NEAR(noise.region_relmse / expected, 1.0, 0.05) << n1 << " of " << n;
    EXPECT_NEAR(noise.relmse, noise.region_relmse, 1e-12);  // every pixel changed
  }
  EXPECT_THROW(EstimateTruthNoise(Image::Rgb(2, 2), Image::Rgb(2, 2), Image::Rgb(2, 2), Image::Rgb(2, 2), 4, 4), Error);
}

// mr-synth's truth states its own noise, and pt's error against it falls as
// 1/spp down to it: a render at s spp and the n-spp truth are independent
// estimates of the same image, so the expected error is
// v/s + v/n = noise (n/s + 1), with v the per-sample variance (the same
// tracer).  Checked on the small capture with a diffuse table top, truth
// 64 spp, pt 1..64 spp: the error never under the stated noise (half of
// it: the estimates' own spread), at 64 spp between 1.2 and 5 times it (2
// ideally; pt's plate reflections lower its variance), and with the noise
// taken off the error falls by 8-32x from 1 to 16 spp (16 ideally).
// Measured 2026-12-03: noise 8.2e-4, 1.56x it at 64 spp, a fall of 14.8.
// With the glossy table top the sun's reflection in the table lights the
// room through caustic paths (camera -> wall or floor -> glossy table ->
// sun): rare samples thousands of times the mean, so that one seed's error
// rose from 32 to 64 spp (5.8e-3 to 1.1e-2; issue 22) -- a heavy tail no
// fixed number of samples can check.
TEST(TruthNoise, PtFallsAsOneOverSppDownToTheTruthsNoise) {
  test::TempDir dir;
  SynthOptions so;
  so.out = dir.path() / "cap";
  so.frames = 1;
  so.truth_spp = 64;
  so.probe = false;
  so.table_top = "diffuse";
  Report rs("mr-synth", "test");
  RunSynth(so, &rs);
  const double noise = rs.metrics()["truth_noise_region_relmse"];
  ASSERT_GT(noise, 0.0);
  EXPECT_LE(rs.metrics()["truth_noise_relmse"].get<double>(), noise);  // the unchanged pixels carry none
  RenderOptions o;
  o.spp = 64;
  o.out_dir = dir.path() / "pt";
  Report r("mr-render", "test");
  RunRenderJob(ReadScene(so.out / "scene.json"), o, &r);
  const Json& curve = r.metrics()["curve"];
  ASSERT_EQ(curve.size(), 7u);  // 1, 2, 4, ..., 64 spp
  std::string figures;
  for (const auto& c : curve)
    figures += fmt::format(" {}:{:.3g}", c["spp"].get<int>(), c["region_relmse"].get<double>());
  for (const auto& c : curve) EXPECT_GT(c["region_relmse"].get<double>(), 0.5 * noise) << figures;
  const double e1 = curve[0]["region_relmse"], e16 = curve[4]["region_relmse"], e64 = curve[6]["region_relmse"];
  EXPECT_GT(e64 / noise, 1.2) << "noise " << noise << figures;
  EXPECT_LT(e64 / noise, 5.0) << "noise " << noise << figures;
  const double fall = (e1 - noise) / (e16 - noise);
  EXPECT_GT(fall, 8.0) << "noise " << noise << figures;
  EXPECT_LT(fall, 32.0) << "noise " << noise << figures;
}

// --truth-region-spp: the object's region (found by a pilot of its own seed)
// takes 8x the samples.  Outside it the truth is the plain truth's, bit for
// bit (the same samples in the same order); inside, its stated noise falls
// by at least 4x (8x for independent samples, 1/N; stratified samples fall
// faster where the integrand is smooth, so up to 64x is accepted; the
// pilot's region and the scoring region, ChangedRegion, are not the same
// pixels; measured 25x) and it agrees with the plain
// truth within their joint noise (mean squared difference at most 3x the
// sum of both noise figures, each relMSE-normalised alike).  Small capture,
// diffuse table top (no caustic fireflies to dominate one of the figures).
TEST(TruthNoise, RegionSamplesConvergeTheObjectsRegionOnly) {
  test::TempDir dir;
  SynthOptions so;
  so.frames = 1;
  so.truth_spp = 32;
  so.probe = false;
  so.table_top = "diffuse";
  so.out = dir.path() / "plain";
  Report plain_report("mr-synth", "test");
  RunSynth(so, &plain_report);
  so.out = dir.path() / "region";
  so.truth_region_spp = 256;
  Report region_report("mr-synth", "test");
  RunSynth(so, &region_report);
  const double plain_noise = plain_report.metrics()["truth_noise_region_relmse"];
  const double region_noise = region_report.metrics()["truth_noise_region_relmse"];
  const double share = region_report.metrics()["truth_region_share"];
  EXPECT_GT(share, 0.05);
  EXPECT_LT(share, 0.95);
  EXPECT_GT(plain_noise / region_noise, 4.0) << plain_noise << " " << region_noise;
  EXPECT_LT(plain_noise / region_noise, 64.0) << plain_noise << " " << region_noise;

  const Image plain = ReadImage(dir.path() / "plain" / "truth" / "00000.exr");
  const Image region = ReadImage(dir.path() / "region" / "truth" / "00000.exr");
  const Image photo = ReadImage(dir.path() / "plain" / "photos" / "00000.exr");
  const Image changed = ChangedRegion(plain, photo);
  int64_t same = 0, differ = 0;
  double sum = 0;
  int64_t values = 0;
  for (int y = 0; y < plain.height(); ++y)
    for (int x = 0; x < plain.width(); ++x) {
      bool equal = true;
      for (int c = 0; c < 3; ++c) {
        equal &= plain.at(x, y, c) == region.at(x, y, c);
        if (changed.at(x, y, 0) > 0) {
          const double t = plain.at(x, y, c), d = t - region.at(x, y, c);
          sum += d * d / (t * t + kRelMseEpsilon);
          ++values;
        }
      }
      (equal ? same : differ)++;
    }
  // Pixels outside the grown pilot region are untouched: at least the
  // share the pilot left out.
  EXPECT_GE(static_cast<double>(same) / (same + differ), 1.0 - share - 1e-9) << same << " " << differ;
  ASSERT_GT(values, 0);
  EXPECT_LT(sum / values, 3 * (plain_noise + region_noise)) << plain_noise << " " << region_noise;

  so.out = dir.path() / "odd";
  so.truth_region_spp = 255;
  Report odd_report("mr-synth", "test");
  EXPECT_THROW(RunSynth(so, &odd_report), UsageError);
  so.truth_region_spp = 16;
  EXPECT_THROW(RunSynth(so, &odd_report), UsageError);
}

}  // namespace
}  // namespace mr
