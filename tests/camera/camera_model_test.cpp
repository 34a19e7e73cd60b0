#include "camera/camera_model.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/math.h"
#include "core/sampling.h"
#include "test_util.h"

namespace mr {
namespace {

struct ModelCase {
  std::string lensmodel;
  std::vector<double> intrinsics;
  double max_off_axis_deg;  // round trips are tested up to this angle
};
void PrintTo(const ModelCase& c, std::ostream* os) { *os << c.lensmodel; }

std::vector<double> Splined(int nx, int ny) {
  std::vector<double> v = {300, 300, 319.5, 239.5};
  Pcg32 rng(3, 4);
  for (int i = 0; i < 2 * nx * ny; ++i) v.push_back(0.01 * (rng.NextDouble() - 0.5));
  return v;
}

std::vector<ModelCase> Cases() {
  return {
      {"LENSMODEL_PINHOLE", {500, 510, 319.5, 239.5}, 60},
      {"LENSMODEL_OPENCV4", {500, 510, 319.5, 239.5, -0.2, 0.05, 1e-3, -1e-3}, 40},
      {"LENSMODEL_OPENCV5", {500, 510, 319.5, 239.5, -0.2, 0.05, 1e-3, -1e-3, 0.01}, 40},
      {"LENSMODEL_OPENCV8", {500, 510, 319.5, 239.5, 0.3, 0.02, 1e-3, -1e-3, 0.001, 0.6, 0.05, 0.002}, 50},
      {"LENSMODEL_OPENCV12",
       {500, 510, 319.5, 239.5, 0.3, 0.02, 1e-3, -1e-3, 0.001, 0.6, 0.05, 0.002, 1e-3, -1e-3, 2e-3, 1e-4},
       50},
      {"LENSMODEL_CAHVOR", {500, 510, 319.5, 239.5, 0.01, -0.02, 0.0, -0.1, 0.02}, 40},
      {"LENSMODEL_CAHVORE_linearity=0.00", {500, 510, 319.5, 239.5, 0.01, -0.02, 0.0, -0.05, 0.01, 0.0, 0.0, 0.0}, 40},
      // Fish-eye models: beyond 90 degrees off axis.
      {"LENSMODEL_STEREOGRAPHIC", {300, 300, 319.5, 239.5}, 120},
      {"LENSMODEL_LONLAT", {200, 200, 319.5, 239.5}, 120},
      {"LENSMODEL_LATLON", {200, 200, 319.5, 239.5}, 120},
      {"LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=220", Splined(16, 12), 100},
  };
}

class LensModels : public ::testing::TestWithParam<ModelCase> {};

// Directions up to max_off_axis_deg from the optical axis, in every azimuth.
std::vector<Eigen::Vector3d> Directions(double max_deg) {
  std::vector<Eigen::Vector3d> d;
  for (double th = 0; th <= max_deg + 1e-9; th += max_deg / 8)
    for (double az = 15; az < 360; az += 30) {  // 15 + 30k: never on the lon/lat seam x = 0
      const double t = th * kDegToRad, a = az * kDegToRad;
      d.emplace_back(std::sin(t) * std::cos(a), std::sin(t) * std::sin(a), std::cos(t));
    }
  return d;
}

TEST_P(LensModels, ProjectUnprojectRoundTrip) {
  const ModelCase& mc = GetParam();
  CameraModel m(mc.lensmodel, mc.intrinsics, 640, 480);
  int tested = 0, beyond90 = 0;
  for (const Eigen::Vector3d& d : Directions(mc.max_off_axis_deg)) {
    Eigen::Vector2d q;
    ASSERT_TRUE(m.Project(d, &q)) << d.transpose();
    Eigen::Vector3d back;
    ASSERT_TRUE(m.Unproject(q, &back)) << mc.lensmodel << " at " << q.transpose();
    // Unprojection is an iterative solve converging to ~1e-9 px; 1e-6 rad
    // bounds its error for focal lengths of a few hundred pixels.
    EXPECT_LT(AngleBetween(back, d), 1e-6) << mc.lensmodel << " dir " << d.transpose();
    Eigen::Vector2d q2;
    ASSERT_TRUE(m.Project(back, &q2));
    EXPECT_LT((q2 - q).norm(), 1e-5) << mc.lensmodel;
    ++tested;
    if (d.z() < 0) ++beyond90;
  }
  EXPECT_GT(tested, 50);
  if (mc.max_off_axis_deg > 90) {
    EXPECT_GT(beyond90, 0);
    EXPECT_TRUE(m.SeesBehind());
  }
}

// From a neighbouring ray (half a pixel away, and from a ray ten degrees
// away) UnprojectNear lands on Unproject's ray: both converge to a small
// fraction of a pixel, 1e-6 rad as above.
TEST_P(LensModels, UnprojectNearAgreesWithUnproject) {
  const ModelCase& mc = GetParam();
  CameraModel m(mc.lensmodel, mc.intrinsics, 640, 480);
  int tested = 0;
  for (const Eigen::Vector3d& d : Directions(mc.max_off_axis_deg)) {
    Eigen::Vector2d q;
    ASSERT_TRUE(m.Project(d, &q));
    Eigen::Vector3d exact, from_neighbour, from_far, neighbour, far_ray;
    ASSERT_TRUE(m.Unproject(q, &exact));
    if (!m.Unproject(q + Eigen::Vector2d(0.5, -0.25), &neighbour)) continue;
    ASSERT_TRUE(m.UnprojectNear(q, neighbour, &from_neighbour)) << mc.lensmodel << " at " << q.transpose();
    EXPECT_LT(AngleBetween(from_neighbour, exact), 1e-6) << mc.lensmodel << " at " << q.transpose();
    EXPECT_NEAR(from_neighbour.norm(), 1.0, 1e-12);
    far_ray = Eigen::AngleAxisd(10 * kDegToRad, Eigen::Vector3d::UnitY()) * exact;
    ASSERT_TRUE(m.UnprojectNear(q, far_ray, &from_far)) << mc.lensmodel << " at " << q.transpose();
    EXPECT_LT(AngleBetween(from_far, exact), 1e-6) << mc.lensmodel << " at " << q.transpose();
    ++tested;
  }
  EXPECT_GT(tested, 50);
  Eigen::Vector3d out;
  EXPECT_FALSE(m.UnprojectNear(Eigen::Vector2d(NAN, 1), Eigen::Vector3d::UnitZ(), &out));
}

TEST_P(LensModels, FileRoundTripIsExact) {
  const ModelCase& mc = GetParam();
  test::TempDir dir;
  double rt[6] = {0.1, -0.2, 0.3, 1.0, 2.0, -3.0};
  CameraModel m(mc.lensmodel, mc.intrinsics, 640, 480, Rigid3::FromRt(rt));
  m.Write(dir / "a.cameramodel");
  CameraModel back = CameraModel::Read(dir / "a.cameramodel");
  EXPECT_EQ(back.lensmodel(), m.lensmodel());
  EXPECT_EQ(back.width(), 640);
  EXPECT_EQ(back.height(), 480);
  ASSERT_EQ(back.intrinsics().size(), m.intrinsics().size());
  // mrcal writes %.*g with enough digits to round-trip doubles (<= 1 ulp).
  for (size_t i = 0; i < m.intrinsics().size(); ++i)
    EXPECT_NEAR(back.intrinsics()[i], m.intrinsics()[i], 1e-12 * std::max(1.0, std::abs(m.intrinsics()[i])));
  EXPECT_TRUE(back.cam_from_ref().IsApprox(m.cam_from_ref(), 1e-12));
}

INSTANTIATE_TEST_SUITE_P(AllMrcalModels, LensModels, ::testing::ValuesIn(Cases()), [](const auto& param_info) {
  std::string n = param_info.param.lensmodel.substr(10);
  return n.substr(0, n.find('_'));
});

TEST(CameraModel, EveryMrcalModelIsCovered) {
  std::set<std::string> tested;
  for (const auto& c : Cases()) tested.insert(c.lensmodel.substr(0, c.lensmodel.find("_", 10)));
  for (const auto& name : SupportedLensModels()) {
    std::string base = name.substr(0, name.find("_", 10));
    EXPECT_TRUE(tested.count(base)) << name << " has no round-trip test";
  }
}

TEST(CameraModel, PinholeSeesNothingBehind) {
  CameraModel m("LENSMODEL_PINHOLE", {500, 500, 319.5, 239.5}, 640, 480);
  Eigen::Vector2d q;
  EXPECT_FALSE(m.Project({0, 0, -1}, &q));
  EXPECT_FALSE(m.Project({1, 0, 0}, &q));
  EXPECT_FALSE(m.Project({0, 0, 0}, &q));
  EXPECT_FALSE(m.Project({std::nan(""), 0, 1}, &q));
  ASSERT_TRUE(m.Project({0, 0, 2}, &q));
  // Pixel convention: the optical axis images at (cx, cy); (0,0) is the
  // centre of the top-left pixel.
  EXPECT_EQ(q, Eigen::Vector2d(319.5, 239.5));
  EXPECT_NEAR(m.HorizontalFovDeg(), 2 * std::atan(320.0 / 500) * kRadToDeg, 1e-9);
}

TEST(CameraModel, FisheyeFieldOfViewBeyond180) {
  // Stereographic r = 2 f tan(theta/2): a 640-px-wide image with f = 100
  // sees theta = 2 atan(320 / 200) = 115 deg to each side.
  CameraModel m("LENSMODEL_STEREOGRAPHIC", {100, 100, 319.5, 239.5}, 640, 480);
  EXPECT_NEAR(m.HorizontalFovDeg(), 4 * std::atan(320.0 / 200) * kRadToDeg, 1e-6);
  EXPECT_GT(m.HorizontalFovDeg(), 180.0);
  Eigen::Vector2d q;
  EXPECT_FALSE(m.Project({0, 0, -1}, &q));  // the one direction it cannot image
}

TEST(CameraModel, BadModelsAreRefused) {
  EXPECT_THROW(CameraModel("LENSMODEL_NOPE", {1, 1, 1, 1}, 10, 10), Error);
  EXPECT_THROW(CameraModel("LENSMODEL_PINHOLE", {1, 1, 1}, 10, 10), Error);
  EXPECT_THROW(CameraModel("LENSMODEL_PINHOLE", {1, std::nan(""), 1, 1}, 10, 10), Error);
  EXPECT_THROW(CameraModel("LENSMODEL_PINHOLE", {-1, 1, 1, 1}, 10, 10), Error);
  EXPECT_THROW(CameraModel("LENSMODEL_PINHOLE", {1, 1, 1, 1}, 0, 10), Error);
  try {
    CameraModel::FromString("{ 'lensmodel': 'LENSMODEL_PINHOLE', ", "bad.cameramodel");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("bad.cameramodel:1: not a valid .cameramodel", 0), 0u) << e.what();
  }
  EXPECT_THROW(CameraModel::Read("/nonexistent/x.cameramodel"), Error);
  // Inputs on which libmrcal 2.2's parser reads past its buffer (found by
  // fuzz/fuzz_cameramodel): each must be a clean error, never a crash.
  const std::string good = CameraModel("LENSMODEL_PINHOLE", {500, 500, 319.5, 239.5}, 640, 480).ToString();
  const std::string with_nul = good.substr(0, 20) + std::string(1, '\0') + good.substr(20);
  const std::string unterminated = "{\n 'lensmodel': 'LENSMODEL_OPENCV4',\n 'i40, 480, ],\n}\n";
  for (const std::string& bad : {with_nul, unterminated}) {
    EXPECT_THROW(CameraModel::FromString(bad, "bad.cameramodel"), Error) << bad;
  }
  // A comment ending the file without a newline is valid and must not crash libmrcal.
  std::string trailing = good;
  trailing.pop_back();  // drop the final newline after '}'
  trailing += "\n# note";
  EXPECT_EQ(CameraModel::FromString(trailing, "ok.cameramodel").width(), 640);
}

// python3-mrcal (Debian) is a test-time oracle: it must read mr's file and
// project the same points to the same pixels.
TEST(CameraModel, Python3MrcalAgrees) {
  if (std::system("/usr/bin/python3 -c 'import mrcal' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "python3-mrcal is not installed";
  test::TempDir dir;
  for (const auto& mc : Cases()) {
    CameraModel m(mc.lensmodel, mc.intrinsics, 640, 480);
    m.Write(dir / "m.cameramodel");
    std::vector<Eigen::Vector3d> pts = {{0.1, -0.2, 1.0}, {-0.3, 0.1, 1.0}, {0.0, 0.0, 1.0}};
    std::ostringstream py;
    py << "import mrcal, numpy as np; m = mrcal.cameramodel('" << (dir / "m.cameramodel").string() << "'); "
       << "p = np.array([[0.1,-0.2,1.0],[-0.3,0.1,1.0],[0.0,0.0,1.0]]); "
       << "q = mrcal.project(p, *m.intrinsics()); print(' '.join('%.12f' % v for v in q.ravel()))";
    std::string cmd = "/usr/bin/python3 -c \"" + py.str() + "\"";
    FILE* f = popen(cmd.c_str(), "r");
    ASSERT_NE(f, nullptr);
    char buf[4096] = {0};
    size_t n = fread(buf, 1, sizeof(buf) - 1, f);
    buf[n] = 0;
    ASSERT_EQ(pclose(f), 0) << mc.lensmodel << ": " << buf;
    std::istringstream in(buf);
    for (const auto& p : pts) {
      Eigen::Vector2d ours, theirs;
      ASSERT_TRUE(m.Project(p, &ours));
      in >> theirs.x() >> theirs.y();
      // Same library underneath; the text round trip keeps 12 decimals.
      EXPECT_NEAR((ours - theirs).norm(), 0.0, 1e-8) << mc.lensmodel;
    }
  }
}

}  // namespace
}  // namespace mr
