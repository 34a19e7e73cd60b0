#include "core/optical_flow.h"

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

// (g - local mean) / local standard deviation, Gaussian sigma 8 px, of g
// smoothed by a Gaussian of 1 px (a render's and a sensor's pixel noise);
// the deviation floored at 2% of the image's mean so that a flat region's
// noise is not blown up into texture.
cv::Mat1f Normalised(const cv::Mat1f& raw) {
  cv::Mat1f g, mu, mu2;
  cv::GaussianBlur(raw, g, cv::Size(0, 0), 1);
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

Eigen::Vector2f Bilinear(const std::vector<Eigen::Vector2f>& f, int w, int h, double x, double y) {  // clamped
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

Eigen::Vector2f FlowField::At(double x, double y) const { return Bilinear(flow, width, height, x, y); }

bool FlowField::MedianNear(double x, double y, double radius, int min_pixels, Eigen::Vector2f* out) const {
  std::vector<float> fx, fy;
  for (const Eigen::Vector2i& p : usable)
    if ((p.cast<double>() - Eigen::Vector2d(x, y)).squaredNorm() <= radius * radius) {
      const Eigen::Vector2f& f = flow[static_cast<size_t>(p.y()) * width + p.x()];
      fx.push_back(f.x());
      fy.push_back(f.y());
    }
  if (static_cast<int>(fx.size()) < std::max(1, min_pixels)) return false;
  const auto mid = static_cast<std::ptrdiff_t>(fx.size() / 2);
  std::nth_element(fx.begin(), fx.begin() + mid, fx.end());
  std::nth_element(fy.begin(), fy.begin() + mid, fy.end());
  *out = {fx[static_cast<size_t>(mid)], fy[static_cast<size_t>(mid)]};
  return true;
}

FlowField MatchImages(const Image& a, const Image& b, const Image* where, const FlowOptions& o) {
  MR_CHECK(a.width() == b.width() && a.height() == b.height());
  MR_CHECK(!where || (where->width() == a.width() && where->height() == a.height()));
  const int w = a.width(), h = a.height();
  FlowField m;
  m.width = w;
  m.height = h;
  cv::Mat1b bad_a, bad_b;
  const cv::Mat1f za = Normalised(Grey(a, &bad_a)), zb = Normalised(Grey(b, &bad_b));
  cv::Mat1b region(h, w, uchar{0});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if ((!where || where->at(x, y, 0) > 0) && !bad_a(y, x) && !bad_b(y, x)) region(y, x) = 255;
  m.region_pixels = cv::countNonZero(region);
  if (o.border_px > 0)
    cv::erode(region, region,
              cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * o.border_px + 1, 2 * o.border_px + 1)));
  const cv::Mat1b ba = Bytes(za), bb = Bytes(zb);
  const cv::Mat2f fwd = Flow(ba, bb), bwd = Flow(bb, ba);
  const cv::Mat1f tex_a = Texture(za), tex_b = Texture(zb);
  m.flow.resize(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const cv::Vec2f f = fwd(y, x);
      m.flow[static_cast<size_t>(y) * w + x] = {f[0], f[1]};
      if (!region(y, x) || std::min(tex_a(y, x), tex_b(y, x)) < o.min_texture) continue;
      ++m.textured;
      const int xb = std::clamp(static_cast<int>(std::lround(x + f[0])), 0, w - 1),
                yb = std::clamp(static_cast<int>(std::lround(y + f[1])), 0, h - 1);
      const cv::Vec2f bk = bwd(yb, xb);
      if (std::hypot(f[0] + bk[0], f[1] + bk[1]) <= o.consistency_px) m.usable.emplace_back(x, y);
    }
  return m;
}

}  // namespace mr
