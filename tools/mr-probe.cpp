// mr-probe: unwraps light-probe photographs into a world-aligned lat-long map.
#include <spdlog/spdlog.h>

#include <Eigen/Geometry>

#include "camera/camera_model.h"
#include "cli/tool.h"
#include "core/error.h"
#include "core/image.h"
#include "core/math.h"
#include "core/report.h"
#include "core/spherical.h"
#include "jobs/probe_sequence.h"
#include "probe/unwrap.h"
#include "scene/frames.h"

int main(int argc, char** argv) {
  CLI::App app;
  std::vector<std::string> photos, probes;
  std::string out, fisheye;
  std::vector<double> rotate;
  mr::UnwrapOptions uo;
  mr::ProbeSequenceOptions so;
  std::string plate_times, exposures, frame_range;
  std::vector<double> sphere;
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
  app.add_option("photos", photos, "HDR photographs (R, G, B first)")->check(CLI::ExistingFile);
  app.add_option("--light", so.light,
                 "Over time: the light camera's frames: a list of TIMESTAMP PATH lines (.txt), a printf pattern "
                 "or a video");
  app.add_option("--sphere-in-plate", so.scene, "Over time: the scene whose plate shows the mirror sphere")
      ->check(CLI::ExistingFile);
  app.add_option("--sphere", sphere, "With --sphere-in-plate: the sphere's centre X,Y,Z (world, m) and radius R (m)")
      ->delimiter(',')
      ->expected(4);
  app.add_option("--plate-times", plate_times,
                 "With --light: the plate's TUM trajectory; each plate frame takes the light frame nearest in time")
      ->check(CLI::ExistingFile);
  app.add_option("--max-dt", so.max_dt, "Largest plate-to-light time difference (s)")
      ->default_val(0.02)
      ->check(mr::kNonNegative);
  app.add_option("--fps", so.fps, "Frame rate of a pattern of light frames (or of the plate, --sphere-in-plate)")
      ->default_val(30)
      ->check(mr::kPositive);
  app.add_option("--time-offset", so.time_offset, "Added to the light frames' times (s)")->default_val(0);
  app.add_option("--exposures", exposures, "The light frames' exposure times (FILENAME TIME lines)")
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
  app.add_option("--frames", frame_range, "Plate frames A:B (over time)");
  app.add_option("--probe", probes, "probe.json for each photograph, or one for all")->check(CLI::ExistingFile);
  app.add_option("--fisheye", fisheye, "The photographs are fish-eye views through this camera model")
      ->check(CLI::ExistingFile);
  app.add_option("--out", out, "Environment map (EXR: R G B confidence.Y)")->required();
  app.add_option("--width", uo.width, "Map width (height is half)")->default_val(512);
  app.add_option("--reflectance", uo.reflectance,
                 "The mirror's reflectance (chrome: about 0.6); the photograph is divided by it")
      ->default_val(1.0);
  app.add_option("--rotate", rotate, "Rotate the world by X,Y,Z degrees (applied as Rz Ry Rx) to correct its alignment")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--camera-cone-deg", uo.camera_cone_deg, "Around the direction back to the camera: low confidence")
      ->default_val(15);
  return mr::RunTool("mr-probe", app, argc, argv, [&] {
    mr::Report& report = mr::ToolReport();
    if (rotate.size() == 3)
      uo.rotate = (Eigen::AngleAxisd(rotate[2] * mr::kDegToRad, Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(rotate[1] * mr::kDegToRad, Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(rotate[0] * mr::kDegToRad, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
    uo.Check();
    if (!so.light.empty() || !so.scene.empty()) {
      if (!photos.empty()) throw mr::UsageError("photographs and a sequence (--light, --sphere-in-plate) contradict");
      if (!probes.empty()) throw mr::UsageError("--probe is for photographs; the sphere in the plate takes --sphere");
      so.fisheye = fisheye;
      so.unwrap = uo;
      so.out = out;
      if (!plate_times.empty()) so.plate_times = plate_times;
      if (!exposures.empty()) so.exposures = exposures;
      if (sphere.size() == 4) {
        so.sphere_centre = Eigen::Vector3d(sphere[0], sphere[1], sphere[2]);
        so.sphere_radius = sphere[3];
      }
      if (!frame_range.empty()) {
        std::string why;
        if (!mr::ParseFrameRange(frame_range, &so.begin, &so.end, &why)) throw mr::UsageError("--frames " + why);
      }
      so.command_line = mr::JoinCommandLine(argc, argv);
      mr::RunProbeSequence(so, &report);
      return mr::kExitOk;
    }
    if (photos.empty()) throw mr::UsageError("give photographs, --light FRAMES or --sphere-in-plate SCENE");
    if (fisheye.empty() && probes.empty())
      throw mr::UsageError("give --probe probe.json (mirror sphere) or --fisheye CAMERA");
    if (!fisheye.empty() && !probes.empty()) throw mr::UsageError("--fisheye and --probe contradict each other");
    if (probes.size() > 1 && probes.size() != photos.size())
      throw mr::UsageError(
          fmt::format("{} --probe files for {} photographs: give one, or one each", probes.size(), photos.size()));
    std::vector<mr::Image> views;
    nlohmann::json per_view = nlohmann::json::array();
    for (size_t i = 0; i < photos.size(); ++i) {
      mr::ScopedTimer t(&report, "unwrap");
      const mr::Image photo = mr::ReadImage(photos[i]);
      report.AddInput(photos[i]);
      mr::UnwrapReport ur;
      if (!fisheye.empty()) {
        const mr::CameraModel cam = mr::CameraModel::Read(fisheye);
        const Eigen::Matrix3d world_from_cam = cam.cam_from_ref().rotation.conjugate().toRotationMatrix();
        views.push_back(mr::UnwrapFisheye(photo, cam, world_from_cam, uo, photos[i], &ur));
      } else {
        const std::string& pj = probes.size() == 1 ? probes[0] : probes[i];
        const mr::ProbeGeometry g = mr::ReadProbe(pj);
        report.AddInput(pj);
        views.push_back(mr::UnwrapMirrorSphere(photo, g, uo, photos[i], &ur));
      }
      per_view.push_back({{"photo", photos[i]},
                          {"seen_fraction", ur.seen_fraction},
                          {"blind_fraction", ur.blind_fraction},
                          {"median_confidence", ur.median_confidence}});
      spdlog::info("{}: {:.1f}% of the sphere of directions seen, median confidence {:.2f} px per map pixel", photos[i],
                   100 * ur.seen_fraction, ur.median_confidence);
    }
    mr::Image env = views.size() == 1 ? views[0] : mr::MergeProbeViews(views);
    if (views.size() == 1) report.Skip("merging views", "one photograph");
    double seen = 0, total = 0;
    for (int y = 0; y < env.height(); ++y)
      for (int x = 0; x < env.width(); ++x) {
        const double sa = mr::LatLongPixelSolidAngle(x, y, env.width(), env.height());
        total += sa;
        seen += env.at(x, y, 3) > 0 ? sa : 0;
      }
    report.SetMetric("views", per_view);
    report.SetMetric("seen_fraction", seen / total);
    if (seen / total < 0.999)
      report.Warn(fmt::format("{:.1f}% of the directions are seen by no photograph (black in the map, confidence 0)",
                              100 * (1 - seen / total)));
    mr::ImageWriteOptions wo;
    wo.tool = "mr-probe";
    wo.command_line = mr::JoinCommandLine(argc, argv);
    wo.attributes["textureformat"] = "LatLong Environment";
    {
      mr::ScopedTimer t(&report, "write");
      mr::WriteImage(out, env, wo);
    }
    report.AddOutput(out);
    return mr::kExitOk;
  });
}
