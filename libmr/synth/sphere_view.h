// Synthetic photographs of a mirror sphere through a known lens: the ground
// truth of mr-calibrate sphere's tests.
#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "camera/camera_model.h"
#include "core/image.h"
#include "light/environment.h"

namespace mr {

struct SphereViewOptions {
  int supersample = 4;       // per pixel edge: the silhouette is box-filtered
  double reflectance = 0.6;  // chrome's, as light-probe practice assumes (no Fresnel)
  Eigen::Matrix3d world_from_cam = Eigen::Matrix3d::Identity();  // the environment's frame
  double exposure = 1;                                           // scales radiance; values are not clipped
  double noise_sigma = 0;                                        // Gaussian noise relative to each value, seeded
  uint64_t seed = 1;
  // The camera's own body: a sphere of this radius (metres) around the
  // camera's centre with this radiance, seen reflected near the sphere's
  // centre (0: no body).
  double camera_body_radius = 0;
  double camera_body_radiance = 0.02;
};

// A perfect mirror sphere of `radius` (metres) centred at `centre` (camera
// frame) in front of `env` (at infinity, seen directly around the sphere):
// linear RGB radiance.  Pixels the lens does not image are black.
Image RenderSphereView(const EnvironmentMap& env, const CameraModel& camera, const Eigen::Vector3d& centre,
                       double radius, const SphereViewOptions& options = {});

// Multiplies every value by 1 + sigma g, g standard normal, seeded per
// pixel and channel (values stay non-negative).
void AddRelativeNoise(Image* img, double sigma, uint64_t seed);

// The environment itself through `camera` (no sphere): a fish-eye probe.
Image RenderEnvironmentView(const EnvironmentMap& env, const CameraModel& camera,
                            const SphereViewOptions& options = {});

}  // namespace mr
