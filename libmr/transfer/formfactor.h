// Per-vertex form-factor transfer of a virtual object: how much of the light
// arriving from each direction reaches each vertex past the object's own
// geometry (the method of ../shared/papers/mirror-sphere-form-factors.txt,
// and Sloan et al. 2002's precomputed radiance transfer in spherical
// harmonics).
//
// For a vertex v with normal n the transfer of a direction cell c is its
// delta form factor
//     T_c(v) = 1/pi * integral over c of V(v, w) max(0, n.w) dw
// (V = 1 where the object does not block w): the paper's cos(theta) dA / pi
// with the occlusion map folded in.  Lit by an environment of mean radiance
// L_c over each cell, a diffuse vertex of albedo rho reflects
//     L_out(v) = rho * sum_c T_c(v) L_c.
// In the SH basis T_k(v) = 1/pi integral V max(0, n.w) Y_k(w) dw and L_k are
// the environment's SH coefficients.  With B bounces, T also carries light
// that reaches v after up to B diffuse reflections on the object itself
// (albedo `albedo`, fixed at precomputation).
//
// Both bases integrate over the same quadrature: a cube map of
// `resolution` x `resolution` cells per face, each split into `supersample`^2
// sub-cells with exact solid angles; one occlusion ray per sub-cell.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/file.h"
#include "core/image.h"
#include "geometry/embree_scene.h"
#include "geometry/mesh.h"

namespace mr {

enum class TransferBasis : uint32_t { kCube = 0, kSh = 1 };

struct TransferOptions {
  TransferBasis basis = TransferBasis::kCube;
  int resolution = 8;    // cube cells per face edge (also the SH quadrature's)
  int order = 4;         // SH bands (order^2 coefficients), 1..8
  int supersample = 2;   // sub-cells per cell edge
  int bounces = 0;       // interreflection on the object itself
  double albedo = 0.8;   // of the object, for the bounces
  int64_t chunk = 4096;  // vertices per chunk: memory stays bounded (bounces 0)
  // Benchmarks only: every bounce-0 ray, for replay through a bare Embree
  // loop (single-threaded runs: the log is not synchronised).
  std::vector<Ray>* ray_log = nullptr;

  // UsageError naming the flag: --resolution, --order, --supersample,
  // --bounces, --albedo or --chunk out of range.
  void Check() const;
};

// What ComputeTransfer found and did; nothing is changed without a count.
struct TransferStats {
  int64_t vertices = 0;
  int64_t normals_computed = 0;         // the mesh had none
  int64_t normals_flipped = 0;          // given normals that disagreed with the faces: replaced
  int64_t vertices_without_normal = 0;  // only in zero-area faces, or unused: transfer zero
  int64_t degenerate_faces = 0;
  int64_t nonmanifold_edges = 0;  // edges of more than two faces (transfer is per vertex: unaffected)
  int64_t fully_occluded = 0;     // e.g. inside closed geometry: transfer zero
  int64_t rays = 0;
  int64_t skipped_vertices = 0;  // not needed by the caller (transfer left zero)
};

struct TransferHeader {
  TransferBasis basis = TransferBasis::kCube;
  int resolution = 0, order = 0, supersample = 0, bounces = 0;
  float albedo = 0;
  int coefficients = 0;  // per vertex
  int64_t vertex_count = 0;
  uint64_t mesh_hash = 0;
  // 0: every vertex computed.  Otherwise only the vertices that a render of
  // up to this many samples per pixel can see (mr-formfactor --scene); the
  // others hold zero.
  int valid_spp = 0;
};

struct VertexTransfer {
  TransferHeader header;
  std::vector<float> data;  // vertex_count x coefficients
  const float* vertex(int64_t v) const { return data.data() + v * header.coefficients; }
};

// A hash of the mesh's positions and triangles: an .ffc computed for another
// mesh is refused.
uint64_t MeshHash(const Mesh& mesh);

int TransferCoefficients(const TransferOptions& o);

// Computes the transfer.  `needed` (optional) marks the vertices to compute;
// the others stay zero and are counted as skipped.
VertexTransfer ComputeTransfer(const Mesh& mesh, const TransferOptions& options, TransferStats* stats,
                               const std::vector<char>* needed = nullptr);

// The .ffc file (docs/formats.md): a 64-byte little-endian header, then
// float32 coefficients vertex by vertex.  Writing is atomic.
void WriteTransfer(const fs::path& path, const VertexTransfer& t);
// ComputeTransfer straight into an .ffc, options.chunk vertices at a time:
// with no bounces, memory stays bounded by the chunk whatever the mesh's
// size (with bounces every vertex's transfer must stay in memory).
TransferHeader ComputeTransferToFile(const Mesh& mesh, const TransferOptions& options, const fs::path& path,
                                     TransferStats* stats, const std::vector<char>* needed = nullptr,
                                     int valid_spp = 0);
VertexTransfer ReadTransfer(const fs::path& path);
// Throws, naming the file, when `t` was computed for another mesh.
void CheckTransferMatches(const VertexTransfer& t, const Mesh& mesh, const std::string& ffc_name,
                          const std::string& mesh_name);

// An environment (lat-long radiance, OpenEXR convention) in the transfer's
// basis, in the object's frame: cube cells hold mean radiance over the cell
// (every map pixel's power goes to the cell its centre falls in, so a
// one-pixel sun keeps its power to a few percent), SH coefficients are
// projections, damped unless `window` is false by the Lanczos sigma factor
// of their band.  On the bunny at order 8 the window trades error for
// ringing: under a sun, relative RMS 0.055 with 3 negative vertices clamped
// unwindowed, 0.067 and none windowed; a Hanning window (0.082) and windows
// applied to both factors (0.096, 0.123) blur more than they need to.
struct EnvironmentCoefficients {
  std::vector<Eigen::Vector3d> rgb;  // per cell / per SH coefficient
};
EnvironmentCoefficients ProjectEnvironment(const Image& env, const std::string& env_name, const TransferHeader& h,
                                           const Eigen::Matrix3d& object_from_world, double scale = 1.0,
                                           bool window = true);

// The SH order the environment needs: the smallest L' <= order such that the
// bands L'..order-1 hold at most `tolerance` of its energy (sum of squared
// coefficients).  Shading with env.rgb truncated to L'^2 coefficients then
// changes the result by at most that share.
int EffectiveShOrder(const EnvironmentCoefficients& env, int order, double tolerance);

// L_out per vertex: albedo * (transfer . environment), the albedo per vertex
// when `vertex_albedo` is given (e.g. the mesh's vertex colours).  Negative
// values (SH ringing) are clamped to zero and counted in *clamped;
// *most_negative gets the lowest value before clamping.
std::vector<Eigen::Vector3d> ShadeVertices(const VertexTransfer& t, const EnvironmentCoefficients& env,
                                           const Eigen::Vector3d& albedo, int64_t* clamped,
                                           double* most_negative = nullptr,
                                           const std::vector<Eigen::Vector3f>* vertex_albedo = nullptr);

// Sets the mesh's vertex colours to `radiance` (per vertex) times the
// exposure that brings its 99th luminance percentile to 1, clamped to
// [0, 1] (a preview of the shading); returns the exposure.
double ColorVerticesByRadiance(const std::vector<Eigen::Vector3d>& radiance, Mesh* mesh);

// Vertex normals as the transfer uses them: the mesh's own where they agree
// with the faces, else area-weighted face normals; zero where none exists.
std::vector<Eigen::Vector3d> TransferNormals(const Mesh& mesh, TransferStats* stats);

}  // namespace mr
