// Light sources extracted from a lat-long environment map, and what they
// leave out.
//
// Energies are luminance times solid angle (each pixel's exact solid angle,
// core/spherical.h), summed in double precision.  Methods:
//  - median-cut (Debevec 2005): regions of the map split in two of equal
//    energy across their longest side (widths scaled by cos latitude),
//    highest-energy region first, from a double-precision summed-area table;
//  - variance-cut (Viriyothai and Debevec 2009): the split (either axis, any
//    position) that minimises the summed energy-weighted spatial variance of
//    the two halves, the region with the largest such variance first;
//  - importance: hierarchical sample warping (Clarberg et al. 2005) of the
//    first N points of a (0,2)-sequence through a quadtree of the energy
//    (each pixel's energy spread over the cells it overlaps), N VPLs of
//    equal luminance power (the Monte Carlo estimator's weights L / (N pdf))
//    with the colour of their cell's dominant pixel;
//  - blobs: pixels above `threshold` times the map's mean radiance,
//    connected (across the longitude seam too), as differential irradiance
//    caching detects light sources; components wider than `max_blob_sr`
//    split at their energy median across their widest spread; the N most
//    energetic parts as area lights (discs of the part's solid angle).
// Each cut region's or blob's light takes the region's whole RGB energy,
// at its energy-weighted centroid direction.  The residual is the map minus
// what the lights took, so lights + residual integrate to the map exactly.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "scene/lights.h"

namespace mr {

struct ExtractOptions {
  std::string method = "median-cut";  // median-cut, variance-cut, importance, blobs
  int count = 16;
  double threshold = 8;               // blobs: times the map's mean radiance
  double max_blob_sr = 0.05;          // blobs: larger components split (a disc of 7.2 degrees)
  int sh_order = 3;                   // the residual's spherical harmonics
  uint32_t seed = 0;                  // importance: the point set's scramble
  void Check() const;
};

struct ExtractedLight {
  Eigen::Vector3d direction = Eigen::Vector3d::UnitY();  // towards the light, world
  Eigen::Vector3d power = Eigen::Vector3d::Zero();       // integral of L dOmega, RGB: irradiance at normal incidence (W/m^2)
  double solid_angle = 0;                                // sr of the pixels it took
  bool area = false;                                     // a disc of that solid angle (blobs) or a delta
};

struct Extraction {
  std::vector<ExtractedLight> lights;
  Image residual;                        // the map minus what the lights took (R G B), same size
  std::vector<Eigen::Vector3d> residual_sh;  // its SH projection, sh_order^2 RGB coefficients
  double taken_fraction = 0;            // of the map's luminance energy
  double seconds = 0;
};

// `env`: R G B first (other layers ignored), finite and non-negative.
Extraction ExtractLights(const Image& env, const ExtractOptions& options);

// lights.json entries (distant lights, real): `name_prefix` + index.
std::vector<Light> ToLights(const Extraction& e, const std::string& name_prefix = "light");

// Diffuse irradiance (luminance) at `normals`: exact from the map, and from
// the lights (deltas at their directions; area lights as uniform discs of
// their solid angle, as mr-render sees them) plus, when
// `with_residual`, the residual's SH (Ramamoorthi-Hanrahan cosine lobe).
std::vector<double> MapIrradiance(const Image& env, const std::vector<Eigen::Vector3d>& normals);
std::vector<double> LightsIrradiance(const Extraction& e, const std::vector<Eigen::Vector3d>& normals,
                                     bool with_residual);
// Normals spread evenly over the sphere (a Fibonacci lattice).
std::vector<Eigen::Vector3d> SphereNormals(int n);

struct IrradianceError {
  double rms_relative = 0;   // RMS of (E - E_ref) over RMS of E_ref
  double max_relative = 0;   // max |E - E_ref| over max E_ref
};
IrradianceError CompareIrradiance(const std::vector<double>& e, const std::vector<double>& ref);

// A lat-long map's luminance energy (integral of luminance dOmega).
double MapEnergy(const Image& env);

// Area-weighted downsampling (keeps every region's energy): a map of
// `width` x width/2.
Image DownsampleEnergy(const Image& env, int width);

}  // namespace mr
