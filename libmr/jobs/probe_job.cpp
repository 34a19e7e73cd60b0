#include "jobs/probe_job.h"

#include <spdlog/spdlog.h>

#include <Eigen/Geometry>

#include "calib/probe_file.h"
#include "camera/camera_model.h"
#include "core/error.h"
#include "core/image.h"
#include "core/math.h"
#include "core/spherical.h"
#include "probe/unwrap.h"
#include "scene/frames.h"

namespace mr {

namespace {

UnwrapOptions UnwrapOf(const ProbeJobOptions& o) {
  UnwrapOptions uo = o.sequence.unwrap;
  if (o.rotate.size() == 3)
    uo.rotate = (Eigen::AngleAxisd(o.rotate[2] * kDegToRad, Eigen::Vector3d::UnitZ()) *
                 Eigen::AngleAxisd(o.rotate[1] * kDegToRad, Eigen::Vector3d::UnitY()) *
                 Eigen::AngleAxisd(o.rotate[0] * kDegToRad, Eigen::Vector3d::UnitX()))
                    .toRotationMatrix();
  return uo;
}

void RunSequence(const ProbeJobOptions& o, Report* report) {
  ProbeSequenceOptions so = o.sequence;
  so.fisheye = o.fisheye;
  so.unwrap = UnwrapOf(o);
  so.out = o.out;
  if (!o.plate_times.empty()) so.plate_times = o.plate_times;
  if (!o.exposures.empty()) so.exposures = o.exposures;
  if (o.sphere.size() == 4) {
    so.sphere_centre = Eigen::Vector3d(o.sphere[0], o.sphere[1], o.sphere[2]);
    so.sphere_radius = o.sphere[3];
  }
  if (!o.frames.empty()) ParseFrameRange(o.frames, &so.begin, &so.end);
  so.command_line = o.command_line;
  RunProbeSequence(so, report);
}

// One photograph unwrapped, its figures into `per_view`.
Image UnwrapPhoto(const ProbeJobOptions& o, const UnwrapOptions& uo, size_t i, Json* per_view, Report* report) {
  ScopedTimer t(report, "unwrap");
  const std::string& photo_file = o.photos[i];
  const Image photo = ReadImage(photo_file);
  report->AddInput(photo_file);
  UnwrapReport ur;
  Image view;
  if (!o.fisheye.empty()) {
    const CameraModel cam = CameraModel::Read(o.fisheye);
    const Eigen::Matrix3d world_from_cam = cam.cam_from_ref().rotation.conjugate().toRotationMatrix();
    view = UnwrapFisheye(photo, cam, world_from_cam, uo, photo_file, &ur);
  } else {
    const std::string& pj = o.probes.size() == 1 ? o.probes[0] : o.probes[i];
    const ProbeGeometry g = ReadProbe(pj);
    report->AddInput(pj);
    view = UnwrapMirrorSphere(photo, g, uo, photo_file, &ur);
  }
  per_view->push_back({{"photo", photo_file},
                       {"seen_fraction", ur.seen_fraction},
                       {"blind_fraction", ur.blind_fraction},
                       {"median_confidence", ur.median_confidence}});
  spdlog::info("{}: {:.1f}% of the sphere of directions seen, median confidence {:.2f} px per map pixel", photo_file,
               100 * ur.seen_fraction, ur.median_confidence);
  return view;
}

// The solid-angle fraction of the map's directions some photograph saw.
double SeenFraction(const Image& env) {
  double seen = 0, total = 0;
  for (int y = 0; y < env.height(); ++y)
    for (int x = 0; x < env.width(); ++x) {
      const double sa = LatLongPixelSolidAngle(x, y, env.width(), env.height());
      total += sa;
      seen += env.at(x, y, 3) > 0 ? sa : 0;
    }
  return seen / total;
}

void RunPhotographs(const ProbeJobOptions& o, Report* report) {
  const UnwrapOptions uo = UnwrapOf(o);
  std::vector<Image> views;
  Json per_view = Json::array();
  for (size_t i = 0; i < o.photos.size(); ++i) views.push_back(UnwrapPhoto(o, uo, i, &per_view, report));
  Image env = views.size() == 1 ? views[0] : MergeProbeViews(views);
  if (views.size() == 1) report->Skip("merging views", "one photograph");
  const double seen = SeenFraction(env);
  report->SetMetric("views", per_view);
  report->SetMetric("seen_fraction", seen);
  if (seen < 0.999)
    report->Warn(fmt::format("{:.1f}% of the directions are seen by no photograph (black in the map, confidence 0)",
                             100 * (1 - seen)));
  ImageWriteOptions wo;
  wo.tool = "mr-probe";
  wo.command_line = o.command_line;
  wo.attributes["textureformat"] = "LatLong Environment";
  {
    ScopedTimer t(report, "write");
    WriteImage(o.out, env, wo);
  }
  report->AddOutput(o.out);
}

}  // namespace

void ProbeJobOptions::Check() const {
  if (!rotate.empty() && rotate.size() != 3) throw UsageError("--rotate: give X,Y,Z degrees");
  if (!sphere.empty() && sphere.size() != 4) throw UsageError("--sphere: give X,Y,Z,R");
  UnwrapOf(*this).Check();
  if (over_time()) {
    if (!photos.empty()) throw UsageError("photographs and a sequence (--light, --sphere-in-plate) contradict");
    if (!probes.empty()) throw UsageError("--probe is for photographs; the sphere in the plate takes --sphere");
    int begin = 0, end = -1;
    std::string why;
    if (!frames.empty() && !ParseFrameRange(frames, &begin, &end, &why)) throw UsageError("--frames " + why);
    return;
  }
  if (photos.empty()) throw UsageError("give photographs, --light FRAMES or --sphere-in-plate SCENE");
  if (fisheye.empty() && probes.empty())
    throw UsageError("give --probe probe.json (mirror sphere) or --fisheye CAMERA");
  if (!fisheye.empty() && !probes.empty()) throw UsageError("--fisheye and --probe contradict each other");
  if (probes.size() > 1 && probes.size() != photos.size())
    throw UsageError(
        fmt::format("{} --probe files for {} photographs: give one, or one each", probes.size(), photos.size()));
}

void RunProbe(const ProbeJobOptions& o, Report* report) {
  o.Check();
  if (o.over_time())
    RunSequence(o, report);
  else
    RunPhotographs(o, report);
}

}  // namespace mr
