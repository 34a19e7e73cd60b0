// A camera's response: how stored code values relate to exposure.
//
// For each channel, a table of g(z) = ln(X) over `levels` equally spaced
// normalised codes z in [0, 1] (code / max code), where X = E * t is the
// exposure (radiance times exposure time) in units of the exposure that
// saturates the channel: g(1) = 0.  So merged radiance is "saturation
// exposures per second", the same for every bracket of one camera.  Codes between table entries are
// interpolated linearly in z.  Recovered from bracketed photographs by
// Debevec-Malik (1997: least squares with a smoothness term, over pixels
// chosen across the code range) or Robertson et al. (2003: alternating
// maximum likelihood over many pixels); both solved here in double
// precision with Eigen, for 8-bit and 16-bit inputs alike (16-bit codes are
// binned to the table's levels).
//
// Saved as response.json ("format": "mr-response", docs/formats.md), read
// back by mr-hdr --response and by mr-render to linearise video frames.
#pragma once

#include <string>
#include <vector>

#include "core/file.h"
#include "core/image.h"
#include "core/json.h"

namespace mr {

struct CameraResponse {
  std::string method = "linear";                  // linear, debevec, robertson, file
  std::vector<std::string> channels;              // R G B
  std::vector<std::vector<double>> log_exposure;  // [channel][level]: g(z)
  bool identity = false;                          // X = z exactly (linear inputs; the table is then only for files)

  int levels() const { return log_exposure.empty() ? 0 : static_cast<int>(log_exposure[0].size()); }
  // X = exp(g(z)) for normalised code z in [0, 1] (clamped).
  double Exposure(int channel, double z) const;
  // dX/dz at z: how much exposure one unit of normalised code spans.
  double ExposureSlope(int channel, double z) const;
  // The inverse of Exposure: the normalised code z in [0, 1] whose exposure
  // is X (0 below the table's first entry, 1 above its last).  Exact to
  // rounding where g is strictly increasing, so Code(c, Exposure(c, z)) = z;
  // on a flat run of g (codes the camera cannot tell apart) the lowest z.
  double Code(int channel, double exposure) const;
};

// X = z: what linear (float, or linear-encoded 16-bit) inputs have.
CameraResponse LinearResponse(int channels, int levels = 256);
// X = the sRGB decoding of z: a photograph stored as sRGB, taken as it says
// (a phone's, without a measured response).
CameraResponse SrgbResponse(int channels, int levels = 256);

// One photograph of a bracket: normalised codes in [0, 1] (or linear
// values for float inputs), its exposure time, and which pixels it saw
// (after alignment some lie outside it).
struct Exposure {
  std::string name;
  Image codes;                 // R G B, row 0 at the top
  double time_s = 0;           // exposure time (or relative exposure)
  std::string pixel_type;      // uint8, uint16, half, float
  std::vector<uint8_t> valid;  // per pixel; empty = all valid
  bool Valid(int64_t pixel) const { return valid.empty() || valid[static_cast<size_t>(pixel)] != 0; }
};

struct ResponseOptions {
  std::string method = "debevec";  // debevec or robertson
  int levels = 256;
  double smoothness = 50;  // Debevec's lambda, per unit weight (codes in levels)
  int samples = 400;       // Debevec: pixels chosen across the code range
  int iterations = 10;     // Robertson, from the Debevec solution
  void Check() const;
};

struct ResponseReport {
  int samples = 0;             // pixels used
  double rms_log = 0;          // RMS of the fit's residual in ln X (Debevec) over weighted samples
  int monotonicity_fixes = 0;  // table entries raised to keep g increasing
  int iterations = 0;
};

// Exposures sorted by time, at least two with distinct times.  Throws
// mr::Error when the bracket cannot determine a response.
CameraResponse RecoverResponse(const std::vector<Exposure>& bracket, const ResponseOptions& options,
                               ResponseReport* report = nullptr);

Json ResponseToJson(const CameraResponse& r);
CameraResponse ParseResponse(const Json& j, const std::string& name);
void WriteResponse(const fs::path& path, const CameraResponse& r, const std::string& provenance = "");
CameraResponse ReadResponse(const fs::path& path);

// Linear relative exposure of a whole photograph through `r` (R G B).
Image Linearise(const Image& codes, const CameraResponse& r);
// Its inverse: exposures X to normalised codes, channel by channel (Code).
Image Delinearise(const Image& exposures, const CameraResponse& r);

}  // namespace mr
