#include "light/lights_file.h"

#include <set>

#include "core/json_node.h"

namespace mr {

namespace {
constexpr double kHuge = 1e30;

Eigen::Vector3d UnitDirection(const JsonNode& n) {
  Eigen::Vector3d d = n.Vec3(-kHuge, kHuge);
  const double len = d.norm();
  if (!(len > 1e-12) || !std::isfinite(len)) n.Fail("direction must be a non-zero vector");
  return d / len;
}

std::vector<double> ToJson(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
}  // namespace

Light ParseLight(const JsonNode& n, const std::string& default_name) {
  if (!n.json().is_object()) n.Fail(fmt::format("expected an object, got {}", n.TypeName()));
  Light l;
  const std::string type = n.Required("type").OneOf({"point", "spot", "distant"});
  l.name = n.Has("name") ? n.Child("name").String() : default_name;
  if (n.Has("virtual")) l.is_virtual = n.Child("virtual").Bool();
  if (type == "point" || type == "spot") {
    if (type == "point")
      n.RequireObject({"type", "name", "virtual", "position", "intensity"});
    else
      n.RequireObject(
          {"type", "name", "virtual", "position", "intensity", "direction", "cone_deg", "falloff_start_deg"});
    l.type = type == "point" ? LightType::kPoint : LightType::kSpot;
    l.position = n.Required("position").Vec3(-kHuge, kHuge);
    l.intensity = n.Required("intensity").Vec3(0, kHuge);
    if (l.type == LightType::kSpot) {
      l.direction = UnitDirection(n.Required("direction"));
      l.cone_deg = n.Required("cone_deg").Number(1e-3, 90);
      l.falloff_start_deg = n.Has("falloff_start_deg") ? n.Child("falloff_start_deg").Number(0, 90) : l.cone_deg;
      if (l.falloff_start_deg > l.cone_deg)
        n.Child("falloff_start_deg").Fail(fmt::format("must not exceed cone_deg ({})", l.cone_deg));
    }
  } else {
    n.RequireObject(
        {"type", "name", "virtual", "direction", "irradiance", "angular_radius_deg", "solid_angle_sr", "radiance"});
    l.type = LightType::kDistant;
    l.direction = UnitDirection(n.Required("direction"));
    l.irradiance = n.Required("irradiance").Vec3(0, kHuge);
    if (n.Has("angular_radius_deg")) l.angular_radius_deg = n.Child("angular_radius_deg").Number(0, 90);
    if (n.Has("solid_angle_sr"))
      l.solid_angle_sr =
          n.Child("solid_angle_sr").Number(0, 4 * 3.14159265358979324 * (1 + 1e-9));  // sums of pixels round
    if (n.Has("radiance")) n.Child("radiance").Vec3(0, kHuge);  // informational: irradiance / solid_angle_sr
  }
  return l;
}

std::vector<Light> ParseLights(const Json& j, const std::string& name) {
  JsonNode root(j, "", &name);
  root.RequireObject({"version", "lights", "comment", "source", "residual"});
  if (root.Has("source")) {
    JsonNode src = root.Child("source");
    src.RequireObject({"method", "count", "map", "key", "next_id"});
    if (src.Has("method")) src.Child("method").String();
    if (src.Has("count")) src.Child("count").Integer(0, 1 << 30);
    if (src.Has("map")) src.Child("map").String();
    if (src.Has("key")) src.Child("key").String();  // mr-lights over time: the inputs' key
    if (src.Has("next_id")) src.Child("next_id").Integer(0, 1 << 30);
  }
  if (root.Has("residual")) {
    JsonNode res = root.Child("residual");
    res.RequireObject({"map", "taken_fraction", "sh_order", "sh"});
    if (res.Has("map")) res.Child("map").String();
    if (res.Has("taken_fraction")) res.Child("taken_fraction").Number(0, 1);
    const int64_t order = res.Has("sh_order") ? res.Child("sh_order").Integer(1, 8) : 0;
    if (res.Has("sh")) {
      JsonNode sh = res.Child("sh");
      if (!sh.json().is_array() || static_cast<int64_t>(sh.json().size()) != order * order)
        sh.Fail(fmt::format("expected sh_order^2 = {} RGB coefficients", order * order));
      for (size_t i = 0; i < sh.json().size(); ++i) sh.Index(i).Vec3(-kHuge, kHuge);
    }
  }
  const int64_t version = root.Required("version").Integer(1, 1000);
  if (version != 1)
    root.Child("version").Fail(fmt::format("this mr reads lights version 1, the file is version {}", version));
  if (root.Has("comment")) root.Child("comment").String();
  JsonNode list = root.Required("lights");
  if (!list.json().is_array()) list.Fail(fmt::format("expected an array of lights, got {}", list.TypeName()));
  std::vector<Light> lights;
  std::set<std::string> names;
  for (size_t i = 0; i < list.json().size(); ++i) {
    JsonNode n = list.Index(i);
    Light l = ParseLight(n, fmt::format("light{}", i));
    if (!names.insert(l.name).second) n.Child("name").Fail(fmt::format("name \"{}\" is used twice", l.name));
    lights.push_back(l);
  }
  return lights;
}

std::vector<Light> ReadLights(const fs::path& path) { return ParseLights(ReadJsonFile(path), path.string()); }

Json LightsToJson(const std::vector<Light>& lights, const std::string& comment) {
  Json list = Json::array();
  for (const Light& l : lights) {
    Json j = {{"name", l.name}, {"virtual", l.is_virtual}};
    switch (l.type) {
      case LightType::kPoint:
      case LightType::kSpot:
        j["type"] = l.type == LightType::kPoint ? "point" : "spot";
        j["position"] = ToJson(l.position);
        j["intensity"] = ToJson(l.intensity);
        if (l.type == LightType::kSpot) {
          j["direction"] = ToJson(l.direction);
          j["cone_deg"] = l.cone_deg;
          j["falloff_start_deg"] = l.falloff_start_deg;
        }
        break;
      case LightType::kDistant:
        j["type"] = "distant";
        j["direction"] = ToJson(l.direction);
        j["irradiance"] = ToJson(l.irradiance);
        j["angular_radius_deg"] = l.angular_radius_deg;
        if (l.solid_angle_sr > 0) {
          j["solid_angle_sr"] = l.solid_angle_sr;
          j["radiance"] = ToJson(l.irradiance / l.solid_angle_sr);
        }
        break;
    }
    list.push_back(j);
  }
  Json out = {{"version", 1}, {"lights", list}};
  if (!comment.empty()) out["comment"] = comment;
  return out;
}

}  // namespace mr
