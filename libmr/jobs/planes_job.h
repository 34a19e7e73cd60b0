// mr-planes' work: a room from a video without depth.  The planes that a
// point cloud supports (COLMAP's sparse points, mr-register --points-out)
// become the room's surfaces, turned to gravity, each vertex's albedo the
// median colour the frames saw there.  docs/methods.md, "A room from the
// video alone".
#pragma once

#include <string>
#include <vector>

#include "core/report.h"
#include "geometry/planes.h"

namespace mr {

struct PlanesJobOptions {
  std::string points;             // PLY point cloud
  std::string poses;              // TUM world_from_cam per frame (mr-register's)
  std::string camera;             // the frames' .cameramodel (with frames)
  std::string frames;             // printf pattern of the video's frames: the albedo (empty: grey)
  std::string transfer = "srgb";  // how 8/16-bit frames relate to radiance: srgb or linear
  int frame_stride = 1;           // albedo from every Nth frame
  double max_view_deg = 80;       // albedo: views more oblique than this are left out
  std::vector<double> up;         // a gravity hint (3 numbers); empty: the cameras' mean up
  // Metres from the cameras' mean centre down to the support plane (the
  // lowest level plane below them: the floor where one is seen): the points
  // and poses are scaled so
  // (a model in COLMAP's arbitrary units); 0: the points are in metres.
  double height = 0;
  // The frame of what is written: "points" (the points' and poses' own),
  // "first-camera" (the first pose's camera frame, as mr-fuse's room: x
  // right, y down, z forward; the report's up is in it) or "gravity" (that
  // frame turned so that up is +y, x level: scene.json's default up).
  std::string world = "points";
  std::string out;        // the room's mesh (PLY, albedo as vertex colours)
  std::string poses_out;  // the poses, scaled and moved (needed with height or world first-camera)
  PlaneOptions planes;
  PlaneMeshOptions mesh;

  // UsageError naming the flag at fault.
  void Check() const;
};

// Runs the job; fills `report` (planes, up, scale, albedo coverage).
// Throws mr::Error naming the file at fault, or "the points support no
// plane".
void RunPlanes(const PlanesJobOptions& options, Report* report);

}  // namespace mr
