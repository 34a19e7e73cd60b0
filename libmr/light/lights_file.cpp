#include "light/lights_file.h"

#include <optional>
#include <set>

#include "core/json_node.h"
#include "core/json_settings.h"

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
  JsonSettings s(n);
  Light l;
  const std::string type = s.Require("type").OneOf({"point", "spot", "distant", "area"});
  const auto name = s.Take("name");
  l.name = name ? name->String() : default_name;
  s.Bool("virtual", &l.is_virtual);
  if (const auto lb = s.Take("lower_bound")) l.strength_note = lb->String();
  if (type == "point" || type == "spot") {
    l.type = type == "point" ? LightType::kPoint : LightType::kSpot;
    const JsonNode position = s.Require("position");
    const JsonNode intensity = s.Require("intensity");
    std::optional<JsonNode> direction, cone, falloff;
    if (l.type == LightType::kSpot) {
      direction.emplace(s.Require("direction"));
      cone.emplace(s.Require("cone_deg"));
      if (const auto f = s.Take("falloff_start_deg")) falloff.emplace(*f);
    }
    s.Done();
    l.position = position.Vec3(-kHuge, kHuge);
    l.intensity = intensity.Vec3(0, kHuge);
    if (l.type == LightType::kSpot) {
      l.direction = UnitDirection(*direction);
      l.cone_deg = cone->Number(1e-3, 90);
      l.falloff_start_deg = falloff ? falloff->Number(0, 90) : l.cone_deg;
      if (l.falloff_start_deg > l.cone_deg) falloff->Fail(fmt::format("must not exceed cone_deg ({})", l.cone_deg));
    }
  } else if (type == "area") {
    l.type = LightType::kArea;
    const JsonNode position = s.Require("position");
    const JsonNode direction = s.Require("direction");
    const JsonNode radiance = s.Require("radiance");
    std::string shape = "rect";
    s.OneOf("shape", &shape, {"rect", "disc"});
    l.shape = shape == "rect" ? AreaShape::kRect : AreaShape::kDisc;
    std::optional<JsonNode> width, height, radius, axis;
    if (l.shape == AreaShape::kRect) {
      width.emplace(s.Require("width"));
      height.emplace(s.Require("height"));
      if (const auto a = s.Take("axis")) axis.emplace(*a);
    } else {
      radius.emplace(s.Require("radius"));
    }
    s.Done();
    l.position = position.Vec3(-kHuge, kHuge);
    l.direction = UnitDirection(direction);
    l.radiance = radiance.Vec3(0, kHuge);
    if (l.shape == AreaShape::kRect) {
      l.width = width->Number(1e-9, kHuge);
      l.height = height->Number(1e-9, kHuge);
      Eigen::Vector3d a = axis ? UnitDirection(*axis) : Eigen::Vector3d::UnitX();
      if (!axis && std::abs(a.dot(l.direction)) > 0.9) a = Eigen::Vector3d::UnitZ();
      a -= a.dot(l.direction) * l.direction;
      if (!(a.norm() > 1e-6)) axis->Fail("must not be parallel to direction");
      l.axis = a.normalized();
    } else {
      l.width = l.height = 2 * radius->Number(1e-9, kHuge);
    }
  } else {
    l.type = LightType::kDistant;
    const JsonNode direction = s.Require("direction");
    const JsonNode irradiance = s.Require("irradiance");
    s.Number("angular_radius_deg", &l.angular_radius_deg, 0, 90);
    s.Number("solid_angle_sr", &l.solid_angle_sr, 0, 4 * 3.14159265358979324 * (1 + 1e-9));  // sums of pixels round
    const auto radiance = s.Take("radiance");  // informational: irradiance / solid_angle_sr
    s.Done();
    l.direction = UnitDirection(direction);
    l.irradiance = irradiance.Vec3(0, kHuge);
    if (radiance) radiance->Vec3(0, kHuge);
  }
  return l;
}

std::vector<Light> ParseLights(const Json& j, const std::string& name) {
  const JsonNode root_node(j, "", &name);
  JsonSettings root(root_node);
  const JsonNode version = root.Require("version");
  const JsonNode list = root.Require("lights");
  const auto comment = root.Take("comment");
  const auto source = root.Take("source");
  const auto residual = root.Take("residual");
  root.Done();
  if (source) {
    JsonSettings src(*source);
    if (const auto v = src.Take("method")) v->String();
    if (const auto v = src.Take("count")) v->Integer(0, 1 << 30);
    if (const auto v = src.Take("map")) v->String();
    if (const auto v = src.Take("key")) v->String();  // mr-lights over time: the inputs' key
    if (const auto v = src.Take("next_id")) v->Integer(0, 1 << 30);
    src.Done();
  }
  if (residual) {
    JsonSettings res(*residual);
    if (const auto v = res.Take("map")) v->String();
    if (const auto v = res.Take("taken_fraction")) v->Number(0, 1);
    const auto order_node = res.Take("sh_order");
    const int64_t order = order_node ? order_node->Integer(1, 8) : 0;
    if (const auto sh = res.Take("sh")) {
      if (!sh->json().is_array() || static_cast<int64_t>(sh->json().size()) != order * order)
        sh->Fail(fmt::format("expected sh_order^2 = {} RGB coefficients", order * order));
      for (size_t i = 0; i < sh->json().size(); ++i) sh->Index(i).Vec3(-kHuge, kHuge);
    }
    res.Done();
  }
  if (const int64_t v = version.Integer(1, 1000); v != 1)
    version.Fail(fmt::format("this mr reads lights version 1, the file is version {}", v));
  if (comment) comment->String();
  if (!list.json().is_array()) list.Fail(fmt::format("expected an array of lights, got {}", list.TypeName()));
  std::vector<Light> lights;
  std::set<std::string> names;
  for (size_t i = 0; i < list.json().size(); ++i) {
    JsonNode n = list.Index(i);
    Light l = ParseLight(n, fmt::format("light{}", i));
    if (!names.insert(l.name).second)  // a default name may meet a given one
      (n.Has("name") ? n.Child("name") : n).Fail(fmt::format("name \"{}\" is used twice", l.name));
    lights.push_back(l);
  }
  return lights;
}

std::vector<Light> ReadLights(const fs::path& path) { return ParseLights(ReadJsonFile(path), path.string()); }

Json LightsToJson(const std::vector<Light>& lights, const std::string& comment) {
  Json list = Json::array();
  for (const Light& l : lights) {
    Json j = {{"name", l.name}, {"virtual", l.is_virtual}};
    if (!l.strength_note.empty()) j["lower_bound"] = l.strength_note;
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
      case LightType::kArea:
        j["type"] = "area";
        j["shape"] = l.shape == AreaShape::kRect ? "rect" : "disc";
        j["position"] = ToJson(l.position);
        j["direction"] = ToJson(l.direction);
        j["radiance"] = ToJson(l.radiance);
        if (l.shape == AreaShape::kRect) {
          j["axis"] = ToJson(l.axis);
          j["width"] = l.width;
          j["height"] = l.height;
        } else {
          j["radius"] = 0.5 * l.width;
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
