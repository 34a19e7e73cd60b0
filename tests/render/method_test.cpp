// The method registry, the settings each method parses from its own
// render.<method> block, and the pixel loop every sampled method shares.
#include "render/method.h"

#include <gtest/gtest.h>

#include <set>

#include "core/error.h"
#include "core/json_node.h"
#include "render/gi_scenes.h"
#include "render/irradiance_cache.h"
#include "render/pixel_loop.h"
#include "render/render_scene.h"

namespace mr {
namespace {

using namespace gi_test;

Scene SceneWithRender(const Json& render) {
  Json j = {{"version", 1},
            {"camera", {{"model", "cam.cameramodel"}}},
            {"virtual", Json::array({{{"mesh", "bunny.ply"}}})},
            {"render", render}};
  return ParseScene(j, ".", "scene.json", false);
}

std::string CheckError(const Json& render) {
  try {
    CheckRenderSettings(SceneWithRender(render));
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(MethodRegistry, IsTheOneListOfMethods) {
  std::set<std::string> names;
  for (const MethodInfo& m : RenderMethodRegistry()) {
    EXPECT_TRUE(names.insert(m.name).second) << m.name << " twice";
    EXPECT_FALSE(m.summary.empty()) << m.name;
    EXPECT_TRUE(m.create) << m.name;
    EXPECT_FALSE(m.sweep.empty()) << m.name << ": mr-eval sweep needs a default axis";
  }
  EXPECT_EQ(RenderMethodNames(), "pt, ic, vpl, vct, prt");
  // prt shades the objects only: not in the default sweep; the one method
  // that reads form factors (mr-pipeline plans the formfactor stage for it).
  EXPECT_EQ(DefaultSweepMethods(), (std::vector<std::string>{"pt", "ic", "vpl", "vct"}));
  for (const MethodInfo& m : RenderMethodRegistry()) EXPECT_EQ(m.uses_formfactors, m.name == "prt") << m.name;
  EXPECT_EQ(&FindRenderMethod("vct"), &RenderMethodRegistry()[3]);
  try {
    FindRenderMethod("magic");
    FAIL() << "no error";
  } catch (const UsageError& e) {
    EXPECT_STREQ(e.what(), "unknown method \"magic\" (pt, ic, vpl, vct, prt)");
  }
}

// Each method parses its own block: defaults written once (in its settings
// struct), unknown keys and bad values rejected with the key path.
TEST(MethodRegistry, EachMethodChecksItsOwnBlock) {
  EXPECT_EQ(CheckError({{"method", "vpl"}, {"vpl", {{"paths", 16}}}, {"ic", {{"rays", 8}}}}), "");
  EXPECT_EQ(CheckError({{"method", "magic"}}),
            "scene.json: render.method: \"magic\" is not one of pt, ic, vpl, vct, prt");
  EXPECT_EQ(CheckError({{"vpll", Json::object()}}).rfind("scene.json: render.vpll: unknown key", 0), 0u)
      << CheckError({{"vpll", Json::object()}});
  EXPECT_EQ(CheckError({{"vpl", {{"clamp", 0.1}}}})
                .rfind("scene.json: render.vpl.clamp: unknown key (allowed here: paths,", 0),
            0u);
  EXPECT_EQ(CheckError({{"vct", {{"relight", "both"}}}}),
            "scene.json: render.vct.relight: \"both\" is not one of delta, split");
  EXPECT_EQ(CheckError({{"ic", {{"min_spacing_px", 40}}}}),
            "scene.json: render.ic.min_spacing_px: is larger than max_spacing_px");
  EXPECT_EQ(CheckError({{"ic", {{"glossy_depth", -2}}}}),
            "scene.json: render.ic.glossy_depth: expected an integer in [-1, 64], got -2");
  EXPECT_EQ(CheckError({{"ic", {{"glossy_rays", 0}}}}),
            "scene.json: render.ic.glossy_rays: expected an integer in [1, 1024], got 0");
  EXPECT_EQ(CheckError({{"prt", {{"spp", 4}}}}).rfind("scene.json: render.prt.spp: unknown key", 0), 0u);
}

// A glossy virtual sphere on the open corner's floor.
void GlossyCorner(RenderScene* s) {
  s->AddReal(Quad({-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}), Diffuse(0.6));
  s->AddReal(Quad({-2, 0, 1}, {2, 0, 1}, {2, 2, 1}, {-2, 2, 1}), Diffuse(0.7));
  Material glossy = Diffuse(0.2);
  glossy.specular = Eigen::Vector3d::Constant(0.7);
  glossy.roughness = 0.1;
  Eigen::Affine3d t = Eigen::Affine3d::Identity();
  t.translate(Eigen::Vector3d(0, 0.3, 0));
  s->AddVirtual(UvSphere(0.3f, 24), t, glossy);
  s->SetEnvironment(Sky(100));
  s->Commit();
}

// render.ic.glossy_depth reaches ic through the registry (it was parsed and
// documented but never used): with 0 the glossy lobe takes next-event light
// only, so the sphere, which mirrors the lit floor and wall, is darker.
TEST(MethodRegistry, IcGlossyDepthChangesTheResult) {
  RenderScene rs;
  GlossyCorner(&rs);
  const CameraModel cam = Pinhole(24, 18, 20);
  const Rigid3 pose = LookAt({0, 0.6, -1.2}, {0, 0.3, 0});
  auto render = [&](const Json& block) {
    const Scene scene = SceneWithRender({{"method", "ic"}, {"ic", block}});
    const std::string file = "scene.json";
    std::unique_ptr<RenderMethod> m =
        CreateRenderMethod(FindRenderMethod("ic"), JsonNode(block, "render.ic", &file), scene);
    Report report("mr-render", "test");
    m->Prepare(JobContext{scene, rs, cam, 4, 0, false, &report});
    std::unique_ptr<FrameMethod> f = m->NewFrame(FrameContext{rs, cam, pose, 0, 0, nullptr});
    f->RenderPass(4);
    return Mean(f->Mixed());
  };
  const double full = render({{"rays", 16}, {"glossy_depth", 5}}), one = render({{"rays", 16}, {"glossy_depth", 1}}),
               none = render({{"rays", 16}, {"glossy_depth", 0}});
  EXPECT_GT(full, none * 1.05) << full << " " << none;
  EXPECT_GE(full, one);  // a shorter glossy path gathers no more light
  EXPECT_NE(full, one);
  EXPECT_EQ(render({{"rays", 16}, {"glossy_depth", 2}}), render({{"rays", 16}}));  // the default: 2
}

// The smallest method: what docs/architecture.md's "How to add a render
// method" builds on.  The loop counts every sample, drops non-finite ones
// (counted, never NaN in the image) and numbers samples across passes.
class ConstantMethod : public PixelLoopMethod {
 public:
  ConstantMethod(const CameraModel& camera, const Rigid3& pose) : PixelLoopMethod(camera, pose, 0, 0) {}
  std::vector<int> last_sample = std::vector<int>(12, -1);

 private:
  void Shade(const Ray&, Sampler&, int64_t, size_t pixel, int sample, PathSample* out) override {
    out->mixed = Eigen::Vector3d(1, 2, 3);
    out->real = pixel == 0 ? Eigen::Vector3d::Constant(NAN) : Eigen::Vector3d(1, 1, 1);
    out->primary_virtual = pixel % 2 == 1;
    out->rays = 1;
    last_sample[pixel] = sample;
  }
};

TEST(PixelLoop, CountsDropsAndNumbersSamples) {
  ConstantMethod m(Pinhole(4, 3, 3), Rigid3());
  m.RenderPass(2);
  m.RenderPass(3);
  EXPECT_EQ(m.samples_per_pixel(), 5);
  EXPECT_EQ(m.last_sample[5], 4);  // samples 0..4: the second pass goes on from the first
  EXPECT_EQ(m.nonfinite_samples(), 5);
  EXPECT_EQ(m.rays_traced(), 60);
  const Image mixed = m.Mixed(), real = m.Real(), mask = m.Mask(), count = m.SampleCount();
  EXPECT_EQ(count.at(0, 0, 0), 5);
  EXPECT_EQ(mixed.at(0, 0, 0), 0);  // pixel 0's samples were all dropped
  EXPECT_EQ(mixed.at(1, 0, 2), 3);
  EXPECT_EQ(real.at(1, 0, 1), 1);
  EXPECT_EQ(mask.at(1, 0, 0), 1);
  EXPECT_EQ(mask.at(2, 0, 0), 0);
  EXPECT_EQ(m.DifferenceVariance().at(1, 0, 0), 0);  // a constant difference has no variance
}

}  // namespace
}  // namespace mr
