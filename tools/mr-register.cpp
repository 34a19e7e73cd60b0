// mr-register: poses and intrinsics of a video's camera from COLMAP, aligned
// to the room.
#include <spdlog/spdlog.h>

#include <Eigen/SVD>
#include <cstdio>

#include "camera/register.h"
#include "cli/tool.h"
#include "core/error.h"
#include "core/image.h"
#include "core/video.h"
#include "geometry/mesh.h"
#include "scene/frames.h"

namespace {

int PrintAlignment(const mr::Report& rep) {
  const auto& m = rep.metrics();
  if (m.contains("alignment") && m["alignment"].contains("pairs"))
    std::printf(
        "aligned %d frames: scale %.6g, centre residual rmse %.4f m "
        "(median %.4f), rotation rmse %.3f deg\n",
        m["alignment"]["pairs"].get<int>(), m["alignment"]["scale"].get<double>(),
        m["alignment"]["centre_rmse_m"].get<double>(), m["alignment"]["centre_median_m"].get<double>(),
        m["alignment"]["rotation_rmse_deg"].get<double>());
  if (m.contains("alignment") && m["alignment"].contains("mesh"))
    std::printf(
        "against the mesh: %d of %d points within the gate, median "
        "distance %.4f m, %.1f%% within 5 cm\n",
        m["alignment"]["mesh"]["inliers"].get<int>(), m["alignment"]["mesh"]["points"].get<int>(),
        m["alignment"]["mesh"]["median_m"].get<double>(), 100 * m["alignment"]["mesh"]["within_5cm"].get<double>());
  if (m.contains("pose_error"))
    std::printf(
        "pose error against the truth: centre rmse %.4f m, rotation "
        "rmse %.3f deg (%d frames)\n",
        m["pose_error"]["centre_rmse_m"].get<double>(), m["pose_error"]["rotation_rmse_deg"].get<double>(),
        m["pose_error"]["frames"].get<int>());
  return mr::kExitOk;
}

}  // namespace

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
  std::string frames, model_dir, trajectory, truth, out, camera_out, camera, workspace;
  std::vector<std::string> meshes;
  std::vector<double> initial;
  mr::RegisterOptions ro;
  mr::ColmapRunOptions co;
  int attempts = 3;
  auto common = [&](CLI::App* c) {
    c->fallthrough();
    c->add_option("--trajectory", trajectory,
                  "Align to this TUM trajectory or 7-Scenes folder (the room's "
                  "frame, e.g. mr-fuse's)")
        ->check(CLI::ExistingPath);
    c->add_option("--match", ro.match, "How frames meet trajectory poses: timestamp, index or auto")
        ->default_val("auto")
        ->check(CLI::IsMember({"auto", "timestamp", "index"}));
    c->add_option("--frames", ro.frames, "Write poses for frames 0..N-1 (default: up to the last registered)");
    c->add_option("--truth", truth,
                  "TUM poses (or a 7-Scenes folder) of the video's frames: "
                  "report the pose error")
        ->check(CLI::ExistingPath);
    c->add_option("--out", out, "TUM poses to write (world_from_cam, timestamp = frame number)")->required();
    c->add_option("--camera-out", camera_out, "The video camera's .cameramodel to write");
    c->add_option("--mesh", meshes,
                  "Align (or refine the alignment) by COLMAP's 3D points "
                  "against this room mesh (repeatable: merged)")
        ->check(CLI::ExistingFile)
        ->expected(1)
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    c->add_option("--initial", initial,
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
  run->add_option("FRAMES", frames, "The video's frames")->required();
  run->add_option("--workspace", workspace, "COLMAP's database, models and log")->required();
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
  run->add_option("--attempts", attempts,
                  "With --trajectory: run COLMAP again (next seed) on a model "
                  "that does not fit, this often")
      ->default_val(3)
      ->check(mr::kPositive);
  run->add_option("--camera", camera, "Known intrinsics (PINHOLE or OPENCV4 .cameramodel), kept fixed")
      ->check(CLI::ExistingFile);
  common(run);
  CLI::App* align = app.add_subcommand("align", "Align an existing COLMAP text model (cameras.txt, images.txt)");
  align->add_option("MODEL", model_dir, "Folder of the text model")->required()->check(CLI::ExistingDirectory);
  common(align);
  return mr::RunTool("mr-register", app, argc, argv, [&] {
    auto& rep = mr::ToolReport();
    if (!trajectory.empty()) ro.trajectory = trajectory;
    if (!truth.empty()) ro.truth = truth;
    ro.out_poses = out;
    if (!meshes.empty()) {
      mr::Mesh merged;
      for (const auto& m : meshes) {
        const mr::Mesh one = mr::ReadMesh(m);
        const int base = static_cast<int>(merged.positions.size());
        merged.positions.insert(merged.positions.end(), one.positions.begin(), one.positions.end());
        for (const auto& t : one.triangles) merged.triangles.push_back(t + Eigen::Vector3i::Constant(base));
        rep.AddInput(m);
      }
      ro.mesh = std::move(merged);
    }
    if (!initial.empty()) {
      Eigen::Matrix4d m = Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(initial.data());
      const Eigen::Matrix3d sr = m.topLeftCorner<3, 3>();
      const double det = sr.determinant();
      if (!(det > 0) || (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9)
        throw mr::UsageError("--initial: expected [s*R t; 0 0 0 1] with s > 0 and R a rotation");
      mr::Similarity3 si;
      si.scale = std::cbrt(det);
      Eigen::JacobiSVD<Eigen::Matrix3d> svd(sr / si.scale, Eigen::ComputeFullU | Eigen::ComputeFullV);
      si.rotation = Eigen::Quaterniond(svd.matrixU() * svd.matrixV().transpose());
      si.translation = m.topRightCorner<3, 1>();
      ro.initial = si;
    }
    ro.out_camera = camera_out;
    ro.note = "written by mr-register (" + rep.ToJson().value("command_line", "") + ")";
    mr::ColmapModel model;
    if (run->parsed()) {
      co.workspace = workspace;
      if (!camera.empty()) co.camera = camera;
      const auto list = mr::ListFrameFiles(frames, workspace);
      spdlog::info("registering {} frames with COLMAP ({} matching)", list.size(), co.matcher);
      if (ro.frames < 0) ro.frames = static_cast<int>(list.size());
      rep.AddInput(frames);
      mr::RegisterFrames(list, co, ro, attempts, &rep);
      return PrintAlignment(rep);
    } else {
      model = mr::ReadColmapText(model_dir);
      if (model.images.empty())
        mr::ThrowErrorAt(mr::FileLoc{(mr::fs::path(model_dir) / "images.txt").string()},
                         "the COLMAP model has no registered images");
      rep.AddInput(model_dir);
    }
    mr::AlignColmapModel(model, ro, &rep);
    return PrintAlignment(rep);
  });
}
