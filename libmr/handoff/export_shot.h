// mr-export: a shot (scene.json: the room, the virtual objects, the camera
// path and lens, the light) written as a glTF 2.0 scene that Blender and
// other glTF readers import, plus the Blender script that sets up what glTF
// cannot carry.  The conventions (axes, the camera, units, extras) are in
// docs/conventions.md, "glTF export"; the file in docs/formats.md.
#pragma once

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
};

struct ShotExportResult {
  int frames = 0;               // camera keys written
  int frames_without_pose = 0;  // in the range, without a finite pose: no key (the camera holds)
  bool perspective = false;     // a glTF perspective camera was written
  std::string no_perspective;   // why not, when not
  int room_meshes = 0, objects = 0, assets = 0, lights = 0;
  fs::path blender_script;  // empty when not written
};

// Writes o.out (and the Blender script) atomically.  Throws mr::Error
// naming the file at fault: an unreadable scene, mesh or camera model, a
// frame range outside the poses, fps <= 0.
ShotExportResult ExportShot(const ShotExportOptions& o, Report* report);

// The Blender script mr-export writes beside the glTF (tools/blender/mr_shot.py).
const std::string& BlenderShotScript();

}  // namespace mr
