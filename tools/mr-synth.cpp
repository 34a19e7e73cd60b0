// mr-synth: a synthetic capture of a known room with exact ground truth.
#include <fmt/format.h>

#include "calib/board.h"
#include "cli/tool.h"
#include "synth/board_view.h"
#include "synth/synth.h"

int main(int argc, char** argv) {
  CLI::App app;
  mr::SynthOptions o;
  mr::ConfigureApp(app, "mr-synth",
                   "Writes a deterministic synthetic capture of a known room: camera model, trajectory (TUM),\n"
                   "photographs I_c (linear EXR and 8-bit PNG), room meshes with their albedos, a sky with a sun,\n"
                   "the virtual object, scene.json, and the ground truth (converged render of room + object)\n"
                   "named by scene.json's \"reference\". Presets: small (64x48, 2 frames, seconds), medium\n"
                   "(320x240, 2 frames, the main job's), room\n"
                   "(640x480, 4 frames, for benchmarks).",
                   "  mr-synth --preset small --out capture && mr-render capture/scene.json");
  app.add_option("--preset", o.preset, "small, medium or room")->default_val("small");
  app.add_option("--out", o.out, "Output folder (created)")->required();
  app.add_option("--seed", o.seed, "Random seed")->default_val(1);
  app.add_option("--object", o.object,
                 "Virtual object: sphere, box, or a mesh file (scaled to about 30 cm across, turned 28.65 degrees "
                 "about y and rested on the table top, centred at (0.1, 0.75, 0), as scene.json's transform.rest_on "
                 "places it; the report's object gives scale, rotation_deg and rests_on)")
      ->default_val("sphere");
  app.add_flag("--spot-light", o.spot_light, "Add a real spot light above the table (written to lights.json)");
  app.add_option("--frames", o.frames, "Frames of the capture (default: the preset's)")->check(mr::kPositive);
  app.add_flag("--dynamic", o.dynamic,
               "A world that changes during the video: the sun moving (env/NNNNN.exr), the spot lamp switched on "
               "halfway (lights/NNNNN.json), the object sliding and turning (a trajectory); the truth per frame");
  app.add_flag("--plate-sphere", o.plate_sphere,
               "A 20 cm mirror sphere on the table, in the plate's view: the plate's own light probe "
               "(plate-sphere.json says where; reference/sphere/ holds the light at its centre per frame)");
  app.add_option("--object-material", o.object_material, "The object's material: diffuse, glossy or mirror")
      ->default_val("diffuse")
      ->check(CLI::IsMember({"diffuse", "glossy", "mirror"}));
  app.add_option("--table-top", o.table_top,
                 "The table top's material: glossy (GGX, roughness 0.25) or diffuse (no caustics: the sun reflected "
                 "by the table, fireflies for a path tracer)")
      ->default_val("glossy")
      ->check(CLI::IsMember({"glossy", "diffuse"}));
  app.add_option("--lens", o.lens,
                 "The scene camera's lens: opencv4 (mild barrel distortion) or pinhole (for renderers without "
                 "lens models)")
      ->default_val("opencv4")
      ->check(CLI::IsMember({"opencv4", "pinhole"}));
  app.add_option("--truth-spp", o.truth_spp, "Samples per pixel of the ground truth (default: the preset's)")
      ->check(mr::kPositive);
  app.add_option("--truth-region-spp", o.truth_region_spp,
                 "Samples per pixel of the ground truth where the object changes the image (a pilot render "
                 "finds the pixels, grown by 2): the difference methods are scored on converges without paying "
                 "for the rest (default: --truth-spp; even, and at least --truth-spp)")
      ->check(mr::kPositive);
  std::string boards, board_file;
  app.add_option(
      "--boards", boards,
      "Instead of a room: calibration photographs of a board through a known lens: pinhole, opencv8, "
      "fisheye190 (a 190-degree splined fish-eye), rig (two cameras), or a .cameramodel file (e.g. a capture's "
      "camera); with the true models in truth/");
  app.add_option("--board", board_file,
                 "The board for --boards (default: 8x6 inner corners of 30 mm, OpenCV's detector)")
      ->check(CLI::ExistingFile);
  bool rgbd = false;
  mr::RgbdSynthSize rs;
  std::vector<int> rgbd_size;
  app.add_flag("--rgbd", rgbd,
               "Instead of a room capture: an RGB-D recording of the room in TUM layout (Kinect-like depth noise,\n"
               "quantisation and holes; path-traced colour; groundtruth.txt), with the true geometry in\n"
               "reference/room.ply, for mr-fuse and mr-eval traj/mesh");
  app.add_option("--rgbd-size", rgbd_size, "--rgbd: W,H,FRAMES (default: small 160,120,60; room 640,480,300)")
      ->delimiter(',')
      ->expected(3);
  app.add_flag("--rgbd-clean", rs.clean, "--rgbd: exact depth (no sensor noise, quantisation or holes)");
  app.add_option("--rgbd-spp", rs.color_spp, "--rgbd: colour samples per pixel (0: no colour)");
  return mr::RunTool("mr-synth", app, argc, argv, [&] {
    o.command_line = mr::JoinCommandLine(argc, argv);
    if (rgbd) {
      if (rgbd_size.size() == 3) {
        rs.width = rgbd_size[0];
        rs.height = rgbd_size[1];
        rs.frames = rgbd_size[2];
      }
      mr::RunSynthRgbd(o, rs, &mr::ToolReport());
      return mr::kExitOk;
    }
    if (!boards.empty()) {
      mr::BoardSpec b;
      b.name = "synthetic 8x6, 30 mm";
      b.inner_x = 8;
      b.inner_y = 6;
      b.square_m = 0.03;
      b.detector = "opencv";
      if (!board_file.empty()) b = mr::ReadBoard(board_file);
      const std::string note =
          fmt::format("written by mr-synth ({}); boards through the {} lens, seed {}", o.command_line, boards, o.seed);
      for (const auto& f : mr::WriteBoardSet(boards, b, o.out, o.seed, note)) mr::ToolReport().AddOutput(f.string());
      return mr::kExitOk;
    }
    mr::RunSynth(o, &mr::ToolReport());
    return mr::kExitOk;
  });
}
