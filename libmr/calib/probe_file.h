// probe.json (docs/formats.md): a mirror sphere's place in its camera's
// frame, with covariance, and the camera's place in the world.  Written by
// mr-calibrate sphere, read by mr-probe.
#pragma once

#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "camera/camera_model.h"
#include "core/file.h"
#include "core/json.h"

namespace mr {

// probe.json (docs/formats.md) with its camera model loaded.
struct ProbeGeometry {
  fs::path path;
  CameraModel camera;
  double radius_m = 0;
  Eigen::Vector3d centre_cam = Eigen::Vector3d::Zero();
  Eigen::Matrix3d world_from_cam = Eigen::Matrix3d::Identity();
};
ProbeGeometry ReadProbe(const fs::path& path);

// Everything probe.json holds.
struct ProbeFile {
  fs::path camera;  // the camera model; written relative to probe.json's folder
  double radius_m = 0;
  Eigen::Vector3d centre_cam = Eigen::Vector3d::Zero();
  Eigen::Matrix3d centre_covariance = Eigen::Matrix3d::Zero();  // m^2
  Eigen::Quaterniond world_from_cam = Eigen::Quaterniond::Identity();
  Eigen::Vector3d camera_in_world = Eigen::Vector3d::Zero();
  std::string world_source;          // what the world frame is
  Json photographs = Json::array();  // per photograph's fit
  double consistency_chi2 = 0;
  std::string provenance;
};

// Writes probe.json atomically.
void WriteProbeFile(const fs::path& path, const ProbeFile& probe);

}  // namespace mr
