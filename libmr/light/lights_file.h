// lights.json: light sources beside the environment map (written by
// mr-lights, or by hand; docs/formats.md has the schema).
//
//   point:   position, intensity I (W/sr): irradiance I cos / d^2
//   spot:    a point light shining along `direction`, full intensity inside
//            `falloff_start_deg`, smoothly down to zero at `cone_deg`
//   distant: a disc of angular radius `angular_radius_deg` around
//            `direction` (pointing towards the light) that gives the
//            irradiance `irradiance` (W/m^2) on a surface facing it; radius
//            0 is a delta (directional) light.  The sun is 0.27 degrees.
//   area:    a lamp panel, a window: a rectangle (`width` along `axis`,
//            `height` across) or a disc (`radius`) centred at `position`,
//            emitting `radiance` (W/(m^2 sr)) uniformly from the side
//            `direction` points to (Lambertian, one-sided).
//
// A light whose strength is only a lower bound (mr-lights: its region was
// clipped in the photograph) says why in "lower_bound".
//
// Every light is real or virtual: a virtual light (a lamp that is part of
// the inserted object) lights I_m only; a real one lights both I_m and I_r.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/file.h"
#include "core/json.h"
#include "core/json_node.h"

namespace mr {

enum class LightType { kPoint, kSpot, kDistant, kArea };
enum class AreaShape { kRect, kDisc };

struct Light {
  std::string name;
  LightType type = LightType::kPoint;
  bool is_virtual = false;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();    // point, spot
  Eigen::Vector3d direction = Eigen::Vector3d::UnitY();  // spot: where it shines; distant: towards the light
  Eigen::Vector3d intensity = Eigen::Vector3d::Zero();   // point, spot: W/sr
  double cone_deg = 30, falloff_start_deg = 25;          // spot
  Eigen::Vector3d irradiance = Eigen::Vector3d::Zero();  // distant: W/m^2 at normal incidence
  double angular_radius_deg = 0;                         // distant: 0 = delta
  double solid_angle_sr = 0;  // distant: the map region it came from (mr-lights), 0 = unknown
  std::string strength_note;  // "lower_bound" in lights.json: why its strength is only a lower bound (empty: measured)
  AreaShape shape = AreaShape::kRect;                  // area
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();     // area, rect: along its width (made normal to `direction`)
  double width = 0, height = 0;                        // area: rect's sides; disc: both the diameter
  Eigen::Vector3d radiance = Eigen::Vector3d::Zero();  // area: W/(m^2 sr)

  // Point, spot and distant lights of radius 0: a single direction from any point.
  bool IsDelta() const {
    return type == LightType::kPoint || type == LightType::kSpot ||
           (type == LightType::kDistant && angular_radius_deg <= 0);
  }
  double Area() const {
    return shape == AreaShape::kRect ? width * height : 0.25 * 3.14159265358979324 * width * width;
  }
};

// Parses and validates (unknown keys, ranges, zero-length directions are
// errors naming `name` and the key path).
std::vector<Light> ParseLights(const Json& j, const std::string& name);
// One light entry (lights.json's "lights" items); `default_name` when it has none.
Light ParseLight(const JsonNode& node, const std::string& default_name);
std::vector<Light> ReadLights(const fs::path& path);
Json LightsToJson(const std::vector<Light>& lights, const std::string& comment = "");

}  // namespace mr
