// The panel's direct light on an object, from a probe at several distances
// from it: the disc at infinity the map gives against the area light placed
// in the room (mr-lights --room).  A 5 x 2.6 x 4 m room, a 0.5 m ceiling
// panel, the object a 0.15 m sphere on the floor; each probe map rendered
// by pt at 512 x 256, 16 samples a pixel.  Prints a table (docs/benchmarks.md,
// "Light as it was in the room").  Usage: bench_light_distance
#include <cstdio>

#include "core/color.h"
#include "core/math.h"
#include "core/spherical.h"
#include "geometry/primitives.h"
#include "jobs/light_positions.h"
#include "light/light_source.h"
#include "probe/light_extraction.h"
#include "render/path_tracer.h"
#include "render/render_scene.h"

namespace {

using namespace mr;

// Irradiance at p (normal n) from `l`, unoccluded.
double Irradiance(const Light& l, const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  return UnoccludedIrradiance(LightSource(l), p, n);
}

}  // namespace

int main() {
  RenderScene scene;
  Material wall;
  wall.albedo = Eigen::Vector3d::Constant(0.5);
  const Mesh room = Box({-2.5f, 0, -2}, {2.5f, 2.6f, 2});
  scene.AddReal(room, wall);
  Light panel;
  panel.name = "panel";
  panel.type = LightType::kArea;
  panel.position = Eigen::Vector3d(0.8, 2.59, 0.5);
  panel.direction = Eigen::Vector3d(0, -1, 0);
  panel.width = panel.height = 0.5;
  panel.radiance = Eigen::Vector3d::Constant(40);
  scene.AddLight(panel);
  scene.Commit();
  // The object's surface points: its sphere's upper half and a ring of floor around it.
  const Eigen::Vector3d object(0, 0.15, 0);
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> points;
  for (const Eigen::Vector3d& n : SphereNormals(200))
    if (n.y() > -0.2) points.push_back({object + 0.15 * n, n});
  for (int k = 0; k < 32; ++k) {
    const double a = kTwoPi * k / 32;
    points.push_back({Eigen::Vector3d(0.3 * std::cos(a), 0, 0.3 * std::sin(a)), Eigen::Vector3d::UnitY()});
  }
  std::vector<double> truth;
  for (const auto& [p, n] : points) truth.push_back(Irradiance(panel, p, n));
  struct Place {
    const char* name;
    Eigen::Vector3d at;
  };
  const std::vector<Place> places = {{"at the object", Eigen::Vector3d(0, 0.5, 0)},
                                     {"0.5 m away", Eigen::Vector3d(-0.5, 0.5, 0)},
                                     {"1.0 m away", Eigen::Vector3d(-1.0, 0.5, 0)},
                                     {"1.5 m away", Eigen::Vector3d(-1.5, 0.5, 0)},
                                     {"1 m, in a corner", Eigen::Vector3d(-0.7, 0.5, -0.7)}};
  PathTracerSettings st;
  st.max_depth = 3;
  std::printf("| probe | distant: RMS error of the panel's irradiance | placed | placed light's centre off |\n");
  std::printf("|---|---|---|---|\n");
  for (const Place& pl : places) {
    const Image env = RenderProbeMap(scene, pl.at, 512, 16, st, 7);
    ExtractOptions eo;
    eo.method = "blobs";
    eo.count = 4;
    eo.keep_wide = true;
    const Extraction ex = ExtractLights(env, eo);
    const std::vector<Light> distant = ToLights(ex);
    PositionOptions po;
    po.probe_centre = pl.at;
    PositionReport pr;
    const std::vector<Light> placed = PositionLights(env, ex, distant, room, po, &pr);
    auto rms = [&](const std::vector<Light>& lights) {
      double se = 0, s2 = 0;
      for (size_t i = 0; i < points.size(); ++i) {
        double e = 0;
        for (const Light& l : lights) e += Irradiance(l, points[i].first, points[i].second);
        se += Square(e - truth[i]);
        s2 += Square(truth[i]);
      }
      return std::sqrt(se / s2);
    };
    double off = -1;
    for (const Light& l : placed)
      if (l.type == LightType::kArea) off = (l.position - panel.position).norm();
    std::printf("| %s | %.1f%% | %.1f%% | %.1f cm |\n", pl.name, 100 * rms(distant), 100 * rms(placed), 100 * off);
  }
  return 0;
}
