// mr-export: a shot (scene.json) as a glTF 2.0 scene, with the Blender
// script that sets up what glTF cannot carry.
#include "cli/tool.h"
#include "core/file.h"
#include "handoff/export_shot.h"
#include "scene/frames.h"

int main(int argc, char** argv) {
  CLI::App app;
  mr::ShotExportOptions o;
  std::string scene, out, frames;
  bool no_script = false;
  mr::ConfigureApp(
      app, "mr-export",
      "Writes a shot (scene.json: the room, the virtual objects, the camera path and lens, the light)\n"
      "as a glTF 2.0 scene (.glb or .gltf) that Blender and other glTF readers import: the room\n"
      "marked as a shadow catcher, the objects with their materials (glTF assets merged in with\n"
      "their textures), the camera as a perspective camera of the lens's pinhole core animated\n"
      "per frame, the lights (KHR_lights_punctual; area lights in extras), and in extras the\n"
      "environment map, the plate and mr's exact values. Beside it, OUT-blender.py sets up in\n"
      "Blender what glTF cannot carry (lens shift and pixel aspect, the world, the shadow catcher,\n"
      "light strengths, the plate): blender -b --python OUT-blender.py -- OUT.glb --blend OUT.blend.\n"
      "Conventions: docs/conventions.md, \"glTF export\".",
      "  mr-export work/scene.json --out shot.glb\n"
      "  blender -b --python shot-blender.py -- shot.glb --blend shot.blend\n"
      "  mr-export scene.json --out shot.gltf --frames 10:40 --fps 25\n"
      "  mr-export scene.json --out shot.glb --stmaps   # distorted lens: render undistorted, redistort in comp\n"
      "  mr-export lens.cameramodel --out lens-pinhole.cameramodel --stmap-max-angle 70   # the ST-maps alone");
  app.add_option("scene", scene, "scene.json, or a .cameramodel for its ST-maps alone")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--out", out, "The glTF scene: .glb (binary) or .gltf (JSON, buffers embedded)")->required();
  app.add_option("--frames", frames, "Frames B:E (end exclusive; default every frame with a pose)");
  app.add_option("--fps", o.fps, "The animation's frames per second")->default_val(30);
  app.add_flag("--no-blender-script", no_script, "Do not write OUT-blender.py");
  app.add_flag("--stmaps", o.stmaps,
               "Write the lens's ST-maps, OUT-undistort.exr and OUT-redistort.exr; the camera is then their "
               "pinhole, grown to hold the lens's view (docs/formats.md, \"ST-maps\")");
  app.add_option("--stmap-max-angle", o.stmap_max_angle_deg,
                 "Degrees from the axis the ST-maps' pinhole holds (a fish-eye's rays beyond are left out)")
      ->default_val(80);
  return mr::RunTool("mr-export", app, argc, argv, [&] {
    if (mr::LowerExtension(scene) == ".cameramodel") {  // a lens alone: its pinhole and ST-maps
      const int64_t unmapped = mr::ExportLens(scene, out, o.stmap_max_angle_deg, &mr::ToolReport());
      std::printf(
          "%s: the pinhole; ST-maps beside it%s\n", out.c_str(),
          unmapped
              ? fmt::format(" ({} lens pixels beyond {} degrees left out)", unmapped, o.stmap_max_angle_deg).c_str()
              : "");
      return mr::kExitOk;
    }
    o.scene = scene;
    o.out = out;
    o.blender_script = !no_script;
    std::string why;
    if (!frames.empty() && !mr::ParseFrameRange(frames, &o.frame_begin, &o.frame_end, &why))
      throw mr::UsageError("--frames: " + why);
    const mr::ShotExportResult r = mr::ExportShot(o, &mr::ToolReport());
    std::printf("%s: %d camera keys, %d room meshes, %d objects (%d assets), %d lights%s\n", out.c_str(), r.frames,
                r.room_meshes, r.objects, r.assets, r.lights, r.perspective ? "" : "; no perspective camera");
    if (!r.blender_script.empty())
      std::printf("in Blender: blender -b --python %s -- %s --blend shot.blend\n", r.blender_script.c_str(),
                  out.c_str());
    return mr::kExitOk;
  });
}
