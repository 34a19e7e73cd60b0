#include "core/report.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/json.h"
#include "test_util.h"

namespace mr {
namespace {

TEST(Report, HasTheDocumentedLayout) {
  Report r("mr-test", "mr-test a b");
  r.AddInput("in.exr");
  r.AddOutput("out.exr");
  r.AddTiming("render", 1.5);
  r.AddTiming("render", 0.5);
  r.Skip("specular cones", "no glossy material in the scene");
  r.Warn("3 values clamped");
  r.SetMetric("error.rmse", 0.01);
  r.SetMetric("error.relmse", 0.02);
  Json j = r.ToJson();
  EXPECT_EQ(j["tool"], "mr-test");
  EXPECT_EQ(j["timings"]["render"], 2.0);
  EXPECT_EQ(j["skipped"][0]["what"], "specular cones");
  EXPECT_EQ(j["metrics"]["error"]["rmse"], 0.01);
  EXPECT_NO_THROW(ValidateReportJson(j, "r.json"));
  test::TempDir dir;
  r.Write(dir / "r.json");
  EXPECT_EQ(ReadJsonFile(dir / "r.json"), j);
  j["extra"] = 1;
  EXPECT_THROW(ValidateReportJson(j, "r.json"), Error);
  j.erase("extra");
  j["timings"]["x"] = -1;
  EXPECT_THROW(ValidateReportJson(j, "r.json"), Error);
}

TEST(Report, ScopedTimerAddsTime) {
  Report r("t", "t");
  { ScopedTimer t(&r, "part"); }
  EXPECT_GE(r.ToJson()["timings"]["part"].get<double>(), 0.0);
}

}  // namespace
}  // namespace mr
