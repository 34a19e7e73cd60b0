#include "light/environment.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/lanes.h"
#include "core/math.h"
#include "core/spherical.h"

namespace mr {

void CheckEnvironmentImage(const Image& img, const std::string& name) {
  const int r = img.ChannelIndex("R"), g = img.ChannelIndex("G"), b = img.ChannelIndex("B");
  if (r < 0 || g < 0 || b < 0) ThrowErrorAt(FileLoc{name}, "environment map needs R, G and B channels");
  if (img.width() < 2 || img.height() < 2) ThrowErrorAt(FileLoc{name}, "environment map must be at least 2x2 pixels");
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int k : {r, g, b}) {
        const float v = img.at(x, y, k);
        if (!std::isfinite(v) || v < 0)
          ThrowErrorAt(FileLoc{name},
                       "pixel ({}, {}) has {} radiance {} in channel {}; an environment map must be "
                       "finite and non-negative",
                       x, y, std::isfinite(v) ? "negative" : "non-finite", v,
                       img.channel_names()[static_cast<size_t>(k)]);
      }
}

EnvironmentMap::EnvironmentMap(const Image& img, const std::string& name, double scale,
                               const Eigen::Matrix3d& world_from_env)
    : width_(img.width()), height_(img.height()), world_from_env_(world_from_env) {
  CheckEnvironmentImage(img, name);
  rotation_ =
      (world_from_env_.transpose() * world_from_env_ - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-12;
  const int r = img.ChannelIndex("R"), g = img.ChannelIndex("G"), b = img.ChannelIndex("B");
  if (!(scale >= 0) || !std::isfinite(scale)) ThrowErrorAt(FileLoc{name}, "environment scale must be finite and >= 0");
  radiance_.resize(static_cast<size_t>(width_) * height_);
  solid_angle_.resize(radiance_.size());
  cdf_.resize(radiance_.size() + 1);
  cdf_[0] = 0;
  CompensatedSum<double> sum;
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      const Eigen::Vector3f c(img.at(x, y, r), img.at(x, y, g), img.at(x, y, b));
      const size_t i = static_cast<size_t>(y) * width_ + x;
      radiance_[i] = c * static_cast<float>(scale);
      solid_angle_[i] = LatLongPixelSolidAngle(x, y, width_, height_);
      sum += Luminance(radiance_[i].cast<double>()) * solid_angle_[i];
      cdf_[i + 1] = sum.Value();
    }
  total_ = sum.Value();
  // sin(latitude) at the rows' upper edges: row y spans [row_sin_[y+1], row_sin_[y]].
  row_sin_.resize(static_cast<size_t>(height_) + 1);
  const double dlat = kPi / (height_ - 1);
  for (int y = 0; y <= height_; ++y)
    row_sin_[static_cast<size_t>(y)] = std::sin(std::clamp(kPi / 2 - (y - 0.5) * dlat, -kPi / 2, kPi / 2));
  // Per-cell solid-angle pdf; rows are chosen by their share of the total,
  // then a cell within the row by its share of the row (cdf_ is row-major, so
  // a row's segment of it is its conditional distribution).
  const size_t n = radiance_.size();
  pdf_.assign(n, 0.0);
  if (total_ > 0)
    for (size_t i = 0; i < n; ++i) pdf_[i] = (cdf_[i + 1] - cdf_[i]) / total_ / solid_angle_[i];
  row_cdf_.resize(static_cast<size_t>(height_) + 1);
  for (int y = 0; y <= height_; ++y) row_cdf_[static_cast<size_t>(y)] = cdf_[static_cast<size_t>(y) * width_];
}

namespace {

// The index i in [0, n) with c[i] <= t < c[i + 1] (c non-decreasing, c[0] <= t);
// never an empty interval: past the last non-empty one (rounding) it is that one.
size_t Invert(const double* c, size_t n, double t) {
  size_t i = static_cast<size_t>(std::upper_bound(c, c + n + 1, t) - c);
  i = i == 0 ? 0 : i - 1;
  if (i >= n) i = n - 1;
  while (i > 0 && !(c[i + 1] > c[i])) --i;  // t rounded onto or past the end
  return i;
}

}  // namespace

EnvironmentMap EnvironmentMap::Constant(const Eigen::Vector3d& radiance) {
  Image img = Image::Rgb(4, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = static_cast<float>(radiance[c]);
  return EnvironmentMap(img, "constant environment");
}

namespace {

// The cell of world direction (dx, dy, dz): the lat-long pixel nearest to
// it (DirectionToLatLongPixel, rounded and clamped), with the latitude as
// atan2(y, sqrt(z^2 + x^2)) and Atan2 for std::atan2 (core/lanes.h).  `m`:
// env_from_world, row-major; w1, h1: the map's width and height less one.
// A NaN direction gives cell 0.
inline int32_t CellOf(double dx, double dy, double dz, const double* m, double w1, double h1) {
  const double x = (m[0] * dx + m[1] * dy) + m[2] * dz;
  const double y = (m[3] * dx + m[4] * dy) + m[5] * dz;
  const double z = (m[6] * dx + m[7] * dy) + m[8] * dz;
  const double lat = Atan2(y, std::sqrt(z * z + x * x)), lon = Atan2(x, z);
  const double fx = std::floor((-lon / kTwoPi + 0.5) * w1 + 0.5), fy = std::floor((-lat / kPi + 0.5) * h1 + 0.5);
  const double px = fx >= 0 ? (fx < w1 ? fx : w1) : 0.0, py = fy >= 0 ? (fy < h1 ? fy : h1) : 0.0;
  return static_cast<int32_t>(py * (w1 + 1) + px);
}

MR_LANES void CellsOf(size_t n, const double* __restrict dx, const double* __restrict dy, const double* __restrict dz,
                      const double* __restrict m, double w1, double h1, int32_t* __restrict cell) {
  for (size_t k = 0; k < n; ++k) cell[k] = CellOf(dx[k], dy[k], dz[k], m, w1, h1);
}

}  // namespace

size_t EnvironmentMap::Cell(const Eigen::Vector3d& dir) const {
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> m = world_from_env_.transpose();
  return static_cast<size_t>(CellOf(dir.x(), dir.y(), dir.z(), m.data(), width_ - 1, height_ - 1));
}

void EnvironmentMap::EvalWithPdf(size_t n, const Eigen::Vector3d* dir, Eigen::Vector3d* radiance, double* pdf) const {
  if (empty()) {
    for (size_t k = 0; k < n; ++k) {
      radiance[k].setZero();
      pdf[k] = 0;
    }
    return;
  }
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> m = world_from_env_.transpose();
  double x[kLaneChunk], y[kLaneChunk], z[kLaneChunk];
  int32_t cell[kLaneChunk];
  for (size_t start = 0; start < n; start += kLaneChunk) {
    const size_t c = std::min(kLaneChunk, n - start);
    for (size_t k = 0; k < c; ++k) {
      x[k] = dir[start + k].x();
      y[k] = dir[start + k].y();
      z[k] = dir[start + k].z();
    }
    CellsOf(c, x, y, z, m.data(), width_ - 1, height_ - 1, cell);
    for (size_t k = 0; k < c; ++k) {
      const size_t i = static_cast<size_t>(cell[k]);
      pdf[start + k] = pdf_[i];
      radiance[start + k] = radiance_[i].cast<double>();
    }
  }
}

Eigen::Vector3d EnvironmentMap::Eval(const Eigen::Vector3d& dir) const {
  if (empty()) return Eigen::Vector3d::Zero();
  return radiance_[Cell(dir)].cast<double>();
}

Eigen::Vector3d EnvironmentMap::EvalWithPdf(const Eigen::Vector3d& dir, double* pdf) const {
  *pdf = 0;
  if (empty()) return Eigen::Vector3d::Zero();
  const size_t i = Cell(dir);
  *pdf = pdf_[i];
  return radiance_[i].cast<double>();
}

double EnvironmentMap::Pdf(const Eigen::Vector3d& dir) const {
  if (empty() || total_ <= 0) return 0;
  return pdf_[Cell(dir)];
}

size_t EnvironmentMap::SampleRow(double u0) const {
  return Invert(row_cdf_.data(), static_cast<size_t>(height_), u0 * total_);
}

bool EnvironmentMap::SampleBand(double u0, Eigen::Vector3d* up, double* lo, double* hi) const {
  if (empty() || total_ <= 0) return false;
  *up = world_from_env_.col(1);
  if (!rotation_) {  // no band known: every direction
    *lo = -INFINITY;
    *hi = INFINITY;
    return true;
  }
  // Sample's sin(latitude) is clamped into its row's [row_sin_[py + 1],
  // row_sin_[py]]; the rotation moves it by rounding only.
  const size_t py = SampleRow(u0);
  *lo = std::max(-1.0, row_sin_[py + 1]) - 1e-9;
  *hi = std::min(1.0, row_sin_[py]) + 1e-9;
  return true;
}

// Where Sample's numbers fall: the cell, its longitude and sin(latitude)
// bounds, and what is left of each number inside it.
struct EnvCellPick {
  size_t i = 0;
  double f0 = 0, f1 = 0, lon_hi = 0, lon_lo = 0, s_hi = 0, s_lo = 0;
};

namespace {

// The direction at (f0, f1) of a pick's cell, uniform in solid angle:
// linear in sin(latitude) and in longitude (LatLongToDirection with
// sin(latitude) = s, without the round trip through asin), then rotated by
// m (row-major world_from_env).  Plain arithmetic: lanes of it vectorise and
// give the scalar call's bits (core/lanes.h).
inline void PlaceInCell(double f0, double f1, double lon_hi, double lon_lo, double s_hi, double s_lo, const double* m,
                        double* x, double* y, double* z) {
  const double s = Clamp(s_hi - f0 * (s_hi - s_lo), -1.0, 1.0);
  const double lon = lon_hi - f1 * (lon_hi - lon_lo), cl = std::sqrt(std::max(0.0, 1 - s * s));
  double sl, cs;
  SinCos(lon, &sl, &cs);
  const double ex = sl * cl, ey = s, ez = cs * cl;
  *x = (m[0] * ex + m[1] * ey) + m[2] * ez;
  *y = (m[3] * ex + m[4] * ey) + m[5] * ez;
  *z = (m[6] * ex + m[7] * ey) + m[8] * ez;
}

// PlaceInCell over picks' fields held apart (structure of arrays).
struct CellPickLanes {
  double f0[kLaneChunk], f1[kLaneChunk], lon_hi[kLaneChunk], lon_lo[kLaneChunk], s_hi[kLaneChunk], s_lo[kLaneChunk];
};

MR_LANES void PlaceInCells(size_t n, const CellPickLanes& p, const double* __restrict m, double* __restrict x,
                           double* __restrict y, double* __restrict z) {
  for (size_t k = 0; k < n; ++k)
    PlaceInCell(p.f0[k], p.f1[k], p.lon_hi[k], p.lon_lo[k], p.s_hi[k], p.s_lo[k], m, &x[k], &y[k], &z[k]);
}

}  // namespace

void EnvironmentMap::Pick(double u0, double u1, EnvCellPick* out) const {
  // Row by u0, cell in the row by u1, both by inverting the cumulative
  // weights; what is left of each places the direction in the cell.  The
  // map from (u0, u1) to directions is continuous and monotone in each, so
  // stratified numbers give stratified directions (over the sun's cells too).
  EnvCellPick& p = *out;
  const size_t py = SampleRow(u0);
  const double r0_lo = row_cdf_[py], r0_w = row_cdf_[py + 1] - r0_lo;
  p.f0 = Clamp((u0 * total_ - r0_lo) / r0_w, 0.0, 1.0);
  const double* row = cdf_.data() + py * static_cast<size_t>(width_);
  const double t1 = r0_lo + u1 * r0_w;
  const size_t px = Invert(row, static_cast<size_t>(width_), t1);
  const double c_w = row[px + 1] - row[px];
  p.f1 = Clamp((t1 - row[px]) / c_w, 0.0, 1.0);
  p.i = py * static_cast<size_t>(width_) + px;
  const double dlon = kTwoPi / (width_ - 1);
  const double lon_c = kPi - static_cast<double>(px) * dlon;
  p.lon_hi = std::min(kPi, lon_c + dlon / 2);
  p.lon_lo = std::max(-kPi, lon_c - dlon / 2);
  p.s_lo = row_sin_[py + 1];
  p.s_hi = row_sin_[py];
}

Eigen::Vector3d EnvironmentMap::Sample(double u0, double u1, Eigen::Vector3d* dir, double* pdf) const {
  *pdf = 0;
  if (empty() || total_ <= 0) return Eigen::Vector3d::Zero();
  EnvCellPick p;
  Pick(u0, u1, &p);
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> m = world_from_env_;
  PlaceInCell(p.f0, p.f1, p.lon_hi, p.lon_lo, p.s_hi, p.s_lo, m.data(), &dir->x(), &dir->y(), &dir->z());
  *pdf = pdf_[p.i];
  return radiance_[p.i].cast<double>();
}

void EnvironmentMap::Sample(size_t n, const double* u0, const double* u1, Eigen::Vector3d* dir,
                            Eigen::Vector3d* radiance, double* pdf) const {
  if (empty() || total_ <= 0) {
    for (size_t k = 0; k < n; ++k) {
      radiance[k].setZero();
      pdf[k] = 0;
    }
    return;
  }
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> m = world_from_env_;
  CellPickLanes lanes;
  size_t cell[kLaneChunk];
  double x[kLaneChunk], y[kLaneChunk], z[kLaneChunk];
  for (size_t start = 0; start < n; start += kLaneChunk) {
    const size_t c = std::min(kLaneChunk, n - start);
    for (size_t k = 0; k < c; ++k) {
      EnvCellPick p;
      Pick(u0[start + k], u1[start + k], &p);
      cell[k] = p.i;
      lanes.f0[k] = p.f0;
      lanes.f1[k] = p.f1;
      lanes.lon_hi[k] = p.lon_hi;
      lanes.lon_lo[k] = p.lon_lo;
      lanes.s_hi[k] = p.s_hi;
      lanes.s_lo[k] = p.s_lo;
    }
    PlaceInCells(c, lanes, m.data(), x, y, z);
    for (size_t k = 0; k < c; ++k) {
      dir[start + k] = Eigen::Vector3d(x[k], y[k], z[k]);
      pdf[start + k] = pdf_[cell[k]];
      radiance[start + k] = radiance_[cell[k]].cast<double>();
    }
  }
}

}  // namespace mr
