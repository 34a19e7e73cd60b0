// The reference of form-factor transfer (transfer/formfactor.h): outgoing
// radiance per vertex by path tracing the object alone in its environment.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "geometry/mesh.h"

namespace mr {

// The reference: L_out per vertex by path tracing the object alone in the
// environment (`rays` samples per vertex, environment and cosine sampling
// combined by MIS, `bounces` interreflections at albedo `albedo`).
std::vector<Eigen::Vector3d> ReferenceVertexRadiance(const Mesh& mesh, const Image& env, const std::string& env_name,
                                                     const Eigen::Matrix3d& world_from_object, double albedo,
                                                     int bounces, int rays, uint64_t seed);

// Per-vertex radiance against a reference: relative RMS (|a - r| over |r|,
// summed over vertices) and relMSE (mean over vertices and channels of
// (a - r)^2 / (r^2 + 0.01), as core/image_metrics.h defines it for pixels).
struct VertexError {
  double relative_rms = 0, relmse = 0;
};
VertexError CompareVertexRadiance(const std::vector<Eigen::Vector3d>& radiance,
                                  const std::vector<Eigen::Vector3d>& reference);

}  // namespace mr
