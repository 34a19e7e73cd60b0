// Camera models: mrcal's lens models through libmrcal.
//
// Pixel convention (docs/conventions.md): mrcal's.  (0, 0) is the centre of
// the top-left pixel; x right, y down.  Camera frame: x right, y down, z
// forward.  Conversions to COLMAP's convention (top-left pixel centre at
// (0.5, 0.5)) happen in the COLMAP reader and writer only.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "camera/pose.h"
#include "core/file.h"

namespace mr {

class CameraModel {
 public:
  CameraModel();
  // `lensmodel` is an mrcal name with its configuration, e.g. "LENSMODEL_OPENCV8"
  // or "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=200".
  // Throws mr::Error when the name is unknown or the intrinsics count is wrong.
  CameraModel(const std::string& lensmodel, std::vector<double> intrinsics, int width, int height,
              const Rigid3& cam_from_ref = Rigid3());

  static CameraModel Read(const fs::path& path);
  // `name` is used in error messages.
  static CameraModel FromString(const std::string& text, const std::string& name);
  // Atomic write in mrcal's .cameramodel format; `note` becomes '#' comment
  // lines (provenance).  Doubles are written with 17 significant digits.
  void Write(const fs::path& path, const std::string& note = "") const;
  std::string ToString(const std::string& note = "") const;

  const std::string& lensmodel() const { return lensmodel_; }
  const std::vector<double>& intrinsics() const { return intrinsics_; }
  int width() const { return width_; }
  int height() const { return height_; }
  // Extrinsics: the camera from the reference (rig or world) frame.
  const Rigid3& cam_from_ref() const { return cam_from_ref_; }
  void set_cam_from_ref(const Rigid3& r) { cam_from_ref_ = r; }
  // mrcal's optimisation inputs (a base-85 .npz, as mrcal writes them; see
  // calib/calibrate.h) and this camera's index among their intrinsics:
  // written with the model so that mrcal's tools can recompute residuals and
  // uncertainties.  Not read back (libmrcal ignores them too).
  void set_optimization_inputs(std::string base85_npz, int icam_intrinsics) {
    optimization_inputs_ = std::move(base85_npz);
    icam_intrinsics_ = icam_intrinsics;
  }
  bool has_optimization_inputs() const { return !optimization_inputs_.empty(); }

  // Whether the model can see points behind the camera plane (z <= 0):
  // the stereographic and lon/lat families.
  bool SeesBehind() const;

  // Projects a point in the camera frame to a pixel.  Returns false for
  // points the model cannot image (behind a pinhole-like camera, the exact
  // backward direction of a stereographic one) or non-finite results.
  bool Project(const Eigen::Vector3d& p_in_cam, Eigen::Vector2d* q) const;
  // Batch version; `ok` may be null.
  void Project(const std::vector<Eigen::Vector3d>& p, std::vector<Eigen::Vector2d>* q, std::vector<char>* ok) const;
  // Unit direction in the camera frame that images at pixel q.  Returns false
  // where the solve fails (outside the model's valid domain).
  bool Unproject(const Eigen::Vector2d& q, Eigen::Vector3d* dir) const;
  // The same from a nearby direction `near` (the ray of a neighbouring
  // pixel or supersample, as renderers sweep the image): Newton steps on the
  // projection and its gradient, with no solver set up per point (libmrcal's
  // unprojection of OPENCV and splined lenses is an iterative solve per
  // point, most of the cost of a synthetic view).  Converges to 1e-8 px of q;
  // where it does not within a few steps it is Unproject.
  bool UnprojectNear(const Eigen::Vector2d& q, const Eigen::Vector3d& near, Eigen::Vector3d* dir) const;

  // Angle (degrees) between the rays through the left and right (top and
  // bottom) edge midpoints, through the optical centre when it is in view.
  double HorizontalFovDeg() const;
  double VerticalFovDeg() const;

  // A short summary: "LENSMODEL_OPENCV8 640x480, fov 90.1 x 73.7 deg".
  std::string Describe() const;

  // The pinhole core fx, fy, cx, cy (the first 4 intrinsics of every mrcal
  // model except CAHVOR(E), where they are also fx fy cx cy).
  Eigen::Vector4d Core() const;

 private:
  struct Impl;
  std::shared_ptr<const Impl> impl_;
  std::string lensmodel_;
  std::vector<double> intrinsics_;
  int width_ = 0, height_ = 0;
  Rigid3 cam_from_ref_;
  std::string optimization_inputs_;
  int icam_intrinsics_ = -1;
};

// All lens-model names libmrcal knows (unconfigured, with "..." for config).
std::vector<std::string> SupportedLensModels();

// COLMAP pixel centres are at +0.5 from mrcal's.
inline Eigen::Vector2d PixelFromColmap(const Eigen::Vector2d& q) { return q.array() - 0.5; }
inline Eigen::Vector2d PixelToColmap(const Eigen::Vector2d& q) { return q.array() + 0.5; }

}  // namespace mr
