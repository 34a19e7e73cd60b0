// mr-probe: unwraps light-probe photographs into a world-aligned lat-long map.
#include "cli/tool.h"
#include "jobs/probe_job.h"

int main(int argc, char** argv) {
  CLI::App app;
  mr::ProbeJobOptions o;
  mr::ProbeSequenceOptions& so = o.sequence;
  mr::UnwrapOptions& uo = o.sequence.unwrap;
  mr::ConfigureApp(
      app, "mr-probe",
      "Unwraps HDR photographs of a mirror sphere (from mr-hdr) into a world-aligned lat-long\n"
      "environment map (OpenEXR's LATLONG convention, docs/conventions.md), using the sphere's centre\n"
      "and the camera's orientation in probe.json (mr-calibrate sphere) and the camera's mrcal model.\n"
      "The reflection is solved exactly for a camera at a finite distance; resampling is filtered by the\n"
      "mapping's Jacobian; a confidence layer says how well each direction is seen. Several views (one\n"
      "probe.json each, or one for all) merge by confidence, which removes the camera's reflection.\n"
      "With --fisheye CAMERA, the photographs are fish-eye views of the room instead (oriented by the\n"
      "camera's extrinsics).\n"
      "Over time (--light or --sphere-in-plate), one map per plate frame (--out with a printf pattern):\n"
      "a light camera's frames (a \"TIMESTAMP PATH\" list, a printf pattern or a video) matched to the\n"
      "plate's timestamps, or the mirror sphere seen in the plate (its world centre and radius, the\n"
      "camera's pose per frame from the scene). Each frame's exposure is read (--exposures, or the file's\n"
      "metadata) or recovered (--auto-exposure); the light is filtered with --time-constant; abrupt\n"
      "changes (a lamp switched on, the sun) pass unfiltered; directions a frame does not see keep the\n"
      "earlier frames' light (docs/methods.md, \"Light over time\").",
      "  mr-probe probe-raw.exr --probe probe.json --reflectance 0.6 --out env.exr\n"
      "  mr-probe front.exr side.exr --probe front.json --probe side.json --out env.exr --width 1024\n"
      "  mr-probe sky.exr --fisheye light.cameramodel --rotate 0,90,0 --out env.exr\n"
      "  mr-probe --light lightcam/frames.txt --fisheye light.cameramodel --plate-times trajectory.txt \\\n"
      "           --time-constant 0.1 --out env/%05d.exr\n"
      "  mr-probe --sphere-in-plate scene.json --sphere 0.4,0.85,0.3,0.1 --reflectance 0.6 --out env/%05d.exr");
  app.add_option("photos", o.photos, "HDR photographs (R, G, B first)")->check(CLI::ExistingFile);
  app.add_option("--light", so.light,
                 "Over time: the light camera's frames: a list of TIMESTAMP PATH lines (.txt), a printf pattern "
                 "or a video");
  app.add_option("--sphere-in-plate", so.scene, "Over time: the scene whose plate shows the mirror sphere")
      ->check(CLI::ExistingFile);
  app.add_option("--sphere", o.sphere, "With --sphere-in-plate: the sphere's centre X,Y,Z (world, m) and radius R (m)")
      ->delimiter(',')
      ->expected(4);
  app.add_option("--plate-times", o.plate_times,
                 "With --light: the plate's TUM trajectory; each plate frame takes the light frame nearest in time")
      ->check(CLI::ExistingFile);
  app.add_option("--max-dt", so.max_dt, "Largest plate-to-light time difference (s)")
      ->default_val(0.02)
      ->check(mr::kNonNegative);
  app.add_option("--fps", so.fps, "Frame rate of a pattern of light frames (or of the plate, --sphere-in-plate)")
      ->default_val(30)
      ->check(mr::kPositive);
  app.add_option("--time-offset", so.time_offset, "Added to the light frames' times (s)")->default_val(0);
  app.add_option("--exposures", o.exposures, "The light frames' exposure times (FILENAME TIME lines)")
      ->check(CLI::ExistingFile);
  app.add_flag("--auto-exposure", so.filter.recover_exposure,
               "Recover each light frame's exposure from the frames themselves (a change of the whole light is "
               "taken for one)");
  app.add_option("--time-constant", so.filter.time_constant_s, "Temporal filter's time constant (s); 0: none")
      ->default_val(0.1)
      ->check(mr::kNonNegative);
  app.add_option("--jump-ratio", so.filter.jump_ratio,
                 "A direction whose light changes by more than this factor passes the filter unfiltered")
      ->default_val(1.5);
  app.add_option("--frames", o.frames, "Plate frames A:B (over time)");
  app.add_option("--probe", o.probes, "probe.json for each photograph, or one for all")->check(CLI::ExistingFile);
  app.add_option("--fisheye", o.fisheye, "The photographs are fish-eye views through this camera model")
      ->check(CLI::ExistingFile);
  app.add_option("--out", o.out, "Environment map (EXR: R G B confidence.Y)")->required();
  app.add_option("--width", uo.width, "Map width (height is half)")->default_val(512);
  app.add_option("--reflectance", uo.reflectance,
                 "The mirror's reflectance (chrome: about 0.6); the photograph is divided by it")
      ->default_val(1.0);
  app.add_option("--rotate", o.rotate,
                 "Rotate the world by X,Y,Z degrees (applied as Rz Ry Rx) to correct its alignment")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--camera-cone-deg", uo.camera_cone_deg, "Around the direction back to the camera: low confidence")
      ->default_val(15);
  return mr::RunTool("mr-probe", app, argc, argv, [&] {
    o.command_line = mr::JoinCommandLine(argc, argv);
    mr::RunProbe(o, &mr::ToolReport());
    return mr::kExitOk;
  });
}
