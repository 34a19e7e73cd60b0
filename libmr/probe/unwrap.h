// Unwrapping light-probe photographs into world-aligned lat-long maps.
//
// Mirror sphere: the camera is at a finite distance, so the reflection
// geometry is solved exactly (no orthographic approximation).  For a world
// direction d, the point of the sphere that reflects d into the camera lies
// in the plane of the camera, the sphere's centre and d; its normal's angle
// from the direction back to the camera is found by bisection (the
// reflected direction's angle grows monotonically with it, from 0 at the
// sphere's centre to the rim).  The point is projected through the
// camera's mrcal model.  Directions behind the sphere, that no point
// reflects, are blind (confidence 0).
//
// Fish-eye: the direction is projected through the camera's model directly
// (fields of view past 180 degrees included).
//
// Resampling is filtered by the mapping's Jacobian (EWA, Heckbert 1989):
// each map pixel averages the photograph over the Gaussian footprint of its
// own cell, J J^T / 4 + (1/2)^2 I in pixels^2, so a compressed rim is
// averaged over all the photograph's pixels it covers (not aliased), and a
// stretched centre is interpolated (not falsely sharp).  J is taken in
// steps of one map pixel's height along two tangents of the direction, so
// it is defined at the poles.  The confidence layer is |det J|: photograph
// pixels per (pi/H)^2 steradians (how well that direction is seen), times a
// factor that falls smoothly to 1e-3 within 15 degrees of the direction
// back to the camera, where the camera and photographer are reflected;
// several views merge by it.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "camera/camera_model.h"
#include "core/file.h"
#include "core/image.h"

namespace mr {

// probe.json (docs/formats.md) with its camera model loaded.
struct ProbeGeometry {
  fs::path path;
  CameraModel camera;
  double radius_m = 0;
  Eigen::Vector3d centre_cam = Eigen::Vector3d::Zero();
  Eigen::Matrix3d world_from_cam = Eigen::Matrix3d::Identity();
};
ProbeGeometry ReadProbe(const fs::path& path);

struct UnwrapOptions {
  int width = 512;                 // the map's width; height = width / 2
  double reflectance = 1.0;        // the mirror's: the photograph is divided by it
  Eigen::Matrix3d rotate = Eigen::Matrix3d::Identity();  // env_from_world correction (--rotate)
  double camera_cone_deg = 15;     // around the direction back to the camera: low confidence
  void Check() const;
};

struct UnwrapReport {
  double seen_fraction = 0;        // of the sphere's solid angle with confidence > 0
  double blind_fraction = 0;       // directions no point reflects (behind the sphere) or outside the image
  double median_confidence = 0;    // photograph pixels per (pi/H)^2 sr, over seen directions
};

// Output: R G B and confidence.Y, a width x width/2 lat-long map
// (core/spherical.h) in the world frame (after `rotate`).
Image UnwrapMirrorSphere(const Image& photo, const ProbeGeometry& probe, const UnwrapOptions& options,
                         const std::string& name, UnwrapReport* report = nullptr);
Image UnwrapFisheye(const Image& photo, const CameraModel& camera, const Eigen::Matrix3d& world_from_cam,
                    const UnwrapOptions& options, const std::string& name, UnwrapReport* report = nullptr);

// Confidence-weighted mean of several unwrapped views (same size).
Image MergeProbeViews(const std::vector<Image>& views);

// The camera-frame point of the sphere that reflects direction `d` (camera
// frame, unit) into the camera at the origin; false when none does.
bool MirrorSpherePoint(const Eigen::Vector3d& centre, double radius, const Eigen::Vector3d& d, Eigen::Vector3d* point);

}  // namespace mr
