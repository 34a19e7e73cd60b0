#include "core/image_metrics.h"

#include <opencv2/imgproc.hpp>

#include <cmath>

#include "core/error.h"
#include "core/math.h"

namespace mr {

namespace {

std::array<int, 3> Rgb(const Image& img, const char* what) {
  std::array<int, 3> idx{img.ChannelIndex("R"), img.ChannelIndex("G"), img.ChannelIndex("B")};
  if (idx[0] < 0 || idx[1] < 0 || idx[2] < 0) ThrowError("{} image has no R, G, B channels", what);
  return idx;
}

cv::Mat DisplayLuminance(const Image& img, const std::array<int, 3>& c) {
  cv::Mat m(img.height(), img.width(), CV_64F);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      double l = Luminance(img.at(x, y, c[0]), img.at(x, y, c[1]), img.at(x, y, c[2]));
      m.at<double>(y, x) = LinearToSrgb(static_cast<float>(Clamp(l, 0.0, 1.0)));
    }
  return m;
}

cv::Mat SsimMap(const cv::Mat& a, const cv::Mat& b) {
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  auto blur = [](const cv::Mat& m) {
    cv::Mat o;
    cv::GaussianBlur(m, o, cv::Size(11, 11), 1.5, 1.5, cv::BORDER_REFLECT);
    return o;
  };
  cv::Mat mu_a = blur(a), mu_b = blur(b);
  cv::Mat saa = blur(a.mul(a)) - mu_a.mul(mu_a), sbb = blur(b.mul(b)) - mu_b.mul(mu_b),
          sab = blur(a.mul(b)) - mu_a.mul(mu_b);
  cv::Mat num = (2 * mu_a.mul(mu_b) + c1).mul(2 * sab + c2);
  cv::Mat den = (mu_a.mul(mu_a) + mu_b.mul(mu_b) + c1).mul(saa + sbb + c2);
  cv::Mat out;
  cv::divide(num, den, out);
  return out;
}

}  // namespace

ImageMetrics CompareImages(const Image& a, const Image& b, const Image* region) {
  if (a.width() != b.width() || a.height() != b.height())
    ThrowError("images differ in size: {}x{} and {}x{}", a.width(), a.height(), b.width(), b.height());
  if (region && (region->width() != a.width() || region->height() != a.height()))
    ThrowError("region is {}x{}, the images {}x{}", region->width(), region->height(), a.width(), a.height());
  const auto ca = Rgb(a, "estimate"), cb = Rgb(b, "reference");
  CompensatedSum<double> se, rel;
  double peak = 1.0;
  int64_t n = 0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      if (region && !(region->at(x, y, 0) > 0)) continue;
      ++n;
      for (int k = 0; k < 3; ++k) {
        const double va = a.at(x, y, ca[static_cast<size_t>(k)]), vb = b.at(x, y, cb[static_cast<size_t>(k)]);
        const double d = va - vb;
        se += d * d;
        rel += d * d / (vb * vb + kRelMseEpsilon);
        peak = std::max(peak, vb);
      }
    }
  ImageMetrics m;
  m.pixels = n;
  if (n == 0) return m;
  const double mse = se.Value() / (3.0 * n);
  m.rmse = std::sqrt(mse);
  m.relmse = rel.Value() / (3.0 * n);
  m.psnr = mse > 0 ? 10 * std::log10(peak * peak / mse) : std::numeric_limits<double>::infinity();
  cv::Mat s = SsimMap(DisplayLuminance(a, ca), DisplayLuminance(b, cb));
  CompensatedSum<double> ss;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      if (!region || region->at(x, y, 0) > 0) ss += s.at<double>(y, x);
  m.ssim = ss.Value() / static_cast<double>(n);
  return m;
}

Image ReadRgbForComparison(const fs::path& path, Transfer transfer, bool raw, ImageFileInfo* info) {
  ImageReadOptions opt;
  opt.default_ldr_transfer = raw ? Transfer::kLinear : transfer;
  opt.use_file_transfer = !raw;
  Image img = ReadImage(path, opt, info);
  if (img.ChannelIndex("R") < 0 && img.ChannelIndex("composite.R") >= 0) img = img.Layer("composite");
  if (img.ChannelIndex("R") < 0 || img.ChannelIndex("G") < 0 || img.ChannelIndex("B") < 0)
    ThrowErrorAt(FileLoc{path.string()}, "image has neither R, G, B channels nor a composite layer");
  Image out = Image::Rgb(img.width(), img.height());
  const int r = img.ChannelIndex("R"), g = img.ChannelIndex("G"), b = img.ChannelIndex("B");
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      out.at(x, y, 0) = img.at(x, y, r);
      out.at(x, y, 1) = img.at(x, y, g);
      out.at(x, y, 2) = img.at(x, y, b);
    }
  return out;
}

Image ScaledDifference(const Image& a, const Image& b, double scale) {
  if (a.width() != b.width() || a.height() != b.height()) ThrowError("images differ in size");
  const auto ca = Rgb(a, "first"), cb = Rgb(b, "second");
  Image out = Image::Rgb(a.width(), a.height());
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      for (int k = 0; k < 3; ++k)
        out.at(x, y, k) = static_cast<float>(
            std::abs(a.at(x, y, ca[static_cast<size_t>(k)]) - b.at(x, y, cb[static_cast<size_t>(k)])) * scale);
  return out;
}

}  // namespace mr
