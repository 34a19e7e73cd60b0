// Differential compositing: I_f = M * I_m + (1 - M) * (I_c + I_m - I_r),
// in linear radiance (docs/conventions.md).  Negative results (where the
// photograph is darker than the removed light) are clamped to 0 and counted.
#pragma once

#include "core/image.h"

namespace mr {

struct CompositeResult {
  Image composite;               // RGB
  Image difference;              // I_m - I_r, RGB
  int64_t clamped_negative = 0;  // channel values clamped to 0
};

// photo, mixed, real: RGB of the same size; mask: one channel in [0,1].
CompositeResult Composite(const Image& photo, const Image& mixed, const Image& real, const Image& mask);
// The same with the objects' own pixels taken from `object` (I_m at another
// scale: M * object + (1 - M) * (I_c + I_m - I_r)).
CompositeResult Composite(const Image& photo, const Image& mixed, const Image& real, const Image& mask,
                          const Image& object);

}  // namespace mr
