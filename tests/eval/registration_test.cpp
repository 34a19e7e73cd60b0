// Registration in pixels (eval/registration.h): the displacement between a
// rendered room and the plate, measured by flow on locally normalised
// images, against known shifts; a textureless frame says it cannot be
// measured; the swim of a point against the plate's own motion.
#include "eval/registration.h"

#include "camera/camera_model.h"
#include "geometry/primitives.h"
#include "render/render_scene.h"

#include <gtest/gtest.h>

#include "ray_cast_image.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>

namespace mr {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

// A smooth texture: 60 sinusoids of wavelengths 6 to 40 px, evaluated at
// (x - dx, y - dy) (its content moved by (dx, dy)), times `gain` plus
// `offset` per channel (the plate's other exposure and white balance).
Image Texture(int w, int h, double dx, double dy, const Eigen::Vector3d& gain, double offset) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  struct Wave {
    double kx, ky, phase, amp;
  };
  std::vector<Wave> waves;
  for (int i = 0; i < 60; ++i) {
    const double lambda = 6 + 34 * u(rng), theta = 6.2831853 * u(rng);
    waves.push_back(
        {std::cos(theta) * 6.2831853 / lambda, std::sin(theta) * 6.2831853 / lambda, 6.2831853 * u(rng), 0.5 + u(rng)});
  }
  Image img(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double v = 0;
      for (const Wave& wv : waves) v += wv.amp * std::sin(wv.kx * (x - dx) + wv.ky * (y - dy) + wv.phase);
      const double g = 1 + 0.04 * v;  // positive radiance around 1
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = static_cast<float>(gain[c] * g + offset);
    }
  return img;
}

Image All(int w, int h) { return Image(w, h, {"Y"}, 1.0f); }

// A known shift of (2.5, -1.25) px with the plate 1.7 x brighter and
// tinted: the mean displacement within 0.1 px of it (DIS's sub-pixel
// refinement on a smooth texture; measured 0.01-0.03 px); with no shift,
// under 0.1 px.  A few NaN pixels in the plate are left out.
TEST(Registration, MeasuresAKnownShiftInPixels) {
  const int w = 320, h = 240;
  const Image rendered = Texture(w, h, 0, 0, Eigen::Vector3d::Ones(), 0);
  Image plate = Texture(w, h, 2.5, -1.25, Eigen::Vector3d(1.7, 1.5, 1.2), 0.05);
  for (int k = 0; k < 20; ++k) plate.at(10 + 7 * k, 50, 0) = std::nanf("");
  const RegistrationResult r = MeasureRegistration(rendered, plate, All(w, h));
  ASSERT_TRUE(r.measurable) << r.why;
  std::printf("shift (2.5, -1.25): measured (%.3f, %.3f), mean %.3f px, p90 %.3f, stderr %.4f, %lld usable of %lld\n",
              r.mean_flow.x(), r.mean_flow.y(), r.mean_px, r.p90_px, r.stderr_px,
              static_cast<long long>(r.usable_pixels), static_cast<long long>(r.region_pixels));
  EXPECT_NEAR(r.mean_flow.x(), 2.5, 0.1);
  EXPECT_NEAR(r.mean_flow.y(), -1.25, 0.1);
  EXPECT_NEAR(r.mean_px, std::hypot(2.5, 1.25), 0.1);
  EXPECT_GT(r.usable_pixels, w * h / 4);  // the texture test keeps about a third of a smooth texture
  const RegistrationResult same =
      MeasureRegistration(rendered, Texture(w, h, 0, 0, Eigen::Vector3d(2, 2, 2), 0), All(w, h));
  ASSERT_TRUE(same.measurable);
  EXPECT_LT(same.mean_px, 0.1);
  // Only where the room is: the region outside is not looked at.
  Image left = Image(w, h, {"Y"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w / 2; ++x) left.at(x, y, 0) = 1;
  const RegistrationResult half = MeasureRegistration(rendered, plate, left);
  EXPECT_LT(half.region_pixels, w * h / 2 + 1);
  EXPECT_NEAR(half.mean_flow.x(), 2.5, 0.1);
}

// A plate frame with motion blur (a 9 px horizontal box, the camera panning
// during a 1/30 s exposure) still gives the shift: the blur is symmetric
// about the frame's instant, so the matched texture's centre does not move;
// within 0.2 px (measured 0.02), fewer pixels usable than unblurred.
TEST(Registration, AMotionBlurredPlateStillGivesTheShift) {
  const int w = 320, h = 240, r = 4;
  const Image sharp = Texture(w, h, 2.5, -1.25, Eigen::Vector3d::Ones(), 0);
  Image plate = sharp;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        double sum = 0;
        for (int k = -r; k <= r; ++k) sum += sharp.at(std::clamp(x + k, 0, w - 1), y, c);
        plate.at(x, y, c) = static_cast<float>(sum / (2 * r + 1));
      }
  const Image rendered = Texture(w, h, 0, 0, Eigen::Vector3d::Ones(), 0);
  const RegistrationResult blurred = MeasureRegistration(rendered, plate, All(w, h));
  ASSERT_TRUE(blurred.measurable) << blurred.why;
  std::printf("motion-blurred plate: measured (%.3f, %.3f), %lld usable\n", blurred.mean_flow.x(),
              blurred.mean_flow.y(), static_cast<long long>(blurred.usable_pixels));
  EXPECT_NEAR(blurred.mean_flow.x(), 2.5, 0.2);
  EXPECT_NEAR(blurred.mean_flow.y(), -1.25, 0.2);
  EXPECT_LT(blurred.usable_pixels, MeasureRegistration(rendered, sharp, All(w, h)).usable_pixels);
}

// Something the room does not hold covers most of the plate (a person
// walking past: random blocks over three quarters of the frame).  The
// flow's checks leave out nine tenths of the covered pixels, but the tenth
// that passes (the flow fitted to the blocks, consistent both ways: 5700
// pixels against the room quarter's 17300, measured) pulls the mean
// displacement about 1 px off; the median displacement is the room's,
// within 0.1 px.
TEST(Registration, AForegroundCoveringMostOfThePlateIsLeftOut) {
  const int w = 320, h = 240;
  const Image rendered = Texture(w, h, 0, 0, Eigen::Vector3d::Ones(), 0);
  const Image room = Texture(w, h, 2.5, -1.25, Eigen::Vector3d::Ones(), 0);
  // The foreground: random 5 px blocks, its own texture.
  std::mt19937 rng(99);
  std::uniform_real_distribution<float> u(0.4f, 1.2f);
  std::vector<float> blocks(static_cast<size_t>((w / 5 + 1) * (h / 5 + 1)));
  for (float& b : blocks) b = u(rng);
  Image plate = room;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (x >= w / 2 || y >= h / 2)
        for (int c = 0; c < 3; ++c) plate.at(x, y, c) = blocks[static_cast<size_t>((y / 5) * (w / 5 + 1) + x / 5)];
  const RegistrationResult r = MeasureRegistration(rendered, plate, All(w, h));
  ASSERT_TRUE(r.measurable) << r.why;
  std::printf("foreground over 3/4: mean (%.3f, %.3f), median (%.3f, %.3f), %lld usable of %lld\n", r.mean_flow.x(),
              r.mean_flow.y(), r.median_flow.x(), r.median_flow.y(), static_cast<long long>(r.usable_pixels),
              static_cast<long long>(r.region_pixels));
  EXPECT_NEAR(r.median_flow.x(), 2.5, 0.1);
  EXPECT_NEAR(r.median_flow.y(), -1.25, 0.1);
  EXPECT_NEAR(r.median_px, std::hypot(2.5, 1.25), 0.1);
}

// A textureless wall (a smooth ramp: no edges, no texture) cannot be
// registered: not measurable, and the reason says so.
TEST(Registration, ATexturelessFrameSaysSo) {
  const int w = 160, h = 120;
  Image ramp(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) ramp.at(x, y, c) = 0.5f + 0.001f * static_cast<float>(x);
  const RegistrationResult r = MeasureRegistration(ramp, ramp, All(w, h));
  EXPECT_FALSE(r.measurable);
  EXPECT_EQ(r.why.rfind("textureless", 0), 0u) << r.why;
  EXPECT_EQ(r.ToJson()["measurable"], false);
}

// The swim: a point whose projection the poses move exactly as the plate's
// content moved has none; one the poses hold still while the plate moves
// swims by the plate's motion; an exposure jump between the frames changes
// neither.
TEST(Registration, SwimIsThePosesMotionLessThePlates) {
  const int w = 320, h = 240;
  const FlowField flow = MatchImages(Texture(w, h, 0, 0, Eigen::Vector3d::Ones(), 0),
                                     Texture(w, h, 3, 1, Eigen::Vector3d::Ones(), 0), nullptr);
  const Eigen::Vector2d at(160, 120);
  EXPECT_LT(Swim(flow, at, at + Eigen::Vector2d(3, 1)), 0.1);
  EXPECT_NEAR(Swim(flow, at, at), std::hypot(3.0, 1.0), 0.1);
  EXPECT_TRUE(std::isnan(Swim(flow, Eigen::Vector2d(-5, 10), at)));
  // An exposure jump between the two plate frames (2.5x brighter, tinted:
  // auto exposure catching up) changes nothing: the flow compares locally
  // normalised images.
  const FlowField jump = MatchImages(Texture(w, h, 0, 0, Eigen::Vector3d::Ones(), 0),
                                     Texture(w, h, 3, 1, Eigen::Vector3d(2.5, 2.3, 2.0), 0.02), nullptr);
  EXPECT_LT(Swim(jump, at, at + Eigen::Vector2d(3, 1)), 0.1);
  EXPECT_NEAR(Swim(jump, at, at), std::hypot(3.0, 1.0), 0.1);
}

// A box room whose walls carry a texture in world coordinates, "rendered"
// by casting each pixel's ray and shading the point it meets (no light
// transport: the refinement sees only geometry and texture), the plate
// the same through the true pose at another exposure.  From a pose 1.5
// degrees and 4 cm off, RefinePose comes back within 0.1 degree and 1 cm,
// and the registration measured after it is under 0.3 px (measured: 0.008
// degree, 0.3 mm, 13.8 px before and 0.01 px after).
// A box room 4 x 2.5 x 5 m textured by 30 waves in random 3D directions,
// wavelengths 8 to 25 cm (12 to 50 px on walls 1.5 to 3.5 m away): texture
// in every direction on every wall.
struct TexturedRoom {
  RenderScene rs;
  std::vector<std::pair<Eigen::Vector3d, double>> waves;
  TexturedRoom() {
    rs.AddReal(Box({-2, 0, -3}, {2, 2.5f, 2}), Material());
    rs.Commit();
    std::mt19937 rng(11);
    std::normal_distribution<double> n01;
    std::uniform_real_distribution<double> u01;
    for (int i = 0; i < 30; ++i) {
      const Eigen::Vector3d k =
          Eigen::Vector3d(n01(rng), n01(rng), n01(rng)).normalized() * (6.2831853 / (0.08 + 0.17 * u01(rng)));
      waves.emplace_back(k, 6.2831853 * u01(rng));
    }
  }
  double Shade(const Eigen::Vector3d& p) const {
    double v = 0;
    for (const auto& [k, phase] : waves) v += std::sin(k.dot(p) + phase);
    return 1 + 0.08 * v;
  }
  Image Render(const CameraModel& camera, const Rigid3& pose) const {
    return test::RayCastImage(rs, camera, pose, [&](const Eigen::Vector3d& p) { return Shade(p); });
  }
};

TEST(Registration, RefinePoseBringsTheRoomBackOntoThePlate) {
  const TexturedRoom tr;
  const RenderScene& rs = tr.rs;
  const CameraModel camera("LENSMODEL_PINHOLE", {300, 300, 159.5, 119.5}, 320, 240);
  auto render = [&](const Rigid3& pose) { return tr.Render(camera, pose); };
  auto room = [&](const Rigid3&) { return Image(320, 240, {"Y"}, 1.0f); };
  const Rigid3 truth(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())),
                     Eigen::Vector3d(0.2, 1.3, 0.5));
  Image plate = render(truth);
  int lit = 0;
  for (float v : plate.values()) lit += v > 0;
  ASSERT_GT(lit, 3 * 320 * 200) << "the room is not rendered";
  for (float& v : plate.values()) v *= 2.5f;
  const Rigid3 off =
      truth * Rigid3(Eigen::Quaterniond(Eigen::AngleAxisd(1.5 * kDeg, Eigen::Vector3d(0.3, 1, 0.2).normalized())),
                     Eigen::Vector3d(0.03, -0.02, 0.02));
  const RegistrationResult before = MeasureRegistration(render(off), plate, room(off));
  const PoseRefinement r = RefinePose(render, room, rs, camera, off, plate);
  ASSERT_TRUE(r.refined) << r.why;
  const Rigid3 err = truth.Inverse() * r.pose;
  const double err_deg = Eigen::AngleAxisd(err.rotation).angle() / kDeg;
  const RegistrationResult after = MeasureRegistration(render(r.pose), plate, room(r.pose));
  std::printf(
      "refined from 1.5 deg / 4 cm: %.3f deg, %.4f m off; matches %d, RMS %.2f -> %.2f px; registration %.2f -> %.2f "
      "px\n",
      err_deg, err.translation.norm(), r.points, r.rms_before_px, r.rms_after_px, before.mean_px, after.mean_px);
  EXPECT_LT(err_deg, 0.1);
  EXPECT_LT(err.translation.norm(), 0.01);
  EXPECT_GT(before.mean_px, 5);
  EXPECT_LT(after.mean_px, 0.3);
  // One correction shared by two frames that share one error (the camera's
  // offset from the room): solved from both frames' matches at once, both
  // come back.
  const Rigid3 offset(Eigen::Quaterniond(Eigen::AngleAxisd(1.0 * kDeg, Eigen::Vector3d(1, 0.4, 0).normalized())),
                      Eigen::Vector3d(0.02, 0.01, -0.03));
  const Rigid3 truth2 = truth * Rigid3(Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY())),
                                       Eigen::Vector3d(0.3, 0, -0.2));
  std::vector<RoomMatches> groups;
  for (const Rigid3& t : {truth, truth2}) {
    const Rigid3 given = t * offset;
    groups.push_back(MatchRoom(render(given), room(given), rs, camera, given, render(t)));
  }
  const PoseRefinement shared = SolveCorrection(camera, groups, Rigid3());
  ASSERT_TRUE(shared.refined) << shared.why;
  for (const auto& [t, g] : {std::pair{truth, groups[0]}, std::pair{truth2, groups[1]}}) {
    const Rigid3 e = t.Inverse() * (g.pose * shared.pose);
    EXPECT_LT(Eigen::AngleAxisd(e.rotation).angle() / kDeg, 0.1);
    EXPECT_LT(e.translation.norm(), 0.01);
  }
  // A plate of nothing (textureless): not refined, and the reason given.
  const PoseRefinement none = RefinePose(render, room, rs, camera, off, Image(320, 240, {"R", "G", "B"}, 1.0f));
  EXPECT_FALSE(none.refined);
  EXPECT_NE(none.why.find("textureless"), std::string::npos) << none.why;
}

// The focal length with a shared correction (PoseRefineOptions::
// intrinsics): the plates made by a camera of focal length 300 px, the room
// rendered through a model 3% short, and poses that share an offset of 1
// degree and 3 cm, over three frames looking different ways.  Two rounds
// (matched again through the corrected camera and poses, as mr-eval
// plate's RefineShared) bring the focal length within 0.3% of 300 (the
// principal point stays), the poses within 0.1 degree and 1 cm.  With the true model given,
// the change found moves the corners by less than 0.5 px and the model
// stays as given.
TEST(Registration, SharedCorrectionFindsTheFocalLengthWhereTheFramesDetermineIt) {
  const TexturedRoom tr;
  const CameraModel truth_camera("LENSMODEL_PINHOLE", {300, 300, 159.5, 119.5}, 320, 240);
  const Rigid3 offset(Eigen::Quaterniond(Eigen::AngleAxisd(1.0 * kDeg, Eigen::Vector3d(1, 0.4, 0).normalized())),
                      Eigen::Vector3d(0.02, 0.01, -0.03));
  std::vector<Rigid3> truths;
  for (int i = 0; i < 3; ++i)
    truths.emplace_back(Eigen::Quaterniond(Eigen::AngleAxisd(0.3 + 0.9 * i, Eigen::Vector3d::UnitY()) *
                                           Eigen::AngleAxisd(0.15 * (i - 1), Eigen::Vector3d::UnitX())),
                        Eigen::Vector3d(0.2 - 0.3 * i, 1.3, 0.5 - 0.4 * i));
  PoseRefineOptions o;
  o.intrinsics = true;
  auto refine = [&](const CameraModel& given) {
    CameraModel camera = given;
    PoseRefinement c;
    for (int round = 0; round < 2; ++round) {
      std::vector<RoomMatches> groups;
      for (const Rigid3& t : truths) {
        const Rigid3 at = t * offset * c.pose;
        RoomMatches m = MatchRoom(tr.Render(camera, at), All(320, 240), tr.rs, camera, at, tr.Render(truth_camera, t));
        m.pose = t * offset;  // the correction is solved from the given poses
        groups.push_back(m);
      }
      const PoseRefinement step = SolveCorrection(camera, groups, c.pose, o);
      EXPECT_TRUE(step.refined) << step.why;
      if (step.intrinsics_refined) camera = WithIntrinsicsCorrection(camera, step.focal_scale, Eigen::Vector2d::Zero());
      c = step;
    }
    for (const Rigid3& t : truths) {
      const Rigid3 e = t.Inverse() * (t * offset * c.pose);
      EXPECT_LT(Eigen::AngleAxisd(e.rotation).angle() / kDeg, 0.1);
      EXPECT_LT(e.translation.norm(), 0.01);
    }
    return std::pair{camera, c};
  };
  const CameraModel wrong("LENSMODEL_PINHOLE", {291, 291, 159.5, 119.5}, 320, 240);
  const auto [found, c] = refine(wrong);
  std::printf("focal length from 291 px: %.2f (last round: scale %.5f +- %.5f)\n", found.intrinsics()[0], c.focal_scale,
              c.focal_scale_sigma);
  EXPECT_NEAR(found.intrinsics()[0] / 300, 1, 0.003);
  EXPECT_EQ(found.intrinsics()[2], 159.5);
  const auto [kept, c2] = refine(truth_camera);
  EXPECT_FALSE(c2.intrinsics_refined);
  EXPECT_NE(c2.intrinsics_why.find("moves no pixel"), std::string::npos) << c2.intrinsics_why;
  EXPECT_EQ(kept.intrinsics(), truth_camera.intrinsics());
}

// COLMAP's points as a prior (RefinePose's `prior`): the observations made
// through one pose (COLMAP's), the plate through another 1 degree and 3 cm
// from it (the room, a second estimate, disagrees with COLMAP's points, as
// on the kitchen).  Without the prior the refinement goes to the plate's
// pose; with it at a weight of 100 per observation (300 observations
// against about 3000 matches) it stays within 0.2 degree of COLMAP's
// (measured 0.14); at weight 1 the prior is a tenth of the evidence, its
// residuals beyond the Huber threshold, and the plate's pose wins (0.03).
TEST(Registration, PriorPointsHoldThePoseByTheirWeight) {
  const TexturedRoom tr;
  const CameraModel camera("LENSMODEL_PINHOLE", {300, 300, 159.5, 119.5}, 320, 240);
  auto render = [&](const Rigid3& pose) { return tr.Render(camera, pose); };
  auto room = [&](const Rigid3&) { return All(320, 240); };
  const Rigid3 colmap(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())),
                      Eigen::Vector3d(0.2, 1.3, 0.5));
  const Rigid3 plate_pose =
      colmap * Rigid3(Eigen::Quaterniond(Eigen::AngleAxisd(1.0 * kDeg, Eigen::Vector3d(0.2, 1, 0.3).normalized())),
                      Eigen::Vector3d(0.02, -0.01, 0.02));
  const Image plate = render(plate_pose);
  RoomMatches prior;  // room points seen by COLMAP's pose, at their projections through it
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(10, 310), uy(10, 230);
  while (prior.X.size() < 300) {
    Eigen::Vector3d dir;
    ASSERT_TRUE(camera.Unproject(Eigen::Vector2d(ux(rng), uy(rng)), &dir));
    Ray ray;
    ray.origin = colmap.translation.cast<float>();
    ray.direction = (colmap.rotation * dir).normalized().cast<float>();
    Hit hit;
    if (!tr.rs.embree().Intersect(ray, &hit)) continue;
    const Eigen::Vector3d X = colmap.translation + static_cast<double>(hit.t) * ray.direction.cast<double>();
    Eigen::Vector2d u;
    ASSERT_TRUE(camera.Project(colmap.Inverse() * X, &u));
    prior.X.push_back(X);
    prior.u.push_back(u);
  }
  auto angle_to = [](const Rigid3& a, const Rigid3& b) {
    return Eigen::AngleAxisd((a.Inverse() * b).rotation).angle() / kDeg;
  };
  const PoseRefinement none = RefinePose(render, room, tr.rs, camera, colmap, plate);
  ASSERT_TRUE(none.refined) << none.why;
  prior.weight = 100;
  const PoseRefinement held = RefinePose(render, room, tr.rs, camera, colmap, plate, {}, &prior);
  prior.weight = 1;
  const PoseRefinement between = RefinePose(render, room, tr.rs, camera, colmap, plate, {}, &prior);
  std::printf("from COLMAP's pose: no prior %.3f deg, weight 100 %.3f deg, weight 1 %.3f deg (the plate's: 1.000)\n",
              angle_to(colmap, none.pose), angle_to(colmap, held.pose), angle_to(colmap, between.pose));
  EXPECT_LT(angle_to(plate_pose, none.pose), 0.1);
  EXPECT_LT(angle_to(colmap, held.pose), 0.2);
  EXPECT_LT(angle_to(plate_pose, between.pose), 0.1);
  EXPECT_GT(angle_to(plate_pose, between.pose), angle_to(plate_pose, none.pose));
}

// Corrections smoothed over time: a constant one is kept; one that
// alternates +-1 degree from frame to frame (a per-frame refinement's own
// error) falls under a third of that at sigma 2 frames (the gap left by a
// frame without its own: 0.24 degree next to it), and that frame takes its
// neighbours'.
TEST(Registration, SmoothOverTimeKeepsTheTrendNotTheJitter) {
  const Rigid3 c(Eigen::Quaterniond(Eigen::AngleAxisd(2 * kDeg, Eigen::Vector3d::UnitX())),
                 Eigen::Vector3d(0.05, 0, 0));
  std::vector<std::optional<Rigid3>> constant(9, c), jitter(9);
  for (int i = 0; i < 9; ++i)
    jitter[i] = Rigid3(Eigen::Quaterniond(Eigen::AngleAxisd((i % 2 ? 1 : -1) * kDeg, Eigen::Vector3d::UnitY())),
                       Eigen::Vector3d::Zero());
  jitter[4].reset();
  for (const Rigid3& s : SmoothOverTime(constant, 2)) {
    EXPECT_LT(Eigen::AngleAxisd(s.rotation.inverse() * c.rotation).angle(), 1e-9);
    EXPECT_LT((s.translation - c.translation).norm(), 1e-12);
  }
  const std::vector<Rigid3> s = SmoothOverTime(jitter, 2);
  ASSERT_EQ(s.size(), 9u);
  for (size_t i = 2; i < 7; ++i) EXPECT_LT(Eigen::AngleAxisd(s[i].rotation).angle() / kDeg, 0.3) << i;  // 0.24 at most
}

}  // namespace
}  // namespace mr
