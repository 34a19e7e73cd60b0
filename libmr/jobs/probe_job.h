// mr-probe's work: light-probe photographs (a mirror sphere, probe.json each
// or one for all, or fish-eye views) unwrapped into one world-aligned
// lat-long map, several views merged by confidence; or, over time, one map
// per plate frame (jobs/probe_sequence.h).
#pragma once

#include <string>
#include <vector>

#include "core/report.h"
#include "jobs/probe_sequence.h"

namespace mr {

struct ProbeJobOptions {
  std::vector<std::string> photos;  // HDR photographs (not with a sequence)
  std::vector<std::string> probes;  // probe.json per photograph, or one for all
  std::string fisheye;              // the photographs are fish-eye views through this model
  std::string out;                  // the map (a printf pattern over time)
  std::vector<double> rotate;       // X,Y,Z degrees (applied as Rz Ry Rx); empty: none
  // Over time: the sequence (sequence.light or sequence.scene set) and the
  // flags that fill its optional parts.
  ProbeSequenceOptions sequence;
  std::string plate_times, exposures, frames;  // --plate-times, --exposures, --frames A:B
  std::vector<double> sphere;                  // X,Y,Z,R (--sphere)
  std::string command_line;

  bool over_time() const { return !sequence.light.empty() || !sequence.scene.empty(); }
  // UsageError naming the flag at fault: --rotate and --sphere sizes,
  // photographs together with a sequence, --probe with a sequence, neither
  // --probe nor --fisheye (or both), probe and photograph counts, --frames,
  // and UnwrapOptions::Check's.
  void Check() const;
};

// Writes the map (or maps) atomically and fills `report` (per view: seen
// fraction, blind fraction, median confidence; the merged map's seen
// fraction). Throws mr::Error naming the file at fault.
void RunProbe(const ProbeJobOptions& options, Report* report);

}  // namespace mr
