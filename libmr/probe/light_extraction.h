// Light sources extracted from a lat-long environment map (median cut,
// variance cut, hierarchical importance, blobs), and the residual they leave
// out: lights + residual integrate to the map exactly.  Each method:
// docs/methods.md, "Light extraction".
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "light/lights_file.h"

namespace mr {

struct ExtractOptions {
  std::string method = "median-cut";  // median-cut, variance-cut, importance, blobs
  int count = 16;
  double threshold = 8;       // blobs: times the map's mean radiance
  double saddle = 0.5;        // blobs: two peaks stay two lights where the light between falls below this of the dimmer
  double max_blob_sr = 0.05;  // blobs: a region whose core is wider stays in the map with its shape (7.2 degrees)
  bool keep_wide = false;     // blobs: wide regions become lights too (to be placed in the room: mr-lights --room)
  int sh_order = 3;           // the residual's spherical harmonics
  uint32_t seed = 0;          // importance: the point set's scramble
  void Check() const;
};

struct ExtractedLight {
  Eigen::Vector3d direction = Eigen::Vector3d::UnitY();  // towards the light, world
  Eigen::Vector3d power = Eigen::Vector3d::Zero();  // integral of L dOmega, RGB: irradiance at normal incidence (W/m^2)
  double solid_angle = 0;                           // sr of the pixels it took
  bool area = false;                                // a disc (blobs) or a delta
  double disc_solid_angle = 0;                      // the disc's (blobs: from its core, not its glow); 0: solid_angle
  double DiscSolidAngle() const { return disc_solid_angle > 0 ? disc_solid_angle : solid_angle; }
  double clipped_share = 0;    // of its energy from the map's clipped pixels (clipped.Y > 0): a lower bound
  std::vector<size_t> pixels;  // blobs: the map pixels (y * width + x) it took
};

struct Extraction {
  std::vector<ExtractedLight> lights;
  Image residual;                            // the map minus what the lights took (R G B), same size
  std::vector<Eigen::Vector3d> residual_sh;  // its SH projection, sh_order^2 RGB coefficients
  double taken_fraction = 0;                 // of the map's luminance energy
  int regions = 0;                           // blobs: the bright regions found (lights: at most `count` of them)
  int split_components = 0;                  // blobs: connected bright regions that became several lights
  int wide_regions = 0;                      // blobs: regions left in the map, wider than max_blob_sr
  double seconds = 0;
};

// `env`: R G B first, finite and non-negative; a clipped.Y layer (mr-probe's)
// marks each light's clipped share; other layers are ignored.
Extraction ExtractLights(const Image& env, const ExtractOptions& options);

// Blobs' lights marked in `drop` (one flag a light) go back into the
// residual map (its SH and taken_fraction recomputed from `env`, the map
// they came from): a window or the sky that could not be placed in the
// room keeps its shape there.
void ReturnToResidual(const Image& env, const std::vector<bool>& drop, int sh_order, Extraction* ex);

// The residual replaced by `map` (R G B, finite and non-negative): the map
// at infinity that goes with the room's own light (jobs/light_positions.h,
// SkyOnly).  Its SH are recomputed; taken_fraction (the lights' share of
// the map they came from) is kept.
void ReplaceResidual(const Image& map, int sh_order, Extraction* ex);

// lights.json entries (distant lights, real): `name_prefix` + index, or
// + ids[index] when `ids` is given (one per light).
std::vector<Light> ToLights(const Extraction& e, const std::string& name_prefix = "light",
                            const std::vector<int>* ids = nullptr);

// A light keeps its identity across frames: each light of `current` takes
// the id of a light of `previous` less than max_angle_deg away, pairs taken
// nearest first, each id once; the rest take fresh ids from *next_id.
// Returns the ids, one per light of `current`; *matched counts the kept ones.
std::vector<int> MatchLights(const std::vector<ExtractedLight>& previous, const std::vector<int>& previous_ids,
                             const std::vector<ExtractedLight>& current, double max_angle_deg, int* next_id,
                             int* matched = nullptr);

// Diffuse irradiance (luminance) at `normals`: exact from the map, and from
// the lights (deltas at their directions; area lights as uniform discs of
// their solid angle, as mr-render sees them) plus, when
// `with_residual`, the residual's SH (Ramamoorthi-Hanrahan cosine lobe).
std::vector<double> MapIrradiance(const Image& env, const std::vector<Eigen::Vector3d>& normals);
std::vector<double> LightsIrradiance(const Extraction& e, const std::vector<Eigen::Vector3d>& normals,
                                     bool with_residual);
// Normals spread evenly over the sphere (a Fibonacci lattice).
std::vector<Eigen::Vector3d> SphereNormals(int n);

struct IrradianceError {
  double rms_relative = 0;  // RMS of (E - E_ref) over RMS of E_ref
  double max_relative = 0;  // max |E - E_ref| over max E_ref
};
IrradianceError CompareIrradiance(const std::vector<double>& e, const std::vector<double>& ref);

// A lat-long map's luminance energy (integral of luminance dOmega).
double MapEnergy(const Image& env);

// Area-weighted downsampling (keeps every region's energy): a map of
// `width` x width/2.
Image DownsampleEnergy(const Image& env, int width);

}  // namespace mr
