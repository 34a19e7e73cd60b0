#include "jobs/fuse_job.h"

#include <gtest/gtest.h>

#include "core/error.h"

namespace mr {
namespace {

// The flag a UsageError names ("" when the options pass).
std::string Refusal(const FuseJobOptions& o) {
  try {
    o.Check();
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

TEST(FuseJob, OptionsNameTheFlagAtFault) {
  FuseJobOptions o;
  o.input = "rgbd";
  o.out = "room";
  EXPECT_EQ(Refusal(o), "");
  o.rgbd.layout = "kinect";  // was a data error (exit 1) found after opening the recording
  EXPECT_NE(Refusal(o).find("--layout"), std::string::npos);
  o.rgbd.layout = "7scenes";
  o.roi = {1, 1, 1, 0, 0, 0};
  EXPECT_NE(Refusal(o).find("--roi"), std::string::npos);
  o.roi_scene = "scene.json";
  EXPECT_NE(Refusal(o).find("--roi-from"), std::string::npos);
  o.roi.clear();
  o.roi_scene.clear();
  o.fuse.icp.iterations = {1, 2, 3, 4, 5};
  EXPECT_NE(Refusal(o).find("--icp-iterations"), std::string::npos);
  o.fuse.icp.iterations = {10};
  o.first_pose = "origin";
  EXPECT_NE(Refusal(o).find("--first-pose"), std::string::npos);
  o.first_pose = "reference";
  EXPECT_EQ(Refusal(o), "");
}

}  // namespace
}  // namespace mr
