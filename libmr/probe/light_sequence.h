// Light captured over time: the maps a light camera (or the mirror sphere
// in the plate) gives frame by frame, matched to the plate's frames by
// timestamp, brought to one exposure, filtered in time with a stated time
// constant, abrupt changes let through unfiltered, and the directions a
// frame does not see filled from earlier frames.  The rules and their
// figures: docs/methods.md, "Light over time".
#pragma once

#include <string>
#include <vector>

#include "core/image.h"

namespace mr {

// For each plate time, the light frame nearest to it within max_dt (s), or
// -1 where none is that near (a dropped light frame: the caller reuses the
// last map).  Several plate frames may take one light frame (a duplicated
// or slower light video).  Both lists ascending.  Throws mr::Error, naming
// both sources and their time ranges, when no plate frame has a light frame
// (the two do not overlap in time).
struct TimeMatch {
  std::vector<int> light_of_plate;
  int unmatched = 0;       // plate frames with no light frame within max_dt
  double max_dt_seen = 0;  // the largest |t_plate - t_light| among matched frames
};
TimeMatch MatchLightToPlate(const std::vector<double>& light_times, const std::vector<double>& plate_times,
                            double max_dt, const std::string& light_name, const std::string& plate_name);

struct LightFilterOptions {
  // Exponential smoothing: a map at time t moves a fraction
  // 1 - exp(-dt / time_constant_s) of the way to the new frame.  0: none.
  double time_constant_s = 0.1;
  // A direction jumps (takes the new frame unfiltered) where its luminance
  // differs from the filtered one by more than this factor either way, by
  // more than `jump_floor` times the map's median luminance, and at least 2 of
  // its 8 neighbours do too (one hot pixel is noise, not a lamp).
  double jump_ratio = 1.5;
  double jump_floor = 0.05;
  // A frame whose jumping directions hold more than this fraction of the
  // map's luminance energy is reported as an abrupt change.
  double jump_report_fraction = 0.01;
  // Recover each frame's exposure relative to the first (auto-exposure):
  // the median ratio of its luminance to the filtered map's over directions
  // seen in both, neither dark nor jumping.  A change of the whole light (a
  // cloud over the sun) is indistinguishable from an exposure change and is
  // taken as one: read exposures where the camera records them.
  bool recover_exposure = false;
  // A direction seen now with less than this fraction of the confidence it
  // had is taken from history (a better earlier view beats a grazing one).
  double confidence_keep = 0.25;
  void Check() const;
};

struct LightFrameReport {
  double exposure = 1;         // the factor the frame was divided by (relative to the first frame)
  double alpha = 1;            // the filter's step this frame (1: no filtering)
  double seen_fraction = 0;    // of the sphere's solid angle, seen by this frame
  double filled_fraction = 0;  // not seen now, taken from an earlier frame
  double jump_fraction = 0;    // of the map's luminance energy in jumping directions
  bool jump = false;           // jump_fraction > jump_report_fraction
};

// Feeds unwrapped maps (R G B confidence, probe/unwrap.h) in time order.
class LightFilter {
 public:
  explicit LightFilter(const LightFilterOptions& options);
  // `map` taken at time `t` (s) and divided by `exposure` (read; with
  // recover_exposure the recovered one multiplies it).  Returns the filtered
  // map (R G B confidence): confidence is the frame's where it was seen,
  // the history's where it was filled, 0 where no frame yet saw it.
  Image Add(const Image& map, double t, double exposure, LightFrameReport* report);
  bool started() const { return started_; }
  // Continues from a map this filter returned at time `t` (an earlier run's
  // output: the output is the whole state).
  void Restore(const Image& state, double t);

 private:
  LightFilterOptions o_;
  Image state_;
  double t_ = 0;
  bool started_ = false;
};

}  // namespace mr

namespace mr {

// A captured map against the true one, by what it lights: the diffuse
// irradiance (luminance) at 256 normals spread over the sphere, from each
// map, the reference taken only over the directions the estimate saw
// (confidence > 0; a 3-channel estimate saw everything).  What the capture
// does not see is reported apart, as the share of the reference's energy.
struct LightMapError {
  double irradiance_rel_rms = 0;      // RMS(E_est - E_ref) / RMS(E_ref)
  double energy_ratio = 0;            // the estimate's energy over the (seen) reference's
  double unseen_energy_fraction = 0;  // of the reference's energy where the estimate saw nothing
  std::vector<double> e_est, e_ref;   // the irradiances, for LightFlicker
};
LightMapError CompareLightMaps(const Image& estimate, const Image& reference);

// The error of the frame-to-frame change: RMS over the normals of
// (E_est(b) - E_est(a)) - (E_ref(b) - E_ref(a)), over RMS(E_ref(b)).
double LightFlicker(const LightMapError& a, const LightMapError& b);

}  // namespace mr
