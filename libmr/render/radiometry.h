// The plate's radiometry: the per-channel gain g that takes the rendered
// real room I_r (the room's albedo under the captured light, in the render's
// units) to the plate's linear values P (P = g I_r, per channel), fitted
// per frame over the pixels where the room is reconstructed, with its
// uncertainty; smoothed over time with exposure jumps kept; and the gains
// file (docs/formats.md, "plate gains") that mr-render reads through
// scene.json's camera.gains.  Derivation and measured figures:
// docs/radiometry.md.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/file.h"
#include "core/image.h"

namespace mr {

using Rgb = std::array<double, 3>;

struct GainFitOptions {
  int tiles = 8;  // tiles per image side: the jackknife's blocks
  // Plates with code values: pixels with a channel's code outside
  // [code_low, code_high] are left out (clipped highlights, the noise and
  // quantisation floor).
  double code_low = 4.0 / 255, code_high = 250.0 / 255;
  // Usable pixels are summed in cells of 8 x 8; cells whose log luminance
  // ratio log(P / I_r) is further than this many robust standard deviations
  // (1.4826 MAD over the cells) from the median are left out (misregistered
  // edges, things the room model lacks); the threshold is at least 0.05.
  double outlier_sigmas = 4;
  int min_pixels = 64;  // fewer usable pixels: no fit
};

struct GainFit {
  bool ok = false;
  Rgb gain{1, 1, 1};   // sum of P over sum of I_r over the pixels used, per channel
  Rgb sigma{0, 0, 0};  // standard error: delete-one-tile jackknife (spatially correlated errors included)
  int64_t pixels = 0;  // used
  int64_t room_pixels = 0, clipped = 0, nonfinite = 0, outliers = 0;  // of the room's pixels, left out
  int tiles = 0;                                                      // tiles with pixels used
  std::string why;                                                    // when !ok: why there is no fit
};

// P: the plate's linear values (RGB); rendered: I_r (RGB, same size);
// room: one channel, > 0 where the pixel shows the reconstructed room;
// codes: null (float plates) or the plate's code values in [0, 1].
// Non-finite values in P, I_r or the codes leave their pixel out (counted).
GainFit FitPlateGain(const Image& plate, const Image& rendered, const Image& room, const Image* codes,
                     const GainFitOptions& options = {});

struct GainSmoothing {
  // Gaussian time constant in frames (0: the per-frame fits as they are).
  double time_constant = 3;
  // An exposure jump between neighbouring fitted frames: their luminance
  // gains differ by more than this ratio and by more than 4 combined
  // standard errors.  Smoothing never crosses a jump.
  double jump_ratio = 1.15;
};

struct FrameGain {
  int frame = 0;
  Rgb gain{1, 1, 1}, sigma{0, 0, 0};  // smoothed (or interpolated)
  Rgb fit{1, 1, 1}, fit_sigma{0, 0, 0};
  bool fitted = false;       // this frame had its own fit
  bool jump_before = false;  // an exposure jump between the previous fitted frame and this one
  int64_t pixels = 0;
};

// One entry per element of `fits` (frames[i] is fits[i]'s frame, ascending).
// Frames without a fit take the gain of the fitted frames around them (in
// their segment between jumps, the nearer side's where a jump lies between).
// Throws mr::Error when no frame has a fit.
std::vector<FrameGain> SmoothGains(const std::vector<int>& frames, const std::vector<GainFit>& fits,
                                   const GainSmoothing& smoothing);

// The gains file: {"version": 1, "kind": "mr-plate-gains", "frames": [{"frame",
// "gain", "sigma", "fit", "fit_sigma", "fitted", "jump_before", "pixels"}]}.
void WritePlateGains(const fs::path& path, const std::vector<FrameGain>& gains, const std::string& note);
// Reads and checks it (gains finite and > 0, frames ascending and unique);
// errors name the file and the key.
std::vector<FrameGain> ReadPlateGains(const fs::path& path);

}  // namespace mr
