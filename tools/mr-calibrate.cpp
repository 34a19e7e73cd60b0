// mr-calibrate: camera, rig and mirror-sphere calibration with mrcal.
#include "calib/calibrate_job.h"
#include "cli/tool.h"

int main(int argc, char** argv) {
  CLI::App app;
  std::string board_file, out, out_dir;
  std::vector<std::string> images, cameras;
  mr::CalibrationOptions o;
  mr::ConfigureApp(app, "mr-calibrate",
                   "Calibrates cameras from photographs of a calibration board (calib/boards/*.json), with\n"
                   "libmrcal's optimiser; the written .cameramodel files carry mrcal's optimisation inputs, so\n"
                   "mrcal's own tools (mrcal-show-projection-uncertainty ...) accept them.\n"
                   "Subcommands: camera (intrinsics of one camera), rig (two or more cameras photographing the\n"
                   "board at the same instants: intrinsics and extrinsics jointly), sphere (a mirror sphere's\n"
                   "centre from its silhouette under a calibrated camera, with its covariance: probe.json).",
                   "  mr-calibrate camera --board calib/boards/chessboard-8x6.json --lensmodel LENSMODEL_OPENCV8 \\\n"
                   "      --out light.cameramodel photos/*.png\n"
                   "  mr-calibrate rig --board calib/boards/chessboard-9x6.json --lensmodel LENSMODEL_OPENCV8 \\\n"
                   "      --camera light='rig/light-*.png' --camera scene='rig/scene-*.png' --out-dir rig/\n"
                   "  mr-calibrate sphere --camera rig/light.cameramodel --radius 0.0254 --out probe.json probe-*.exr");
  app.require_subcommand(1);
  CLI::App* cam = app.add_subcommand("camera", "Intrinsics of one camera from photographs of a board");
  cam->fallthrough();  // --report, --threads ... after the subcommand
  cam->add_option("--board", board_file, "Board definition (calib/boards/*.json)")
      ->required()
      ->check(CLI::ExistingFile);
  cam->add_option("--lensmodel", o.lensmodel, "Any mrcal lens model with an intrinsics core")
      ->default_val("LENSMODEL_OPENCV8");
  cam->add_option("--focal", o.focal_px, "Seed focal length in pixels (default: half the image width)");
  cam->add_option("--out", out, "The .cameramodel to write")->required();
  cam->add_option("images", images, "Photographs of the board")->required()->check(CLI::ExistingFile);
  CLI::App* rig = app.add_subcommand(
      "rig", "Two or more cameras photographing the board at the same instants: intrinsics and extrinsics, jointly");
  rig->fallthrough();
  rig->add_option("--board", board_file, "Board definition (calib/boards/*.json)")
      ->required()
      ->check(CLI::ExistingFile);
  rig->add_option("--lensmodel", o.lensmodel, "One mrcal lens model for every camera (mrcal's restriction)")
      ->default_val("LENSMODEL_OPENCV8");
  rig->add_option("--focal", o.focal_px, "Seed focal length in pixels (default: half the image width)");
  rig->add_option("--camera", cameras,
                  "NAME='DIR/PREFIX*SUFFIX', once per camera, the first being the reference; photographs are "
                  "paired across cameras by what the '*' matches")
      ->required();
  rig->add_option("--out-dir", out_dir, "Where NAME.cameramodel is written for each camera")->required();
  CLI::App* sph = app.add_subcommand(
      "sphere", "A mirror sphere's centre, from its silhouette in photographs by a calibrated camera");
  sph->fallthrough();
  std::string camera_file, world_board;
  std::vector<double> circle;
  mr::SphereOptions so;
  sph->add_option("--camera", camera_file, "The camera's .cameramodel (its extrinsics place it in the rig)")
      ->required()
      ->check(CLI::ExistingFile);
  sph->add_option("--radius", so.radius_m, "The sphere's radius, metres (measured with calipers)")
      ->required()
      ->check(mr::kPositive);
  sph->add_option("--circle", circle,
                  "A first circle x,y,r px instead of the Hough transform (the rim's edges found in either polarity)")
      ->delimiter(',')
      ->expected(3);
  sph->add_option("--min-visible", so.min_visible, "Refuse when less of the silhouette is in the image")
      ->default_val(0.5);
  sph->add_option("--world-board", world_board,
                  "A photograph by this camera of the board lying flat, printed side up: it defines the world "
                  "(origin at its first inner corner, +x along its rows, +y up, +z along its columns); needs --board")
      ->check(CLI::ExistingFile);
  sph->add_option("--board", board_file, "Board definition, for --world-board")->check(CLI::ExistingFile);
  sph->add_option("--out", out, "probe.json to write")->required();
  sph->add_option("images", images,
                  "Photographs of the sphere (camera and sphere fixed), or masks of its silhouette (two levels, "
                  "either polarity: the sphere is the level less present on the border)")
      ->required()
      ->check(CLI::ExistingFile);
  return mr::RunTool("mr-calibrate", app, argc, argv, [&] {
    mr::Report& report = mr::ToolReport();
    const std::string provenance = mr::JoinCommandLine(argc, argv);
    if (sph->parsed())
      mr::RunSphereCalibration({camera_file, so, circle, world_board, board_file, images, out, provenance}, &report);
    else if (cam->parsed())
      mr::RunCameraCalibration({board_file, images, out, o, provenance}, &report);
    else
      mr::RunRigCalibration({board_file, cameras, out_dir, o, provenance}, &report);
    return mr::kExitOk;
  });
}
