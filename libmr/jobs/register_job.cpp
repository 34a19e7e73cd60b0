#include "jobs/register_job.h"

#include <spdlog/spdlog.h>

#include <Eigen/SVD>
#include <cmath>
#include <cstdio>

#include "camera/colmap_text.h"
#include "core/error.h"
#include "core/video.h"
#include "geometry/mesh.h"
#include "scene/frames.h"

namespace mr {

namespace {

// --initial as a similarity; nullopt when it is not [s*R t; 0 0 0 1].
std::optional<Similarity3> InitialSimilarity(const std::vector<double>& initial) {
  const Eigen::Matrix4d m = Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(initial.data());
  const Eigen::Matrix3d sr = m.topLeftCorner<3, 3>();
  const double det = sr.determinant();
  if (!(det > 0) || (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) return std::nullopt;
  Similarity3 si;
  si.scale = std::cbrt(det);
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sr / si.scale, Eigen::ComputeFullU | Eigen::ComputeFullV);
  si.rotation = Eigen::Quaterniond(svd.matrixU() * svd.matrixV().transpose());
  si.translation = m.topRightCorner<3, 1>();
  return si;
}

Mesh MergedMeshes(const std::vector<std::string>& meshes, Report* report) {
  Mesh merged;
  for (const auto& m : meshes) {
    const Mesh one = ReadMesh(m);
    const int base = static_cast<int>(merged.positions.size());
    merged.positions.insert(merged.positions.end(), one.positions.begin(), one.positions.end());
    for (const auto& t : one.triangles) merged.triangles.push_back(t + Eigen::Vector3i::Constant(base));
    report->AddInput(m);
  }
  return merged;
}

// The options of the alignment, with the mesh, start and outputs filled in.
RegisterOptions AlignOptions(const RegisterJobOptions& o, Report* report) {
  RegisterOptions ro = o.align;
  if (!o.trajectory.empty()) ro.trajectory = o.trajectory;
  if (!o.truth.empty()) ro.truth = o.truth;
  ro.out_poses = o.out;
  if (!o.meshes.empty()) ro.mesh = MergedMeshes(o.meshes, report);
  if (!o.initial.empty()) ro.initial = InitialSimilarity(o.initial);
  ro.out_camera = o.camera_out;
  ro.out_points = o.points_out;
  ro.out_observations = o.observations_out;
  ro.note = "written by mr-register (" + o.command_line + ")";
  return ro;
}

void PrintAlignment(const Report& rep) {
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
}

}  // namespace

void RegisterJobOptions::Check() const {
  if (run_colmap() == !model_dir.empty()) throw UsageError("give FRAMES (colmap) or MODEL (align)");
  if (out.empty()) throw UsageError("--out is required");
  if (!initial.empty() && (initial.size() != 16 || !InitialSimilarity(initial)))
    throw UsageError("--initial: expected [s*R t; 0 0 0 1] with s > 0 and R a rotation");
  if (attempts < 1) throw UsageError("--attempts must be at least 1");
  RegisterOptions with_start = align;
  if (!trajectory.empty()) with_start.trajectory = trajectory;
  if (!initial.empty()) with_start.initial = Similarity3{};
  if (!meshes.empty()) with_start.mesh = Mesh{};
  with_start.Check();
  if (run_colmap()) colmap.Check();
}

void RunRegister(const RegisterJobOptions& o, Report* report) {
  o.Check();
  RegisterOptions ro = AlignOptions(o, report);
  if (o.run_colmap()) {
    ColmapRunOptions co = o.colmap;
    co.workspace = o.workspace;
    if (!o.camera.empty()) co.camera = o.camera;
    const auto list = ListFrameFiles(o.frames, o.workspace);
    spdlog::info("registering {} frames with COLMAP ({} matching)", list.size(), co.matcher);
    if (ro.frames < 0) ro.frames = static_cast<int>(list.size());
    report->AddInput(o.frames);
    RegisterFrames(list, co, ro, o.attempts, report);
  } else {
    const ColmapModel model = ReadColmapText(o.model_dir);
    if (model.images.empty())
      ThrowErrorAt(FileLoc{(fs::path(o.model_dir) / "images.txt").string()},
                   "the COLMAP model has no registered images");
    report->AddInput(o.model_dir);
    AlignColmapModel(model, ro, report);
  }
  PrintAlignment(*report);
}

}  // namespace mr
