// mr-formfactor's work: a virtual object's per-vertex form-factor transfer
// written as OBJECT.ffc (vertices no camera sample sees skipped with a
// scene), or the mesh shaded with a transfer under an environment map and
// written as a PLY, with the error against a path-traced reference.
#pragma once

#include <string>
#include <vector>

#include "core/report.h"
#include "transfer/formfactor.h"

namespace mr {

struct FormfactorJobOptions {
  std::string mesh, out;
  std::string basis = "cube";  // cube | sh
  TransferOptions transfer;    // --resolution, --order, --supersample, --bounces, --albedo
  // Read an OBJ with its MTL materials, its vertices as mr-render reads it
  // with "material": "mtl" (split where a corner's uv or normal differs), so
  // that the .ffc matches that render's mesh.
  bool mtl = false;
  std::string scene, object;  // skip the vertices this scene's camera cannot see of this object
  int spp = 0;                // with a scene: the renders' samples per pixel (0: the scene's)
  // Shading instead: the transfer (--ffc), the map (--shade), its rotation
  // about +y, the albedo (or the mesh's vertex colours), SH windowing, and
  // the reference's rays per vertex (0: none).
  std::string ffc, shade;
  std::vector<double> color = {0.8, 0.8, 0.8};
  double env_rotation_deg = 0;
  bool vertex_albedo = false, no_window = false;
  int reference_rays = 0;
  std::string command_line;

  bool shading() const { return !shade.empty(); }
  // UsageError naming the flag at fault: --basis, --shade without --ffc,
  // --scene without --object, --color's size, negative counts, and
  // TransferOptions::Check's when computing a transfer.
  void Check() const;
};

// Runs the job; fills `report` (timings, the transfer's counters and
// warnings, or the shading's clamping and reference error).
void RunFormfactor(const FormfactorJobOptions& options, Report* report);

}  // namespace mr
