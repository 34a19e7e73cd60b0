#include "light/environment.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
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
  // Per-cell solid-angle pdf, and Vose's alias table over the cells' weights:
  // O(1) sampling with exactly the probabilities weight / total.
  const size_t n = radiance_.size();
  pdf_.assign(n, 0.0);
  alias_prob_.assign(n, 0.0);
  alias_.assign(n, 0);
  if (total_ > 0) {
    std::vector<double> scaled(n);
    std::vector<uint32_t> small, large;
    for (size_t i = 0; i < n; ++i) {
      const double w = cdf_[i + 1] - cdf_[i];
      pdf_[i] = w / total_ / solid_angle_[i];
      scaled[i] = w / total_ * static_cast<double>(n);
      (scaled[i] < 1 ? small : large).push_back(static_cast<uint32_t>(i));
    }
    while (!small.empty() && !large.empty()) {
      const uint32_t s = small.back(), l = large.back();
      small.pop_back();
      alias_prob_[s] = scaled[s];
      alias_[s] = l;
      scaled[l] = (scaled[l] + scaled[s]) - 1;
      if (scaled[l] < 1) {
        large.pop_back();
        small.push_back(l);
      }
    }
    // What is left has probability 1 up to rounding; a cell of zero weight
    // left here by rounding must never be chosen: point it at a large cell.
    for (uint32_t i : large) alias_prob_[i] = 1;
    for (uint32_t i : small) {
      if (cdf_[i + 1] - cdf_[i] > 0) {
        alias_prob_[i] = 1;
      } else {
        alias_prob_[i] = 0;
        alias_[i] = large.empty() ? FirstPositiveCell() : large.front();
      }
    }
  }
  for (size_t i = 0; i < n; ++i)
    if (alias_prob_[i] < 1 && !(cdf_[alias_[i] + 1] - cdf_[alias_[i]] > 0))
      alias_prob_[i] = 1;  // never alias to a zero cell
}

uint32_t EnvironmentMap::FirstPositiveCell() const {
  for (size_t i = 0; i < radiance_.size(); ++i)
    if (cdf_[i + 1] - cdf_[i] > 0) return static_cast<uint32_t>(i);
  return 0;
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

Eigen::Vector3d EnvironmentMap::EvalWithPdf(const Eigen::Vector3d& dir, double* pdf) const {
  *pdf = 0;
  if (empty()) return Eigen::Vector3d::Zero();
  int px, py;
  const size_t i = static_cast<size_t>(Cell(world_from_env_.transpose() * dir, &px, &py));
  *pdf = pdf_[i];
  return radiance_[i].cast<double>();
}

double EnvironmentMap::Pdf(const Eigen::Vector3d& dir) const {
  if (empty() || total_ <= 0) return 0;
  int px, py;
  const size_t i = static_cast<size_t>(Cell(world_from_env_.transpose() * dir, &px, &py));
  return pdf_[i];
}

Eigen::Vector3d EnvironmentMap::Sample(double u0, double u1, double u2, Eigen::Vector3d* dir, double* pdf) const {
  *pdf = 0;
  if (empty() || total_ <= 0) return Eigen::Vector3d::Zero();
  // Cell from the alias table (cells of zero weight are never chosen).
  const double un = u0 * static_cast<double>(radiance_.size());
  size_t i = std::min(static_cast<size_t>(un), radiance_.size() - 1);
  if (un - static_cast<double>(i) >= alias_prob_[i]) i = alias_[i];
  const int px = static_cast<int>(i % width_), py = static_cast<int>(i / width_);
  // Uniform in solid angle within the cell.
  const double dlon = kTwoPi / (width_ - 1);
  const double lon_c = kPi - px * dlon;
  const double lon_hi = std::min(kPi, lon_c + dlon / 2), lon_lo = std::max(-kPi, lon_c - dlon / 2);
  const double s_lo = row_sin_[static_cast<size_t>(py) + 1], s_hi = row_sin_[static_cast<size_t>(py)];
  const double s = Clamp(s_lo + u1 * (s_hi - s_lo), -1.0, 1.0);
  // LatLongToDirection with sin(latitude) = s, without the round trip through asin.
  const double lon = lon_lo + u2 * (lon_hi - lon_lo), cl = SafeSqrt(1 - s * s);
  *dir = world_from_env_ * Eigen::Vector3d(std::sin(lon) * cl, s, std::cos(lon) * cl);
  *pdf = pdf_[i];
  return radiance_[i].cast<double>();
}

}  // namespace mr
