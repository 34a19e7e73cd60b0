// Matching the plate's grain: the plate is noisy, the rendered object is
// not.  The plate's noise is estimated as a function of intensity, per
// channel, in code values, from the frames themselves (patches' high-pass
// energy, the lower quartile per intensity bin: docs/radiometry.md,
// "Grain"); matching noise is then added where the composite shows the
// render, deterministic per pixel and frame.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/json.h"

namespace mr {

struct NoiseProfile {
  static constexpr int kBins = 16;  // code value bins over [0, 1]
  // Standard deviation of the noise in code values (0..1) at each bin's
  // centre, per channel; bins without flat patches take their neighbours'.
  std::array<std::array<double, kBins>, 3> sigma{};
  std::array<int, kBins> patches{};  // flat patches that measured each bin (summed over channels)
  int64_t patches_used = 0;
  // The noise at code value `code` of channel `c`: linear between bin centres.
  double At(int c, double code) const;
  Json ToJson() const;
};

// From code-value images (RGB, values in [0, 1]) of the plate: every 8x8
// patch away from clipping (codes within [1/255, 254/255]) measures its
// noise as the RMS of a 3x3 high-pass (pixel minus its neighbours' mean,
// whose variance is 9/8 of the noise's for white noise); per intensity bin
// the lower quartile of the patches' values, corrected for its bias under
// pure noise, is the noise (texture and edges only raise a patch's value).
// Bins no patch measured take the nearest measured bin's value; with no
// measured bin at all the profile is zero (a noise-free plate).
NoiseProfile EstimateNoise(const std::vector<Image>& codes);

// Adds Gaussian noise of the profile's sigma, at each pixel's code value,
// to `codes` where `weight` (one channel) is > 0, scaled by weight: a
// pixel that the render shows fully gets the plate's noise; a partly
// covered one the part its plate share does not already carry
// (sqrt(1 - (1 - M)^2) for mask M).  Channels are independent.  The noise
// of pixel i of frame f comes from its own generator, seeded by
// (seed, frame, i): the same bytes for any thread count or shard.
void AddGrain(const NoiseProfile& profile, const Image& weight, uint64_t seed, int frame, Image* codes);

}  // namespace mr
