// Image error metrics of mr-eval and of every method's error-vs-time report.
//
// Definitions (docs/formats.md):
//   RMSE   = sqrt(mean over pixels and RGB of (a - b)^2)
//   relMSE = mean over pixels and RGB of (a - b)^2 / (b^2 + 0.01)   (b the reference)
//   PSNR   = 10 log10(peak^2 / MSE), peak = the reference's largest value (at least 1)
//   SSIM   = mean SSIM (Wang et al. 2004; Gaussian window sigma 1.5, K1 0.01, K2 0.03)
//            of the sRGB-encoded, [0,1]-clamped luminance
// A region restricts every metric to the pixels where the region image is > 0.
#pragma once

#include "core/image.h"

namespace mr {

struct ImageMetrics {
  double rmse = 0, relmse = 0, psnr = 0, ssim = 0;
  int64_t pixels = 0;  // pixels counted
};

inline constexpr double kRelMseEpsilon = 0.01;

// `a` is the estimate, `b` the reference; both RGB (the first three channels
// R, G, B) of the same size.  `region` is null or a one-channel image.
ImageMetrics CompareImages(const Image& a, const Image& b, const Image* region = nullptr);

// Reads the RGB of an image for comparison: its R, G, B channels, or the
// composite layer of an mr-render EXR.  Integer files decode with `transfer`.
// `raw` keeps integer pixels as code values / max (display values).
// `info`, when given, receives how the file stored its pixels.
Image ReadRgbForComparison(const fs::path& path, Transfer transfer = Transfer::kLinear, bool raw = false,
                           ImageFileInfo* info = nullptr);

// |a - b| * scale per channel, for comparison figures.
Image ScaledDifference(const Image& a, const Image& b, double scale);

}  // namespace mr
