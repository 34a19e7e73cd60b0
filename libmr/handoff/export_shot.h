// mr-export: a shot (scene.json: the room, the virtual objects, the camera
// path and lens, the light) written as a glTF 2.0 scene that Blender and
// other glTF readers import, plus the Blender script that sets up what glTF
// cannot carry.  The conventions (axes, the camera, units, extras) are in
// docs/conventions.md, "glTF export"; the file in docs/formats.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "core/report.h"

namespace mr {

namespace fs = std::filesystem;

struct ShotExportOptions {
  fs::path scene;                       // scene.json
  fs::path out;                         // shot.glb or shot.gltf
  int frame_begin = 0, frame_end = -1;  // [begin, end); end -1: every frame with a pose
  double fps = 30;                      // frames per second of the animation (> 0)
  bool blender_script = true;           // write OUT's stem + "-blender.py" beside it
  // Write the lens's ST-maps beside it (OUT's stem + "-undistort.exr",
  // "-redistort.exr": handoff/stmap.h); the perspective camera is then the
  // ST-maps' pinhole, grown to hold the lens's view within stmap_max_angle_deg.
  bool stmaps = false;
  double stmap_max_angle_deg = 80;
};

struct ShotExportResult {
  int frames = 0;               // camera keys written
  int frames_without_pose = 0;  // in the range, without a finite pose: no key (the camera holds)
  bool perspective = false;     // a glTF perspective camera was written
  std::string no_perspective;   // why not, when not
  int room_meshes = 0, objects = 0, assets = 0, lights = 0;
  fs::path blender_script;        // empty when not written
  fs::path undistort, redistort;  // the ST-maps, empty when not written
  int64_t stmap_unmapped = 0;     // lens pixels beyond the widest angle (alpha 0 in the redistort map)
};

// Writes o.out (and the Blender script) atomically.  Throws mr::Error
// naming the file at fault: an unreadable scene, mesh or camera model, a
// frame range outside the poses, fps <= 0.
ShotExportResult ExportShot(const ShotExportOptions& o, Report* report);

// A lens alone (mr-export CAM.cameramodel --out PINHOLE.cameramodel): the
// ST-maps' pinhole written to `out` (a .cameramodel) and the maps beside it
// (its stem + "-undistort.exr", "-redistort.exr").  Returns the lens pixels
// left out (beyond max_angle_deg).
int64_t ExportLens(const fs::path& model, const fs::path& out, double max_angle_deg, Report* report);

// The Blender script mr-export writes beside the glTF (tools/blender/mr_shot.py).
const std::string& BlenderShotScript();

}  // namespace mr
