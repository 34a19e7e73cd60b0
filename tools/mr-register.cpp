// mr-register: poses and intrinsics of a video's camera from COLMAP, aligned
// to the room.
#include "cli/tool.h"
#include "jobs/register_job.h"

int main(int argc, char** argv) {
  CLI::App app;
  mr::ConfigureApp(app, "mr-register",
                   "Poses of a video's camera in the room's frame, from "
                   "COLMAP. `colmap` registers the frames with the\n"
                   "colmap command (SIFT features, sequential or exhaustive "
                   "matching, incremental mapping; CPU);\n"
                   "`align` takes an existing COLMAP text model. Either way "
                   "the model is aligned to the room by a\n"
                   "similarity transform (scale, rotation, translation) fitted "
                   "with Ceres to the camera centres and\n"
                   "orientations of --trajectory (mr-fuse's) with a robust "
                   "(Cauchy) loss, and written as TUM poses, one\n"
                   "per frame (timestamp = frame number; frames COLMAP left "
                   "out are interpolated and reported), with a\n"
                   ".cameramodel of the camera (COLMAP's intrinsics, or "
                   "--camera's when given: kept fixed). Frames meet\n"
                   "trajectory poses by the number in their file names "
                   "(--match). The report holds the alignment\n"
                   "residuals (centre RMSE in metres, rotation RMSE in "
                   "degrees) and, with --truth, the pose error.",
                   "  mr-register colmap video/%05d.png --workspace "
                   "work/colmap --camera camera.cameramodel \\\n"
                   "      --trajectory room/trajectory.txt --out "
                   "video/poses.txt --camera-out video/camera.cameramodel\n"
                   "  mr-register align colmap/sparse-text --trajectory "
                   "room/trajectory.txt --out poses.txt");
  app.require_subcommand(1);
  mr::RegisterJobOptions o;
  mr::RegisterOptions& ro = o.align;
  mr::ColmapRunOptions& co = o.colmap;
  auto common = [&](CLI::App* c) {
    c->fallthrough();
    c->add_option("--trajectory", o.trajectory,
                  "Align to this TUM trajectory or 7-Scenes folder (the room's "
                  "frame, e.g. mr-fuse's)")
        ->check(CLI::ExistingPath);
    c->add_option("--match", ro.match, "How frames meet trajectory poses: timestamp, index or auto")
        ->default_val("auto")
        ->check(CLI::IsMember({"auto", "timestamp", "index"}));
    c->add_option("--frames", ro.frames, "Write poses for frames 0..N-1 (default: up to the last registered)");
    c->add_option("--truth", o.truth,
                  "TUM poses (or a 7-Scenes folder) of the video's frames: "
                  "report the pose error")
        ->check(CLI::ExistingPath);
    c->add_option("--out", o.out, "TUM poses to write (world_from_cam, timestamp = frame number)")->required();
    c->add_option("--camera-out", o.camera_out, "The video camera's .cameramodel to write");
    c->add_option("--points-out", o.points_out,
                  "COLMAP's well-observed 3D points (track and error as --mesh's), moved into the room's frame, "
                  "as a PLY point cloud (mr-planes)");
    c->add_option("--observations-out", o.observations_out,
                  "Each registered frame's observations of those points (pixel and room-frame point, JSON: "
                  "mr-eval plate --prior-points)");
    c->add_option("--mesh", o.meshes,
                  "Align (or refine the alignment) by COLMAP's 3D points "
                  "against this room mesh (repeatable: merged)")
        ->check(CLI::ExistingFile)
        ->expected(1)
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    c->add_option("--initial", o.initial,
                  "Start of the mesh alignment without --trajectory: 16 "
                  "numbers, row-major 4x4 [s*R t; 0 0 0 1] "
                  "taking COLMAP's frame to the room's")
        ->delimiter(',')
        ->expected(16);
    c->add_option("--mesh-gate", ro.mesh_fit.gate_m, "Mesh alignment: points farther than this (m) are not used")
        ->default_val(0.15);
    c->add_option("--centre-loss", ro.fit.centre_loss_m, "Robust loss scale of centre residuals (m)")
        ->default_val(0.05);
    c->add_option("--rotation-weight", ro.fit.rotation_weight_m,
                  "Metres per radian of orientation residuals (0: centres only)")
        ->default_val(0.1);
  };
  CLI::App* run = app.add_subcommand("colmap",
                                     "Register FRAMES (a folder, a printf pattern of PNG/JPEG "
                                     "frames, or a video) with COLMAP");
  run->add_option("FRAMES", o.frames, "The video's frames")->required();
  run->add_option("--workspace", o.workspace, "COLMAP's database, models and log")->required();
  run->add_option("--matcher", co.matcher, "sequential (video) or exhaustive")
      ->default_val("sequential")
      ->check(CLI::IsMember({"sequential", "exhaustive"}));
  run->add_option("--overlap", co.overlap, "sequential: each frame is matched with this many following ones")
      ->default_val(10);
  run->add_option("--colmap-timeout", co.timeout_s,
                  "Seconds a colmap step may run before it is ended and reported (0: no limit)")
      ->default_val(0)
      ->check(mr::kNonNegative);
  run->add_option("--colmap", co.colmap, "The colmap executable")->default_val("colmap");
  run->add_option("--attempts", o.attempts,
                  "With --trajectory: run COLMAP again (next seed) on a model "
                  "that does not fit, this often")
      ->default_val(3)
      ->check(mr::kPositive);
  run->add_option("--camera", o.camera, "Known intrinsics (PINHOLE or OPENCV4 .cameramodel), kept fixed")
      ->check(CLI::ExistingFile);
  common(run);
  CLI::App* align = app.add_subcommand("align", "Align an existing COLMAP text model (cameras.txt, images.txt)");
  align->add_option("MODEL", o.model_dir, "Folder of the text model")->required()->check(CLI::ExistingDirectory);
  common(align);
  return mr::RunTool("mr-register", app, argc, argv, [&] {
    o.command_line = mr::ToolReport().ToJson().value("command_line", "");
    mr::RunRegister(o, &mr::ToolReport());
    return mr::kExitOk;
  });
}
