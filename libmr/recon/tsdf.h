// A truncated signed distance field in sparse voxel blocks addressed by a
// hash (Nießner et al. 2013; InfiniTAM): memory grows with the observed
// surface, not the room's volume.  Fusion is KinectFusion's weighted running
// average of projective distances; colour is averaged per voxel.  Raycasting
// gives the model's vertex and normal maps for tracking; meshing is
// surface nets over the allocated blocks (one vertex per cell that the
// surface crosses, one quad per crossed edge: watertight where observed, no
// lookup tables, exact on planes).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "camera/pose.h"
#include "core/image.h"
#include "geometry/mesh.h"
#include "recon/rgbd.h"

namespace mr {

// Per-pixel maps of one view; invalid pixels hold NaN in x.
struct PointMaps {
  int width = 0, height = 0;
  std::vector<Eigen::Vector3f> vertices, normals;
  bool valid(size_t i) const { return vertices[i].x() == vertices[i].x(); }
};

struct TsdfOptions {
  float voxel_size = 0.01f;        // metres
  float truncation = 0;            // metres; 0: 4 voxels (at least 1.5 cm)
  float max_weight = 128;          // running average window (frames)
  Eigen::AlignedBox3f roi;         // empty: everywhere; else blocks outside are never allocated
  int64_t max_blocks = 4'000'000;  // refuse to grow beyond (8^3 voxels, 20 bytes each)
};

struct IntegrateStats {
  int64_t blocks_touched = 0;  // blocks in this frame's truncation band
  int64_t blocks_new = 0;      // of which newly allocated
  int64_t voxels_updated = 0;
  int64_t blocks_refused = 0;  // outside the ROI or past max_blocks
};

struct MeshOptions {
  float min_weight = 1.5f;           // voxels seen fewer times are unknown
  int min_component_triangles = 64;  // smaller connected pieces are dropped
  Eigen::AlignedBox3f roi;           // empty: everything
};

struct MeshStats {
  int64_t components_dropped = 0, triangles_dropped = 0, degenerate_dropped = 0;
};

class TsdfVolume {
 public:
  static constexpr int kBlock = 8;
  struct Voxel {
    float sdf = 1;  // truncated signed distance / truncation, in [-1, 1]; + in front
    float weight = 0;
    float r = 0, g = 0, b = 0;
  };

  explicit TsdfVolume(const TsdfOptions& options);
  ~TsdfVolume();
  TsdfVolume(TsdfVolume&&) noexcept;
  TsdfVolume& operator=(TsdfVolume&&) noexcept;

  const TsdfOptions& options() const { return options_; }
  float truncation() const { return trunc_; }

  // Finds (and allocates, within the ROI) the blocks of the truncation band
  // around `depth` seen from world_from_cam.  Returns the blocks touched.
  std::vector<int32_t> AllocateBand(const DepthMap& depth, const PinholeIntrinsics& K, const Rigid3& world_from_cam,
                                    IntegrateStats* stats);
  // Updates the voxels of `blocks` (from AllocateBand) with this frame.
  // `color` (linear RGB, depth's size) may be null.
  void Integrate(const std::vector<int32_t>& blocks, const DepthMap& depth, const Image* color,
                 const PinholeIntrinsics& K, const Rigid3& world_from_cam, IntegrateStats* stats);

  // Model maps seen from world_from_cam (world coordinates), by marching
  // rays from near to far metres.  `hint` (depth seen from this pose, e.g.
  // the frame just fused) starts each ray two truncation bands before the
  // measured depth instead of at `near_m`, and skips pixels without depth
  // (tracking associates the next frame's pixels, which are near these).
  PointMaps Raycast(const PinholeIntrinsics& K, const Rigid3& world_from_cam, float near_m = 0.2f, float far_m = 8.0f,
                    const DepthMap* hint = nullptr) const;

  // TSDF and weight trilinearly interpolated at p (world); false where any
  // of the 8 voxels is unobserved.
  bool Sample(const Eigen::Vector3f& p, float* sdf, float* weight = nullptr, Eigen::Vector3f* color = nullptr) const;

  // Vertices carry normals (the TSDF gradient), colour (linear, the voxels'
  // mean) and `confidence` (the fused weight).
  Mesh ExtractMesh(const MeshOptions& options, std::vector<float>* confidence, MeshStats* stats = nullptr) const;

  int64_t block_count() const;
  int64_t MemoryBytes() const;

 private:
  bool SampleCached(const Eigen::Vector3f& p, void* cache, float* sdf, float* weight = nullptr,
                    Eigen::Vector3f* color = nullptr) const;
  struct Impl;
  TsdfOptions options_;
  float trunc_;
  std::unique_ptr<Impl> impl_;
};

// Drops connected components (through shared vertices) with fewer than
// min_triangles triangles and degenerate triangles, then unreferenced
// vertices; `per_vertex` arrays (same length as the vertices) are compacted
// alongside.
void CleanMesh(Mesh* mesh, int min_triangles, std::vector<std::vector<float>*> per_vertex, MeshStats* stats);

}  // namespace mr
