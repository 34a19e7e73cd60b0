#include "synth/bracket.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"
#include "core/sampling.h"

namespace mr {

std::vector<Exposure> SynthesiseBracket(const Image& radiance, const BracketOptions& o) {
  if (o.bits != 8 && o.bits != 16) ThrowError("synthetic brackets are 8 or 16 bit, not {}", o.bits);
  Image blurred = radiance;
  GaussianBlur(&blurred, o.blur_px);
  const double levels = std::pow(2.0, o.bits) - 1;
  std::vector<Exposure> out;
  for (size_t j = 0; j < o.times.size(); ++j) {
    Exposure e;
    e.name = fmt::format("t={}", o.times[j]);
    e.time_s = o.times[j];
    e.pixel_type = o.bits == 8 ? "uint8" : "uint16";
    e.codes = Image(radiance.width(), radiance.height(), radiance.channel_names());
    const int nc = radiance.channels();
    ParallelFor(0, radiance.pixel_count(), [&](int64_t p) {
      Pcg32 rng(HashCombine(o.seed, j), static_cast<uint64_t>(p));
      for (int c = 0; c < nc; ++c) {
        const double X = blurred.values()[static_cast<size_t>(p * nc + c)] * o.times[j];
        const double sigma = std::sqrt(o.shot_noise * std::max(X, 0.0) + o.read_noise * o.read_noise);
        const double Xn = std::clamp(X + sigma * NextGaussian(rng), 0.0, 1.0);
        const double z = o.bits == 8 ? LinearToSrgb(static_cast<float>(Xn)) : Xn;
        e.codes.values()[static_cast<size_t>(p * nc + c)] = static_cast<float>(std::round(z * levels) / levels);
      }
    });
    out.push_back(std::move(e));
  }
  return out;
}

double TrueLogExposure(double z, int bits) {
  return std::log(std::max(1e-12, bits == 8 ? static_cast<double>(SrgbToLinear(static_cast<float>(z))) : z));
}

}  // namespace mr
