#include "jobs/probe_job.h"

#include <spdlog/spdlog.h>

#include <Eigen/Geometry>

#include "calib/probe_file.h"
#include "camera/camera_model.h"
#include "core/error.h"
#include "core/image.h"
#include "core/math.h"
#include "core/spherical.h"
#include "hdr/exposure_merge.h"
#include "hdr/response.h"
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

// A photograph's clipped pixels (a byte a pixel, non-zero where some
// channel is).  An 8/16-bit photograph is taken as a bracket of one through
// its stated transfer (MergeExposures: codes at 97% of full scale or more
// are clipped, JPEG's ringing below a clipped core included), and the light
// above the clip is recovered from each highlight's glow where the glow
// allows (docs/methods.md, "HDR", the censored-source fit); those pixels of
// *photo take the estimate, the others keep their clipped value, a lower
// bound.  An EXR from mr-hdr brings its saturated.Y, already estimated.
struct Clipped {
  std::vector<uint8_t> mask;
  std::string how;  // in words, for the report
  int regions = 0, recovered = 0;
  std::vector<std::string> why_not;  // per region not recovered
};

Clipped FindClipped(const std::string& file, const ImageFileInfo& info, Image* photo) {
  Clipped out;
  out.mask.assign(static_cast<size_t>(photo->pixel_count()), 0);
  const int sat = photo->ChannelIndex("saturated.Y");
  if (sat >= 0) {
    for (int64_t p = 0; p < photo->pixel_count(); ++p)
      out.mask[static_cast<size_t>(p)] = photo->values()[static_cast<size_t>(p * photo->channels() + sat)] > 0;
    out.how = "saturated.Y (mr-hdr's censored pixels, estimated or bounded there)";
    return out;
  }
  if (!info.decoded_from_ldr) return out;
  const Exposure e = ReadExposure(file, 1.0);
  const int nc = e.codes.channels();
  const CameraResponse response = info.transfer == Transfer::kSrgb ? SrgbResponse(nc) : LinearResponse(nc);
  MergeReport rep;
  const Image merged = MergeExposures({e}, response, ExposureMergeOptions(), &rep);
  const int msat = merged.ChannelIndex("saturated.Y");
  for (int64_t p = 0; p < photo->pixel_count(); ++p) {
    if (!(merged.values()[static_cast<size_t>(p * merged.channels() + msat)] > 0)) continue;
    out.mask[static_cast<size_t>(p)] = 1;
    for (int c = 0; c < std::min(3, nc); ++c)
      photo->values()[static_cast<size_t>(p * photo->channels() + c)] =
          merged.values()[static_cast<size_t>(p * merged.channels() + c)];
  }
  out.how = fmt::format("{}-bit codes at {:.0f}% of full scale or more", info.pixel_type == "uint8" ? 8 : 16,
                        100 * ExposureMergeOptions().high);
  out.regions = static_cast<int>(rep.regions.size());
  for (const CensoredRegion& r : rep.regions) {
    if (r.fitted)
      ++out.recovered;
    else
      out.why_not.push_back(r.why_not);
  }
  return out;
}

// One photograph unwrapped, its figures into `per_view`.
Image UnwrapPhoto(const ProbeJobOptions& o, const UnwrapOptions& uo, size_t i, Json* per_view, Report* report) {
  ScopedTimer t(report, "unwrap");
  const std::string& photo_file = o.photos[i];
  ImageFileInfo info;
  Image photo = ReadImage(photo_file, {}, &info);
  report->AddInput(photo_file);
  const Clipped clipped = FindClipped(photo_file, info, &photo);
  UnwrapReport ur;
  Image view;
  if (!o.fisheye.empty()) {
    const CameraModel cam = CameraModel::Read(o.fisheye);
    const Eigen::Matrix3d world_from_cam = cam.cam_from_ref().rotation.conjugate().toRotationMatrix();
    view = UnwrapFisheye(photo, cam, world_from_cam, uo, photo_file, &ur, &clipped.mask);
  } else {
    const std::string& pj = o.probes.size() == 1 ? o.probes[0] : o.probes[i];
    const ProbeGeometry g = ReadProbe(pj);
    report->AddInput(pj);
    view = UnwrapMirrorSphere(photo, g, uo, photo_file, &ur, &clipped.mask);
  }
  per_view->push_back({{"photo", photo_file},
                       {"seen_fraction", ur.seen_fraction},
                       {"blind_fraction", ur.blind_fraction},
                       {"median_confidence", ur.median_confidence},
                       {"clipped_pixels", ur.clipped_pixels},
                       {"clipped_fraction", ur.clipped_fraction}});
  if (ur.clipped_pixels > 0) {
    per_view->back()["clipped"] = {{"found_by", clipped.how},
                                   {"highlights", clipped.regions},
                                   {"recovered", clipped.recovered},
                                   {"not_recovered_why", clipped.why_not}};
    report->Warn(fmt::format(
        "{}: {} pixels showing the probe are clipped ({}){}: the light there is {} (the map's clipped.Y layer; "
        "mr-lights marks the lights over them); {} measures it",
        photo_file, ur.clipped_pixels, clipped.how,
        clipped.regions > 0 ? fmt::format("; of the photograph's {} clipped highlights {} recovered from their glow",
                                          clipped.regions, clipped.recovered)
                            : std::string(),
        clipped.regions > 0 && clipped.recovered == clipped.regions ? "an estimate from the glow"
                                                                    : "a lower bound where not recovered",
        info.decoded_from_ldr ? "a bracket (mr-hdr)" : "a shorter exposure in the bracket"));
  }
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
