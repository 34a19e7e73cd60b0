// COLMAP's text model: cameras.txt, images.txt, points3D.txt
// (https://colmap.github.io/format.html).
//
// images.txt stores world-to-camera (cam_from_world) poses with the
// quaternion scalar first: "IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME".
// COLMAP puts the centre of the top-left pixel at (0.5, 0.5); mr at (0, 0).
// The reader subtracts 0.5 from principal points and 2D observations and the
// writer adds it back, so everything in memory is in mr's convention.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/file.h"

namespace mr {

struct ColmapCamera {
  int64_t id = 0;
  std::string model;  // SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV, ...
  int width = 0, height = 0;
  std::vector<double> params;  // principal point already in mr's pixel convention
};

struct ColmapObservation {
  Eigen::Vector2d xy;  // mr's pixel convention
  int64_t point3d_id = -1;
};

struct ColmapImage {
  int64_t id = 0;
  Rigid3 cam_from_world;
  int64_t camera_id = 0;
  std::string name;
  std::vector<ColmapObservation> points2d;
};

struct ColmapTrackElement {
  int64_t image_id = 0;
  int64_t point2d_idx = 0;
};

struct ColmapPoint3D {
  int64_t id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  uint8_t rgb[3] = {0, 0, 0};
  double error = 0;
  std::vector<ColmapTrackElement> track;
};

struct ColmapModel {
  std::map<int64_t, ColmapCamera> cameras;
  std::map<int64_t, ColmapImage> images;
  std::map<int64_t, ColmapPoint3D> points3d;
};

// Reads cameras.txt, images.txt and points3D.txt from `dir` (points3D.txt may
// be absent).  Checks that images name known cameras and points.
ColmapModel ReadColmapText(const fs::path& dir);
// Writes the three files atomically, each with COLMAP's header comments.
void WriteColmapText(const fs::path& dir, const ColmapModel& model);

// Parsers on strings, for tests and fuzzing.  `name` appears in errors.
std::map<int64_t, ColmapCamera> ParseColmapCameras(const std::string& text, const std::string& name);
std::map<int64_t, ColmapImage> ParseColmapImages(const std::string& text, const std::string& name);
std::map<int64_t, ColmapPoint3D> ParseColmapPoints3D(const std::string& text, const std::string& name);
std::string FormatColmapCameras(const std::map<int64_t, ColmapCamera>& cameras);
std::string FormatColmapImages(const std::map<int64_t, ColmapImage>& images);
std::string FormatColmapPoints3D(const std::map<int64_t, ColmapPoint3D>& points);

// The mrcal equivalent of a COLMAP camera (pinhole, radial and OpenCV models).
// Throws mr::Error for models mrcal has no equivalent of.
CameraModel ToCameraModel(const ColmapCamera& cam);

}  // namespace mr
