#include "core/contact_sheet.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/math.h"

namespace mr {

namespace {

constexpr int kStrip = 22;  // label strip height, pixels
constexpr int kMargin = 4;  // between panels
constexpr float kGround = 0.15f;

}  // namespace

Image ContactSheet(const std::vector<SheetPanel>& panels, int columns) {
  if (panels.empty() || columns < 1) ThrowError("a contact sheet needs panels and at least one column");
  const int pw = panels[0].image->width(), ph = panels[0].image->height();
  for (const SheetPanel& p : panels)
    if (p.image->width() != pw || p.image->height() != ph)
      ThrowError("contact sheet panels differ in size: {}x{} and {}x{}", p.image->width(), p.image->height(), pw, ph);
  const int n = static_cast<int>(panels.size());
  const int cols = std::min(columns, n), rows = (n + cols - 1) / cols;
  const int cell_w = pw + kMargin, cell_h = ph + kStrip + kMargin;
  const int W = cols * cell_w + kMargin, H = rows * cell_h + kMargin;
  cv::Mat sheet(H, W, CV_8UC3, cv::Scalar::all(std::lround(kGround * 255)));
  for (int i = 0; i < n; ++i) {
    const Image& img = *panels[static_cast<size_t>(i)].image;
    const int x0 = kMargin + (i % cols) * cell_w, y0 = kMargin + (i / cols) * cell_h;
    const int nc = img.channels();
    for (int y = 0; y < ph; ++y)
      for (int x = 0; x < pw; ++x) {
        cv::Vec3b& p = sheet.at<cv::Vec3b>(y0 + kStrip + y, x0 + x);
        for (int c = 0; c < 3; ++c) {
          const float v = img.at(x, y, nc >= 3 ? c : 0);
          p[2 - c] = static_cast<uint8_t>(std::lround(Clamp(std::isfinite(v) ? v : 0.0f, 0.0f, 1.0f) * 255.0f));
        }
      }
    // The label, shrunk to fit the panel's width.
    const std::string& label = panels[static_cast<size_t>(i)].label;
    double scale = 0.45;
    int base = 0;
    cv::Size sz = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &base);
    if (sz.width > pw) {
      scale *= static_cast<double>(pw) / sz.width;
      sz = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &base);
    }
    cv::putText(sheet, label, cv::Point(x0 + 2, y0 + kStrip - 7), cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar::all(235),
                1, cv::LINE_AA);
  }
  Image out = Image::Rgb(W, H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const cv::Vec3b& p = sheet.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = p[2 - c] / 255.0f;
    }
  return out;
}

Image SignedDifferencePanel(const Image& d, double scale, double* used) {
  if (scale <= 0) {
    float m = 0;
    for (float v : d.values())
      if (std::isfinite(v)) m = std::max(m, std::abs(v));
    scale = m > 0 ? m : 1;
  }
  if (used) *used = scale;
  Image out = d;
  const float s = static_cast<float>(scale);
  for (float& v : out.values()) v = std::isfinite(v) ? Clamp(0.5f + 0.5f * v / s, 0.0f, 1.0f) : 0.5f;
  return out;
}

}  // namespace mr
