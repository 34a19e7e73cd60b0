// `prt`: virtual objects shaded from their precomputed form-factor transfer
// (mr-formfactor, transfer/formfactor.h) and the environment map.
//
// Each vertex's outgoing radiance is albedo x (transfer . environment), with
// the environment projected into the object's frame; camera samples that hit
// an object take the barycentric blend of its triangle's vertices.  prt
// shades the objects only: their shadows and light on the real room are not
// rendered (I_m = I_r = the photograph outside the objects), and lights.json's
// lights (and the scene's virtual ones) enter as the object's centre sees
// them, added to its environment (AddLightsSeenFrom).  The report says so.
#pragma once

#include <map>
#include <vector>

#include "core/image.h"
#include "core/report.h"
#include "light/light_source.h"
#include "render/camera_sampler.h"
#include "render/method.h"
#include "render/path_tracer.h"
#include "scene/scene.h"

namespace mr {

struct PrtObject {
  std::vector<Eigen::Vector3d> vertex_radiance;
  std::vector<Eigen::Vector3i> triangles;
  Eigen::Vector3d emission = Eigen::Vector3d::Zero();
};

// A copy of lat-long map `env` (world_from_env its orientation) with
// `lights` added as the point `centre` sees them: each light's irradiance
// integral at `centre`, over strata x strata stratified samples (a delta
// light's one direction exact), goes into the pixel of each sample's
// direction as radiance over that pixel's solid angle, in the map's units
// before `scale` (lighting.environment_scale), so that a projection of the
// map keeps its power.  The room does not occlude them (prt ignores it).
Image AddLightsSeenFrom(const Image& env, const std::vector<LightSource>& lights, const Eigen::Vector3d& centre,
                        const Eigen::Matrix3d& world_from_env, double scale, int strata = 16);

// Loads every virtual object's .ffc (refusing a missing one or one computed
// for another mesh), projects the environment and shades the vertices.
// Keyed by the objects' geometry ids in `rs`.
// `spp`: the samples per pixel the render will take (an .ffc computed for
// fewer, with unseen vertices left out, is refused).
std::map<uint32_t, PrtObject> PreparePrt(const Scene& scene, const RenderScene& rs, int spp, Report* report,
                                         int frame = 0);

// The vertices of virtual object `object` that mr-render's camera samples
// (the scene's frames, seed and `spp`) can see: the corners of every
// triangle a camera sample hits.  With bounces 0 the others' transfer can
// change no pixel, so mr-formfactor --scene skips them.
std::vector<char> VerticesSeenByCamera(const Scene& scene, const std::string& object, int spp, int64_t* frames_seen);

class PrtFrameRenderer : public FrameMethod {
 public:
  // `background`: what the camera sees where no object is (the photograph
  // as radiance); null for black.
  PrtFrameRenderer(const RenderScene& scene, const std::map<uint32_t, PrtObject>& objects, const CameraModel& camera,
                   const Rigid3& world_from_cam, uint64_t seed, int frame, const Image* background,
                   const CameraExposure& exposure = {});
  void RenderPass(int spp) override;
  Image Mixed() const override;
  Image Real() const override;
  Image Mask() const override;
  Image DifferenceVariance() const override;
  Image SampleCount() const override;

 private:
  const RenderScene& scene_;
  const std::map<uint32_t, PrtObject>& objects_;
  CameraSampler sampler_;
  int width_, height_;
  Image background_;
  std::vector<Eigen::Vector3d> sum_object_;
  std::vector<int> count_, coverage_;
  int spp_ = 0;
};

// The registry's `prt` (render.prt: no settings; the transfer's are the .ffc's).
std::unique_ptr<RenderMethod> MakePrtMethod(JsonSettings& block, const Scene& scene);

}  // namespace mr
