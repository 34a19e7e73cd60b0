// Unwrapping light-probe photographs (a mirror sphere at a finite distance,
// or a fish-eye view) into world-aligned lat-long maps with a confidence
// layer, resampled with the mapping's Jacobian.  The reflection geometry, the
// filter and the confidence: docs/methods.md, "Probe unwrapping".
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/probe_file.h"
#include "camera/camera_model.h"
#include "core/file.h"
#include "core/image.h"

namespace mr {

struct UnwrapOptions {
  int width = 512;                                       // the map's width; height = width / 2
  double reflectance = 1.0;                              // the mirror's: the photograph is divided by it
  Eigen::Matrix3d rotate = Eigen::Matrix3d::Identity();  // env_from_world correction (--rotate)
  double camera_cone_deg = 15;                           // around the direction back to the camera: low confidence
  void Check() const;
};

struct UnwrapReport {
  double seen_fraction = 0;      // of the sphere's solid angle with confidence > 0
  double blind_fraction = 0;     // directions no point reflects (behind the sphere) or outside the image
  double median_confidence = 0;  // photograph pixels per (pi/H)^2 sr, over seen directions
  int64_t clipped_pixels = 0;    // photograph pixels on the probe marked clipped
  double clipped_fraction = 0;   // of the map's seen solid angle with clipped.Y > 0
};

// Output: R G B and confidence.Y, a width x width/2 lat-long map
// (core/spherical.h) in the world frame (after `rotate`).  `clipped`
// (optional, one byte a photograph pixel, non-zero where clipped in some
// channel): when any pixel that shows the probe is, the map gets a
// clipped.Y layer, the share of each map pixel's footprint that was
// clipped (its light there is a lower bound or an estimate).
Image UnwrapMirrorSphere(const Image& photo, const ProbeGeometry& probe, const UnwrapOptions& options,
                         const std::string& name, UnwrapReport* report = nullptr,
                         const std::vector<uint8_t>* clipped = nullptr);
Image UnwrapFisheye(const Image& photo, const CameraModel& camera, const Eigen::Matrix3d& world_from_cam,
                    const UnwrapOptions& options, const std::string& name, UnwrapReport* report = nullptr,
                    const std::vector<uint8_t>* clipped = nullptr);

// Confidence-weighted mean of several unwrapped views (same size); a
// clipped.Y layer where any view has one (a view without counts as 0).
Image MergeProbeViews(const std::vector<Image>& views);

// The camera-frame point of the sphere that reflects direction `d` (camera
// frame, unit) into the camera at the origin; false when none does.
bool MirrorSpherePoint(const Eigen::Vector3d& centre, double radius, const Eigen::Vector3d& d, Eigen::Vector3d* point);

}  // namespace mr
