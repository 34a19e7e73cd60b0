// mr-hdr's work: a bracket of photographs merged into linear radiance with
// its variance (docs/formats.md), the camera response recovered, read or
// taken as linear, and what the merge censored or left out in the report.
#pragma once

#include <string>
#include <vector>

#include "core/report.h"
#include "hdr/exposure_merge.h"
#include "hdr/response.h"

namespace mr {

struct HdrJobOptions {
  std::vector<std::string> images;  // the bracket, any order
  std::string exposures;            // exposure times (empty: EXIF)
  std::string out;                  // the merged EXR
  std::string response_in;          // a response.json to use (empty: recovered, or linear)
  std::string response_out;         // where to keep the recovered response (empty: not kept)
  bool align = false;               // hand-held brackets
  bool linear = false;              // 8/16-bit inputs are linear
  bool half = false;                // half floats (refused when a value exceeds 65504)
  ExposureMergeOptions merge;
  ResponseOptions response;
  std::string command_line;  // written into the EXR and response.json

  // UsageError naming the flags at fault (and the merge's and response's
  // own checks).
  void Check() const;
};

// Runs the job; fills `report`.  Nothing is written before the merge has
// succeeded.  Throws mr::Error naming the photograph or file at fault.
void RunHdrMerge(const HdrJobOptions& options, Report* report);

}  // namespace mr
