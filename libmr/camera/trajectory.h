// Camera trajectories: TUM text files and 7-Scenes per-frame pose files.
//
// TUM RGB-D: one pose per line, "timestamp tx ty tz qx qy qz qw", the
// camera-to-world transform (world_from_cam); '#' starts a comment.
// 7-Scenes: one file per frame holding the 4x4 camera-to-world matrix.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "camera/pose.h"
#include "core/file.h"

namespace mr {

struct TimedPose {
  double timestamp = 0;  // seconds (7-Scenes: the frame index)
  Rigid3 world_from_cam;
};

struct Trajectory {
  std::vector<TimedPose> poses;
  // Largest rotation-block deviation from orthonormal seen while reading
  // (7-Scenes poses are slightly off); 0 for TUM.
  double max_orthonormality_error = 0;

  size_t size() const { return poses.size(); }
  double Duration() const;
  double PathLength() const;  // metres, sum of camera-centre steps
};

// TUM.  `name` names the stream in error messages ("FILE:LINE: ...").
Trajectory ReadTum(std::istream& in, const std::string& name);
Trajectory ReadTum(const fs::path& path);
void WriteTum(std::ostream& out, const Trajectory& t);
void WriteTum(const fs::path& path, const Trajectory& t);

// 7-Scenes: one 4x4 matrix (camera-to-world).  The last row must be 0 0 0 1.
Rigid3 Read7ScenesPose(std::istream& in, const std::string& name, double* orthonormality_error = nullptr);
Rigid3 Read7ScenesPose(const fs::path& path, double* orthonormality_error = nullptr);
void Write7ScenesPose(const fs::path& path, const Rigid3& world_from_cam);
// All frame-NNNNNN.pose.txt files of a folder, in frame order; timestamp = NNNNNN.
Trajectory Read7ScenesFolder(const fs::path& dir);

// The TUM association of two timestamp lists: index pairs (a, b), greedy by
// smallest |ta - tb| <= max_dt, each index used once, sorted by a.  Each ta
// is offered its 8 nearest tb within max_dt (TUM's associate.py offers all
// of them): the same pairs wherever fewer than 8 lie that close, as in any
// recording, and O(n log n) where a list repeats one timestamp thousands of
// times (all of them: n^2 candidates, a hang found by fuzz_rgbdlist).
std::vector<std::pair<int, int>> AssociateTimestamps(const std::vector<double>& a, const std::vector<double>& b,
                                                     double max_dt);

// Guesses the kind of pose file: "tum", "7scenes" (a 4x4 matrix), or "" when neither.
std::string DetectPoseFormat(const fs::path& path);

}  // namespace mr
