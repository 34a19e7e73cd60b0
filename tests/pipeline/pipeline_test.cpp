// mr-pipeline's planner and content hashes (the runs themselves are tested
// as users run them, in tests/cli/pipeline.sh).
#include "pipeline/pipeline.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "core/error.h"
#include "test_util.h"

namespace mr {
namespace {

TEST(ContentHash, FilesAndFoldersByContent) {
  test::TempDir dir;
  WriteTextFile(dir / "a.txt", "one");
  const uint64_t a = ContentHash(dir / "a.txt");
  WriteTextFile(dir / "a.txt", "one");  // rewritten, same content
  EXPECT_EQ(ContentHash(dir / "a.txt"), a);
  WriteTextFile(dir / "a.txt", "onf");  // one byte
  EXPECT_NE(ContentHash(dir / "a.txt"), a);
  WriteTextFile(dir / "a.txt", "one\n");  // one byte more
  EXPECT_NE(ContentHash(dir / "a.txt"), a);
  // A folder: names and contents, whatever the order files were made in.
  fs::create_directories(dir / "f1");
  fs::create_directories(dir / "f2");
  WriteTextFile(dir / "f1" / "x", "1");
  WriteTextFile(dir / "f1" / "y", "2");
  WriteTextFile(dir / "f2" / "y", "2");
  WriteTextFile(dir / "f2" / "x", "1");
  EXPECT_EQ(ContentHash(dir / "f1"), ContentHash(dir / "f2"));
  fs::rename(dir / "f2" / "y", dir / "f2" / "z");  // same bytes, another name
  EXPECT_NE(ContentHash(dir / "f1"), ContentHash(dir / "f2"));
  // Empty and 8-byte-aligned inputs differ from their neighbours.
  WriteTextFile(dir / "e", "");
  WriteTextFile(dir / "z8", std::string(8, '\0'));
  WriteTextFile(dir / "z9", std::string(9, '\0'));
  EXPECT_NE(ContentHash(dir / "e"), ContentHash(dir / "z8"));
  EXPECT_NE(ContentHash(dir / "z8"), ContentHash(dir / "z9"));
}

const PipelineStage& Stage(const Pipeline& p, const std::string& name) {
  for (const auto& s : p.stages)
    if (s.name == name) return s;
  throw std::runtime_error("no stage " + name);
}

TEST(PlanPipeline, LeavesOutWhatTheInputsDoNotNeed) {
  test::TempDir dir;
  for (const char* f : {"cam.cameramodel", "env.exr", "room.ply", "poses.txt", "ball.ply"}) WriteTextFile(dir / f, "x");
  WriteTextFile(dir / "p.json", R"({"version": 1,
    "camera": {"model": "cam.cameramodel"}, "lighting": {"environment": "env.exr"},
    "room": {"real": {"mesh": "room.ply"}}, "video": {"poses": {"tum": "poses.txt"}},
    "virtual": [{"mesh": "ball.ply"}], "render": {"method": "prt"}})");
  const Pipeline p = PlanPipeline(dir / "p.json");
  ASSERT_EQ(p.stages.size(), PipelineStageNames().size());
  for (const char* s :
       {"calibrate", "sphere", "hdr", "probe", "lights", "fuse", "register", "planes", "radiometry", "sweep"})
    EXPECT_FALSE(Stage(p, s).skip.empty()) << s;
  for (const char* s : {"formfactor", "scene", "render"}) EXPECT_TRUE(Stage(p, s).skip.empty()) << s;
  EXPECT_EQ(Stage(p, "formfactor").tool, "mr-formfactor");  // prt needs form factors
  EXPECT_EQ(p.scene["virtual"][0]["formfactors"], "object0.ffc");
  EXPECT_EQ(p.scene["real"][0]["mesh"], "../room.ply");  // relative to work/
  EXPECT_FALSE(p.scene["render"].contains("ic")) << "a given room keeps ic's own spacing";
}

// The main job's shape (examples/synthetic/pipeline.json): the light from a
// probe and the room from RGB-D with its albedo de-lit by that light, whose
// map the probe stage has yet to make.  (A regression: the plan asked for
// lighting.environment, which this file does not have, and nlohmann's
// out_of_range ended mr-pipeline.)
TEST(PlanPipeline, TheRoomIsDelitByTheMapTheProbeStageMakes) {
  test::TempDir dir;
  for (const char* f : {"cam.cameramodel", "probe.exr", "sphere.exr", "light.cameramodel", "poses.txt", "ball.ply"})
    WriteTextFile(dir / f, "x");
  fs::create_directories(dir / "rgbd");
  WriteTextFile(dir / "p.json", R"({"version": 1,
    "camera": {"model": "cam.cameramodel"},
    "lighting": {"probe": {"photos": "probe.exr",
                           "sphere": {"camera": "light.cameramodel", "photos": "sphere.exr", "radius": 0.0254}}},
    "room": {"rgbd": "rgbd"}, "video": {"poses": {"tum": "poses.txt"}},
    "virtual": [{"mesh": "ball.ply"}], "render": {"method": "pt"}})");
  const Pipeline p = PlanPipeline(dir / "p.json");
  const PipelineStage& fuse = Stage(p, "fuse");
  ASSERT_TRUE(fuse.skip.empty()) << fuse.skip;
  const auto env = std::find(fuse.args.begin(), fuse.args.end(), "--env");
  ASSERT_NE(env, fuse.args.end());
  EXPECT_EQ(fs::path(*(env + 1)).filename(), "env.exr");
  EXPECT_TRUE(Stage(p, "probe").skip.empty());
  // ic's records on a fused room's rough facets: spaced by 8 px (docs/methods.md,
  // "On a reconstructed room"), the plan saying so where ic renders; a user's
  // own value stands.
  EXPECT_EQ(p.scene["render"]["ic"]["min_spacing_px"], 8);
  EXPECT_EQ(p.scene["render"]["ic"]["normal_deg"], 90);
  EXPECT_EQ(Stage(p, "render").does.find("spaced by"), std::string::npos) << "pt renders: " << Stage(p, "render").does;
  const std::string file = ReadTextFile(dir / "p.json");
  const size_t render = file.find(R"("render": {"method": "pt"})");
  ASSERT_NE(render, std::string::npos);
  for (const char* block :
       {R"("render": {"method": "ic"})", R"("render": {"method": "ic", "ic": {"min_spacing_px": 3}})",
        R"("render": {"method": "ic", "ic": {"normal_deg": 20, "min_spacing_px": 3}})"}) {
    std::string edited = file;
    WriteTextFile(dir / "p.json", edited.replace(render, 26, block));
    const Pipeline q = PlanPipeline(dir / "p.json");
    const bool own = std::string(block).find("min_spacing_px") != std::string::npos;
    const bool own_normal = std::string(block).find("normal_deg") != std::string::npos;
    EXPECT_EQ(q.scene["render"]["ic"]["min_spacing_px"], own ? 3 : 8) << block;
    EXPECT_EQ(q.scene["render"]["ic"]["normal_deg"], own_normal ? 20 : 90) << block;
    const std::string& does = Stage(q, "render").does;
    EXPECT_EQ(does.find("spaced by 8 px") != std::string::npos, !own) << does;
    EXPECT_EQ(does.find("90-degree normal term") != std::string::npos, !own_normal) << does;
  }
}

// A world that changes: the light per frame (patterns) and an object's
// trajectory pass through to scene.json; extracting lights from a map per
// frame is refused (not built yet), naming the key.
TEST(PlanPipeline, PassesThePerFrameWorldThrough) {
  test::TempDir dir;
  for (const char* f : {"cam.cameramodel", "room.ply", "poses.txt", "ball.ply"}) WriteTextFile(dir / f, "x");
  fs::create_directories(dir / "env");
  fs::create_directories(dir / "lights");
  WriteTextFile(dir / "p.json", R"({"version": 1,
    "camera": {"model": "cam.cameramodel"},
    "lighting": {"environment": "env/%05d.exr", "lights": "lights/%05d.json"},
    "room": {"real": {"mesh": "room.ply"}}, "video": {"poses": {"tum": "poses.txt"}},
    "virtual": [{"mesh": "ball.ply", "trajectory": [{"frame": 0}, {"frame": 4, "translation": [1, 0, 0]}]}],
    "render": {"method": "pt"}})");
  const Pipeline p = PlanPipeline(dir / "p.json");
  EXPECT_EQ(p.scene["lighting"]["environment"], "../env/%05d.exr");
  EXPECT_EQ(p.scene["lighting"]["lights"], "../lights/%05d.json");
  EXPECT_EQ(p.scene["virtual"][0]["trajectory"].size(), 2u);
  WriteTextFile(dir / "q.json", R"({"version": 1,
    "camera": {"model": "cam.cameramodel"},
    "lighting": {"environment": "env/%05d.exr", "lights": {"options": {"count": 2}}},
    "room": {"real": {"mesh": "room.ply"}}, "video": {"poses": {"tum": "poses.txt"}},
    "virtual": [{"mesh": "ball.ply"}], "render": {"method": "pt"}})");
  // Lights extracted per frame: patterns in, patterns out.
  const Pipeline q = PlanPipeline(dir / "q.json");
  const PipelineStage& l = Stage(q, "lights");
  EXPECT_TRUE(l.skip.empty());
  EXPECT_EQ(l.args[2], (dir.path() / "work" / "lights" / "%05d.json").string());
  EXPECT_EQ(q.scene["lighting"]["lights"], "lights/%05d.json");
  EXPECT_EQ(q.scene["lighting"]["environment"], "env-residual/%05d.exr");
}

// A light camera's video: mr-probe makes a map per plate frame, matched to
// the video's poses by timestamp; the photograph stages say why they have
// nothing to do; the scene takes the maps' pattern.
TEST(PlanPipeline, CapturesTheLightFromALightVideo) {
  test::TempDir dir;
  for (const char* f : {"cam.cameramodel", "room.ply", "poses.txt", "ball.ply", "fe.cameramodel"})
    WriteTextFile(dir / f, "x");
  fs::create_directories(dir / "lightcam");
  WriteTextFile(dir / "lightcam" / "frames.txt", "0.0 00000.exr\n");
  WriteTextFile(dir / "p.json", R"({"version": 1,
    "camera": {"model": "cam.cameramodel"},
    "lighting": {"light_video": {"frames": "lightcam/frames.txt", "fisheye": "fe.cameramodel",
                                 "options": {"time-constant": 0.2}}},
    "room": {"real": {"mesh": "room.ply"}}, "video": {"poses": {"tum": "poses.txt"}},
    "virtual": [{"mesh": "ball.ply"}], "render": {"method": "pt"}})");
  const Pipeline p = PlanPipeline(dir / "p.json");
  const PipelineStage& s = Stage(p, "probe");
  EXPECT_TRUE(s.skip.empty());
  const std::vector<std::string> want = {"--light",         (dir.path() / "lightcam" / "frames.txt").string(),
                                         "--fisheye",       (dir.path() / "fe.cameramodel").string(),
                                         "--out",           (dir.path() / "work" / "env" / "%05d.exr").string(),
                                         "--plate-times",   (dir.path() / "poses.txt").string(),
                                         "--time-constant", "0.2"};
  EXPECT_EQ(s.args, want);
  EXPECT_EQ(s.inputs.front(), dir.path() / "lightcam");  // the list's folder: every frame's content
  EXPECT_EQ(p.scene["lighting"]["environment"], "env/%05d.exr");
  EXPECT_NE(Stage(p, "hdr").skip.find("light camera's video"), std::string::npos) << Stage(p, "hdr").skip;
  WriteTextFile(dir / "q.json", R"({"version": 1, "camera": {"model": "cam.cameramodel"},
    "lighting": {"environment": "x.exr", "light_video": {"frames": "lightcam/frames.txt", "fisheye": "fe.cameramodel"}},
    "room": {"real": {"mesh": "room.ply"}}, "video": {"poses": {"tum": "poses.txt"}},
    "virtual": [{"mesh": "ball.ply"}]})");
  EXPECT_THROW(PlanPipeline(dir / "q.json"), Error);
}

// room.planes: the room from the video's own points.  register keeps
// COLMAP's frame (no room to align to) and its points; planes turns them into
// the room in metres, turned to gravity, and the scene takes its mesh (albedo
// from its vertex colours) and its poses.  Without registration here, or
// without a height, an error naming the key.
TEST(PlanPipeline, ARoomFromTheVideosOwnPoints) {
  test::TempDir dir;
  for (const char* f : {"cam.cameramodel", "env.exr", "poses.txt", "ball.ply"}) WriteTextFile(dir / f, "x");
  fs::create_directories(dir / "video");
  WriteTextFile(dir / "p.json", R"({"version": 1,
    "camera": {"model": "cam.cameramodel"}, "lighting": {"environment": "env.exr"},
    "room": {"planes": {"height": 1.4, "options": {"cell": 0.03}}},
    "video": {"frames": "video/%05d.jpg", "poses": {"register": {"matcher": "exhaustive"}}},
    "virtual": [{"mesh": "ball.ply", "transform": {"at_pixel": {"frame": 0, "pixel": [320, 300]}}}],
    "render": {"method": "pt"}})");
  const Pipeline p = PlanPipeline(dir / "p.json");
  const fs::path work = dir.path() / "work";
  EXPECT_NE(Stage(p, "fuse").skip.find("room.planes"), std::string::npos);
  const PipelineStage& reg = Stage(p, "register");
  ASSERT_TRUE(reg.skip.empty());
  EXPECT_EQ(std::count(reg.args.begin(), reg.args.end(), "--trajectory"), 0);
  EXPECT_NE(std::find(reg.args.begin(), reg.args.end(), (work / "video" / "points.ply").string()), reg.args.end());
  const PipelineStage& planes = Stage(p, "planes");
  ASSERT_TRUE(planes.skip.empty()) << planes.skip;
  const std::vector<std::string> want = {(work / "video" / "points.ply").string(),
                                         "--poses",
                                         (work / "video" / "poses.txt").string(),
                                         "--camera",
                                         (dir.path() / "cam.cameramodel").string(),
                                         "--frames",
                                         (dir.path() / "video" / "%05d.jpg").string(),
                                         "--height",
                                         "1.4",
                                         "--world",
                                         "gravity",
                                         "--poses-out",
                                         (work / "room" / "poses.txt").string(),
                                         "--out",
                                         (work / "room" / "room.ply").string(),
                                         "--cell",
                                         "0.03"};
  EXPECT_EQ(planes.args, want);
  EXPECT_EQ(p.scene["real"][0]["mesh"], "room/room.ply");
  EXPECT_EQ(p.scene["real"][0]["material"]["albedo_from_vertex_colors"], true);
  EXPECT_EQ(p.scene["camera"]["poses"]["path"], "room/poses.txt");
  const auto& names = PipelineStageNames();
  auto at = [&](const char* n) { return std::find(names.begin(), names.end(), n) - names.begin(); };
  EXPECT_LT(at("register"), at("planes"));
  EXPECT_LT(at("planes"), at("lights"));
  auto error = [&](const std::string& text) {
    WriteTextFile(dir / "q.json", text);
    try {
      PlanPipeline(dir / "q.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error(R"({"version": 1, "camera": {"model": "cam.cameramodel"}, "lighting": {"environment": "env.exr"},
    "room": {"planes": {"height": 1.4}}, "video": {"poses": {"tum": "poses.txt"}}, "virtual": [{"mesh": "ball.ply"}]})")
                .find("room.planes needs the video registered here"),
            std::string::npos);
  EXPECT_NE(error(R"({"version": 1, "camera": {"model": "cam.cameramodel"}, "lighting": {"environment": "env.exr"},
    "room": {"planes": {}}, "video": {"frames": "video/%05d.jpg", "poses": {"register": true}},
    "virtual": [{"mesh": "ball.ply"}]})")
                .find("height"),
            std::string::npos);
}

// The mirror sphere in the plate: plate_probe runs after the plate's poses
// (here given) on WORK/plate.json, the plate's camera section that the
// stage writes first; lights come after it; the photograph stages say why
// they have nothing to do; a fused room cannot be de-lit by a light made
// after it, and a video environment is no map for mr-lights: errors naming
// the key.
TEST(PlanPipeline, CapturesTheLightFromTheSphereInThePlate) {
  test::TempDir dir;
  for (const char* f : {"cam.cameramodel", "room.ply", "poses.txt", "ball.ply", "env.mp4"}) WriteTextFile(dir / f, "x");
  fs::create_directories(dir / "plate");
  fs::create_directories(dir / "rgbd");
  WriteTextFile(dir / "p.json", R"({"version": 1,
    "camera": {"model": "cam.cameramodel"},
    "lighting": {"sphere_in_plate": {"centre": [-0.42, 0.85, -0.22], "radius": 0.1, "reflectance": 0.6,
                                     "options": {"time-constant": 0.2}},
                 "lights": {"options": {"count": 1}}},
    "room": {"real": {"mesh": "room.ply"}},
    "video": {"frames": "plate/%05d.exr", "frames_transfer": "linear", "poses": {"tum": "poses.txt"}},
    "virtual": [{"mesh": "ball.ply"}], "render": {"method": "pt"}})");
  const Pipeline p = PlanPipeline(dir / "p.json");
  const PipelineStage& s = Stage(p, "plate_probe");
  ASSERT_TRUE(s.skip.empty()) << s.skip;
  const fs::path work = dir.path() / "work";
  const std::vector<std::string> want = {"--sphere-in-plate",
                                         (work / "plate.json").string(),
                                         "--sphere",
                                         "-0.42,0.85,-0.22,0.1",
                                         "--out",
                                         (work / "env" / "%05d.exr").string(),
                                         "--reflectance",
                                         "0.6",
                                         "--time-constant",
                                         "0.2"};
  EXPECT_EQ(s.args, want);
  EXPECT_EQ(s.writes_first, work / "plate.json");
  EXPECT_EQ(s.writes_first_json["camera"]["frames"], "../plate/%05d.exr");
  EXPECT_FALSE(s.writes_first_json["camera"].contains("gains"));  // linear: fitted as a check, not applied
  EXPECT_EQ(s.writes_first_json["camera"]["poses"]["path"], "../poses.txt");
  const auto& names = PipelineStageNames();
  auto at = [&](const char* n) { return std::find(names.begin(), names.end(), n) - names.begin(); };
  EXPECT_LT(at("register"), at("plate_probe"));
  EXPECT_LT(at("plate_probe"), at("lights"));
  EXPECT_EQ(Stage(p, "lights").args[0], (work / "env" / "%05d.exr").string());
  EXPECT_NE(Stage(p, "probe").skip.find("plate_probe"), std::string::npos) << Stage(p, "probe").skip;
  EXPECT_NE(Stage(p, "hdr").skip.find("sphere in the plate"), std::string::npos) << Stage(p, "hdr").skip;

  // lighting.lights.place: the lights that land on the room are placed there
  // from the sphere's centre; with a separate probe (no shared world) or a
  // turned map it is refused, naming the key.
  WriteTextFile(dir / "placed.json", R"({"version": 1,
    "camera": {"model": "cam.cameramodel"},
    "lighting": {"sphere_in_plate": {"centre": [-0.42, 0.85, -0.22], "radius": 0.1},
                 "lights": {"place": true, "options": {"count": 2}}},
    "room": {"real": {"mesh": "room.ply"}},
    "video": {"frames": "plate/%05d.exr", "frames_transfer": "linear", "poses": {"tum": "poses.txt"}},
    "virtual": [{"mesh": "ball.ply"}], "render": {"method": "pt"}})");
  {
    const Pipeline placed = PlanPipeline(dir / "placed.json");
    const PipelineStage& l = Stage(placed, "lights");
    const std::vector<std::string> tail(l.args.begin() + 5, l.args.end());
    const std::vector<std::string> want_tail = {"--method",   "blobs",
                                                "--room",     (dir / "room.ply").string(),
                                                "--probe-at", "-0.42,0.85,-0.22",
                                                "--room-map", (placed.work / "env-room" / "%05d.exr").string(),
                                                "--count",    "2"};
    EXPECT_EQ(tail, want_tail);
    EXPECT_NE(std::find(l.inputs.begin(), l.inputs.end(), dir / "room.ply"), l.inputs.end());
    // The rest of the map is the room's own light, seen from the sphere.
    EXPECT_EQ(placed.scene["lighting"]["probes"],
              ParseJsonStrict(R"([{"at": [-0.42, 0.85, -0.22], "map": "env-room/%05d.exr"}])", "want"));
  }
  WriteTextFile(dir / "placed-env.json", R"({"version": 1, "camera": {"model": "cam.cameramodel"},
    "lighting": {"environment": "room.ply", "lights": {"place": true}},
    "room": {"real": {"mesh": "room.ply"}}, "video": {"poses": {"tum": "poses.txt"}},
    "virtual": [{"mesh": "ball.ply"}]})");
  try {
    PlanPipeline(dir / "placed-env.json");
    ADD_FAILURE() << "planned";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("lighting.lights.place"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("sphere in the plate"), std::string::npos) << e.what();
  }
  WriteTextFile(dir / "q.json", R"({"version": 1, "camera": {"model": "cam.cameramodel"},
    "lighting": {"sphere_in_plate": {"centre": [0, 1, 0], "radius": 0.1}},
    "room": {"rgbd": "rgbd"}, "video": {"frames": "plate/%05d.exr", "poses": {"fuse": true}},
    "virtual": [{"mesh": "ball.ply"}]})");
  try {
    PlanPipeline(dir / "q.json");
    ADD_FAILURE() << "planned";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("only once the plate's poses are known"), std::string::npos) << e.what();
  }
  WriteTextFile(dir / "v.json", R"({"version": 1, "camera": {"model": "cam.cameramodel"},
    "lighting": {"environment": "env.mp4", "lights": {"options": {}}},
    "room": {"real": {"mesh": "room.ply"}}, "video": {"poses": {"tum": "poses.txt"}},
    "virtual": [{"mesh": "ball.ply"}]})");
  try {
    PlanPipeline(dir / "v.json");
    ADD_FAILURE() << "planned";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("lighting.environment is a video"), std::string::npos) << e.what();
  }
}

// A plate's gains are fitted unless given, turned off or hand-set; the
// render (and the sweep) then depend on the fitted file.
TEST(PlanPipeline, FitsThePlatesGainsUnlessToldOtherwise) {
  test::TempDir dir;
  for (const char* f : {"cam.cameramodel", "env.exr", "room.ply", "poses.txt", "ball.ply", "g.json"})
    WriteTextFile(dir / f, "x");
  fs::create_directories(dir / "v");
  WriteTextFile(dir / "v" / "00000.jpg", "x");
  auto plan = [&](const std::string& video) {
    WriteTextFile(dir / "p.json", R"({"version": 1,
      "camera": {"model": "cam.cameramodel"}, "lighting": {"environment": "env.exr"},
      "room": {"real": {"mesh": "room.ply"}}, "video": {"frames": "v/%05d.jpg", "poses": {"tum": "poses.txt"})" +
                                      video + R"(}, "virtual": [{"mesh": "ball.ply"}]})");
    return PlanPipeline(dir / "p.json");
  };
  Pipeline p = plan("");
  const PipelineStage& r = Stage(p, "radiometry");
  EXPECT_TRUE(r.skip.empty());
  EXPECT_EQ(r.tool, "mr-eval");
  EXPECT_EQ(r.args[0], "plate");
  EXPECT_EQ(p.scene["camera"]["gains"], "radiometry/gains.json");
  const auto& in = Stage(p, "render").inputs;
  EXPECT_NE(std::find(in.begin(), in.end(), dir.path() / "work" / "radiometry" / "gains.json"), in.end());
  p = plan(R"(, "gains": {"options": {"spp": 64, "stride": 5}})");
  EXPECT_NE(std::find(Stage(p, "radiometry").args.begin(), Stage(p, "radiometry").args.end(), "--stride"),
            Stage(p, "radiometry").args.end());
  p = plan(R"(, "gains": false)");
  EXPECT_EQ(Stage(p, "radiometry").skip, "video.gains is false");
  EXPECT_FALSE(p.scene["camera"].contains("gains"));
  p = plan(R"(, "gains": "g.json")");
  EXPECT_FALSE(Stage(p, "radiometry").skip.empty());
  EXPECT_EQ(p.scene["camera"]["gains"], "../g.json");
  p = plan(R"(, "frames_transfer": "display", "exposure": 0.5)");
  EXPECT_NE(Stage(p, "radiometry").skip.find("hand-set"), std::string::npos);
  EXPECT_THROW(plan(R"(, "frames_transfer": "display", "exposure": 0.5, "gains": {"options": {}})"), Error);
  EXPECT_THROW(plan(R"(, "gains": true)"), Error);
  // A linear plate: fitted as a check, not applied unless asked.
  p = plan(R"(, "frames_transfer": "linear")");
  EXPECT_TRUE(Stage(p, "radiometry").skip.empty());
  EXPECT_FALSE(p.scene["camera"].contains("gains"));
  p = plan(R"(, "frames_transfer": "linear", "gains": {"apply": true, "scale": "room"})");
  EXPECT_EQ(p.scene["camera"]["gains"], "radiometry/gains.json");
  EXPECT_EQ(p.scene["camera"]["gains_scale"], "room");
  // video.refine_poses: the plate check refines them, the render takes them
  // (scene-plate.json keeps the registered ones it refines from).
  p = plan(R"(, "refine_poses": true)");
  const auto& ra = Stage(p, "radiometry").args;
  const auto it = std::find(ra.begin(), ra.end(), "--refine-poses");
  ASSERT_NE(it, ra.end());
  EXPECT_EQ(*std::next(it), (dir.path() / "work" / "radiometry" / "poses.tum").string());
  EXPECT_EQ(p.refined_poses, "radiometry/poses.tum");
  const auto& rin = Stage(p, "render").inputs;
  EXPECT_NE(std::find(rin.begin(), rin.end(), dir.path() / "work" / "radiometry" / "poses.tum"), rin.end());
  EXPECT_THROW(plan(R"(, "refine_poses": true, "gains": false)"), Error);  // no plate check to refine them
  // COLMAP's points as a prior need COLMAP's registration here: with a
  // given trajectory there are none, and that is an error naming the key.
  EXPECT_THROW(plan(R"(, "refine_poses": {"prior_weight": 1})"), Error);
  EXPECT_THROW(plan(R"(, "refine_poses": {"prior": 1})"), Error);  // an unknown key
}

// video.refine_poses.prior_weight: the register stage writes COLMAP's
// observations, the radiometry stage refines with them as a prior.
TEST(PlanPipeline, ColmapPointsAsAPriorInTheRefinement) {
  test::TempDir dir;
  for (const char* f : {"cam.cameramodel", "env.exr", "room.ply", "ball.ply"}) WriteTextFile(dir / f, "x");
  fs::create_directories(dir / "video");
  WriteTextFile(dir / "p.json", R"({"version": 1,
    "camera": {"model": "cam.cameramodel"}, "lighting": {"environment": "env.exr"},
    "room": {"real": {"mesh": "room.ply"}},
    "video": {"frames": "video/%05d.jpg", "refine_poses": {"prior_weight": 2},
              "poses": {"register": true, "initial": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}},
    "virtual": [{"mesh": "ball.ply"}]})");
  const Pipeline p = PlanPipeline(dir / "p.json");
  const fs::path obs = dir.path() / "work" / "video" / "observations.json";
  const PipelineStage& reg = Stage(p, "register");
  const auto o = std::find(reg.args.begin(), reg.args.end(), "--observations-out");
  ASSERT_NE(o, reg.args.end());
  EXPECT_EQ(*std::next(o), obs.string());
  EXPECT_NE(std::find(reg.outputs.begin(), reg.outputs.end(), obs), reg.outputs.end());
  const PipelineStage& rad = Stage(p, "radiometry");
  const auto pp = std::find(rad.args.begin(), rad.args.end(), "--prior-points");
  ASSERT_NE(pp, rad.args.end());
  EXPECT_EQ(*std::next(pp), obs.string());
  EXPECT_EQ(*std::next(pp, 2), "--prior-weight");
  EXPECT_EQ(*std::next(pp, 3), "2");
  EXPECT_NE(std::find(rad.inputs.begin(), rad.inputs.end(), obs), rad.inputs.end());
  EXPECT_NE(std::find(rad.args.begin(), rad.args.end(), "--refine-poses"), rad.args.end());
}

TEST(PlanPipeline, ErrorsNameTheFileAndKey) {
  test::TempDir dir;
  WriteTextFile(dir / "p.json", R"({"version": 1, "camera": {"model": "nothere.cameramodel"}})");
  try {
    PlanPipeline(dir / "p.json");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("p.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("camera.model"), std::string::npos) << e.what();
  }
  WriteTextFile(dir / "q.json", R"({"version": 2})");
  EXPECT_THROW(PlanPipeline(dir / "q.json"), Error);
  WriteTextFile(dir / "r.json", R"({"version": 1, "camera": )");
  EXPECT_THROW(PlanPipeline(dir / "r.json"), Error);
}

// --until and --force name stages of the table; a misspelt one is a usage
// error listing them, before any stage runs.
TEST(PipelineRunOptions, StagesAreCheckedAgainstTheTable) {
  PipelineRunOptions o;
  o.until = "render";
  o.force = {"fuse"};
  EXPECT_NO_THROW(o.Check());
  o.force = {"fusion"};
  try {
    o.Check();
    FAIL() << "--force fusion was accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("--force fusion: no such stage (stages: calibrate"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace mr
