#include "render/method.h"

#include "core/error.h"
#include "render/irradiance_cache.h"
#include "render/prt.h"
#include "render/pt.h"
#include "render/vct.h"
#include "render/vpl.h"

namespace mr {

const std::vector<MethodInfo>& RenderMethodRegistry() {
  static const std::vector<MethodInfo> methods = {
      {.name = "pt",
       .summary = "differential path tracing: the unbiased reference",
       .sweep = {{"spp", {1, 4, 16, 64, 256}}},
       .create = MakePtMethod},
      {.name = "ic",
       .summary = "differential irradiance caching (Kan & Kaufmann 2013)",
       .one_pass = true,
       .sweep = {{"rays", {32, 64, 128, 256}}, {"spp", {4, 8, 16, 32}}},
       .create = MakeIcMethod},
      {.name = "vpl",
       .summary = "differential instant radiosity (Knecht et al. 2010)",
       .one_pass = true,
       .prepare_timing = "build vpls",
       .sweep = {{"paths", {64, 128, 256, 512}}, {"spp", {2, 4, 8, 16}}},
       .create = MakeVplMethod},
      {.name = "vct",
       .summary = "delta global illumination by voxel cone tracing (Thoner & Kuijper 2016)",
       .one_pass = true,
       .prepare_timing = "build volumes",
       .sweep = {{"resolution", {32, 64, 128}}, {"spp", {4}}},
       .create = MakeVctMethod},
      {.name = "prt",
       .summary = "the virtual objects shaded from precomputed form factors (no light on the room)",
       .uses_formfactors = true,
       .default_sweep = false,
       .prepare_timing = "prepare prt",
       .sweep = {{"spp", {1, 4, 16}}},
       .create = MakePrtMethod},
  };
  return methods;
}

std::vector<std::string> DefaultSweepMethods() {
  std::vector<std::string> out;
  for (const MethodInfo& m : RenderMethodRegistry())
    if (m.default_sweep) out.push_back(m.name);
  return out;
}

std::string RenderMethodNames() {
  std::string s;
  for (const MethodInfo& m : RenderMethodRegistry()) s += (s.empty() ? "" : ", ") + m.name;
  return s;
}

const MethodInfo& FindRenderMethod(std::string_view name) {
  for (const MethodInfo& m : RenderMethodRegistry())
    if (m.name == name) return m;
  throw UsageError(fmt::format("unknown method \"{}\" ({})", name, RenderMethodNames()));
}

namespace {

// The scene's render.<name> block, or an empty object.
std::unique_ptr<RenderMethod> Create(const MethodInfo& m, const Scene& scene, const std::string& file) {
  static const Json kEmpty = Json::object();
  const auto it = scene.render.method_settings.find(m.name);
  const Json& block = it == scene.render.method_settings.end() ? kEmpty : it->second;
  return CreateRenderMethod(m, JsonNode(block, "render." + m.name, &file), scene);
}

}  // namespace

std::unique_ptr<RenderMethod> CreateRenderMethod(const MethodInfo& m, const JsonNode& block, const Scene& scene) {
  JsonSettings settings(block);
  std::unique_ptr<RenderMethod> method = m.create(settings, scene);
  settings.Done();
  return method;
}

std::vector<SettingDecl> RenderMethodSettings(const MethodInfo& m) {
  static const Json kEmpty = Json::object();
  static const std::string kFile = "(defaults)";
  JsonSettings settings(JsonNode(kEmpty, "render." + m.name, &kFile));
  m.create(settings, Scene{});
  return settings.declared();
}

void CheckRenderSettings(const Scene& scene) {
  const std::string file = scene.file.string();
  const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const MethodInfo& m : RenderMethodRegistry()) n.push_back(m.name);
    return n;
  }();
  if (!scene.render.method.empty()) {
    const Json j = scene.render.method;
    JsonNode(j, "render.method", &file).OneOf(names);
  }
  for (const auto& [name, block] : scene.render.method_settings) {
    bool known = false;
    for (const MethodInfo& m : RenderMethodRegistry()) known = known || m.name == name;
    if (!known)
      JsonNode(block, "render." + name, &file)
          .Fail(fmt::format("unknown key (allowed here: the generic settings, or a method's block: {})",
                            RenderMethodNames()));
  }
  for (const MethodInfo& m : RenderMethodRegistry()) Create(m, scene, file);
}

std::unique_ptr<RenderMethod> CreateRenderMethod(const Scene& scene, const std::string& name) {
  CheckRenderSettings(scene);
  return Create(FindRenderMethod(name.empty() ? scene.render.method : name), scene, scene.file.string());
}

}  // namespace mr
