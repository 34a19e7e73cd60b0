// Synthetic bracketed photographs of a known radiance image: the ground
// truth of mr-hdr's tests and of mr-synth's probe brackets.
//
// The camera: a Gaussian lens blur of `blur_px` (the glare that spreads a
// sun into its neighbours), a sensor that saturates at exposure X = 1 with
// shot and read noise in X, then the sRGB curve as its response, quantised
// to `bits`.  TrueLogExposure gives the response mr-hdr should recover.
#pragma once

#include <cstdint>
#include <vector>

#include "core/image.h"
#include "hdr/response.h"

namespace mr {

struct BracketOptions {
  std::vector<double> times = {1, 0.25, 0.0625, 0.015625};  // seconds: X = radiance * t
  int bits = 8;                                             // 8 or 16 (16: linear codes, no sRGB curve)
  double blur_px = 0;                                       // lens blur, sigma
  double shot_noise = 1e-4;                                 // variance of X per unit X
  double read_noise = 3e-4;                                 // sigma of X (both as mr-hdr's defaults)
  uint64_t seed = 1;
};

// One Exposure per time, in the given order, named "t=<time>".
std::vector<Exposure> SynthesiseBracket(const Image& radiance, const BracketOptions& options);

// ln X of the synthetic camera's response at normalised code z.
double TrueLogExposure(double z, int bits);

}  // namespace mr
