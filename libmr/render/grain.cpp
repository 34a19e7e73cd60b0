#include "render/grain.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/hash.h"
#include "core/sampling.h"

namespace mr {

namespace {

constexpr int kPatch = 8;
constexpr double kQuantile = 0.25;

double Gaussian(Pcg32& rng) {
  const double u1 = std::max(1e-300, rng.NextDouble()), u2 = rng.NextDouble();
  return std::sqrt(-2 * std::log(u1)) * std::cos(2 * 3.14159265358979323846 * u2);
}

// Per channel, the patches' noise measurements: the RMS of the 3x3
// high-pass over the patch's pixels with a full neighbourhood, over
// sqrt(9/8).  `fn(c, mean, rms)` receives each patch away from clipping.
template <class Fn>
void PatchNoise(const Image& img, Fn fn) {
  const int w = img.width(), h = img.height();
  for (int py = 0; py + kPatch <= h; py += kPatch)
    for (int px = 0; px + kPatch <= w; px += kPatch)
      for (int c = 0; c < 3; ++c) {
        double sum = 0, sum_r2 = 0;
        int n = 0;
        bool clipped = false;
        for (int y = py; y < py + kPatch && !clipped; ++y)
          for (int x = px; x < px + kPatch; ++x) {
            const double v = img.at(x, y, c);
            if (!std::isfinite(v) || v < 1.0 / 255 || v > 254.0 / 255) {
              clipped = true;
              break;
            }
            sum += v;
            if (x == 0 || y == 0 || x == w - 1 || y == h - 1) continue;
            double nb = 0;
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx)
                if (dx || dy) nb += img.at(x + dx, y + dy, c);
            const double r = v - nb / 8;
            sum_r2 += r * r;
            ++n;
          }
        if (clipped || n < kPatch * kPatch / 2 || !std::isfinite(sum_r2)) continue;
        fn(c, sum / (kPatch * kPatch), std::sqrt(sum_r2 / n / (9.0 / 8.0)));
      }
}

double Quantile(std::vector<double> v, double q) {
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// The lower quartile of the patches' values over the noise's sigma, for
// white Gaussian noise: found once by measuring 4096 patches of it.
double QuartileBias() {
  static const double bias = [] {
    const int side = kPatch * 64;
    Image img = Image::Rgb(side, side);
    Pcg32 rng(12345, 1);
    for (float& v : img.values()) v = static_cast<float>(0.5 + 0.01 * Gaussian(rng));
    std::vector<double> rms;
    PatchNoise(img, [&](int c, double, double s) {
      if (c == 0) rms.push_back(s / 0.01);
    });
    return Quantile(rms, kQuantile);
  }();
  return bias;
}

}  // namespace

double NoiseProfile::At(int c, double code) const {
  if (!std::isfinite(code)) code = 0;  // never an index from NaN
  const double t = std::clamp(code * kBins - 0.5, 0.0, kBins - 1.0);
  const int i = std::min(static_cast<int>(t), kBins - 2);
  const double f = t - i;
  return (1 - f) * sigma[static_cast<size_t>(c)][static_cast<size_t>(i)] +
         f * sigma[static_cast<size_t>(c)][static_cast<size_t>(i + 1)];
}

Json NoiseProfile::ToJson() const {
  Json bins = Json::array();
  for (int b = 0; b < kBins; ++b)
    bins.push_back(
        {{"code", (b + 0.5) / kBins},
         {"sigma",
          {sigma[0][static_cast<size_t>(b)], sigma[1][static_cast<size_t>(b)], sigma[2][static_cast<size_t>(b)]}},
         {"patches", patches[static_cast<size_t>(b)]}});
  return Json{{"bins", bins}, {"patches", patches_used}};
}

NoiseProfile EstimateNoise(const std::vector<Image>& codes) {
  std::array<std::array<std::vector<double>, NoiseProfile::kBins>, 3> by_bin;
  NoiseProfile p;
  for (const Image& img : codes) {
    if (img.channels() < 3) ThrowError("noise estimation needs RGB code values");
    PatchNoise(img, [&](int c, double mean, double rms) {
      const int b = std::clamp(static_cast<int>(mean * NoiseProfile::kBins), 0, NoiseProfile::kBins - 1);
      by_bin[static_cast<size_t>(c)][static_cast<size_t>(b)].push_back(rms);
      ++p.patches[static_cast<size_t>(b)];
      ++p.patches_used;
    });
  }
  const double bias = QuartileBias();
  for (size_t c = 0; c < 3; ++c) {
    std::array<bool, NoiseProfile::kBins> measured{};
    constexpr size_t kMinPatches = 8;  // fewer: the quartile is not a quartile
    for (size_t b = 0; b < NoiseProfile::kBins; ++b)
      if (by_bin[c][b].size() >= kMinPatches) {
        p.sigma[c][b] = Quantile(by_bin[c][b], kQuantile) / bias;
        measured[b] = true;
      }
    // Unmeasured bins: the nearest measured bin's value (the lower one on a tie).
    for (int b = 0; b < NoiseProfile::kBins; ++b) {
      if (measured[static_cast<size_t>(b)]) continue;
      for (int d = 1; d < NoiseProfile::kBins; ++d) {
        if (b - d >= 0 && measured[static_cast<size_t>(b - d)]) {
          p.sigma[c][static_cast<size_t>(b)] = p.sigma[c][static_cast<size_t>(b - d)];
          break;
        }
        if (b + d < NoiseProfile::kBins && measured[static_cast<size_t>(b + d)]) {
          p.sigma[c][static_cast<size_t>(b)] = p.sigma[c][static_cast<size_t>(b + d)];
          break;
        }
      }
    }
  }
  return p;
}

void AddGrain(const NoiseProfile& profile, const Image& weight, uint64_t seed, int frame, Image* codes) {
  const int w = codes->width(), h = codes->height();
  if (weight.width() != w || weight.height() != h) ThrowError("grain: the weight and the image differ in size");
  const uint64_t frame_seed = HashCombine(seed, static_cast<uint64_t>(frame) ^ 0x6772616e69ull);  // "grain"
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double m = weight.at(x, y, 0);
      if (!(m > 0)) continue;
      const double s = std::sqrt(std::max(0.0, 1 - (1 - std::min(m, 1.0)) * (1 - std::min(m, 1.0))));
      Pcg32 rng(frame_seed, static_cast<uint64_t>(y) * static_cast<uint64_t>(w) + static_cast<uint64_t>(x));
      for (int c = 0; c < 3; ++c) {
        float& v = codes->at(x, y, c);
        v = static_cast<float>(v + s * profile.At(c, v) * Gaussian(rng));
      }
    }
}

}  // namespace mr
