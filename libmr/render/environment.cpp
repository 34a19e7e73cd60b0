#include "render/environment.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/math.h"
#include "core/spherical.h"

namespace mr {

EnvironmentMap::EnvironmentMap(const Image& img, const std::string& name, double scale,
                               const Eigen::Matrix3d& world_from_env)
    : width_(img.width()), height_(img.height()), world_from_env_(world_from_env) {
  const int r = img.ChannelIndex("R"), g = img.ChannelIndex("G"), b = img.ChannelIndex("B");
  if (r < 0 || g < 0 || b < 0) ThrowErrorAt(FileLoc{name}, "environment map needs R, G and B channels");
  if (width_ < 2 || height_ < 2) ThrowErrorAt(FileLoc{name}, "environment map must be at least 2x2 pixels");
  if (!(scale >= 0) || !std::isfinite(scale)) ThrowErrorAt(FileLoc{name}, "environment scale must be finite and >= 0");
  radiance_.resize(static_cast<size_t>(width_) * height_);
  solid_angle_.resize(radiance_.size());
  cdf_.resize(radiance_.size() + 1);
  cdf_[0] = 0;
  CompensatedSum<double> sum;
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      Eigen::Vector3f c(img.at(x, y, r), img.at(x, y, g), img.at(x, y, b));
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(c[k]) || c[k] < 0)
          ThrowErrorAt(FileLoc{name}, "pixel ({}, {}) has {} radiance {} in channel {}; an environment map must be "
                       "finite and non-negative", x, y, std::isfinite(c[k]) ? "negative" : "non-finite", c[k], "RGB"[k]);
      const size_t i = static_cast<size_t>(y) * width_ + x;
      radiance_[i] = c * static_cast<float>(scale);
      solid_angle_[i] = LatLongPixelSolidAngle(x, y, width_, height_);
      sum += Luminance(radiance_[i].cast<double>()) * solid_angle_[i];
      cdf_[i + 1] = sum.Value();
    }
  total_ = sum.Value();
}

EnvironmentMap EnvironmentMap::Constant(const Eigen::Vector3d& radiance) {
  Image img = Image::Rgb(4, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = static_cast<float>(radiance[c]);
  return EnvironmentMap(img, "constant environment");
}

int EnvironmentMap::Cell(const Eigen::Vector3d& env_dir, int* px, int* py) const {
  Eigen::Vector2d p = DirectionToLatLongPixel(env_dir, width_, height_);
  *px = Clamp(static_cast<int>(std::lround(p.x())), 0, width_ - 1);
  *py = Clamp(static_cast<int>(std::lround(p.y())), 0, height_ - 1);
  return *py * width_ + *px;
}

Eigen::Vector3d EnvironmentMap::Eval(const Eigen::Vector3d& dir) const {
  if (empty()) return Eigen::Vector3d::Zero();
  int px, py;
  return radiance_[static_cast<size_t>(Cell(world_from_env_.transpose() * dir, &px, &py))].cast<double>();
}

double EnvironmentMap::Pdf(const Eigen::Vector3d& dir) const {
  if (empty() || total_ <= 0) return 0;
  int px, py;
  const size_t i = static_cast<size_t>(Cell(world_from_env_.transpose() * dir, &px, &py));
  return (cdf_[i + 1] - cdf_[i]) / total_ / solid_angle_[i];
}

Eigen::Vector3d EnvironmentMap::Sample(double u0, double u1, double u2, Eigen::Vector3d* dir, double* pdf) const {
  *pdf = 0;
  if (empty() || total_ <= 0) return Eigen::Vector3d::Zero();
  // Cell by binary search on the CDF (cells of zero weight are never chosen).
  const double target = u0 * total_;
  size_t i = static_cast<size_t>(std::upper_bound(cdf_.begin() + 1, cdf_.end(), target) - cdf_.begin() - 1);
  i = std::min(i, radiance_.size() - 1);
  while (cdf_[i + 1] - cdf_[i] <= 0 && i > 0) --i;  // guard: u0 at a flat step
  const int px = static_cast<int>(i % width_), py = static_cast<int>(i / width_);
  // Uniform in solid angle within the cell.
  const double dlat = kPi / (height_ - 1), dlon = kTwoPi / (width_ - 1);
  const double lat_c = kPi / 2 - py * dlat, lon_c = kPi - px * dlon;
  const double lat_hi = std::min(kPi / 2, lat_c + dlat / 2), lat_lo = std::max(-kPi / 2, lat_c - dlat / 2);
  const double lon_hi = std::min(kPi, lon_c + dlon / 2), lon_lo = std::max(-kPi, lon_c - dlon / 2);
  const double s = std::sin(lat_lo) + u1 * (std::sin(lat_hi) - std::sin(lat_lo));
  LatLong ll;
  ll.latitude = SafeASin(s);
  ll.longitude = lon_lo + u2 * (lon_hi - lon_lo);
  *dir = world_from_env_ * LatLongToDirection(ll);
  *pdf = (cdf_[i + 1] - cdf_[i]) / total_ / solid_angle_[i];
  return radiance_[i].cast<double>();
}

}  // namespace mr
