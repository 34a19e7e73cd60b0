#include "eval/plate_check.h"
#include "core/check.h"

#include <spdlog/spdlog.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <map>
#include <numbers>
#include <optional>

#include "camera/trajectory.h"
#include "core/color.h"
#include "core/contact_sheet.h"
#include "core/error.h"
#include "core/image_metrics.h"
#include "core/json.h"
#include "core/progress.h"
#include "eval/registration.h"
#include "render/camera_sampler.h"
#include "render/frame_io.h"
#include "render/method.h"
#include "render/render_job.h"
#include "render/render_scene.h"
#include "render/world.h"
#include "scene/frames.h"

namespace mr {

namespace {

// 1 where the pixel shows the reconstructed room: the rays through its four
// corners all hit real geometry at depths within 10% of one another (so
// silhouettes, where a small pose error swaps foreground and background,
// and pixels that see the environment are left out).
Image RoomPixels(const RenderScene& rs, const CameraModel& camera, const Rigid3& pose) {
  const CameraSampler cs(camera, pose, 0, 0);
  Image room = Image::Gray(camera.width(), camera.height());
  for (int y = 0; y < camera.height(); ++y)
    for (int x = 0; x < camera.width(); ++x) {
      if (!cs.PixelValid(x, y)) continue;
      Eigen::Vector3d c[4];
      cs.CornerDirections(x, y, c);
      float lo = std::numeric_limits<float>::infinity(), hi = 0;
      bool all = true;
      for (const Eigen::Vector3d& d : c) {
        Ray ray;
        ray.origin = pose.translation.cast<float>();
        ray.direction = d.cast<float>();
        ray.mask = kMaskReal;
        Hit hit;
        if (!rs.embree().Intersect(ray, &hit)) {
          all = false;
          break;
        }
        lo = std::min(lo, hit.t);
        hi = std::max(hi, hit.t);
      }
      if (all && hi <= 1.1f * lo) room.at(x, y, 0) = 1;
    }
  return room;
}

// 1 within band_px of a geometric edge of the room seen through `pose`: a
// crease (the surfaces hit by neighbouring pixels' rays turn by more than
// 20 degrees) or a depth step (10%).  Shading and shadows fall anywhere; a
// room's creases are where its geometry is.
Image GeometricEdgeBand(const RenderScene& rs, const CameraModel& camera, const Rigid3& pose, int band_px) {
  const CameraSampler cs(camera, pose, 0, 0);
  const int w = camera.width(), h = camera.height();
  std::vector<Eigen::Vector3f> n(static_cast<size_t>(w) * h, Eigen::Vector3f::Zero());
  std::vector<float> t(n.size(), 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!cs.PixelValid(x, y)) continue;
      Eigen::Vector3d c[4];
      cs.CornerDirections(x, y, c);
      Ray ray;
      ray.origin = pose.translation.cast<float>();
      ray.direction = (c[0] + c[1] + c[2] + c[3]).normalized().cast<float>();
      ray.mask = kMaskReal;
      Hit hit;
      if (!rs.embree().Intersect(ray, &hit)) continue;
      n[static_cast<size_t>(y) * w + x] = hit.geometric_normal.normalized();
      t[static_cast<size_t>(y) * w + x] = hit.t;
    }
  cv::Mat edge = cv::Mat::zeros(h, w, CV_8U);
  const float cos20 = std::cos(20.0f * static_cast<float>(std::numbers::pi) / 180);
  for (int y = 0; y + 1 < h; ++y)
    for (int x = 0; x + 1 < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      for (const size_t j : {i + 1, i + static_cast<size_t>(w)}) {
        if (!(t[i] > 0 && t[j] > 0)) continue;
        // Unsigned: a mesh's winding may flip the normal between triangles of one plane.
        if (std::abs(n[i].dot(n[j])) < cos20 || std::max(t[i], t[j]) > 1.1f * std::min(t[i], t[j]))
          edge.at<uint8_t>(y, x) = 255;
      }
    }
  cv::dilate(edge, edge, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * band_px + 1, 2 * band_px + 1)));
  Image band = Image::Gray(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) band.at(x, y, 0) = edge.at<uint8_t>(y, x) ? 1.0f : 0.0f;
  return band;
}

// The pixels registration is measured and refined over: the room's
// (RoomPixels), or with register_on "edges" those of them near its
// geometric edges.
Image RegistrationPixels(const RenderScene& rs, const CameraModel& camera, const Rigid3& pose,
                         const PlateCheckOptions& o) {
  Image room = RoomPixels(rs, camera, pose);
  if (o.register_on != "edges") return room;
  const Image band = GeometricEdgeBand(rs, camera, pose, o.edge_band_px);
  for (size_t i = 0; i < room.values().size(); ++i) room.values()[i] *= band.values()[i];
  return room;
}

Image Scaled(Image img, const Rgb& g) {
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) *= static_cast<float>(g[c]);
  return img;
}

Json ToJson(const Rgb& v) { return Json::array({v[0], v[1], v[2]}); }

}  // namespace

Image AroundObjects(const Image& mask) {
  const int w = mask.width(), h = mask.height();
  cv::Mat1b foot(h, w, uchar{0});
  int64_t area = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (mask.at(x, y, 0) > 0.5f) foot(y, x) = 255, ++area;
  Image out = Image::Gray(w, h);
  if (area == 0) return out;
  const int r = std::max(8, static_cast<int>(std::lround(std::sqrt(static_cast<double>(area) / std::numbers::pi))));
  cv::Mat1b grown;
  cv::dilate(foot, grown, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (grown(y, x) && !foot(y, x)) out.at(x, y, 0) = 1;
  return out;
}

namespace {

// Per rendered frame: the sums that give the error at any per-channel
// gain g exactly (sum of (g I - P)^2 / (P^2 + eps) is quadratic in g), so
// that the error at the smoothed gain needs no image kept.
struct ErrorSums {
  Rgb a{0, 0, 0}, b{0, 0, 0}, c{0, 0, 0};     // relMSE: I^2 w, I P w, P^2 w with w = 1 / (P^2 + eps)
  Rgb ii{0, 0, 0}, ip{0, 0, 0}, pp{0, 0, 0};  // RMSE
  int64_t n = 0;
  void Add(const Image& real, const Image& plate, const Image& where) {
    for (int y = 0; y < real.height(); ++y)
      for (int x = 0; x < real.width(); ++x) {
        if (!(where.at(x, y, 0) > 0)) continue;
        bool finite = true;
        for (int ch = 0; ch < 3; ++ch)
          finite = finite && std::isfinite(real.at(x, y, ch)) && std::isfinite(plate.at(x, y, ch));
        if (!finite) continue;
        ++n;
        for (int ch = 0; ch < 3; ++ch) {
          const double i = real.at(x, y, ch), p = plate.at(x, y, ch), w = 1 / (p * p + kRelMseEpsilon);
          a[ch] += i * i * w, b[ch] += i * p * w, c[ch] += p * p * w;
          ii[ch] += i * i, ip[ch] += i * p, pp[ch] += p * p;
        }
      }
  }
  double RelMse(const Rgb& g) const {
    double s = 0;
    for (int ch = 0; ch < 3; ++ch) s += g[ch] * g[ch] * a[ch] - 2 * g[ch] * b[ch] + c[ch];
    return std::max(0.0, s) / (3.0 * static_cast<double>(n));
  }
  double Rmse(const Rgb& g) const {
    double s = 0;
    for (int ch = 0; ch < 3; ++ch) s += g[ch] * g[ch] * ii[ch] - 2 * g[ch] * ip[ch] + pp[ch];
    return std::sqrt(std::max(0.0, s) / (3.0 * static_cast<double>(n)));
  }
};
struct Measured {
  ErrorSums room, region;
  double ssim = 0;                  // at the frame's own fitted gain
  RegistrationResult registration;  // the room rendered against the plate, in pixels
  PoseRefinement refinement;        // with refine_poses
  RegistrationResult registration_after;
};

// OUT/NNNNN-rerender.png: the plate | the room rendered at the fitted gain |
// their difference | the pixels compared.
void WriteRerenderSheet(const PlateCheckOptions& o, const FrameDecoding& decoding, const PhotoEncoding& enc,
                        const Image& plate, const Image& fitted, const Image& room, const GainFit& fit, int f,
                        const Measured& m, Report* report) {
  // Shown as the plate's own code values: through the response (or the
  // linear transfer) the frames were decoded with; display-space plates
  // and float ones through sRGB.
  auto srgb = [&](Image img) {
    if (enc.has_codes && !decoding.display_space) return decoding.ToCodes(img, enc);
    for (float& v : img.values()) v = LinearToSrgb(std::clamp(v, 0.0f, 1.0f));
    return img;
  };
  const Image plate_srgb = srgb(plate), fitted_srgb = srgb(fitted);
  Image diff = fitted_srgb;
  for (size_t p = 0; p < diff.values().size(); ++p) diff.values()[p] -= plate_srgb.values()[p];
  const Image diff_panel = SignedDifferencePanel(diff, 0.25);
  const Rgb g = fit.ok ? fit.gain : Rgb{1, 1, 1};
  const Image sheet =
      ContactSheet({{&plate_srgb, fmt::format("plate, frame {}; registration {}", f,
                                              !m.registration.measurable ? std::string("not measurable")
                                              : m.refinement.refined
                                                  ? fmt::format("{:.1f} px, refined {:.1f} px", m.registration.mean_px,
                                                                m.registration_after.mean_px)
                                                  : fmt::format("{:.1f} px", m.registration.mean_px))},
                    {&fitted_srgb, fmt::format("room rendered, x ({:.3g}, {:.3g}, {:.3g})", g[0], g[1], g[2])},
                    {&diff_panel, "rendered - plate (codes), +-0.25"},
                    {&room, "pixels compared (the room)"}},
                   2);
  ImageWriteOptions wo;
  wo.tool = o.tool;
  wo.command_line = o.command_line;
  wo.pixel_type = PixelType::kUint8;
  wo.ldr_transfer = Transfer::kLinear;  // already display values
  wo.attributes["oiio:ColorSpace"] = "sRGB";
  const fs::path path = o.out / fmt::format("{:05d}-rerender.png", f);
  WriteImage(path, sheet, wo);
  report->AddOutput(path.string());
}

// The error after the fit (at the smoothed gain), per rendered frame, and
// the gains' range, into the report and the log.
void ReportErrors(const PlateCheckOptions& o, const std::vector<FrameGain>& gains, const std::vector<GainFit>& fits,
                  const std::vector<Measured>& measured, int begin, const fs::path& gains_path, Report* report) {
  Json frames_json = Json::array();
  double sum_relmse = 0, sum_ssim = 0, sum_region = 0;
  int n_measured = 0, n_region = 0, jumps = 0;
  std::vector<double> reg_mean, reg_p90;  // the frames whose registration was measurable
  std::vector<double> reg_after;          // after refinement, the frames refined
  Rgb gmin{1e300, 1e300, 1e300}, gmax{0, 0, 0};
  size_t ki = 0;
  if (o.at_gain > 0) report->SetMetric("errors_at_gain", o.at_gain);
  for (size_t i = 0; i < gains.size(); ++i) {
    FrameGain g = gains[i];
    if (o.at_gain > 0) g.gain = {o.at_gain, o.at_gain, o.at_gain};
    const GainFit& fit = fits[i];
    jumps += g.jump_before;
    for (int c = 0; c < 3; ++c)
      gmin[c] = std::min(gmin[c], gains[i].gain[c]), gmax[c] = std::max(gmax[c], gains[i].gain[c]);
    Json fj = {{"frame", g.frame}, {"gain", ToJson(gains[i].gain)}, {"sigma", ToJson(g.sigma)}, {"fitted", g.fitted}};
    if (g.jump_before) fj["jump_before"] = true;
    if ((g.frame - begin) % o.stride == 0) {
      const Measured& m = measured[ki++];
      fj["room_pixels"] = fit.room_pixels;
      fj["clipped"] = fit.clipped;
      fj["outliers"] = fit.outliers;
      fj["nonfinite"] = fit.nonfinite;
      if (fit.ok) {
        fj["fit"] = ToJson(fit.gain);
        fj["fit_sigma"] = ToJson(fit.sigma);
        fj["pixels"] = fit.pixels;
      } else {
        fj["why"] = fit.why;
      }
      if (m.room.n > 0) {
        fj["relmse"] = m.room.RelMse(g.gain);
        fj["rmse"] = m.room.Rmse(g.gain);
        fj["ssim"] = m.ssim;
        sum_relmse += m.room.RelMse(g.gain);
        sum_ssim += m.ssim;
        ++n_measured;
      }
      fj["registration"] = m.registration.ToJson();
      if (!o.refine_poses.empty()) {
        Json rj = m.refinement.ToJson();
        rj["registration_after"] = m.registration_after.ToJson();
        fj["pose_refinement"] = rj;
        if (m.refinement.refined && m.registration_after.measurable) reg_after.push_back(m.registration_after.mean_px);
      }
      if (m.registration.measurable) {
        reg_mean.push_back(m.registration.mean_px);
        reg_p90.push_back(m.registration.p90_px);
      }
      if (m.region.n > 0) {
        fj["region_relmse"] = m.region.RelMse(g.gain);
        fj["region_pixels"] = m.region.n;
        sum_region += m.region.RelMse(g.gain);
        ++n_region;
      }
    }
    frames_json.push_back(fj);
  }
  report->SetMetric("frames", frames_json);
  report->SetMetric("method", o.method);
  report->SetMetric("spp", o.spp);
  report->SetMetric("gains_file", gains_path.string());
  report->SetMetric("gain_min", ToJson(gmin));
  report->SetMetric("gain_max", ToJson(gmax));
  report->SetMetric("exposure_jumps", jumps);
  if (n_measured > 0) {
    report->SetMetric("relmse", sum_relmse / n_measured);
    report->SetMetric("ssim", sum_ssim / n_measured);
  }
  if (n_region > 0) report->SetMetric("region_relmse", sum_region / n_region);
  if (!reg_mean.empty()) {
    double m = 0, p = 0;
    for (size_t i = 0; i < reg_mean.size(); ++i) m += reg_mean[i], p = std::max(p, reg_p90[i]);
    m /= static_cast<double>(reg_mean.size());
    report->SetMetric("registration", {{"frames_measured", reg_mean.size()},
                                       {"frames", measured.size()},
                                       {"mean_px", m},
                                       {"worst_mean_px", *std::max_element(reg_mean.begin(), reg_mean.end())},
                                       {"worst_p90_px", p}});
    spdlog::info(
        "registration of the room to the plate: {:.2f} px mean over {} of {} frames (worst frame {:.2f}, "
        "its 90th percentile up to {:.2f} px)",
        m, reg_mean.size(), measured.size(), *std::max_element(reg_mean.begin(), reg_mean.end()), p);
  } else if (!measured.empty()) {
    report->Warn("registration in pixels: no frame measurable (" + measured.front().registration.why + ")");
  }
  if (!o.refine_poses.empty()) {
    // With nothing refined the poses are the given ones: after = before.
    double a = 0;
    for (double v : reg_after.empty() ? reg_mean : reg_after) a += v;
    const size_t n = reg_after.empty() ? reg_mean.size() : reg_after.size();
    const double after = n ? a / static_cast<double>(n) : 0.0;
    report->SetMetric(
        "pose_refinement",
        {{"frames_refined", reg_after.size()}, {"mean_px_after", after}, {"poses", o.refine_poses.string()}});
    spdlog::info("poses refined against the room: {} of {} frames, registration {:.2f} px mean after", reg_after.size(),
                 measured.size(), after);
  }
  spdlog::info("plate gains: R {:.4g}..{:.4g}, G {:.4g}..{:.4g}, B {:.4g}..{:.4g} over {} frames, {} exposure jumps",
               gmin[0], gmax[0], gmin[1], gmax[1], gmin[2], gmax[2], gains.size(), jumps);
  if (n_measured > 0)
    spdlog::info("re-rendering error after the fit: relMSE {:.4g}, SSIM {:.4f}{}", sum_relmse / n_measured,
                 sum_ssim / n_measured,
                 n_region > 0 ? fmt::format(", around the objects relMSE {:.4g}", sum_region / n_region) : "");
}

// Every pose of the scene, the refined frames' replaced and the frames in
// [begin, end) between them corrected by the refined frames' corrections
// (each in the camera's frame) interpolated in time (slerp and lerp; the
// nearest one's beyond the first and last), so that no frame jumps where
// the correction changes; as TUM in frame order.
void WriteRefinedPoses(const PlateCheckOptions& o, const std::vector<Rigid3>& poses,
                       const std::map<int, Rigid3>& refined, int begin, int end, Report* report) {
  auto correction = [&](std::map<int, Rigid3>::const_iterator it) {
    return poses[static_cast<size_t>(it->first)].Inverse() * it->second;
  };
  Trajectory t;
  for (size_t i = 0; i < poses.size(); ++i) {
    const int f = static_cast<int>(i);
    Rigid3 p = poses[i];
    if (!refined.empty() && f >= begin && f < end) {
      const auto hi = refined.lower_bound(f);
      Rigid3 c;
      if (hi == refined.end()) {
        c = correction(std::prev(hi));
      } else if (hi->first == f || hi == refined.begin()) {
        c = correction(hi);
      } else {
        const auto lo = std::prev(hi);
        const double a = static_cast<double>(f - lo->first) / (hi->first - lo->first);
        const Rigid3 c0 = correction(lo), c1 = correction(hi);
        c = Rigid3(c0.rotation.slerp(a, c1.rotation), (1 - a) * c0.translation + a * c1.translation);
      }
      p = p * c;
    }
    t.poses.push_back({static_cast<double>(f), p});
  }
  WriteTum(o.refine_poses, t);
  report->AddOutput(o.refine_poses.string());
}

// Each fitted frame (`frame_ids`) again, in order: its plate and the room
// rendered through poses[f] * correction(i), handed to `use`.
void EachFittedFrame(const Scene& scene, const PlateCheckOptions& o, const CameraModel& camera,
                     const std::vector<Rigid3>& poses, int begin, const std::vector<int>& frame_ids,
                     RenderMethod* method, RenderScene* rs, FrameReader* frames, const FrameDecoding& decoding,
                     Report* report, const std::function<Rigid3(size_t)>& correction,
                     const std::function<void(size_t, const Image&, const Image&, const Image&)>& use) {
  WorldTracker world(scene, *rs, begin);
  for (size_t i = 0; i < frame_ids.size(); ++i) {
    const int f = frame_ids[i];
    if (const WorldChange wc = world.Advance(f, rs); wc.any())
      method->WorldChanged(JobContext{scene, *rs, camera, o.spp, begin, true, report, f}, wc);
    const Rigid3 pose = poses[static_cast<size_t>(f)] * correction(i);
    PhotoEncoding enc;
    const Image plate = decoding.ToPlateLinear(*frames->Photo(f, &enc));
    const FrameContext fc{*rs, camera, pose, scene.render.seed, f, nullptr, nullptr, FrameExposure(scene, poses, f)};
    std::unique_ptr<FrameMethod> fr = method->NewFrame(fc);
    fr->RenderPass(o.spp);
    use(i, plate, fr->Real(), RegistrationPixels(*rs, camera, pose, o));
  }
}

// Whether `after` is not lower than `before` by the fraction `min` (both
// measurable; an unmeasurable one is no evidence either way: not better).
bool NotBetter(const RegistrationResult& before, const RegistrationResult& after, double min) {
  return !before.measurable || !after.measurable || !(after.mean_px < (1 - min) * before.mean_px);
}

// mr-register --observations-out: frame -> its observations as fixed
// matches of weight `weight`.  mr::Error naming the file where it is not
// that format.
std::map<int, RoomMatches> ReadPriorPoints(const fs::path& path, double weight, Report* report) {
  const Json j = ReadJsonFile(path);
  const FileLoc at{path.string()};
  if (!j.is_object() || j.value("version", 0) != 1 || !j.contains("frames") || !j["frames"].is_object())
    ThrowErrorAt(at, "is not mr-register's observations (version 1, frames)");
  std::map<int, RoomMatches> out;
  for (const auto& [key, list] : j["frames"].items()) {
    char* end = nullptr;
    const long f = std::strtol(key.c_str(), &end, 10);
    if (key.empty() || *end != '\0' || f < 0 || f > INT32_MAX || !list.is_array())
      ThrowErrorAt(at, "frame \"{}\" is not a frame number", key);
    RoomMatches& m = out[static_cast<int>(f)];
    m.weight = weight;
    for (const Json& ob : list) {
      if (!ob.is_array() || ob.size() != 5) ThrowErrorAt(at, "frame {}: an observation is not [u, v, X, Y, Z]", f);
      double v[5];
      for (int k = 0; k < 5; ++k) {
        if (!ob[k].is_number() || !std::isfinite(ob[k].get<double>()))
          ThrowErrorAt(at, "frame {}: an observation holds a value that is not a finite number", f);
        v[k] = ob[k].get<double>();
      }
      m.u.emplace_back(v[0], v[1]);
      m.X.emplace_back(v[2], v[3], v[4]);
    }
  }
  report->AddInput(path.string());
  return out;
}

// --refine-mode shared: one correction for the frames, solved from the
// matches the fitted frames' renders gave (`matches`, frames `frame_ids`),
// then o.refine.rounds - 1 times again from the frames rendered through
// their corrected poses; each frame's registration is measured again
// through its corrected pose into *measured, and *refined gets every
// fitted frame's corrected pose.
// With o.refine_camera, the intrinsics too (PoseRefineOptions::intrinsics):
// each round's frames are rendered and matched through the camera as
// corrected so far, and *cam is the camera at the end (the given one where
// no round determined them).
void RefineShared(const Scene& scene, const PlateCheckOptions& o, CameraModel* cam, const std::vector<Rigid3>& poses,
                  int begin, std::vector<RoomMatches> matches, const std::vector<RoomMatches>& priors,
                  const std::vector<int>& frame_ids, RenderMethod* method, RenderScene* rs, FrameReader* frames,
                  const FrameDecoding& decoding, std::vector<Measured>* measured, std::map<int, Rigid3>* refined,
                  Report* report) {
  auto each_frame = [&](const Rigid3& c,
                        const std::function<void(size_t, const Image&, const Image&, const Image&)>& use) {
    EachFittedFrame(
        scene, o, *cam, poses, begin, frame_ids, method, rs, frames, decoding, report, [&](size_t) { return c; }, use);
  };
  PoseRefineOptions ro = o.refine;
  ro.intrinsics = !o.refine_camera.empty();
  auto solve = [&](const Rigid3& start) {
    std::vector<RoomMatches> groups = matches;
    groups.insert(groups.end(), priors.begin(), priors.end());
    PoseRefinement c = SolveCorrection(*cam, groups, start, ro);
    if (c.refined && c.intrinsics_refined)
      *cam = WithIntrinsicsCorrection(*cam, c.focal_scale, Eigen::Vector2d::Zero());
    if (ro.intrinsics && !c.intrinsics_refined) spdlog::info("intrinsics kept: {}", c.intrinsics_why);
    return c;
  };
  PoseRefinement c = solve(Rigid3());
  for (int round = 1; round < o.refine.rounds && c.refined; ++round) {
    const double rms_before = c.rms_before_px;
    each_frame(c.pose, [&](size_t i, const Image& plate, const Image& real, const Image& room) {
      matches[i] = MatchRoom(real, room, *rs, *cam, poses[static_cast<size_t>(frame_ids[i])] * c.pose, plate, o.refine);
      matches[i].pose = poses[static_cast<size_t>(frame_ids[i])];  // the correction is solved from the input poses
    });
    c = solve(c.pose);
    c.rms_before_px = rms_before;
  }
  if (!c.refined) {
    report->Warn("poses not refined: " + c.why);
    for (Measured& m : *measured) m.refinement = c;
    return;
  }
  spdlog::info(
      "one correction for the {} fitted frames: {:.2f} degrees, {:.3f} m; the matches' RMS {:.2f} -> {:.2f} px",
      frame_ids.size(), c.rotation_deg, c.translation_m, c.rms_before_px, c.rms_after_px);
  each_frame(c.pose, [&](size_t i, const Image& plate, const Image& real, const Image& room) {
    Measured& m = (*measured)[i];
    m.refinement = c;
    m.refinement.pose = poses[static_cast<size_t>(frame_ids[i])] * c.pose;
    m.registration_after = MeasureRegistration(real, plate, room);
    (*refined)[frame_ids[i]] = m.refinement.pose;
  });
}

// --refine-mode smooth: each fitted frame's own correction (already in
// *refined), averaged over the fitted frames around it with Gaussian
// weights (sigma o.refine_smooth_frames fitted frames; rotations by their
// normalised, sign-aligned quaternion mean), so that the frames' own
// errors do not make the objects swim; the registration is measured again
// through the smoothed poses.
void SmoothCorrections(const Scene& scene, const PlateCheckOptions& o, const CameraModel& camera,
                       const std::vector<Rigid3>& poses, int begin, const std::vector<int>& frame_ids,
                       RenderMethod* method, RenderScene* rs, FrameReader* frames, const FrameDecoding& decoding,
                       std::vector<Measured>* measured, std::map<int, Rigid3>* refined, Report* report) {
  std::vector<std::optional<Rigid3>> own(frame_ids.size());  // each fitted frame's own correction
  bool any = false;
  for (size_t i = 0; i < frame_ids.size(); ++i)
    if (const auto it = refined->find(frame_ids[i]); it != refined->end()) {
      own[i] = poses[static_cast<size_t>(frame_ids[i])].Inverse() * it->second;
      any = true;
    }
  if (!any) return;
  const std::vector<Rigid3> smooth = SmoothOverTime(own, o.refine_smooth_frames);
  refined->clear();
  EachFittedFrame(
      scene, o, camera, poses, begin, frame_ids, method, rs, frames, decoding, report,
      [&](size_t i) { return smooth[i]; },
      [&](size_t i, const Image& plate, const Image& real, const Image& room) {
        Measured& m = (*measured)[i];
        m.refinement.refined = true;
        m.refinement.pose = poses[static_cast<size_t>(frame_ids[i])] * smooth[i];
        m.refinement.rotation_deg = Eigen::AngleAxisd(smooth[i].rotation).angle() * 180 / std::numbers::pi;
        m.refinement.translation_m = smooth[i].translation.norm();
        m.registration_after = MeasureRegistration(real, plate, room);
        (*refined)[frame_ids[i]] = m.refinement.pose;
      });
}

// --refine-mode frame and smooth: frame f's own refinement into *m (and
// *refined, where kept): RefinePose from the frame's pose, the registration
// measured again through the result, and the result kept only where that
// registration fell by o.refine.min_improvement (the report says which).
void RefineFrame(const Scene& scene, const PlateCheckOptions& o, const CameraModel& camera,
                 const std::vector<Rigid3>& poses, int f, RenderMethod* method, const RenderScene& rs,
                 const Image& plate, const RoomMatches* prior, Measured* m, std::map<int, Rigid3>* refined,
                 Report* report) {
  const Rigid3& pose = poses[static_cast<size_t>(f)];
  auto render = [&](const Rigid3& p) {
    const FrameContext fc{rs, camera, p, scene.render.seed, f, nullptr, nullptr, FrameExposure(scene, poses, f)};
    std::unique_ptr<FrameMethod> fr = method->NewFrame(fc);
    fr->RenderPass(o.spp);
    return fr->Real();
  };
  auto pixels = [&](const Rigid3& p) { return RegistrationPixels(rs, camera, p, o); };
  m->refinement = RefinePose(render, pixels, rs, camera, pose, plate, o.refine, prior);
  if (!m->refinement.refined) {
    report->Warn(fmt::format("frame {}: pose not refined: {}", f, m->refinement.why));
    return;
  }
  m->registration_after = MeasureRegistration(render(m->refinement.pose), plate, pixels(m->refinement.pose));
  if (!NotBetter(m->registration, m->registration_after, o.refine.min_improvement)) {
    (*refined)[f] = m->refinement.pose;
    return;
  }
  m->refinement.refined = false;
  m->refinement.pose = pose;
  m->refinement.why =
      m->registration_after.measurable
          ? fmt::format("registration {:.2f} px before, {:.2f} px after: not lower by {:g}%", m->registration.mean_px,
                        m->registration_after.mean_px, 100 * o.refine.min_improvement)
          : fmt::format("registration {:.2f} px before, not measurable after ({})", m->registration.mean_px,
                        m->registration_after.why);
  report->Warn(fmt::format("frame {}: pose kept: {}", f, m->refinement.why));
}

// Over the refined frames (after sharing or smoothing): the registration's
// mean before and after; where it did not fall by min_improvement, every
// refinement is undone (the poses written are the given ones) and the
// report says why.
// Returns whether the refinements stand.
bool KeepIfBetter(const PlateCheckOptions& o, std::vector<Measured>* measured, std::map<int, Rigid3>* refined,
                  Report* report) {
  RegistrationResult before, after;
  int n = 0;
  for (const Measured& m : *measured)
    if (m.refinement.refined && m.registration.measurable && m.registration_after.measurable) {
      before.mean_px += m.registration.mean_px;
      after.mean_px += m.registration_after.mean_px;
      ++n;
    }
  if (n == 0) return false;
  before.measurable = after.measurable = true;
  if (!NotBetter(before, after, o.refine.min_improvement)) return true;
  const std::string why =
      fmt::format("registration {:.2f} px mean before, {:.2f} px after over {} frames: not lower by {:g}%",
                  before.mean_px / n, after.mean_px / n, n, 100 * o.refine.min_improvement);
  report->Warn("poses kept as given: " + why);
  refined->clear();
  for (Measured& m : *measured)
    if (m.refinement.refined) {
      m.refinement.refined = false;
      m.refinement.why = why;
    }
  return false;
}

// --refine-camera: the camera the refinement ended with (the given one
// where it was undone or determined nothing), written with its change in
// the report.
void WriteRefinedCamera(const PlateCheckOptions& o, const CameraModel& given, const CameraModel& cam, Report* report) {
  const double scale = cam.intrinsics()[0] / given.intrinsics()[0];
  const bool refined = cam.intrinsics() != given.intrinsics();
  const std::string what = refined ? fmt::format("focal length x {:.5f}", scale) : "intrinsics as given";
  cam.Write(o.refine_camera,
            fmt::format("written by {} ({}): {} (the shared pose refinement)", o.tool, o.command_line, what));
  report->AddOutput(o.refine_camera.string());
  report->SetMetric("refined_camera",
                    {{"path", o.refine_camera.string()}, {"intrinsics_refined", refined}, {"focal_scale", scale}});
  spdlog::info("camera: {} ({})", o.refine_camera.string(), what);
}

}  // namespace

void PlateCheckOptions::Check() const {
  if (out.empty()) throw UsageError("--out is required");
  if (spp < 1 || stride < 1) throw UsageError("--spp and --stride must be at least 1");
  FindRenderMethod(method);
  if (!(at_gain >= 0))
    throw UsageError(fmt::format("--at-gain {} must not be negative (0: the fitted gains)", at_gain));
  if (!(smoothing.time_constant >= 0)) throw UsageError("--smooth must be 0 or positive");
  if (!(smoothing.jump_ratio > 1)) throw UsageError("--jump-ratio must be above 1");
  if (register_on != "texture" && register_on != "edges")
    throw UsageError(fmt::format("--register-on {}: texture or edges", register_on));
  if (edge_band_px < 1) throw UsageError("--edge-band must be at least 1");
  if (!prior_points.empty() && refine_poses.empty()) throw UsageError("--prior-points needs --refine-poses");
  if (!(prior_weight > 0)) throw UsageError("--prior-weight must be positive");
  if (!refine_camera.empty() && (refine_poses.empty() || !refine_shared))
    throw UsageError("--refine-camera needs --refine-poses and --refine-mode shared (one correction for the frames)");
}

void RunPlateCheck(const Scene& scene_in, const PlateCheckOptions& o, Report* report) {
  if (!scene_in.camera.frames)
    throw UsageError(fmt::format("{}: the scene names no plate (camera.frames): there is nothing to fit or check",
                                 scene_in.file.string()));
  o.Check();
  // The gains are what this fits: a gains file the scene names (an earlier
  // fit) is not read.
  Scene scene = scene_in;
  if (scene.camera.gains) {
    report->Skip("camera.gains " + scene.camera.gains->string(), "mr-eval plate fits the gains the file holds");
    scene.camera.gains.reset();
  }
  const MethodInfo& info = FindRenderMethod(o.method);
  std::unique_ptr<RenderMethod> method = CreateRenderMethod(scene, o.method);
  RenderScene rs;
  const JobInputs in = LoadJobInputs(scene, o.frame_begin, o.frame_end, &rs, report);
  const CameraModel& camera = in.camera;
  const std::vector<Rigid3>& poses = in.poses;
  const int begin = in.begin, end = in.end;
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (!fs::is_directory(o.out))
    ThrowErrorAt(FileLoc{o.out.string()}, "cannot create the output folder{}", ec ? ": " + ec.message() : "");
  const FrameDecoding decoding = FrameDecoding::FromScene(scene, report);
  FrameReader frames(scene, camera, decoding);
  {
    ScopedTimer t(report, info.prepare_timing.empty() ? "prepare" : info.prepare_timing);
    method->Prepare(JobContext{scene, rs, camera, o.spp, begin, true, report, begin});
  }
  WorldTracker world(scene, rs, begin);  // a light that changes per frame lights each frame's room
  if (o.stride > 1)
    report->Skip(fmt::format("fits of frames between every {}th", o.stride),
                 "--stride: they take the gains of the fitted frames around them");

  std::vector<int> frame_ids;
  std::vector<GainFit> fits;
  std::vector<Measured> measured;   // per rendered frame
  std::map<int, Rigid3> refined;    // frame -> its refined pose
  std::vector<RoomMatches> shared;  // refine_shared: each fitted frame's matches
  std::vector<int> fitted_frames;
  std::vector<int> shared_frames;
  std::vector<RoomMatches> shared_priors;  // refine_shared: the fitted frames' prior observations
  const std::map<int, RoomMatches> priors =
      o.prior_points.empty() ? std::map<int, RoomMatches>() : ReadPriorPoints(o.prior_points, o.prior_weight, report);
  Progress progress("plate fit", end - begin);
  for (int f = begin; f < end; ++f) {
    frame_ids.push_back(f);
    if ((f - begin) % o.stride != 0) {
      GainFit none;
      none.why = "--stride";
      fits.push_back(none);
      progress.Update(f - begin + 1);
      continue;
    }
    const Rigid3& pose = poses[static_cast<size_t>(f)];
    fitted_frames.push_back(f);
    if (const WorldChange wc = world.Advance(f, &rs); wc.any())
      method->WorldChanged(JobContext{scene, rs, camera, o.spp, begin, true, report, f}, wc);
    PhotoEncoding enc;
    const Image photo = *frames.Photo(f, &enc);
    const Image plate = decoding.ToPlateLinear(photo);
    Image codes;
    if (enc.has_codes) codes = decoding.ToCodes(decoding.ToRadiance(photo), enc);
    Image real, mask;
    {
      ScopedTimer t(report, "render room");
      const FrameContext fc{rs, camera, pose, scene.render.seed, f, nullptr, nullptr, FrameExposure(scene, poses, f)};
      std::unique_ptr<FrameMethod> fr = method->NewFrame(fc);
      fr->RenderPass(o.spp);
      real = fr->Real();
      mask = fr->Mask();
    }
    Measured m;
    Image room;
    {
      ScopedTimer t(report, "fit");
      room = RoomPixels(rs, camera, pose);
      fits.push_back(FitPlateGain(plate, real, room, enc.has_codes ? &codes : nullptr, o.fit));
      Image region = AroundObjects(mask);
      for (size_t p = 0; p < region.values().size(); ++p) region.values()[p] *= room.values()[p];
      m.room.Add(real, plate, room);
      m.region.Add(real, plate, region);
    }
    const GainFit& fit = fits.back();
    if (!fit.ok) {
      report->Warn(fmt::format("frame {}: no gain fit: {}", f, fit.why));
    }
    const Image fitted = Scaled(real, fit.ok ? fit.gain : Rgb{1, 1, 1});
    m.ssim = CompareImages(fitted, plate, &room).ssim;
    const Image reg_pixels = o.register_on == "edges" ? RegistrationPixels(rs, camera, pose, o) : room;
    {
      ScopedTimer t(report, "registration");
      m.registration = MeasureRegistration(real, plate, reg_pixels);
    }
    if (!o.refine_poses.empty() && o.refine_shared) {
      ScopedTimer t(report, "pose refinement");
      shared.push_back(MatchRoom(real, reg_pixels, rs, camera, pose, plate, o.refine));
      shared_frames.push_back(f);
      if (const auto pr = priors.find(f); pr != priors.end()) {
        shared_priors.push_back(pr->second);
        shared_priors.back().pose = pose;
      }
    } else if (!o.refine_poses.empty()) {
      ScopedTimer t(report, "pose refinement");
      const auto pr = priors.find(f);
      RefineFrame(scene, o, camera, poses, f, method.get(), rs, plate, pr == priors.end() ? nullptr : &pr->second, &m,
                  &refined, report);
    }
    if (o.images) WriteRerenderSheet(o, decoding, enc, plate, fitted, room, fit, f, m, report);
    measured.push_back(std::move(m));
    progress.Update(f - begin + 1);
  }
  progress.Done();
  const std::vector<FrameGain> gains = SmoothGains(frame_ids, fits, o.smoothing);
  const fs::path gains_path = o.out / "gains.json";
  WritePlateGains(gains_path, gains,
                  fmt::format("written by {} ({}) from {}: render-to-plate gains per frame, {} at {} spp", o.tool,
                              o.command_line, scene.file.string(), o.method, o.spp));
  report->AddOutput(gains_path.string());

  CameraModel refined_camera = camera;
  if (!o.refine_poses.empty() && o.refine_shared) {
    ScopedTimer t(report, "pose refinement");
    RefineShared(scene, o, &refined_camera, poses, begin, shared, shared_priors, shared_frames, method.get(), &rs,
                 &frames, decoding, &measured, &refined, report);
  } else if (!o.refine_poses.empty() && o.refine_smooth_frames > 0) {
    ScopedTimer t(report, "pose refinement");
    SmoothCorrections(scene, o, camera, poses, begin, fitted_frames, method.get(), &rs, &frames, decoding, &measured,
                      &refined, report);
  }
  if (!o.refine_poses.empty()) {
    if (!KeepIfBetter(o, &measured, &refined, report)) refined_camera = camera;
    WriteRefinedPoses(o, poses, refined, begin, end, report);
    if (!o.refine_camera.empty()) WriteRefinedCamera(o, camera, refined_camera, report);
  }
  MR_CHECK_EQ(gains.size(), fits.size());  // SmoothGains: one gain per frame
  ReportErrors(o, gains, fits, measured, begin, gains_path, report);
  spdlog::info("gains: {}", gains_path.string());
}

}  // namespace mr
