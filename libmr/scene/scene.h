// scene.json: what mr-render renders (docs/formats.md has the full schema).
//
// Validation is strict: unknown keys, wrong types, out-of-range values and
// missing files are errors naming the key path and the file, e.g.
//   scene.json: virtual[1].material.albedo: expected 3 numbers in [0,1], got 4
// Relative paths resolve against the scene file's folder.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/file.h"
#include "core/json.h"
#include "light/lights_file.h"

namespace mr {

inline constexpr int kSceneVersion = 1;

struct Material {
  Eigen::Vector3d albedo = Eigen::Vector3d::Constant(0.5);  // diffuse reflectance [0,1]
  Eigen::Vector3d specular = Eigen::Vector3d::Zero();       // glossy reflectance [0,1]
  double roughness = 0.5;                                   // (0,1]: GGX alpha = roughness^2
  Eigen::Vector3d emission = Eigen::Vector3d::Zero();       // radiance, W/(sr m^2), >= 0
  bool albedo_from_vertex_colors = false;
  // An image whose texels are the albedo at the mesh's texture coordinates
  // (uv (0,0) at the image's bottom left, repeating; bilinear); empty: none.
  fs::path albedo_texture;
  // Which normal shades the surface: the triangle's own (kGeometric, flat
  // facets: mr's behaviour before shading normals) or the mesh's vertex
  // normals interpolated over it (kVertex; mr::Error where the mesh has
  // none).  An asset's file materials choose kVertex where it has normals.
  enum class Normals { kGeometric, kVertex } normals = Normals::kGeometric;
  bool IsGlossy() const { return specular.maxCoeff() > 0; }
  bool IsEmissive() const { return emission.maxCoeff() > 0; }
};

enum class PoseFormat { kTum, k7Scenes, kColmap };

struct SceneCamera {
  fs::path model;                  // .cameramodel
  std::optional<fs::path> frames;  // video file or printf pattern ("frames/%05d.png")
  bool frames_are_video = false;
  // How the frames relate to radiance: "linear" (radiance), "srgb" (the sRGB
  // curve is the camera response: decoded to radiance, composited linearly),
  // "display" (response unknown: composited in display space, see mr-render),
  // "response" (decoded through `response`, mr-hdr's response.json, and
  // divided by `exposure`, the frames' exposure time: composited linearly).
  std::string frames_transfer = "srgb";
  // Plates in a colour space of an OpenColorIO config (docs/formats.md,
  // "Plates through OpenColorIO"), replacing frames_transfer: the frames'
  // codes decoded from `frames_colorspace` to `ocio_working` (the space mr
  // composites in, linear Rec.709) and the 8- and 16-bit outputs encoded
  // back.  `ocio_config`: the config (none: mr's own, ocio/mr.ocio).
  std::string frames_colorspace;  // empty: none
  std::optional<fs::path> ocio_config;
  std::string ocio_working = "Linear Rec.709 (sRGB)";
  double exposure = 1.0;  // "display": display value = sRGB(clamp(exposure x radiance)); "response": seconds
  std::optional<fs::path> response;
  // The plate's radiometric gains per frame (mr-eval plate's gains.json): the
  // render-to-plate scale that lights the virtual objects in the plate's own
  // units; replaces `exposure` as the render's scale in "display" (the two
  // together are refused).  Absent: exposure ("display") or 1.
  std::optional<fs::path> gains;
  // What the gains scale (docs/radiometry.md, "What the gain scales"):
  // "render" (the room's albedo is trusted and the plate's units unknown:
  // everything rendered is brought to the plate's units) or "room" (the
  // plate is in the captured light's units and the gains correct the
  // room's albedo scale: the room's part of the difference is scaled, the
  // objects' own pixels are not, Debevec's calibration of the local scene).
  // Default "render".
  std::string gains_scale = "render";
  std::optional<fs::path> poses;  // TUM file, 7-Scenes folder, or COLMAP text folder
  PoseFormat pose_format = PoseFormat::kTum;
  bool poses_of_rig = false;  // the poses are the rig reference's (world_from_ref), not the camera's
  // Motion blur: the time the shutter is open, as a fraction of the frame
  // interval (0: none; 0.5 is a 180-degree shutter), centred on the frame;
  // the camera moves between neighbouring frames' poses over it.
  double shutter = 0;
  // Depth of field: a thin lens of this aperture radius (metres: the focal
  // length over twice the f-number; 0: a pinhole) focused at focus_distance
  // (metres, along the optical axis).
  double aperture_radius = 0, focus_distance = 1;
};

struct SceneLighting {
  // Lat-long EXR/HDR, OpenEXR envmap convention; with environment_per_frame
  // a printf pattern of one map per frame ("env/%05d.exr"), a frame without
  // its own taking the last earlier frame's (EnvironmentAt, frames.h).
  // Or a video (IsVideoFile): frame f of the plate is lit by the video's
  // frame f (its last past its end), 8-bit sRGB decoded to linear and then
  // scaled by environment_scale: an LDR 360-degree camera's video, whose
  // clipped sun is lost (docs/formats.md, "Light over time").
  std::optional<fs::path> environment;
  bool environment_per_frame = false, environment_video = false;
  double environment_scale = 1.0;
  Eigen::Matrix3d world_from_env = Eigen::Matrix3d::Identity();
  std::optional<fs::path> lights;  // lights.json from mr-lights; a pattern with lights_per_frame
  bool lights_per_frame = false;
  // Where the light was captured (lighting.probes, at most 16): a ray from
  // a virtual object that meets the real room takes the radiance the probe
  // saw there instead of the rendered room's (render/plate_view.h,
  // docs/methods.md "The room's own light").  `map`: a lat-long map in the
  // environment's units and orientation (environment_scale and its
  // rotation apply), or a printf pattern of one per frame (as environment);
  // none: the environment itself, the frame's own.
  struct Probe {
    Eigen::Vector3d at = Eigen::Vector3d::Zero();
    std::optional<fs::path> map;
    bool map_per_frame = false;
  };
  std::vector<Probe> probes;
};

struct SceneReal {
  fs::path mesh;
  Material material;
};

// A virtual object's pose at a frame of the video (docs/conventions.md,
// "Object trajectories"): world_from_object = T * R * S.
struct ObjectKeyframe {
  double frame = 0;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();  // >= 0; 0 in any axis collapses the object
};

struct SceneVirtual {
  std::string name;
  fs::path mesh;
  Eigen::Affine3d world_from_object = Eigen::Affine3d::Identity();  // without keyframes
  // The trajectory, frames strictly increasing; empty: world_from_object at
  // every frame.
  std::vector<ObjectKeyframe> keyframes;
  Material material;
  std::optional<fs::path> formfactors;  // .ffc from mr-formfactor
  // Shaded by the mesh file's own materials (geometry/asset.h): always for
  // a glTF asset (.gltf, .glb), and for an OBJ whose "material" is "mtl"
  // (its MTL library); `material` is then unused.
  bool file_materials = false;
  // transform.rest_on, resolved: the real surface point the object rests
  // on (its translation set so; docs/formats.md).
  std::optional<Eigen::Vector3d> rests_on;
  // world_from_object at `frame`: between two keyframes translation and
  // scale linear, rotation slerp (the shorter way); before the first and
  // after the last, held.
  Eigen::Affine3d WorldFromObjectAt(double frame) const;
};

// A trajectory's pose at `frame` (docs/conventions.md, "Object
// trajectories"): between two keyframes translation and scale linear,
// rotation slerp (the shorter way); before the first and after the last,
// held; `fixed` when there are no keyframes.
Eigen::Affine3d PoseAt(const std::vector<ObjectKeyframe>& keyframes, const Eigen::Affine3d& fixed, double frame);

// A virtual light that moves: scene.json's `virtual` entries with "light"
// (a lights.json light, in its own frame) instead of "mesh".  Its world
// position is world_from_object x position, its direction the rotation's
// image (scale moves the position only).  Always virtual: it lights I_m.
struct SceneVirtualLight {
  std::string name;
  Light light;
  Eigen::Affine3d world_from_object = Eigen::Affine3d::Identity();
  std::vector<ObjectKeyframe> keyframes;
  Light At(double frame) const;
};

struct SceneRender {
  // The method's name (render/method.h's registry checks it) and each
  // method's settings block, render.<name>, as written: the method parses
  // and validates its own (CheckRenderSettings).
  std::string method = "pt";
  std::map<std::string, Json> method_settings;
  int spp = 64;
  int max_depth = 5;
  uint64_t seed = 0;
  int frame_begin = 0, frame_end = -1;  // [begin, end); end -1 = all
  double time_budget_s = 0;             // 0 = none
  // render.adaptive: a pixel stops taking samples once it has min_spp and
  // the composite's own noise around it is at most `threshold` (relMSE;
  // render/pixel_accumulator.h).  0: every pixel takes spp samples.
  double adaptive_threshold = 0;
  int adaptive_min_spp = 16;
  // Reflections take the room from the frame's own plate, then from these
  // neighbours' (frames f +- k step, k = 1..plate_neighbours, nearest first)
  // where the frame's own does not see the point (docs/methods.md).
  int plate_neighbours = 2;
  int plate_neighbour_step = 3;
  // When the world changes between frames: "incremental" (each method
  // keeps what the change cannot reach, RenderMethod::WorldChanged) or
  // "rebuild" (every view-independent structure made again, as for a first
  // frame: the reference the incremental updates are measured against).
  std::string world_update = "incremental";
};

// The layers a frame's EXR can hold, in the order they are written.
const std::vector<std::string>& OutputLayers();

struct SceneOutput {
  fs::path dir = "out";
  bool png = true;
  bool half = false;  // EXR layers as half floats (refused where values exceed 65504)
  // The composite video, written when the frames are a video: "mp4"
  // (MPEG-4, lossy), "mkv" (FFV1, lossless) or "none".
  std::string video = "mp4";
  bool review = false;  // OUT/NNNNN-review.png: plate | composite | difference | mask, labelled
  // The plate's grain added where the composite shows the render: "auto"
  // (for plates with code values: photographs and video; float plates and
  // synthetic composites have no sensor noise to match), "on" or "off".
  std::string grain = "auto";
  // EXR layers written (OutputLayers(); composite is required): all by default.
  std::vector<std::string> layers = OutputLayers();
};

struct Scene {
  fs::path file;  // the scene file itself
  SceneCamera camera;
  SceneLighting lighting;
  std::vector<SceneReal> reals;  // "real": one {mesh, material} or a list
  std::vector<SceneVirtual> virtuals;
  std::vector<SceneVirtualLight> virtual_lights;  // `virtual` entries that are lights
  SceneRender render;
  SceneOutput output;
  std::optional<fs::path> reference;  // ground truth (mr-synth)
};

// Whether any real or virtual material emits light.
inline bool AnyEmissive(const Scene& s) {
  for (const auto& r : s.reals)
    if (r.material.IsEmissive()) return true;
  for (const auto& v : s.virtuals)
    if (v.material.IsEmissive()) return true;
  return false;
}

// Reads and validates a scene file; `check_files` also requires every named
// input file to exist.
Scene ReadScene(const fs::path& path, bool check_files = true);
// Validates JSON already parsed; `base` resolves relative paths; `name` is
// the file name used in messages.
Scene ParseScene(const Json& j, const fs::path& base, const std::string& name, bool check_files);

}  // namespace mr
