// Planes in a point cloud (a room from a video without depth: COLMAP's
// sparse points become the floor, table tops and walls).
//
// DetectPlanes finds planes one after another by RANSAC (three-point
// hypotheses, the plane with most points within `distance` kept, refitted
// to its inliers, its points removed).  A first pass, as the points have
// them, fixes gravity: `up` is the normal of the largest plane within
// `up_hint_deg` of the hint (table tops and floors are level to well under
// a degree, more exact than a hand-held camera's mean up).  A second pass
// then turns every hypothesis to gravity before scoring it (within
// `snap_deg` of level or upright it becomes exactly so; others are skipped
// unless kept), so that level and upright slabs are what is counted, and
// parallel slabs of one surface are merged.
// MeshPlanes turns each plane's inliers into a surface: the cells of a
// grid on the plane within `grow` of an inlier, holes filled, parts with
// too few points dropped.  docs/methods.md, "A room from the video alone".
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"

namespace mr {

struct PlaneOptions {
  double distance = 0.02;      // inlier distance, in the points' units
  int min_points = 60;         // a plane (and each part of it) needs this many inliers
  double min_fraction = 0.02;  // ... and this fraction of all the points
  int max_planes = 8;          // kept (slanted ones dropped do not count)
  int hypotheses = 3000;       // RANSAC hypotheses per plane
  // Gravity: the hint (any length; zero: none, no plane is turned) and how
  // far from it the plane that fixes `up` may be.
  Eigen::Vector3d up_hint = Eigen::Vector3d::Zero();
  double up_hint_deg = 45;  // a camera pitched down 35 degrees at a table is 35 off
  double snap_deg = 10;     // horizontal / vertical within this are made exact
  // With gravity known, planes neither level nor upright (within snap_deg)
  // are dropped unless kept: an indoor room's large surfaces are level or
  // upright, and a tilted plane through sparse points is more often a fit
  // across two of them (a counter's top and its front) than a ramp.
  bool keep_slanted = false;
  // Level planes (or upright ones facing the same way) closer than this are
  // merged into one (0: never): SfM points of one table top scatter by a
  // centimetre or more, and RANSAC's gate splits them into slabs.
  double merge_distance = 0.06;
  uint64_t seed = 1;

  void Check() const;  // UsageError naming the option at fault
};

struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();  // unit; towards the viewpoints
  double offset = 0;                                  // normal . x = offset on the plane
  std::string kind;                                   // "horizontal", "vertical" or "slanted"
  std::vector<int> inliers;                           // indices into the points
  double rms = 0;                                     // inliers' distance to the plane
  double tilt_deg = 0;                                // angle of the fitted normal from the final one (the snap)
};

struct PlaneSet {
  std::vector<Plane> planes;   // largest first
  std::vector<Plane> dropped;  // slanted planes left out (PlaneOptions::keep_slanted)
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  std::string up_from;  // "plane" (the largest level one), "hint" or "none"
  int points = 0, unexplained = 0;
  int merged = 0;  // planes merged into a larger parallel one (PlaneOptions::merge_distance)
};

// `viewpoints` (e.g. camera centres; may be empty) orient each normal
// towards their mean.  Throws mr::Error when no plane has enough points
// ("the points support no plane"), naming the counts.
PlaneSet DetectPlanes(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& viewpoints,
                      const PlaneOptions& options);

struct PlaneMeshOptions {
  double cell = 0.02;   // grid spacing on the plane (points' units)
  double grow = 0.15;   // cells this far from an inlier are surface
  int min_points = 60;  // a connected part with fewer inliers is dropped
};

// One mesh of all planes: a grid of cells per plane (two triangles each,
// front towards the plane's normal), vertex normals the plane's; the
// scalar "plane" gives each vertex's plane index.  *kept (optional) gets
// the number of inliers on kept parts, per plane.
Mesh MeshPlanes(const std::vector<Eigen::Vector3d>& points, const PlaneSet& set, const PlaneMeshOptions& options,
                std::vector<int>* kept = nullptr);

}  // namespace mr
