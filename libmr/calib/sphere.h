// A mirror sphere located from its silhouette under a calibrated lens: its
// centre with covariance, from a cone fitted to the silhouette's rays.
// The steps of the fit: docs/methods.md, "Locating the mirror sphere".
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "camera/camera_model.h"
#include "core/image.h"

namespace mr {

struct SphereOptions {
  double radius_m = 0;                    // the sphere's radius, metres
  std::optional<Eigen::Vector3d> circle;  // a first circle (x, y, r px) instead of the Hough transform
  double min_visible = 0.5;               // of the silhouette, inside the image
  int samples = 360;                      // edge points searched around the silhouette

  // UsageError naming the flag: --radius not positive, --min-visible
  // outside [0, 1], no edge samples.
  void Check() const;
};

struct SphereFit {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();      // camera frame, metres
  double radius_m = 0;                                   // as given
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // of the centre, m^2
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();       // the cone's, unit
  double half_angle = 0;                                 // radians
  double sigma_half_angle = 0;                           // radians, 1 sigma
  double rms_rad = 0;                                    // angular residual of the inliers
  double rms_px = 0;                                     // the same, in pixels at the silhouette
  int edge_points = 0, inliers = 0;
  double correlation = 1;       // how many neighbouring edge points err as one (the variance's inflation)
  double visible_fraction = 0;  // of the fitted silhouette
  Eigen::Vector3d first_circle = Eigen::Vector3d::Zero();  // x, y, r px
  std::vector<Eigen::Vector2d> edges;                      // the inlier edge points, px
  int polarity = 1;           // +1: the sphere darker than its surroundings at the rim (a mirror), -1 brighter
  std::string silhouette;     // where the first circle came from and the polarity, in words
  double mask_mismatch = -1;  // a mask: the share of its region > 2 px from the fitted outline; -1: no mask
};

// `photo`: a photograph of the sphere, or a mask of its silhouette (nearly
// every pixel at one of two levels, either polarity; the sphere is the
// class less present on the image's border).  The rim is searched darker
// inside (a mirror) first, brighter inside where that finds none; a mask
// says its polarity.  `name` names the photograph in messages.  Throws
// mr::Error with the reason when no sphere is found, too little of it is
// visible, or a mask's region is not a sphere's silhouette.
SphereFit FitMirrorSphere(const Image& photo, const CameraModel& camera, const SphereOptions& options,
                          const std::string& name);

// Several photographs of the same sphere (camera and sphere fixed):
// inverse-covariance weighted mean of their centres.  `chi2` (optional):
// the spread of the fits against their covariances (about 3 per
// photograph beyond the first when they agree).
SphereFit CombineSphereFits(const std::vector<SphereFit>& fits, double* chi2 = nullptr);

}  // namespace mr
