// Differential compositing: I_f = M * I_m + (1 - M) * (I_c + I_m - I_r),
// in linear radiance (docs/conventions.md).  Negative results (where the
// photograph is darker than the removed light) are clamped to 0 and counted.
#pragma once

#include "core/image.h"

namespace mr {

struct CompositeResult {
  Image composite;   // RGB
  Image difference;  // I_m - I_r, RGB
  // The objects alone, premultiplied: M * object (RGB) with alpha M, so that
  // the composite is, in float32 and bit for bit, max(0, objects over
  // (photo + difference)): Porter-Duff over, A + (1 - A.alpha) B.
  Image objects;
  int64_t clamped_negative = 0;  // channel values clamped to 0
};

// photo, mixed, real: RGB of the same size; mask: one channel in [0,1].
CompositeResult Composite(const Image& photo, const Image& mixed, const Image& real, const Image& mask);
// The same with the objects' own pixels taken from `object` (I_m at another
// scale: M * object + (1 - M) * (I_c + I_m - I_r)).
CompositeResult Composite(const Image& photo, const Image& mixed, const Image& real, const Image& mask,
                          const Image& object);

// A plate channel at the top of its code range holds only a lower bound of
// its radiance: the true value is above it by an unknown amount, which
// hides a small change.  Where the object does not cover the pixel (mask
// 0), `clipped` (RGB, > 0 per clipped channel) is set and the composite
// differs from `photo` (both radiance) by less than `hidden` of it, the
// composite takes the photo's value (the plate's code is kept); a larger
// change (a shadow across a blown-out wall) is kept and counted.
struct ClippedChannels {
  int64_t kept = 0, changed = 0;
};
ClippedChannels KeepClippedChannels(const Image& photo, const Image& clipped, const Image& mask, Image* composite,
                                    double hidden = 0.1);

}  // namespace mr
