#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Geometry>

#include "calib/sphere.h"
#include "core/error.h"
#include "core/math.h"
#include "core/sampling.h"
#include "core/spherical.h"
#include "hdr/exposure_merge.h"
#include "light/environment.h"
#include "probe/unwrap.h"
#include "synth/sphere_view.h"
#include "synth/synth.h"
#include "test_util.h"

namespace mr {
namespace {

// A smooth sky: brighter up, warm towards +x, a soft blob towards -z; low
// frequency, so that resampling does not change it much.
Image SmoothSky(int w, int h) {
  Image img = Image::Rgb(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector3d d = LatLongPixelToDirection(Eigen::Vector2d(x, y), w, h);
      const double base = 0.6 + 0.4 * d.y();
      const double blob = 2 * std::exp(-(d - Eigen::Vector3d(0, 0.3, -0.95).normalized()).squaredNorm() / 0.2);
      img.at(x, y, 0) = static_cast<float>(base * (1 + 0.3 * d.x()) + blob);
      img.at(x, y, 1) = static_cast<float>(base + 0.5 * blob);
      img.at(x, y, 2) = static_cast<float>(base * (1 - 0.2 * d.x()) + 0.2 * blob);
    }
  return img;
}

struct Errors {
  double median = 0, p95 = 0;
  int n = 0;
};

// Relative luminance errors of `env` against `truth` (evaluated at each
// map pixel's direction) where `keep(direction)`.
template <typename Keep>
Errors Compare(const Image& env, const EnvironmentMap& truth, const Keep& keep) {
  std::vector<double> e;
  for (int y = 0; y < env.height(); ++y)
    for (int x = 0; x < env.width(); ++x) {
      const Eigen::Vector3d d = LatLongPixelToDirection(Eigen::Vector2d(x, y), env.width(), env.height());
      if (!keep(d) || env.at(x, y, 3) <= 0) continue;
      const Eigen::Vector3d t = truth.Eval(d);
      const Eigen::Vector3d m(env.at(x, y, 0), env.at(x, y, 1), env.at(x, y, 2));
      e.push_back(std::abs(Luminance(m) / Luminance(t) - 1));
    }
  Errors r;
  r.n = static_cast<int>(e.size());
  if (e.empty()) return r;
  std::sort(e.begin(), e.end());
  r.median = e[e.size() / 2];
  r.p95 = e[e.size() * 95 / 100];
  return r;
}

// The exact perspective reflection: the found point reflects the view ray
// into the asked direction (to 1e-9), for directions all around; and far
// away the normal bisects the camera direction and d, as the orthographic
// approximation says.
TEST(Probe, MirrorSpherePointReflectsExactly) {
  const Eigen::Vector3d c(0.05, -0.03, 0.3);
  const double R = 0.0254;
  Pcg32 rng(3);
  int found = 0;
  for (int i = 0; i < 2000; ++i) {
    const auto s = SampleUniformSphere(rng.NextDouble(), rng.NextDouble());
    const Eigen::Vector3d d(s[0], s[1], s[2]);
    Eigen::Vector3d p;
    if (!MirrorSpherePoint(c, R, d, &p)) {
      // Blind: d points away from the camera, behind the sphere.
      EXPECT_LT(d.dot(-c.normalized()), -0.9);
      continue;
    }
    ++found;
    const Eigen::Vector3d n = (p - c) / R, v = p.normalized();
    EXPECT_NEAR(n.norm(), 1, 1e-12);
    EXPECT_LT((v - 2 * v.dot(n) * n - d).norm(), 1e-9);
  }
  EXPECT_GT(found, 1900);
  const Eigen::Vector3d far(0, 0, 1e6);
  const Eigen::Vector3d d = Eigen::Vector3d(1, 0, 1).normalized();  // 135 degrees from the direction to the camera
  Eigen::Vector3d p;
  ASSERT_TRUE(MirrorSpherePoint(far, 1, d, &p));
  const Eigen::Vector3d n = p - far;
  EXPECT_NEAR(std::acos(n.dot(-far.normalized())) / kDegToRad, 67.5, 1e-3);
}

ProbeGeometry Geometry(const CameraModel& cam, const Eigen::Vector3d& centre, const Eigen::Matrix3d& world_from_cam) {
  ProbeGeometry g;
  g.camera = cam;
  g.radius_m = 0.0254;
  g.centre_cam = centre;
  g.world_from_cam = world_from_cam;
  return g;
}

// A 2-inch chrome ball (reflectance 0.6) 0.3 m from a long lens, the camera
// turned in the world: the unwrapped map matches the environment away from
// the rim (reflection points within 75% of the rim's angle) and from the
// camera's direction: median error under 2%, 95th percentile under 8%
// (the Jacobian filter blurs the blob's flanks by about a map pixel).  Most
// of the sphere is seen.
TEST(Probe, UnwrapRecoversTheEnvironment) {
  const EnvironmentMap truth(SmoothSky(256, 128), "sky");
  const CameraModel cam("LENSMODEL_OPENCV8", {2000, 2000, 319.5, 239.5, 0, 0, 0, 0, 0, 0, 0, 0}, 640, 480);
  const Eigen::Matrix3d world_from_cam =
      (Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  const Eigen::Vector3d centre(0.01, 0.005, 0.3);
  SphereViewOptions vo;
  vo.world_from_cam = world_from_cam;
  const Image photo = RenderSphereView(truth, cam, centre, 0.0254, vo);
  UnwrapOptions uo;
  uo.width = 128;
  uo.reflectance = 0.6;
  UnwrapReport rep;
  const ProbeGeometry g = Geometry(cam, centre, world_from_cam);
  const Image env = UnwrapMirrorSphere(photo, g, uo, "sphere.exr", &rep);
  const Eigen::Vector3d back = world_from_cam * (-centre.normalized());  // towards the camera, world
  const double theta_max = std::acos(g.radius_m / centre.norm());
  const Errors e = Compare(env, truth, [&](const Eigen::Vector3d& d) {
    Eigen::Vector3d p;
    if (!MirrorSpherePoint(centre, g.radius_m, world_from_cam.transpose() * d, &p)) return false;
    const double theta = std::acos(std::clamp((p - centre).normalized().dot(-centre.normalized()), -1.0, 1.0));
    return theta < 0.75 * theta_max && AngleBetween(d, back) > 20 * kDegToRad;
  });
  std::printf("unwrapped: median %.4f, p95 %.4f over %d pixels; %.1f%% seen, median confidence %.2f\n", e.median, e.p95,
              e.n, 100 * rep.seen_fraction, rep.median_confidence);
  EXPECT_GT(e.n, 2000);
  EXPECT_LT(e.median, 0.02);
  EXPECT_LT(e.p95, 0.08);
  EXPECT_GT(rep.seen_fraction, 0.9);
}

// A ball partly out of the frame (its centre 0.6 radii inside the right
// edge): the directions it shows outside the image are unseen (confidence
// 0, counted in blind_fraction), those it shows inside are as right as a
// whole ball's, and a clipped mask over the rest of it marks nothing it
// cannot see.
TEST(Probe, BallPartlyOutOfTheFrame) {
  const EnvironmentMap truth(SmoothSky(256, 128), "sky");
  const CameraModel cam("LENSMODEL_OPENCV8", {1000, 1000, 159.5, 119.5, 0, 0, 0, 0, 0, 0, 0, 0}, 320, 240);
  const double r_px = 1000 * 0.0254 / 0.3;  // about 85 px
  const Eigen::Vector3d centre((319 - 0.6 * r_px - 159.5) * 0.3 / 1000, 0, 0.3);
  const Image photo = RenderSphereView(truth, cam, centre, 0.0254, {});
  UnwrapOptions uo;
  uo.width = 128;
  uo.reflectance = 0.6;
  const ProbeGeometry g = Geometry(cam, centre, Eigen::Matrix3d::Identity());
  UnwrapReport whole, part;
  const Eigen::Vector3d inside_centre(0, 0, 0.3);
  (void)UnwrapMirrorSphere(RenderSphereView(truth, cam, inside_centre, 0.0254, {}),
                           Geometry(cam, inside_centre, Eigen::Matrix3d::Identity()), uo, "whole.exr", &whole);
  std::vector<uint8_t> clipped(static_cast<size_t>(photo.pixel_count()), 1);  // "everything clipped"
  const Image env = UnwrapMirrorSphere(photo, g, uo, "edge.exr", &part, &clipped);
  const Errors e = Compare(env, truth, [&](const Eigen::Vector3d& d) {
    Eigen::Vector3d p;
    if (!MirrorSpherePoint(centre, g.radius_m, d, &p)) return false;
    const double theta = std::acos(std::clamp((p - centre).normalized().dot(-centre.normalized()), -1.0, 1.0));
    return theta < 0.6 * std::acos(g.radius_m / centre.norm()) &&
           AngleBetween(d, Eigen::Vector3d(0, 0, -1)) > 20 * kDegToRad;
  });
  std::printf(
      "partly out of the frame: %.1f%% seen (whole ball %.1f%%), median error %.4f over %d pixels, %lld clipped\n",
      100 * part.seen_fraction, 100 * whole.seen_fraction, e.median, e.n, static_cast<long long>(part.clipped_pixels));
  EXPECT_LT(part.seen_fraction, whole.seen_fraction - 0.1);
  EXPECT_NEAR(part.blind_fraction, 1 - part.seen_fraction, 1e-12);
  EXPECT_GT(e.n, 500);
  EXPECT_LT(e.median, 0.02);
  // Only the photograph's pixels that show the ball are counted, and the
  // map is clipped only where it is seen.
  EXPECT_GT(part.clipped_pixels, 0);
  EXPECT_LT(part.clipped_pixels, static_cast<int64_t>(kPi * r_px * r_px));
  for (int y = 0; y < env.height(); ++y)
    for (int x = 0; x < env.width(); ++x)
      if (env.at(x, y, 3) <= 0) ASSERT_EQ(env.at(x, y, 4), 0.0f) << x << " " << y;
}

// A 200-degree stereographic fish-eye looking down: directions up to 95
// degrees from its axis (past its horizon) unwrap to within 2% (median);
// every direction within 100 degrees is seen (the image circle), none
// beyond 119 (the frame's corners), and the opposite pole is unseen.
TEST(Probe, FisheyePastOneEightyDegrees) {
  const EnvironmentMap truth(SmoothSky(256, 128), "sky");
  const CameraModel cam("LENSMODEL_STEREOGRAPHIC", {134, 134, 319.5, 319.5}, 640, 640);
  // Camera z (forward) along world +y, camera y along world +z.
  Eigen::Matrix3d world_from_cam;
  world_from_cam.col(0) = Eigen::Vector3d(1, 0, 0);
  world_from_cam.col(1) = Eigen::Vector3d(0, 0, 1);
  world_from_cam.col(2) = Eigen::Vector3d(0, -1, 0).cross(Eigen::Vector3d(0, 0, 1)) * -1;
  world_from_cam.col(2) = world_from_cam.col(0).cross(world_from_cam.col(1));
  Image photo = Image::Rgb(640, 640);
  for (int y = 0; y < 640; ++y)
    for (int x = 0; x < 640; ++x) {
      Eigen::Vector3d d;
      if (!cam.Unproject(Eigen::Vector2d(x, y), &d)) continue;
      const Eigen::Vector3d L = truth.Eval(world_from_cam * d.normalized());
      for (int c = 0; c < 3; ++c) photo.at(x, y, c) = static_cast<float>(L[c]);
    }
  UnwrapOptions uo;
  uo.width = 128;
  UnwrapReport rep;
  const Image env = UnwrapFisheye(photo, cam, world_from_cam, uo, "fisheye.exr", &rep);
  const Eigen::Vector3d axis = world_from_cam.col(2);
  const Errors e =
      Compare(env, truth, [&](const Eigen::Vector3d& d) { return AngleBetween(d, axis) < 95 * kDegToRad; });
  std::printf("fish-eye: median %.4f, p95 %.4f over %d pixels; %.1f%% seen (axis %.2f %.2f %.2f)\n", e.median, e.p95,
              e.n, 100 * rep.seen_fraction, axis.x(), axis.y(), axis.z());
  EXPECT_LT(e.median, 0.02);
  EXPECT_LT(e.p95, 0.06);
  int wrong = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 128; ++x) {
      const double a = AngleBetween(LatLongPixelToDirection(Eigen::Vector2d(x, y), 128, 64), axis) / kDegToRad;
      wrong += (a < 99 && !(env.at(x, y, 3) > 0)) || (a > 119 && env.at(x, y, 3) != 0);
    }
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(rep.seen_fraction, 0.587);                             // 1 - cos(100 deg) over 2
  EXPECT_LT(rep.seen_fraction, 0.743);                             // 1 - cos(119 deg) over 2
  for (int x = 0; x < 128; ++x) EXPECT_EQ(env.at(x, 0, 3), 0.0f);  // the +y pole: behind the lens
}

// The camera is reflected in the sphere.  Two views 90 degrees apart merge
// by confidence: in the direction back towards the first camera the merged
// map is the environment again (within 10%), where the first view alone
// shows the camera's dark body.
TEST(Probe, TwoViewsRemoveTheCamera) {
  const EnvironmentMap truth(SmoothSky(256, 128), "sky");
  const CameraModel cam("LENSMODEL_OPENCV8", {2000, 2000, 319.5, 239.5, 0, 0, 0, 0, 0, 0, 0, 0}, 640, 480);
  const Eigen::Vector3d centre(0, 0, 0.3);
  UnwrapOptions uo;
  uo.width = 128;
  uo.reflectance = 0.6;
  std::vector<Image> views;
  std::vector<Eigen::Vector3d> backs;
  for (const double yaw : {0.0, 90.0}) {
    // The camera orbits the sphere: the world sees it from a direction
    // turned by `yaw` about +y.
    const Eigen::Matrix3d world_from_cam =
        Eigen::AngleAxisd(yaw * kDegToRad, Eigen::Vector3d::UnitY()).toRotationMatrix();
    SphereViewOptions vo;
    vo.world_from_cam = world_from_cam;
    vo.camera_body_radius = 0.04;
    const Image photo = RenderSphereView(truth, cam, centre, 0.0254, vo);
    views.push_back(UnwrapMirrorSphere(photo, Geometry(cam, centre, world_from_cam), uo, "view.exr"));
    backs.push_back(world_from_cam * (-centre.normalized()));
  }
  const Image merged = MergeProbeViews(views);
  const Eigen::Vector2d px = DirectionToLatLongPixel(backs[0], 128, 64);
  const int x = static_cast<int>(std::lround(px.x())), y = static_cast<int>(std::lround(px.y()));
  const double t = Luminance(truth.Eval(backs[0]));
  auto lum = [&](const Image& m) { return Luminance(Eigen::Vector3d(m.at(x, y, 0), m.at(x, y, 1), m.at(x, y, 2))); };
  std::printf("towards camera 1: truth %.3f, view 1 %.3f, merged %.3f\n", t, lum(views[0]), lum(merged));
  EXPECT_LT(lum(views[0]), 0.3 * t);
  EXPECT_NEAR(lum(merged) / t, 1, 0.1);
}

// Bad input: a photograph whose size is not its camera's, and NaN pixels.
TEST(Probe, BadInputIsRefused) {
  const CameraModel cam("LENSMODEL_PINHOLE", {2000, 2000, 319.5, 239.5}, 640, 480);
  const ProbeGeometry g = Geometry(cam, Eigen::Vector3d(0, 0, 0.3), Eigen::Matrix3d::Identity());
  try {
    UnwrapMirrorSphere(Image::Rgb(320, 240), g, {}, "small.exr");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("small.exr"), std::string::npos);
  }
  Image nan = Image::Rgb(640, 480, 1.0f);
  nan.at(5, 5, 2) = NAN;
  EXPECT_THROW(UnwrapMirrorSphere(nan, g, {}, "nan.exr"), Error);
}

}  // namespace
}  // namespace mr

namespace mr {
namespace {

// A sun of 3x3 map pixels, 1e4 times the sky: unwrapping spreads it over
// more map pixels but keeps its energy, within 5% inside 15 degrees, at
// every map width (a one-pixel sun is not resolved by the photograph's 4x4
// supersampling: 16% short, the same at every width).
TEST(Probe, UnwrapKeepsTheSunsEnergy) {
  Image sky = Image::Rgb(256, 129, 0.5f);
  const int sx = 85, sy = 25;
  double sun_energy = 0;
  for (int y = sy - 1; y <= sy + 1; ++y)
    for (int x = sx - 1; x <= sx + 1; ++x) {
      for (int c = 0; c < 3; ++c) sky.at(x, y, c) = 5000;
      sun_energy += (5000 - 0.5) * LatLongPixelSolidAngle(x, y, 256, 129);
    }
  const EnvironmentMap truth(sky, "sky");
  const Eigen::Vector3d sun = LatLongPixelToDirection(Eigen::Vector2d(sx, sy), 256, 129);
  const CameraModel cam("LENSMODEL_STEREOGRAPHIC", {134, 134, 319.5, 319.5}, 640, 640);
  const Eigen::Matrix3d world_from_cam = Eigen::Vector3d(1, -1, -1).asDiagonal();
  const Eigen::Vector3d centre(0.04, -0.02, 0.12);
  SphereViewOptions vo;
  vo.world_from_cam = world_from_cam;
  vo.supersample = 4;
  const Image photo = RenderSphereView(truth, cam, centre, 0.0254, vo);
  for (const int width : {128, 256, 512}) {
    UnwrapOptions uo;
    uo.width = width;
    uo.reflectance = 0.6;
    const Image env = UnwrapMirrorSphere(photo, Geometry(cam, centre, world_from_cam), uo, "sun.exr");
    double e = 0;
    for (int y = 0; y < env.height(); ++y)
      for (int x = 0; x < env.width(); ++x) {
        const Eigen::Vector3d d = LatLongPixelToDirection(Eigen::Vector2d(x, y), env.width(), env.height());
        if (AngleBetween(d, sun) < 15 * kDegToRad)
          e += (env.at(x, y, 1) - 0.5) * LatLongPixelSolidAngle(x, y, env.width(), env.height());
      }
    std::printf("width %d: sun energy %.5f of %.5f (ratio %.3f)\n", width, e, sun_energy, e / sun_energy);
    EXPECT_NEAR(e / sun_energy, 1, 0.05);
  }
}

}  // namespace
}  // namespace mr

namespace mr {
namespace {

// The rim at grazing angles: along the great circle from the direction
// back to the camera to the blind spot, every seen direction has a finite
// value, the confidence falls towards the rim (the sphere compresses the
// last degrees of the silhouette into a sliver), and directions past the
// rim are blind.
TEST(Probe, RimAtGrazingAngles) {
  const EnvironmentMap truth(SmoothSky(256, 128), "sky");
  const CameraModel cam("LENSMODEL_OPENCV8", {2000, 2000, 319.5, 239.5, 0, 0, 0, 0, 0, 0, 0, 0}, 640, 480);
  const Eigen::Vector3d centre(0, 0, 0.3);
  SphereViewOptions vo;
  const Image photo = RenderSphereView(truth, cam, centre, 0.0254, vo);
  UnwrapOptions uo;
  uo.width = 512;
  uo.reflectance = 0.6;
  const Image env = UnwrapMirrorSphere(photo, Geometry(cam, centre, Eigen::Matrix3d::Identity()), uo, "rim.exr");
  for (float v : env.values()) ASSERT_TRUE(std::isfinite(v));
  const double blind = 180 - std::asin(0.0254 / 0.3) / kDegToRad;  // the rim's reflected angle
  auto conf_at = [&](double deg) {
    // From -z (back to the camera) towards +x.
    const Eigen::Vector3d d(std::sin(deg * kDegToRad), 0, -std::cos(deg * kDegToRad));
    const Eigen::Vector2d q = DirectionToLatLongPixel(d, 512, 256);
    return env.at(static_cast<int>(std::lround(q.x())), static_cast<int>(std::lround(q.y())), 3);
  };
  std::printf("blind beyond %.2f deg; confidence at 90: %.3g, 150: %.3g, 165: %.3g, %.1f: %.3g, %.1f: %.3g\n", blind,
              conf_at(90), conf_at(150), conf_at(165), blind - 2, conf_at(blind - 2), blind + 1, conf_at(blind + 1));
  EXPECT_GT(conf_at(90), conf_at(150));
  EXPECT_GT(conf_at(150), conf_at(165));
  EXPECT_GT(conf_at(165), conf_at(blind - 2));
  EXPECT_GT(conf_at(blind - 2), 0);
  EXPECT_EQ(conf_at(blind + 1), 0);
}

}  // namespace
}  // namespace mr

namespace mr {
namespace {

// The real mirror ball end to end: three JPEG exposures (times from EXIF)
// aligned and merged, the ball located in the merge (an uncalibrated phone:
// a long pinhole stands in, with the circle given as in the sphere test),
// and unwrapped: 99% of the directions are seen (measured), every value is
// finite, and the brightest lamp keeps at least half its peak through the
// Jacobian filter.
TEST(ProbeRealData, MirrorBallBracketToMap) {
  MR_REQUIRE_SHARED_DATA("mirrorball-iphone");
  const fs::path dir = test::SharedData("mirrorball-iphone") / "mirrorball";
  std::vector<Exposure> bracket;
  for (const char* f : {"ball_exp_1-10s.JPG", "ball_exp_1-40s.JPG", "ball_exp_1-160s.JPG"})
    bracket.push_back(ReadExposure(dir / f));  // the time from EXIF
  AlignExposures(&bracket);
  const Image hdr = MergeExposures(bracket, RecoverResponse(bracket, {}), {}).Layer("");
  const double fpx = 3300;
  const CameraModel cam("LENSMODEL_PINHOLE", {fpx, fpx, 0.5 * (hdr.width() - 1), 0.5 * (hdr.height() - 1)}, hdr.width(),
                        hdr.height());
  SphereOptions so;
  so.radius_m = 0.0254;
  so.circle = Eigen::Vector3d(0.5 * hdr.width(), 0.5 * hdr.height() + 5, 232);
  const SphereFit fit = FitMirrorSphere(hdr, cam, so, "merged ball");
  UnwrapOptions uo;
  uo.width = 256;
  UnwrapReport rep;
  const Image env = UnwrapMirrorSphere(hdr, Geometry(cam, fit.centre, Eigen::Matrix3d::Identity()), uo, "ball", &rep);
  std::vector<float> lum;
  for (int y = 0; y < env.height(); ++y)
    for (int x = 0; x < env.width(); ++x) {
      for (int c = 0; c < 4; ++c) ASSERT_TRUE(std::isfinite(env.at(x, y, c)));
      if (env.at(x, y, 3) > 0) lum.push_back(env.at(x, y, 1));
    }
  std::sort(lum.begin(), lum.end());
  // The photograph's brightest pixel on the ball.
  double photo_top = 0;
  for (int y = 0; y < hdr.height(); ++y)
    for (int x = 0; x < hdr.width(); ++x) {
      Eigen::Vector3d d;
      if (!cam.Unproject(Eigen::Vector2d(x, y), &d)) continue;
      if (AngleBetween(d.normalized(), fit.centre.normalized()) < 0.95 * fit.half_angle)
        photo_top = std::max<double>(photo_top, hdr.at(x, y, 1));
    }
  const double median = lum[lum.size() / 2], top = lum.back();
  std::printf("ball at %.3f m (radius %.1f px): %.1f%% seen; brightest %.3g (%.0f x the median), photograph's %.3g\n",
              fit.centre.norm(), fpx * std::tan(fit.half_angle), 100 * rep.seen_fraction, top, top / median, photo_top);
  EXPECT_GT(rep.seen_fraction, 0.9);
  EXPECT_GT(top, 0.5 * photo_top);  // the filter averages a lamp over its footprint, but not away
}

}  // namespace
}  // namespace mr

namespace mr {
namespace {

// mr-synth's probe bracket through the whole chain: 8-bit photographs read
// back as codes, the response recovered, merged, the sphere located from
// its own photograph, unwrapped into the world: the map matches the
// environment the photographs were made from away from the rim and the
// camera's reflection: median within 5% (measured 0.6%; the response's unit
// is extrapolated to saturation) and 80% of the directions within 15%
// (measured 2.2%).
TEST(ProbeChain, SyntheticBracketToWorldMap) {
  test::TempDir tmp;
  SynthOptions o;
  o.out = tmp.path();
  Report r("mr-synth", "test");
  Image sky = SmoothSky(256, 128);
  WriteProbe(o, sky, &r);
  const fs::path probe = tmp.path() / "probe";
  std::vector<Exposure> bracket;
  std::istringstream times(ReadTextFile(probe / "bracket" / "exposures.txt"));
  for (std::string line; std::getline(times, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string name;
    double time = 0;
    ls >> name >> time;
    const Exposure e = ReadExposure(probe / "bracket" / name, time);
    bracket.push_back(e);
  }
  ASSERT_EQ(bracket.size(), 4u);
  const Image hdr = MergeExposures(bracket, RecoverResponse(bracket, {}), {}).Layer("");
  const CameraModel cam = CameraModel::Read(probe / "light.cameramodel");
  SphereOptions so;
  so.radius_m = 0.0254;
  const SphereFit fit = FitMirrorSphere(ReadImage(probe / "sphere.exr"), cam, so, "sphere.exr");
  ProbeGeometry g = Geometry(cam, fit.centre, cam.cam_from_ref().rotation.conjugate().toRotationMatrix());
  UnwrapOptions uo;
  uo.width = 128;
  uo.reflectance = 0.6;
  const Image env = UnwrapMirrorSphere(hdr, g, uo, "raw");
  const EnvironmentMap truth(sky, "sky");
  const Eigen::Vector3d back = g.world_from_cam * (-fit.centre.normalized());
  const double theta_max = std::acos(g.radius_m / fit.centre.norm());
  std::vector<double> ratio;
  for (int y = 0; y < env.height(); ++y)
    for (int x = 0; x < env.width(); ++x) {
      const Eigen::Vector3d d = LatLongPixelToDirection(Eigen::Vector2d(x, y), env.width(), env.height());
      Eigen::Vector3d p;
      if (!MirrorSpherePoint(fit.centre, g.radius_m, g.world_from_cam.transpose() * d, &p)) continue;
      const double theta =
          std::acos(std::clamp((p - fit.centre).normalized().dot(-fit.centre.normalized()), -1.0, 1.0));
      if (theta > 0.75 * theta_max || AngleBetween(d, back) < 25 * kDegToRad) continue;
      ratio.push_back(Luminance(Eigen::Vector3d(env.at(x, y, 0), env.at(x, y, 1), env.at(x, y, 2))) /
                      Luminance(truth.Eval(d)));
    }
  std::sort(ratio.begin(), ratio.end());
  const double med = ratio[ratio.size() / 2];
  std::printf("chain: median ratio %.4f, 10th-90th percentile %.4f-%.4f over %zu directions\n", med,
              ratio[ratio.size() / 10], ratio[ratio.size() * 9 / 10], ratio.size());
  EXPECT_NEAR(med, 1, 0.05);
  EXPECT_GT(ratio[ratio.size() / 10], 0.85);
  EXPECT_LT(ratio[ratio.size() * 9 / 10], 1.15);
}

}  // namespace
}  // namespace mr
