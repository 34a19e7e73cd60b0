// mr-synth: synthetic captures of a known "real" room with exact ground truth.
//
// A capture folder holds everything a real capture would (camera model,
// trajectory, photographs I_c, room meshes with their albedos, an
// environment map) plus the ground truth: a converged differential render
// of room + virtual object per frame, named by scene.json's "reference".
// The photographs are the real-only paths of that same render, so the
// truth differs from the photograph exactly where the object changes the
// image (docs/formats.md, "Synthetic captures").  Later stages add
// chessboard, mirror-sphere and RGB-D generators beside these.
#pragma once

#include <optional>
#include <string>

#include "camera/camera_model.h"
#include "camera/trajectory.h"
#include "core/file.h"
#include "core/image.h"
#include "core/report.h"
#include "geometry/mesh.h"
#include "light/lights_file.h"
#include "scene/scene.h"

namespace mr {

struct SynthOptions {
  std::string preset = "small";  // small | room
  fs::path out;
  uint64_t seed = 1;
  std::string object = "sphere";  // sphere | box | a mesh file (OBJ/PLY/OFF/STL)
  int truth_spp = 0;              // 0: the preset's
  // Samples per pixel of the truth in the object's region (0: truth_spp):
  // where a pilot render (its own seed, independent of the truth's samples,
  // so the choice of pixels adds no bias) sees the object change the image,
  // grown by 2 pixels, the truth takes this many samples.  The difference
  // the methods are scored on lives there; elsewhere truth_spp suffices.
  // Must be at least truth_spp; both even, so that the truth's two halves
  // (its noise estimate) are halves in every pixel.
  int truth_region_spp = 0;
  int frames = 0;  // 0: the preset's
  // The object's material: diffuse (albedo 0.8/0.75/0.7), glossy (albedo
  // 0.25, GGX specular 0.6 at roughness 0.3) or mirror (specular 0.9 at
  // roughness 0.05).
  std::string object_material = "diffuse";
  // The table top: glossy (the default) or diffuse (no caustic paths: the
  // sun reflected by the table onto the room and the object).
  std::string table_top = "glossy";
  // The scene camera's lens: opencv4 (a mild barrel distortion, the default)
  // or pinhole (for renderers without lens models, e.g. bench/cycles_compare.py).
  std::string lens = "opencv4";
  bool spot_light = false;  // a real spot light above the table (lights.json)
  // A world that changes during the video: the sun moving across the sky
  // (env/NNNNN.exr), the spot lamp switched on halfway (lights/NNNNN.json),
  // the object sliding across the table and turning (a trajectory); the
  // truth rendered per frame in that frame's world.
  bool dynamic = false;
  // A mirror sphere standing on the table in the plate's view, a real part
  // of the room (meshes/plate_sphere.ply): the light probe of the plate
  // itself (mr-probe --sphere-in-plate).  plate-sphere.json says where it is;
  // reference/sphere/NNNNN.exr is, per frame, the exact light arriving at
  // its centre from the room and the sky (the map a perfect probe there
  // would capture; the sphere itself left out).
  bool plate_sphere = false;
  bool probe = true;  // write probe/ (the light probe's photographs); tests that need none leave it out
  std::string tool = "mr-synth", command_line;

  // UsageError naming the flag: --out missing, an unknown --preset, --object-material,
  // --table-top or --lens, negative sample counts or frames.
  void Check() const;
};

struct SynthPreset {
  int width, height, frames, truth_spp, render_spp;
  double sun_to_sky;  // sun radiance / sky radiance
};
SynthPreset GetSynthPreset(const std::string& name);

// probe/: the light camera, a mirror sphere's photograph, a bracket of it
// and a bracket of the fish-eye at the zenith, and truth.json (docs/formats.md).
void WriteProbe(const SynthOptions& options, const Image& sky, Report* report);

// Writes the capture; fills `report`.  MakeSynthCapture, WriteSynthInputs,
// then per frame the truth rendered and written with its photographs.
void RunSynth(const SynthOptions& options, Report* report);

// The room's real parts: floor, back and left walls, a table with a glossy
// top and legs, two boxes of known albedo.
struct SynthPart {
  std::string name;
  Mesh mesh;
  Material material;
};
// `glossy_table`: the table top glossy (GGX specular 0.6, roughness 0.25;
// the sun's reflection in it lights the room, caustic paths that are a
// path tracer's fireflies) or diffuse (albedo 0.15/0.15/0.18 alone).
std::vector<SynthPart> SynthRoom(bool glossy_table = true);
// A capture as computed, before anything is written: the room, the object
// on the table, the sky and lights, the camera and its path.
// The plate's mirror sphere (SynthOptions::plate_sphere).
struct SynthPlateSphere {
  Eigen::Vector3d centre{-0.42, 0.85, -0.22};  // world, metres: resting on the table top's near left
  double radius = 0.1;                         // a 20 cm garden ball
  double reflectance = 0.6;                    // chrome's, constant (no Fresnel term, render/bsdf.h)
  // GGX roughness 0.2 (alpha 0.04): a lobe of about 2 degrees, which
  // smooths the reflection across the mesh's flat facets (1.9 degrees; the
  // renderer shades by geometric normals: at roughness 0.01 each facet
  // reflects one direction and a sun between them is missed) and stays
  // below what the plate resolves of the sphere (4 degrees a pixel).
  double roughness = 0.2;
};
struct SynthCapture {
  SynthPreset preset{};
  std::optional<SynthPlateSphere> plate_sphere;
  // With SynthOptions::dynamic: the sky of each frame, whether the lamp is
  // on, the object's keyframes (first and last frame).
  std::vector<Image> skies;
  std::vector<char> lamp_on;
  std::vector<ObjectKeyframe> keyframes;
  int truth_spp = 0;
  std::vector<SynthPart> parts;
  Mesh object;
  // The object scaled to about 30 cm across (object_scale) and rested on the
  // table top, its footprint centred at object_rests_on.
  double object_scale = 1;
  Eigen::Vector3d object_rotation_deg = Eigen::Vector3d::Zero();  // x, y, z as scene.json's rotation_deg
  Eigen::Vector3d object_rests_on = Eigen::Vector3d::Zero();
  Eigen::Affine3d world_from_object = Eigen::Affine3d::Identity();
  Material object_material;
  Image sky;
  std::vector<Light> lights;
  CameraModel camera;
  Trajectory trajectory;
};
SynthCapture MakeSynthCapture(const SynthOptions& options);

// The capture's inputs: meshes, camera model, trajectory, env.exr,
// lights.json, scene.json and the probe (WriteProbe); `note` is their provenance.
void WriteSynthInputs(const SynthOptions& options, const SynthCapture& capture, const std::string& note,
                      Report* report);

// The parts' geometry as one mesh (the reference for mr-eval mesh).
Mesh MergeParts(const std::vector<SynthPart>& parts);

// Instead of a capture: an RGB-D recording of the room (TUM layout, with a
// Kinect-like sensor, synth/rgbd_view.h) in options.out, the room's true
// geometry in reference/room.ply and its sky in reference/env.exr.
struct RgbdSynthSize {
  int width = 0, height = 0, frames = 0;  // 0: the preset's (small 160x120x60, room 640x480x300)
  int color_spp = -1;                     // -1: the preset's (2, 1)
  double exposure = 0.5;
  bool clean = false;  // no sensor noise, quantisation or holes
};
void RunSynthRgbd(const SynthOptions& options, const RgbdSynthSize& size, Report* report);

}  // namespace mr
