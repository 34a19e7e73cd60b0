#include "render/composite.h"

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
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float m = mask.at(x, y, 0);
      for (int c = 0; c < 3; ++c) {
        const float d = mixed.at(x, y, c) - real.at(x, y, c);
        float v = m * object.at(x, y, c) + (1 - m) * (photo.at(x, y, c) + d);
        if (v < 0) {
          v = 0;
          ++r.clamped_negative;
        }
        r.composite.at(x, y, c) = v;
        r.difference.at(x, y, c) = d;
      }
    }
  return r;
}

}  // namespace mr
