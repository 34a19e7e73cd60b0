// Colour spaces through OpenColorIO (2.1): a transform between two colour
// spaces of a config, applied to RGB images.  mr's own config (ocio/mr.ocio,
// compiled in) names plates' camera log encodings and ACES spaces by
// OpenColorIO's built-in transforms, under the ACES CG config's names.
// docs/formats.md, "Plates through OpenColorIO".
#pragma once

#include <memory>
#include <string>

#include "core/image.h"

namespace mr {

// The text of ocio/mr.ocio.
const std::string& MrOcioConfig();

class ColorTransform {
 public:
  // From colour space `from` to `to` of the config at `config_path` (empty:
  // mr's own).  Throws mr::Error naming `key` (the scene key that chose the
  // space, e.g. "camera.frames_colorspace") and the config: an unreadable or
  // invalid config, a space it does not name (listing those it does), or a
  // transform OpenColorIO cannot build in this direction (one whose inverse
  // is not defined).
  ColorTransform(const std::string& config_path, const std::string& from, const std::string& to,
                 const std::string& key);
  ~ColorTransform();
  ColorTransform(const ColorTransform&) = delete;
  ColorTransform& operator=(const ColorTransform&) = delete;
  // In place, on an image's first three channels (float32, as OpenColorIO's
  // CPU processor computes them).
  void Apply(Image* img) const;
  void ApplyRgb(float rgb[3]) const;
  const std::string& from() const { return from_; }
  const std::string& to() const { return to_; }
  // "mr.ocio" or the config's path, for messages and reports.
  const std::string& config_name() const { return config_name_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string from_, to_, config_name_;
};

}  // namespace mr
