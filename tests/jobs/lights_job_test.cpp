#include "jobs/lights_job.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/file.h"
#include "core/image.h"
#include "core/json.h"
#include "test_util.h"

namespace mr {
namespace {

TEST(LightsJob, LightNumberReadsOnlyMrLightsNames) {
  EXPECT_EQ(LightNumber("light0"), 0);
  EXPECT_EQ(LightNumber("light42"), 42);
  EXPECT_EQ(LightNumber("light"), -1);
  EXPECT_EQ(LightNumber("lightx"), -1);
  EXPECT_EQ(LightNumber("light4x"), -1);
  EXPECT_EQ(LightNumber("sun"), -1);
  EXPECT_EQ(LightNumber("light99999999999"), -1);  // would overflow an int
}

TEST(LightsJob, OptionsNameTheFlagAtFault) {
  LightsJobOptions o;
  o.env = "env.exr";
  auto message = [&] {
    try {
      o.Check();
    } catch (const UsageError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message().find("--out"), std::string::npos);
  o.out = "lights.json";
  EXPECT_EQ(message(), "");
  o.residual_width = 7;
  EXPECT_NE(message().find("--residual-width"), std::string::npos);
  o.residual_width = 64;
  o.sweep = true;
  o.table = "t.csv";
  o.counts = "1,x";
  EXPECT_NE(message().find("--counts"), std::string::npos);
  o.counts = "1,2";
  EXPECT_EQ(message(), "");
  o.env = "env/%05d.exr";
  EXPECT_NE(message().find("--sweep"), std::string::npos);
  o.sweep = false;
  EXPECT_NE(message().find("patterns"), std::string::npos);
  o.env = "env.exr";
  o.room = "room.ply";
  EXPECT_NE(message().find("--probe-at"), std::string::npos);
  o.probe_at = {0, 1, 0};
  EXPECT_NE(message().find("--method blobs"), std::string::npos);
  o.extract.method = "blobs";
  EXPECT_EQ(message(), "");
  o.room.clear();
  EXPECT_NE(message().find("--room"), std::string::npos);
  o.probe_at.clear();
  o.room_map = "room.exr";
  EXPECT_NE(message().find("--room-map needs --room"), std::string::npos);
}

// A map with one bright spot at column x.
Image SpotMap(int x) {
  Image m = Image::Rgb(64, 32);
  for (float& v : m.values()) v = 0.1f;
  for (int c = 0; c < 3; ++c) m.at(x, 12, c) = 500;
  return m;
}

// Over time, a lights file whose key matches is kept only when its lights
// carry mr-lights' names: one renamed by hand (or corrupted) is extracted
// again instead of failing on the name.
TEST(LightsJob, KeptFramesNeedMrLightsNames) {
  test::TempDir dir;
  fs::create_directories(dir.path() / "env");
  WriteImage(dir.path() / "env" / "00000.exr", SpotMap(10));
  WriteImage(dir.path() / "env" / "00001.exr", SpotMap(11));
  LightsJobOptions o;
  o.env = (dir.path() / "env" / "%05d.exr").string();
  o.out = (dir.path() / "lights" / "%05d.json").string();
  o.extract.method = "blobs";
  o.extract.count = 2;
  {
    Report r;
    RunLights(o, &r);
    EXPECT_EQ(r.metrics()["frames_kept"].get<int>(), 0);
  }
  {
    Report r;
    RunLights(o, &r);
    EXPECT_EQ(r.metrics()["frames_kept"].get<int>(), 2);
  }
  const fs::path first = dir.path() / "lights" / "00000.json";
  Json j = ReadJsonFile(first);
  ASSERT_FALSE(j["lights"].empty());
  j["lights"][0]["name"] = "lightx";
  WriteTextFile(first, j.dump(2));
  Report r;
  RunLights(o, &r);
  EXPECT_EQ(r.metrics()["frames_kept"].get<int>(), 1);
  EXPECT_FALSE(r.metrics()["frames"][0].contains("kept"));
  EXPECT_EQ(ReadJsonFile(first)["lights"][0]["name"], "light0");
}

}  // namespace
}  // namespace mr
