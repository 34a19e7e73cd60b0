// Trajectory and surface error, as the TUM RGB-D benchmark and multi-view
// stereo benchmarks define them.
//
// ATE (evaluate_ate.py): estimate and reference are associated by
// timestamp (nearest, at most max_dt apart, each used once), the estimate's
// camera centres are aligned to the reference's by Horn's closed-form rigid
// transform (no scale), and the error is the RMSE of the remaining centre
// distances.  RPE (evaluate_rpe.py): over all associated pairs (i, j) whose
// reference times are `delta` apart (the j nearest t_i + delta),
// E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j); translational RPE is the RMSE of
// |trans(E)|, rotational the RMSE of angle(E).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "camera/trajectory.h"
#include "geometry/mesh.h"

namespace mr {

struct AteResult {
  int pairs = 0;
  double rmse = 0, mean = 0, median = 0, max = 0;  // metres
  Rigid3 ref_from_est;                             // Horn's alignment
};

// Horn (1987), closed form via SVD (Umeyama without scale): the rigid
// transform T minimising sum |T * est[i] - ref[i]|^2.
Rigid3 AlignRigid(const std::vector<Eigen::Vector3d>& est, const std::vector<Eigen::Vector3d>& ref);

AteResult ComputeAte(const Trajectory& estimate, const Trajectory& reference, double max_dt = 0.02);

struct RpeResult {
  int pairs = 0;
  double trans_rmse = 0, trans_mean = 0, trans_median = 0, trans_max = 0;  // metres per delta
  double rot_rmse_deg = 0, rot_mean_deg = 0;
};

// delta in seconds (the timestamps' unit; for 7-Scenes, frames).
RpeResult ComputeRpe(const Trajectory& estimate, const Trajectory& reference, double delta, double max_dt = 0.02);

// Surface distances between meshes from area-uniform samples (seeded):
// accuracy = distances from the estimate's samples to the reference
// surface, completeness = from the reference's samples to the estimate.
// Distances are exact point-to-triangle distances, capped at `cutoff`.
struct SurfaceDistance {
  int64_t samples = 0;
  double mean = 0, median = 0, rmse = 0, p90 = 0;  // metres (capped at cutoff)
  double within = 0;                               // fraction within `threshold`
};
struct MeshErrorResult {
  SurfaceDistance accuracy, completeness;
  double threshold = 0, cutoff = 0;
  double fscore = 0;  // harmonic mean of the two `within` fractions
};
MeshErrorResult CompareMeshes(const Mesh& estimate, const Mesh& reference, double threshold = 0.01, double cutoff = 0.1,
                              int64_t samples = 200000, uint64_t seed = 1, const Eigen::AlignedBox3f* region = nullptr);

}  // namespace mr
