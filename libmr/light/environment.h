// A lat-long environment map (OpenEXR's LATLONG convention, docs/conventions.md)
// with luminance importance sampling.
//
// Radiance is piecewise constant over the pixels' cells (each cell bounded
// halfway to its neighbours, so that the nearest pixel of a direction is the
// cell it lies in), and directions are sampled by choosing a cell in
// proportion to luminance x solid angle and then uniformly in solid angle
// inside it: Eval, Sample and Pdf are exactly consistent, which the tests check.
// Sampling inverts the marginal (rows) and conditional (cells in a row)
// distributions, a continuous map of the unit square: stratified numbers
// (Sampler) stay stratified over the map, the sun's few cells included.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/color.h"
#include "core/image.h"

namespace mr {

// Throws mr::Error naming `name` unless `img` is an environment map mr can
// light with: R, G and B channels, at least 2x2 pixels, every value finite
// and non-negative (the first bad pixel is named).
void CheckEnvironmentImage(const Image& img, const std::string& name);

struct EnvCellPick;

class EnvironmentMap {
 public:
  EnvironmentMap() = default;
  // `img` must have R, G, B channels and finite, non-negative values: a
  // NaN/Inf/negative pixel is an error naming `name` and the pixel.
  // `world_from_env` rotates map directions into the world.
  EnvironmentMap(const Image& img, const std::string& name, double scale = 1.0,
                 const Eigen::Matrix3d& world_from_env = Eigen::Matrix3d::Identity());
  static EnvironmentMap Constant(const Eigen::Vector3d& radiance);

  bool empty() const { return width_ == 0; }
  int width() const { return width_; }
  int height() const { return height_; }

  // Radiance arriving from world direction `dir` (unit).
  Eigen::Vector3d Eval(const Eigen::Vector3d& dir) const;
  // Samples a world direction from (u0, u1) in [0,1)^2 (u0: the row, u1: the
  // cell in it); returns the radiance and sets the solid-angle pdf.
  Eigen::Vector3d Sample(double u0, double u1, Eigen::Vector3d* dir, double* pdf) const;
  // Sample for n pairs (u0[k], u1[k]) at once, the direction's arithmetic in
  // lanes (core/lanes.h): the same bits as n calls.
  void Sample(size_t n, const double* u0, const double* u1, Eigen::Vector3d* dir, Eigen::Vector3d* radiance,
              double* pdf) const;
  // What Sample(u0, u1) can return for this u0, whatever u1: a direction
  // whose dot product with `up` lies in [*lo, *hi] (its row's band of
  // latitudes, widened by 1e-9); false where Sample returns no direction.
  // `up` is the map's pole in the world.  Callers that keep only directions
  // in a known set skip Sample where the band misses it (the same result).
  bool SampleBand(double u0, Eigen::Vector3d* up, double* lo, double* hi) const;
  double Pdf(const Eigen::Vector3d& dir) const;
  // Eval and Pdf with one lookup (what an escaped path needs).
  Eigen::Vector3d EvalWithPdf(const Eigen::Vector3d& dir, double* pdf) const;
  // EvalWithPdf for n directions at once, the cells found in lanes
  // (core/lanes.h): the same bits as n calls.
  void EvalWithPdf(size_t n, const Eigen::Vector3d* dir, Eigen::Vector3d* radiance, double* pdf) const;
  // Total power proxy: integral of luminance over the sphere.
  double LuminanceIntegral() const { return total_; }

 private:
  size_t Cell(const Eigen::Vector3d& dir) const;             // the cell of world direction dir
  size_t SampleRow(double u0) const;                         // Sample's row for u0
  void Pick(double u0, double u1, EnvCellPick* pick) const;  // Sample's cell
  int width_ = 0, height_ = 0;
  std::vector<Eigen::Vector3f> radiance_;  // per pixel, scaled
  std::vector<double> cdf_;                // over cells, luminance x solid angle
  std::vector<double> solid_angle_;
  std::vector<double> pdf_;      // per cell, solid angle
  std::vector<double> row_sin_;  // sin(latitude) of the row edges
  std::vector<double> row_cdf_;  // cdf_ at the rows' starts (height + 1)
  double total_ = 0;
  Eigen::Matrix3d world_from_env_ = Eigen::Matrix3d::Identity();
  bool rotation_ = true;  // world_from_env_ is a rotation (to 1e-12): SampleBand holds
};

}  // namespace mr
