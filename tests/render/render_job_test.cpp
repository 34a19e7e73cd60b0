// The render job on a small synthetic capture: convergence, determinism,
// the plate kept where the objects change nothing, outputs, prt, bad input.
#include "render/render_job_fixture.h"

namespace mr {
namespace render_job_test {
namespace {

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

// The objects' mask against the reference's changed region: the capture's
// own scene puts the object where the truth has it (most of the mask lies
// where the truth differs from the plate, no warning); moved 0.6 m sideways,
// the mask falls where the truth shows the room, and the report says so.
TEST_F(Capture, MovedObjectIsNamedAgainstItsReference) {
  const Json j = ReadJsonFile(Cap() / "scene.json");
  RenderOptions o;
  o.spp = 2;
  o.frame_end = 1;
  Report same("mr-render", "test");
  RenderVariant(j, "in-place", o, &same);
  EXPECT_GT(same.metrics()["frames"][0]["mask_in_reference_change"].get<double>(), 0.9);
  for (const std::string& w : same.warnings()) EXPECT_EQ(w.find("not where they were"), std::string::npos) << w;
  Json moved = j;
  moved["virtual"][0]["transform"]["matrix"][3] = moved["virtual"][0]["transform"]["matrix"][3].get<double>() + 0.6;
  Report r("mr-render", "test");
  RenderVariant(moved, "moved", o, &r);
  EXPECT_LT(r.metrics()["frames"][0]["mask_in_reference_change"].get<double>(), 0.5);
  bool named = false;
  for (const std::string& w : r.warnings()) named = named || w.find("not where they were") != std::string::npos;
  EXPECT_TRUE(named);
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
  Report r("mr-render", "test");
  Image out = RenderFirstFrame(s, 2, "empty", &r);
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

// lighting.probes through the job: a probe at frame 0's camera (its map the
// environment) gives the reflected points the plate does not see (behind
// the camera), counted in the frame's report; the report names the
// probes, vct says it renders the room instead, and a probe map with a
// NaN pixel is refused naming it before anything is written.
TEST_F(Capture, ProbesGiveTheRoomWhereThePlateDoesNot) {
  Json j = ReadJsonFile(Cap() / "scene.json");
  const Rigid3 pose = LoadScenePoses(ReadScene(Cap() / "scene.json"))[0];
  j["lighting"]["probes"] = Json::array({{{"at", {pose.translation.x(), pose.translation.y(), pose.translation.z()}}}});
  RenderOptions o;
  o.spp = 4;
  o.frame_end = 1;
  o.method = "pt";
  Report r("mr-render", "test");
  RenderVariant(j, "probes", o, &r);
  EXPECT_EQ(r.metrics()["probes"], 1);
  const Json& pr = r.metrics()["frames"][0]["plate_reflections"];
  std::printf("plate reflections: %s\n", pr.dump().c_str());
  EXPECT_GT(pr["from_probe"].get<int64_t>(), 0);
  EXPECT_GT(pr["from_plate"].get<int64_t>(), 0);
  o.method = "vct";
  Report rv("mr-render", "test");
  RenderVariant(j, "probes", o, &rv);
  bool said = false;
  for (const auto& sk : rv.skipped()) said = said || sk["what"] == "the probes' radiance";
  EXPECT_TRUE(said);
  Image env = ReadImage(Cap() / "env.exr");
  env.at(5, 2, 0) = std::numeric_limits<float>::infinity();
  WriteImage(Cap() / "bad-probe.exr", env);
  j["lighting"]["probes"][0]["map"] = "bad-probe.exr";
  o.method = "pt";
  Report rb("mr-render", "test");
  try {
    RenderVariant(j, "probes-bad", o, &rb);
    ADD_FAILURE() << "a probe map with an infinite pixel was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad-probe.exr"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir_->path() / "probes-bad-pt" / "00000.exr"));
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

}  // namespace
}  // namespace render_job_test
}  // namespace mr
