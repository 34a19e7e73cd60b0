// mr-calibrate's work: a camera, a rig or a mirror sphere calibrated from
// photographs, the results written (.cameramodel files, probe.json) and
// described in the report (fit, views, projection uncertainty, extrinsics).
#pragma once

#include <string>
#include <vector>

#include "calib/calibrate.h"
#include "calib/sphere.h"
#include "core/report.h"

namespace mr {

// mr-calibrate camera: one camera's intrinsics.
struct CameraJob {
  std::string board;                // calib/boards/*.json
  std::vector<std::string> images;  // photographs of the board, all of one size
  std::string out;                  // the .cameramodel to write
  CalibrationOptions options;
  std::string provenance;  // the command line, into the model's comment
  // UsageError naming the flag: no photographs, no --out, and
  // CalibrationOptions::Check's.
  void Check() const;
};
void RunCameraCalibration(const CameraJob& job, Report* report);

// mr-calibrate rig: two or more cameras photographing the board at the same
// instants.  `cameras`: NAME=DIR/PREFIX*SUFFIX each, the first the
// reference; photographs pair across cameras by what the '*' matches, in
// natural order (numbers by value).  Every model is written only once all
// are solved.
struct RigJob {
  std::string board;
  std::vector<std::string> cameras;
  std::string out_dir;  // NAME.cameramodel for each camera
  CalibrationOptions options;
  std::string provenance;
  // UsageError naming the flag: fewer than two --camera, one not
  // NAME=PATTERN or a name given twice, and CalibrationOptions::Check's.
  void Check() const;
};
void RunRigCalibration(const RigJob& job, Report* report);

// mr-calibrate sphere: the mirror sphere's centre from photographs by a
// calibrated camera, in the world of the camera's rig or of a board lying
// flat (`world_board`, with `board`); writes probe.json.
struct SphereJob {
  std::string camera;  // .cameramodel
  SphereOptions options;
  std::vector<double> circle;  // x, y, r px: a first circle instead of the Hough transform (empty: none)
  std::string world_board, board;
  std::vector<std::string> images;
  std::string out;  // probe.json
  std::string provenance;
  // UsageError naming the flag: --world-board without --board, --circle not
  // x,y,r, no photographs, and SphereOptions::Check's.
  void Check() const;
};
void RunSphereCalibration(const SphereJob& job, Report* report);

}  // namespace mr
