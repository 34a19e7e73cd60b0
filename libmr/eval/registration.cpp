#include "eval/registration.h"

#include <fmt/format.h>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>

#include "core/check.h"

namespace mr {

namespace {

// Grey (the channels' mean; one channel as is), non-finite pixels 0 and
// marked in *bad.
cv::Mat1f Grey(const Image& img, cv::Mat1b* bad) {
  cv::Mat1f g(img.height(), img.width(), 0.0f);
  *bad = cv::Mat1b(img.height(), img.width(), uchar{0});
  const int nc = std::min(3, img.channels());
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      float s = 0;
      for (int c = 0; c < nc; ++c) s += img.at(x, y, c);
      if (!std::isfinite(s)) {
        (*bad)(y, x) = 1;
        continue;
      }
      g(y, x) = s / static_cast<float>(nc);
    }
  return g;
}

// (g - local mean) / local standard deviation, Gaussian sigma 8 px; the
// deviation floored at 2% of the image's mean so that a flat region's
// noise is not blown up into texture.
cv::Mat1f Normalised(const cv::Mat1f& g) {
  cv::Mat1f mu, mu2;
  cv::GaussianBlur(g, mu, cv::Size(0, 0), 8);
  cv::GaussianBlur(g.mul(g), mu2, cv::Size(0, 0), 8);
  const float floor = std::max(1e-12f, 0.02f * static_cast<float>(cv::mean(g)[0]));
  cv::Mat1f z(g.size());
  for (int y = 0; y < g.rows; ++y)
    for (int x = 0; x < g.cols; ++x) {
      const float var = std::max(0.0f, mu2(y, x) - mu(y, x) * mu(y, x));
      z(y, x) = (g(y, x) - mu(y, x)) / std::max(std::sqrt(var), floor);
    }
  return z;
}

cv::Mat1b Bytes(const cv::Mat1f& z) {
  cv::Mat1b b(z.size());
  for (int y = 0; y < z.rows; ++y)
    for (int x = 0; x < z.cols; ++x) b(y, x) = cv::saturate_cast<uchar>(128 + 32 * z(y, x));
  return b;
}

cv::Mat2f Flow(const cv::Mat1b& a, const cv::Mat1b& b) {
  cv::Ptr<cv::DISOpticalFlow> dis = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
  cv::Mat2f flow;
  dis->calc(a, b, flow);
  return flow;
}

// The structure tensor's smaller eigenvalue (gradients per pixel, Gaussian sigma 2 px).
cv::Mat1f Texture(const cv::Mat1f& z) {
  cv::Mat1f gx, gy;
  cv::Scharr(z, gx, CV_32F, 1, 0, 1.0 / 32);
  cv::Scharr(z, gy, CV_32F, 0, 1, 1.0 / 32);
  cv::Mat1f jxx, jyy, jxy;
  cv::GaussianBlur(gx.mul(gx), jxx, cv::Size(0, 0), 2);
  cv::GaussianBlur(gy.mul(gy), jyy, cv::Size(0, 0), 2);
  cv::GaussianBlur(gx.mul(gy), jxy, cv::Size(0, 0), 2);
  cv::Mat1f lmin(z.size());
  for (int y = 0; y < z.rows; ++y)
    for (int x = 0; x < z.cols; ++x) {
      const float h = 0.5f * (jxx(y, x) + jyy(y, x)), d = 0.5f * (jxx(y, x) - jyy(y, x));
      lmin(y, x) = h - std::sqrt(d * d + jxy(y, x) * jxy(y, x));
    }
  return lmin;
}

Eigen::Vector2f Bilinear(const std::vector<Eigen::Vector2f>& f, int w, int h, double x, double y) {
  x = std::clamp(x, 0.0, w - 1.0);
  y = std::clamp(y, 0.0, h - 1.0);
  const int x0 = std::min(static_cast<int>(x), w - 2 < 0 ? 0 : w - 2),
            y0 = std::min(static_cast<int>(y), h - 2 < 0 ? 0 : h - 2);
  const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
  const float ax = static_cast<float>(x - x0), ay = static_cast<float>(y - y0);
  auto at = [&](int xx, int yy) { return f[static_cast<size_t>(yy) * w + xx]; };
  return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x1, y0)) + ay * ((1 - ax) * at(x0, y1) + ax * at(x1, y1));
}

}  // namespace

Json RegistrationResult::ToJson() const {
  Json j = {{"measurable", measurable}, {"region_pixels", region_pixels}, {"usable_pixels", usable_pixels}};
  if (!measurable) {
    j["why"] = why;
    return j;
  }
  j["mean_px"] = mean_px;
  j["p90_px"] = p90_px;
  j["stderr_px"] = stderr_px;
  j["mean_flow_px"] = Json::array({mean_flow.x(), mean_flow.y()});
  return j;
}

RegistrationResult MeasureRegistration(const Image& rendered, const Image& plate, const Image& where,
                                       const RegistrationOptions& o) {
  MR_CHECK(rendered.width() == plate.width() && rendered.height() == plate.height());
  MR_CHECK(where.width() == plate.width() && where.height() == plate.height());
  const int w = plate.width(), h = plate.height();
  RegistrationResult r;
  cv::Mat1b bad_a, bad_b;
  const cv::Mat1f za = Normalised(Grey(rendered, &bad_a)), zb = Normalised(Grey(plate, &bad_b));
  cv::Mat1b region(h, w, uchar{0});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (where.at(x, y, 0) > 0 && !bad_a(y, x) && !bad_b(y, x)) region(y, x) = 255;
  r.region_pixels = cv::countNonZero(region);
  if (o.border_px > 0)
    cv::erode(region, region,
              cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * o.border_px + 1, 2 * o.border_px + 1)));
  const cv::Mat1b ba = Bytes(za), bb = Bytes(zb);
  const cv::Mat2f fwd = Flow(ba, bb), bwd = Flow(bb, ba);
  const cv::Mat1f tex_a = Texture(za), tex_b = Texture(zb);
  std::vector<float> mags;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  const int tiles_x = (w + o.tile_px - 1) / o.tile_px, tiles_y = (h + o.tile_px - 1) / o.tile_px;
  std::vector<double> tile_sum(static_cast<size_t>(tiles_x) * tiles_y, 0.0);
  std::vector<int> tile_n(tile_sum.size(), 0);
  int64_t textured = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!region(y, x)) continue;
      if (std::min(tex_a(y, x), tex_b(y, x)) < o.min_texture) continue;
      ++textured;
      const cv::Vec2f f = fwd(y, x);
      const int xb = std::clamp(static_cast<int>(std::lround(x + f[0])), 0, w - 1),
                yb = std::clamp(static_cast<int>(std::lround(y + f[1])), 0, h - 1);
      const cv::Vec2f b = bwd(yb, xb);
      if (std::hypot(f[0] + b[0], f[1] + b[1]) > o.consistency_px) continue;
      const float m = std::hypot(f[0], f[1]);
      mags.push_back(m);
      sum += Eigen::Vector2d(f[0], f[1]);
      const size_t t = static_cast<size_t>(y / o.tile_px) * tiles_x + static_cast<size_t>(x / o.tile_px);
      tile_sum[t] += m;
      ++tile_n[t];
    }
  r.usable_pixels = static_cast<int64_t>(mags.size());
  if (r.usable_pixels < o.min_pixels) {
    r.why = r.region_pixels == 0 ? "the room covers no pixel of the frame"
            : textured < o.min_pixels
                ? fmt::format("textureless: {} of the room's {} pixels carry texture or edges (at least {} needed)",
                              textured, r.region_pixels, o.min_pixels)
                : fmt::format("{} of the room's {} textured pixels agree forward and back (at least {} needed)",
                              r.usable_pixels, textured, o.min_pixels);
    return r;
  }
  r.measurable = true;
  double total = 0;
  for (float m : mags) total += m;
  r.mean_px = total / static_cast<double>(mags.size());
  r.mean_flow = sum / static_cast<double>(mags.size());
  const size_t k = static_cast<size_t>(0.9 * static_cast<double>(mags.size() - 1));
  std::nth_element(mags.begin(), mags.begin() + static_cast<std::ptrdiff_t>(k), mags.end());
  r.p90_px = mags[k];
  // The standard error over tiles (neighbouring pixels' flow is one
  // estimate, not independent ones): the spread of the tiles' means.
  std::vector<double> means;
  for (size_t t = 0; t < tile_sum.size(); ++t)
    if (tile_n[t] >= 16) means.push_back(tile_sum[t] / tile_n[t]);
  if (means.size() >= 2) {
    double m = 0, v = 0;
    for (double x : means) m += x;
    m /= static_cast<double>(means.size());
    for (double x : means) v += (x - m) * (x - m);
    r.stderr_px = std::sqrt(v / static_cast<double>(means.size() - 1) / static_cast<double>(means.size()));
  }
  return r;
}

std::vector<Eigen::Vector2f> PlateFlow(const Image& a, const Image& b) {
  MR_CHECK(a.width() == b.width() && a.height() == b.height());
  cv::Mat1b bad_a, bad_b;
  const cv::Mat2f f = Flow(Bytes(Normalised(Grey(a, &bad_a))), Bytes(Normalised(Grey(b, &bad_b))));
  std::vector<Eigen::Vector2f> out(static_cast<size_t>(a.width()) * a.height());
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) out[static_cast<size_t>(y) * a.width() + x] = {f(y, x)[0], f(y, x)[1]};
  return out;
}

double Swim(const std::vector<Eigen::Vector2f>& flow, int width, int height, const Eigen::Vector2d& from,
            const Eigen::Vector2d& to) {
  if (!(from.x() >= 0 && from.y() >= 0 && from.x() <= width - 1 && from.y() <= height - 1))
    return std::numeric_limits<double>::quiet_NaN();
  const Eigen::Vector2f f = Bilinear(flow, width, height, from.x(), from.y());
  return (to - from - f.cast<double>()).norm();
}

}  // namespace mr
