// Per-vertex albedo of a reconstructed room.
//
// Without lighting: the viewing-angle-weighted mean observed colour (as in
// Differential Instant Radiosity), from every stride-th tracked frame where
// the vertex is visible (its depth agrees with the frame's depth map).
//
// With lighting (lights.json and/or an environment map): the albedo that
// makes Lambertian shading match the observations, I = g_f * rho * E / pi,
// where E is the irradiance ray traced over the reconstructed mesh (direct
// light with shadow rays; indirect light from cosine-weighted hemisphere
// rays that take the room's own observed radiance where they hit it, so
// every bounce is included, and the map where they escape; a vertex clipped
// in every view that lies on an area light of `lights` gives none of its
// own: the light carries it) and g_f is an
// unknown per-frame gain (auto exposure; the first frame's is 1).  Gains
// and the albedo of a subset of well-observed vertices are solved jointly
// with Ceres (Huber loss); every vertex's albedo then follows by iteratively
// reweighted least squares with the gains fixed.
#pragma once

#include <string>

#include "core/report.h"
#include "geometry/mesh.h"
#include "recon/fusion.h"
#include "recon/rgbd.h"

namespace mr {

struct AlbedoOptions {
  int frame_stride = 5;           // use every Nth tracked frame
  double max_angle_deg = 75;      // ignore grazing views
  double depth_tolerance = 0.03;  // metres: visibility test against the frame's depth
  std::string lights, env;        // lighting; both empty: mean colour only
  double camera_scale = 1.0;      // camera colour units per unit of radiance (observations are divided by it)
  int rays = 256;                 // hemisphere rays per vertex
  int solve_vertices = 3000;      // vertices in the joint Ceres solve
  double huber = 0.05;            // colour units
  uint64_t seed = 1;
};

struct AlbedoStats {
  int frames_used = 0;
  int64_t vertices_observed = 0, vertices_unobserved = 0;
  int64_t vertices_from_neighbours = 0;  // unobserved, albedo from the surface around them
  int64_t vertices_isolated = 0;         // unobserved with nothing observed connected: albedo 0.5
  bool delit = false;
  double gain_min = 1, gain_max = 1;
  double mean_irradiance = 0;
  int64_t albedo_clamped = 0;      // vertices whose albedo came out above 1
  int64_t vertices_on_lights = 0;  // clipped in every view and on an area light: no room light of their own
};

// Gives every vertex that is not `known` the mean of its known neighbours'
// values, in rings outwards along the triangles' edges (each ring from the
// one inside it), so that a vertex no frame saw takes the albedo of the
// surface around it.  Vertices with no known vertex in their connected part
// of the mesh get `fallback`.  Returns the number filled from neighbours;
// *isolated (optional) receives the number given `fallback`.
int64_t FillFromNeighbours(const std::vector<Eigen::Vector3i>& triangles, const std::vector<bool>& known,
                           const Eigen::Vector3d& fallback, std::vector<Eigen::Vector3d>* values,
                           int64_t* isolated = nullptr);

// Sets mesh->colors to the albedo (clamped to [0,1]) and adds scalars
// albedo_r/g/b (unclamped) and observed_r/g/b (mean observed colour over
// camera_scale).  Saturated colour samples are left out.
AlbedoStats ComputeAlbedo(const RgbdSequence& seq, const FuseResult& fused, double max_depth,
                          const AlbedoOptions& options, Mesh* mesh, Report* report);

}  // namespace mr
