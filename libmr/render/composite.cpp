#include "render/composite.h"

#include <cmath>

#include "core/check.h"
#include "core/error.h"

namespace mr {

CompositeResult Composite(const Image& photo, const Image& mixed, const Image& real, const Image& mask) {
  return Composite(photo, mixed, real, mask, mixed);
}

CompositeResult Composite(const Image& photo, const Image& mixed, const Image& real, const Image& mask,
                          const Image& object) {
  const int w = mixed.width(), h = mixed.height();
  for (const Image* img : {&photo, &real, &mask, &object})
    if (img->width() != w || img->height() != h)
      ThrowError("compositing images of different sizes: {}x{} and {}x{}", img->width(), img->height(), w, h);
  if (photo.channels() < 3 || mixed.channels() < 3 || real.channels() < 3 || object.channels() < 3 ||
      mask.channels() < 1)
    ThrowError("compositing needs RGB photo, mixed and real images and a one-channel mask");
  CompositeResult r;
  r.composite = Image::Rgb(w, h);
  r.difference = Image::Rgb(w, h);
  r.objects = Image::Rgba(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float m = mask.at(x, y, 0);
      r.objects.at(x, y, 3) = m;
      for (int c = 0; c < 3; ++c) {
        // Each step rounded to float as a compositor's over rounds it:
        // objects + (1 - alpha) * (photo + difference).
        const float d = mixed.at(x, y, c) - real.at(x, y, c);
        const float o = m * object.at(x, y, c);
        const float one_minus = 1 - m;
        const float b = photo.at(x, y, c) + d;
        const float under = one_minus * b;
        float v = o + under;
        r.objects.at(x, y, c) = o;
        // Negative where the removed light exceeds the plate: clamped.  A
        // plate's own negative value (a colour outside the working space's
        // gamut, from a wider one) is kept, so that it encodes back.
        if (v < 0 && v != photo.at(x, y, c)) {
          v = 0;
          ++r.clamped_negative;
        }
        r.composite.at(x, y, c) = v;
        r.difference.at(x, y, c) = d;
      }
    }
  return r;
}

ClippedChannels KeepClippedChannels(const Image& photo, const Image& clipped, const Image& mask, Image* composite,
                                    double hidden) {
  MR_CHECK(photo.width() == composite->width() && photo.height() == composite->height() &&
           clipped.width() == photo.width() && clipped.height() == photo.height() && mask.width() == photo.width() &&
           mask.height() == photo.height() && clipped.channels() == 3 && photo.channels() == 3);
  ClippedChannels n;
  for (int y = 0; y < photo.height(); ++y)
    for (int x = 0; x < photo.width(); ++x) {
      if (mask.at(x, y, 0) > 0) continue;
      for (int c = 0; c < 3; ++c) {
        if (!(clipped.at(x, y, c) > 0)) continue;
        const float p = photo.at(x, y, c);
        float& v = composite->at(x, y, c);
        if (v == p) continue;
        if (std::abs(v - p) < hidden * std::abs(p)) {
          v = p;
          ++n.kept;
        } else {
          ++n.changed;
        }
      }
    }
  return n;
}

}  // namespace mr
