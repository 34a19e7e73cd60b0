// Video poses from COLMAP (mr-register): a COLMAP model of the video's
// frames, made by the `colmap` command or given, aligned to the room's frame
// by a similarity transform solved with Ceres, written as TUM poses (one per
// frame) and a .cameramodel.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "camera/colmap_text.h"
#include "camera/pose.h"
#include "camera/trajectory.h"
#include "core/error.h"
#include "core/file.h"
#include "core/report.h"
#include "geometry/mesh.h"

namespace mr {

// p_b = scale * rotation * p_a + translation.
struct Similarity3 {
  double scale = 1;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector3d Apply(const Eigen::Vector3d& p) const { return scale * (rotation * p) + translation; }
  // A camera pose (world_from_cam, world = frame a) moved into frame b.
  Rigid3 Apply(const Rigid3& world_from_cam) const;
};

// Corresponding camera poses in two frames (world_from_cam each).
struct PosePair {
  Rigid3 a, b;
};

struct SimilarityFitOptions {
  // Robust (Cauchy) loss scales: camera-centre residuals in metres of frame
  // b, orientation residuals in degrees.
  double centre_loss_m = 0.05;
  double rotation_loss_deg = 2;
  // Orientation residuals enter as this many metres per radian, so that a
  // camera moving on a line (rotation about it unobservable from centres)
  // still fixes the rotation.  0: centres only.
  double rotation_weight_m = 0.1;
};

struct SimilarityFit {
  Similarity3 b_from_a;
  std::vector<double> centre_residual_m;  // per pair, |s R c_a + t - c_b|
  std::vector<double> rotation_residual_deg;
  double centre_rmse_m = 0, centre_median_m = 0, rotation_rmse_deg = 0;
  int iterations = 0;
  double start_scale = 1;       // the closed-form scale; the fit stays within x2 of it
  bool scale_at_bound = false;  // ... and ran to that bound: the pairs disagree
};

// Closed-form start (chordal mean of the relative rotations; scale and
// translation from the centres by least squares) refined by Ceres with
// robust losses.  Throws mr::Error when fewer than 3 pairs are given or the
// centres cannot fix the scale (all at one point).
SimilarityFit FitSimilarity(const std::vector<PosePair>& pairs, const SimilarityFitOptions& options = {});

struct MeshFitOptions {
  double gate_m = 0.15;  // correspondences farther than this are not used
  double loss_m = 0.02;  // Cauchy loss scale of point-to-plane residuals
  int max_iterations = 30;
  int min_track = 3;          // COLMAP points seen in fewer images are left out
  double max_error_px = 2.0;  // ... and those with a larger reprojection error
};

struct MeshFit {
  Similarity3 b_from_a;
  int points = 0, inliers = 0,
      iterations = 0;               // inliers: within the gate at the end
  double median_m = 0, rmse_m = 0;  // point-to-mesh distances of the inliers
  double within_5cm = 0;            // fraction of the points within 5 cm
  double start_median_m = 0;        // the same figures at the start
  int start_inliers = 0;
};

// Refines a similarity that takes points (COLMAP's 3D points, frame a) onto
// a mesh (the room, frame b), ICP-style: closest points on the mesh, then
// robust point-to-plane least squares (Ceres) for scale, rotation and
// translation, repeated until it settles.  Needs a start within about the
// gate (from the trajectory, or given).  Throws mr::Error with fewer than 6
// correspondences.
MeshFit RefineSimilarityToMesh(const std::vector<Eigen::Vector3d>& points, const Mesh& mesh, const Similarity3& start,
                               const MeshFitOptions& options = {});

// The frame number in an image name: the last run of digits of its stem
// ("frame-000010.color.jpg" -> 10); -1 if none.
int FrameNumberOf(const std::string& image_name);

struct RegisterOptions {
  std::optional<fs::path> trajectory;  // align to this TUM trajectory (mr-fuse's)
  // How a frame meets its trajectory pose: "timestamp" (the frame number is
  // the timestamp, as in 7-Scenes), "index" (frame n is the n-th pose), or
  // "auto" (whichever pairs more frames; timestamp on a tie).
  std::string match = "auto";
  int frames = -1;                // poses written for frames 0..frames-1 (-1: up to the last
                                  // registered)
  std::optional<fs::path> truth;  // TUM poses of the video frames: pose error reported
  // Refine (or, without a trajectory, find from `initial`) the alignment
  // by COLMAP's 3D points against the room's mesh.
  std::optional<Mesh> mesh;
  std::optional<Similarity3> initial;
  MeshFitOptions mesh_fit;
  SimilarityFitOptions fit;
  // The alignment is refused (AlignmentError) beyond these.
  double max_rotation_rmse_deg = 10;
  double max_centre_median_fraction = 0.1;  // of the trajectory's extent (bounding-box diagonal)
  fs::path out_poses, out_camera;
  // COLMAP's well-observed 3D points (mesh_fit's min_track and
  // max_error_px), moved by the alignment, as a PLY point cloud: colours
  // (sRGB decoded to linear) and the scalars track and error_px (mr-planes).
  fs::path out_points;
  // Each registered frame's observations of those points: JSON
  // {"version": 1, "frames": {"N": [[u, v, X, Y, Z], ...]}}, u, v in mr's
  // pixel convention, X, Y, Z in the room's frame (mr-eval plate
  // --prior-points: COLMAP's points as a prior in the pose refinement).
  fs::path out_observations;
  std::string note;  // provenance for the written camera model

  // UsageError naming the flag: an unknown --match, --mesh without --trajectory
  // or --initial, alignment limits that are not positive.
  void Check() const;
};

// A COLMAP model that does not fit the trajectory (mr-register colmap
// retries COLMAP with another seed on it).
class AlignmentError : public Error {
 public:
  using Error::Error;
};

// Aligns `model` to the trajectory (identity without one), writes TUM poses
// for every frame (frames COLMAP did not register are interpolated between
// their registered neighbours and listed in the report) and the camera
// model; fills `report` with the alignment residuals (and the pose error
// against the truth).
void AlignColmapModel(const ColmapModel& model, const RegisterOptions& options, Report* report);

struct ColmapRunOptions {
  fs::path workspace;                  // database, sparse model, text model
  std::string matcher = "sequential";  // sequential | exhaustive
  std::optional<fs::path> camera;      // known intrinsics (kept fixed), else COLMAP estimates them
  int overlap = 10;                    // sequential: neighbours matched
  std::string colmap = "colmap";       // the executable
  int seed = 1;                        // COLMAP's --random_seed
  double timeout_s = 0;                // a colmap step running longer is ended and is an error (0: no limit)

  // UsageError naming the flag: --matcher, --overlap, --timeout.
  void Check() const;
};

// Registers `images` (a folder's image files, or a printf pattern's frames)
// with the colmap command (feature_extractor, sequential/exhaustive matcher,
// mapper, model_converter; all on the CPU) and returns the largest model.
// Throws mr::Error naming the failing colmap step and its log.
ColmapModel RunColmap(const std::vector<fs::path>& images, const ColmapRunOptions& options, Report* report);

}  // namespace mr

namespace mr {

// RunColmap, then AlignColmapModel.  COLMAP is not deterministic across runs
// (threads, RANSAC) and now and then builds a model that does not fit the
// room's trajectory (measured on 30 7-Scenes frames: 2 of 3 runs); with a
// trajectory, such a model is refused and COLMAP runs again with the next
// seed, up to `attempts` times (each refusal is a warning in the report).
void RegisterFrames(const std::vector<fs::path>& images, ColmapRunOptions colmap, const RegisterOptions& options,
                    int attempts, Report* report);

}  // namespace mr
