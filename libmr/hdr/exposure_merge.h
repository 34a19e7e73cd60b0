// Merging a bracket of exposures into linear radiance with its variance
// (inverse-variance weighted under a sensor noise model), with ghosts
// flagged and censored (saturated everywhere) pixels bounded from below.
// The noise model and the censored-source fit: docs/methods.md, "HDR".
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "hdr/response.h"

namespace mr {

struct ExposureMergeOptions {
  double low = 0.02;         // normalised codes at or below: too dark to use
  double high = 0.97;        // at or above: saturated
  double read_noise = 3e-4;  // sigma of the linear signal s at black (fraction of saturation)
  double shot_noise = 1e-4;  // variance of s per unit s (1 / full-well electrons)
  bool ghosts = true;
  double ghost_sigma = 5;     // samples further apart than this (in sigma) are a ghost
  double model_error = 0.05;  // relative: response, JPEG and interpolation errors
  bool fit_censored = true;   // fit censored regions (else: lower bound only)
  double psf_sigma_px = 0;    // the lens's blur, when known (0: from the ring)
  void Check() const;
};

struct CensoredRegion {
  int pixels = 0;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();       // px
  Eigen::Vector3d lower_bound = Eigen::Vector3d::Zero();  // energy: sum of radiance over its pixels, RGB
  Eigen::Vector3d estimate = Eigen::Vector3d::Zero();     // what was filled in
  double blur_px = 0;                                     // the fitted s (0 when not fitted)
  double source_radius_px = 0;                            // the disc the fit kept
  bool fitted = false;
  std::string why_not;  // when not fitted
};

struct MergeReport {
  int64_t pixels = 0, censored_pixels = 0, black_pixels = 0, ghost_pixels = 0;
  double censored_lower_bound_fraction = 0;  // of the image's total energy (luminance)
  double censored_added_fraction = 0;        // what the fits add beyond the lower bound
  std::vector<CensoredRegion> regions;
  std::vector<std::string> order;  // names, shortest exposure first
  std::vector<std::string> warnings;
  int reference = 0;  // index (in `order`) of the best exposed photograph
};

// Output layers: R G B (radiance, response units per second), variance.R/G/B,
// saturated.Y (1 where censored in any channel), ghost.Y.  Exposures may
// come in any order; a photograph given twice is used once (warned).
Image MergeExposures(std::vector<Exposure> bracket, const CameraResponse& response, const ExposureMergeOptions& options,
                     MergeReport* report = nullptr);

// Aligns hand-held brackets (median threshold bitmaps, OpenCV's AlignMTB,
// Ward 2003) to the middle exposure by whole-pixel shifts; photographs of
// different sizes (crops) are centred on each other first.  Every exposure
// comes back with the reference's size and `valid` marking pixels it saw.
// Shifts up to 2^max_bits - 1 px (fewer on small images: the coarsest
// level keeps 16 px).  Returns each exposure's shift in the input order: reference pixel q
// shows exposure i's pixel q - shift.
std::vector<Eigen::Vector2i> AlignExposures(std::vector<Exposure>* bracket, int max_bits = 6);

// Reads one photograph of a bracket as raw normalised codes (no transfer
// decoding: the response does that), with its pixel type and exposure:
// `time_s` when positive, else from its metadata (`how` says which), else
// an error naming the file.
Exposure ReadExposure(const fs::path& path, double time_s = 0, std::string* how = nullptr);

// A photograph's exposure from its metadata: ExposureTime (s), and
// FNumber / ISO when present (t * ISO/100 / N^2 relative to f/1, ISO 100),
// so brackets that vary aperture or gain merge too.  0 when unknown.
double ExposureFromMetadata(const std::map<std::string, std::string>& attributes, std::string* how);

}  // namespace mr
