// Lights where they are (jobs/light_positions.h): a lamp panel seen in a
// probe map becomes an area light where it is in the room.
#include "jobs/light_positions.h"

#include "core/file.h"
#include "core/image.h"
#include "core/report.h"
#include "jobs/lights_job.h"
#include "light/lights_file.h"
#include "test_util.h"

#include <gtest/gtest.h>

#include "core/color.h"
#include "core/math.h"
#include "core/spherical.h"
#include "geometry/primitives.h"
#include "light/light_source.h"
#include "render/path_tracer.h"
#include "render/render_scene.h"

namespace mr {
namespace {

// Irradiance at p (normal n) from `l`, 64 x 64 stratified samples,
// unoccluded (the room is an empty box).
double Irradiance(const Light& l, const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  return UnoccludedIrradiance(LightSource(l), p, n, 64);
}

// A 4 x 2.5 x 4 m room (albedo 0.5) lit by a 0.5 m ceiling panel, a probe
// 1.2 m from under it rendered by pt (each map pixel the radiance arriving
// at its centre): mr-lights' blob of the panel, placed by tracing its
// pixels into the room, lands within 2 cm of the panel with its size
// within 10% and its radiance within 10%; on the floor 1.5 m from the probe
// its irradiance is within 5% of the panel's, where the distant disc the
// map gives is off by the measured figure printed (the failure the issue
// reports: every captured direction at infinity).
TEST(LightPositions, ACeilingPanelBecomesAnAreaLightWhereItIs) {
  RenderScene scene;
  Material wall;
  wall.albedo = Eigen::Vector3d::Constant(0.5);
  const Mesh room = Box({-2, 0, -2}, {2, 2.5f, 2});
  scene.AddReal(room, wall);
  Light panel;
  panel.name = "panel";
  panel.type = LightType::kArea;
  panel.position = Eigen::Vector3d(0.5, 2.49, 0.3);
  panel.direction = Eigen::Vector3d(0, -1, 0);
  panel.axis = Eigen::Vector3d(1, 0, 0);
  panel.width = 0.5;
  panel.height = 0.5;
  panel.radiance = Eigen::Vector3d::Constant(50);
  scene.AddLight(panel);
  scene.Commit();
  const Eigen::Vector3d probe(-0.5, 1.0, -0.5);
  PathTracerSettings st;
  st.max_depth = 1;  // the walls' direct light: the panel itself is seen exactly (camera rays meet it)
  const Image env = RenderProbeMap(scene, probe, 512, 4, st, 7);
  ExtractOptions eo;
  eo.method = "blobs";
  eo.count = 4;
  eo.keep_wide = true;  // as mr-lights --room
  const Extraction ex = ExtractLights(env, eo);
  ASSERT_EQ(ex.lights.size(), 1u);
  const std::vector<Light> distant = ToLights(ex);
  PositionOptions po;
  po.probe_centre = probe;
  PositionReport pr;
  const std::vector<Light> placed = PositionLights(env, ex, distant, room, po, &pr);
  ASSERT_EQ(pr.positioned, 1);
  const Light& l = placed[0];
  ASSERT_EQ(l.type, LightType::kArea);
  std::printf("%s\nradiance %.2f (truth 50)\n", pr.notes[0].c_str(), l.radiance.x());
  EXPECT_LT((l.position - panel.position).norm(), 0.02);
  EXPECT_GT(l.direction.dot(panel.direction), 0.999);
  EXPECT_NEAR(l.width, 0.5, 0.05);
  EXPECT_NEAR(l.height, 0.5, 0.05);
  EXPECT_NEAR(l.radiance.x(), 50, 5);
  const Eigen::Vector3d floor(1.0, 0.0, 1.0), up(0, 1, 0);
  const double truth = Irradiance(panel, floor, up), at_room = Irradiance(l, floor, up),
               at_infinity = Irradiance(distant[0], floor, up);
  std::printf("floor 1.5 m from the probe: irradiance %.3f, placed %.3f (%+.1f%%), at infinity %.3f (%+.1f%%)\n", truth,
              at_room, 100 * (at_room / truth - 1), at_infinity, 100 * (at_infinity / truth - 1));
  EXPECT_NEAR(at_room, truth, 0.05 * truth);
  EXPECT_GT(std::abs(at_infinity - truth), std::abs(at_room - truth));
}

// mr-lights --room on a map with a panel straight up (over the ceiling the
// room's mesh has) and a wide window to the side (where the mesh has no
// wall: its rays leave the room): the panel becomes an area light, the
// window goes back into the residual map with its shape, no disc at
// infinity; lights and residual still hold the map's energy.
TEST(LightPositions, AWindowThatLeavesTheRoomStaysInTheMap) {
  test::TempDir dir;
  WriteTextFile(dir / "ceiling.obj", "v -2 2.5 -2\nv 2 2.5 -2\nv 2 2.5 2\nv -2 2.5 2\nf 1 2 3\nf 1 3 4\n");
  Image env = Image::Rgb(256, 128);
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 256; ++x) {
      const Eigen::Vector3d d = LatLongPixelToDirection(Eigen::Vector2d(x, y), 256, 128);
      const bool panel = AngleBetween(d, Eigen::Vector3d(0.2, 1, 0).normalized()) < 10 * kDegToRad;
      const bool window = std::abs(d.y()) < 0.3 && std::abs(std::atan2(d.z(), d.x())) < 0.4 && d.x() > 0;
      const float v = panel ? 200.0f : window ? 60.0f : 1.0f;
      for (int c = 0; c < 3; ++c) env.at(x, y, c) = v;
    }
  WriteImage(dir / "env.exr", env);
  LightsJobOptions o;
  o.env = (dir / "env.exr").string();
  o.out = (dir / "lights.json").string();
  o.residual = (dir / "residual.exr").string();
  o.residual_width = 256;
  o.extract.method = "blobs";
  o.room = (dir / "ceiling.obj").string();
  o.probe_at = {0, 1, 0};
  o.room_map = (dir / "room.exr").string();
  Report report;
  RunLights(o, &report);
  // The room's map is the residual at full size: the ceiling seen from the
  // probe (1), the panel taken out (0); the shares of the map's light add up.
  const Image room = ReadImage(dir / "room.exr");
  ASSERT_EQ(room.width(), 256);
  const Eigen::Vector2d up = DirectionToLatLongPixel(Eigen::Vector3d(-0.3, 1, 0.3).normalized(), 256, 128);
  EXPECT_FLOAT_EQ(room.at(static_cast<int>(up.x()), static_cast<int>(up.y()), 0), 1.0f);
  // The disc's rim, outside the rectangle fitted to it (sides sqrt(3) r),
  // takes the ceiling's radiance around it, not a dark ring; the panel's
  // centre stays taken out (the area light is it).
  const Eigen::Vector3d panel = Eigen::Vector3d(0.2, 1, 0).normalized();
  const Eigen::Vector3d rim = Eigen::AngleAxisd(9.5 * kDegToRad, Eigen::Vector3d::UnitZ()) * panel;
  const Eigen::Vector2d at_rim = DirectionToLatLongPixel(rim, 256, 128),
                        at_centre = DirectionToLatLongPixel(panel, 256, 128);
  EXPECT_FLOAT_EQ(room.at(static_cast<int>(std::lround(at_rim.x())), static_cast<int>(std::lround(at_rim.y())), 0),
                  1.0f);
  EXPECT_FLOAT_EQ(
      room.at(static_cast<int>(std::lround(at_centre.x())), static_cast<int>(std::lround(at_centre.y())), 0), 0.0f);
  EXPECT_GT(report.metrics()["positioned"]["glow_pixels_filled"].get<int64_t>(), 0);
  const Json& share = report.metrics()["light_model"];
  EXPECT_NEAR(share["placed"].get<double>() + share["room"].get<double>() + share["infinity"].get<double>(), 1, 1e-9);
  EXPECT_GT(share["placed"].get<double>(), 0.1);
  EXPECT_GT(share["room"].get<double>(), 0.03);  // the ceiling, radiance 1 over about 2.5 sr: 4.6%
  const std::vector<Light> lights = ReadLights(dir / "lights.json");
  ASSERT_EQ(lights.size(), 1u);
  EXPECT_EQ(lights[0].type, LightType::kArea);
  EXPECT_EQ(report.metrics()["positioned"]["left_in_the_map"], 1);
  const Image residual = ReadImage(dir / "residual.exr");
  double window = 0;
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 256; ++x)
      if (residual.at(x, y, 0) > 30) window += LatLongPixelSolidAngle(x, y, 256, 128);
  std::printf("the window's %.3f sr stays in the residual map\n", window);
  EXPECT_GT(window, 0.3);
}

// b's triangles added to a's (positions only).
void Append(Mesh* a, const Mesh& b) {
  const int base = static_cast<int>(a->positions.size());
  a->positions.insert(a->positions.end(), b.positions.begin(), b.positions.end());
  for (const Eigen::Vector3i& t : b.triangles) a->triangles.push_back(t + Eigen::Vector3i::Constant(base));
}

// The map at infinity keeps only the directions that leave the room: in a
// room open at the top and at +x (a floor and three walls), seen from its
// middle, every pixel whose ray meets a wall or the floor takes the sky of
// its row (here the map's radiance depends on the latitude alone, so the
// filled pixels are exactly the sky's), rows that see no sky clear of the
// room copy the nearest that does, and a closed box leaves nothing at
// infinity.
TEST(LightPositions, OnlyWhatLeavesTheRoomStaysAtInfinity) {
  Mesh room = Quad({-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2});  // floor
  room.normals.clear();
  for (const Mesh& wall :
       {Quad({-2, 0, -2}, {-2, 0, 2}, {-2, 2, 2}, {-2, 2, -2}), Quad({-2, 0, 2}, {2, 0, 2}, {2, 2, 2}, {-2, 2, 2}),
        Quad({-2, 0, -2}, {2, 0, -2}, {2, 2, -2}, {-2, 2, -2})})
    Append(&room, wall);
  const int W = 128, H = 65;
  Image map = Image::Rgb(W, H), sky = Image::Rgb(W, H);
  const Eigen::Vector3d centre(0, 1, 0);
  // Where the ray leaves: above the walls' tops, or out of the open side.
  auto leaves = [&](const Eigen::Vector3d& d) {
    double t_exit = INFINITY;  // the box's x, z extent
    for (int a : {0, 2})
      if (std::abs(d[a]) > 1e-12) t_exit = std::min(t_exit, ((d[a] > 0 ? 2 : -2) - centre[a]) / d[a]);
    const Eigen::Vector3d p = centre + t_exit * d;
    if (d.y() < 0 && centre.y() / -d.y() < t_exit) return false;  // the floor first
    return p.y() > 2 || (p.x() > 2 - 1e-9 && std::abs(p.z()) < 2);
  };
  int n_sky = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const Eigen::Vector3d d = LatLongPixelToDirection(Eigen::Vector2d(x, y), W, H);
      const float s = static_cast<float>(1.5 + d.y());
      const bool out = leaves(d);
      n_sky += out;
      for (int c = 0; c < 3; ++c) map.at(x, y, c) = out ? s : 10.0f, sky.at(x, y, c) = s;
    }
  SkyReport r;
  const Image got = SkyOnly(map, room, centre, &r);
  EXPECT_NEAR(static_cast<double>(r.room_pixels), W * H - n_sky, 0.01 * W * H);  // rays along an edge may differ
  EXPECT_GT(r.room_share, 0.5);
  int checked = 0, copied = 0;
  auto leaves_at = [&](int x, int y) {
    return leaves(LatLongPixelToDirection(Eigen::Vector2d((x + W) % W, std::clamp(y, 0, H - 1)), W, H));
  };
  for (int y = 0; y < H; ++y) {
    bool row_sky = false;  // a pixel clear of the room (it and its 8 neighbours leave it)
    for (int x = 0; x < W; ++x) {
      bool clear = true;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) clear = clear && leaves_at(x + dx, y + dy);
      row_sky = row_sky || clear;
    }
    for (int x = 0; x < W; ++x) {
      if (row_sky) {
        ASSERT_NEAR(got.at(x, y, 0), sky.at(x, y, 0), 1e-5) << x << " " << y;
        ++checked;
      } else {
        EXPECT_LT(got.at(x, y, 0), 10.0f);  // no wall at infinity
        EXPECT_GT(got.at(x, y, 0), 0.0f);
        ++copied;
      }
    }
  }
  EXPECT_GT(checked, W * H / 2);
  EXPECT_GT(copied, 0);  // steeply down: the floor in every direction
  // Closed: a lid on the box and a wall at +x.
  Append(&room, Quad({-2, 2, -2}, {-2, 2, 2}, {2, 2, 2}, {2, 2, -2}));
  Append(&room, Quad({2, 0, -2}, {2, 0, 2}, {2, 2, 2}, {2, 2, -2}));
  const Image none = SkyOnly(map, room, centre, &r);
  EXPECT_EQ(r.room_pixels, W * H);
  EXPECT_DOUBLE_EQ(r.room_share, 1.0);
  for (float v : none.values()) ASSERT_EQ(v, 0.0f);
}

// A lamp mirrored in a polished floor (the mirror-ball plate's granite
// counter) is not a second light: mr-lights --room places the panel on the
// ceiling and leaves its reflection, 5 degrees across at a tenth of its
// radiance where the floor mirrors it, to the room's own light (the room
// map keeps it); without the check it became a lamp on the floor, lighting
// the room a second time from below.
TEST(LightPositions, AReflectionInTheFloorIsNotALight) {
  test::TempDir dir;
  WriteTextFile(dir / "room.obj",
                "v -3 2.5 -3\nv 3 2.5 -3\nv 3 2.5 3\nv -3 2.5 3\nv -3 0 -3\nv 3 0 -3\nv 3 0 3\nv -3 0 3\n"
                "f 1 2 3\nf 1 3 4\nf 5 7 6\nf 5 8 7\n");
  Image env = Image::Rgb(256, 128);
  const Eigen::Vector3d lamp = Eigen::Vector3d(0.3, 1.5, 0).normalized();    // (0.3, 2.5, 0) from (0, 1, 0)
  const Eigen::Vector3d image = Eigen::Vector3d(0.3, -3.5, 0).normalized();  // its mirror image, (0.3, -2.5, 0)
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 256; ++x) {
      const Eigen::Vector3d d = LatLongPixelToDirection(Eigen::Vector2d(x, y), 256, 128);
      const float v = AngleBetween(d, lamp) < 8 * kDegToRad    ? 200.0f
                      : AngleBetween(d, image) < 5 * kDegToRad ? 20.0f
                                                               : 1.0f;
      for (int c = 0; c < 3; ++c) env.at(x, y, c) = v;
    }
  WriteImage(dir / "env.exr", env);
  LightsJobOptions o;
  o.env = (dir / "env.exr").string();
  o.out = (dir / "lights.json").string();
  o.residual = (dir / "residual.exr").string();
  o.extract.method = "blobs";
  o.room = (dir / "room.obj").string();
  o.probe_at = {0, 1, 0};
  o.room_map = (dir / "room.exr").string();
  Report report;
  RunLights(o, &report);
  const std::vector<Light> lights = ReadLights(dir / "lights.json");
  ASSERT_EQ(lights.size(), 1u);
  EXPECT_EQ(lights[0].type, LightType::kArea);
  EXPECT_LT(lights[0].direction.y(), -0.99);  // on the ceiling, facing down
  EXPECT_EQ(report.metrics()["positioned"]["reflections"], 1);
  const Image room = ReadImage(dir / "room.exr");
  const Eigen::Vector2d at = DirectionToLatLongPixel(image, 256, 128);
  EXPECT_FLOAT_EQ(room.at(static_cast<int>(std::lround(at.x())), static_cast<int>(std::lround(at.y())), 0), 20.0f);
}

}  // namespace
}  // namespace mr
