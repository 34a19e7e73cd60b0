#include "recon/fusion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <memory>

#include <fmt/format.h>

#include "core/error.h"
#include "core/image.h"

namespace mr {

namespace {

double Seconds(std::chrono::steady_clock::time_point a) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
}

const Rigid3* PoseAt(const Trajectory& t, double timestamp) {
  const TimedPose* best = nullptr;
  for (const auto& p : t.poses)
    if (!best || std::abs(p.timestamp - timestamp) < std::abs(best->timestamp - timestamp)) best = &p;
  if (!best || std::abs(best->timestamp - timestamp) > 0.02) return nullptr;
  return &best->world_from_cam;
}

double Median(const std::deque<double>& v) {
  std::vector<double> s(v.begin(), v.end());
  std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(s.size() / 2), s.end());
  return s[s.size() / 2];
}

// The raycast model shaded by a head light (normal . view), grey.
void WritePreview(const FuseOptions& o, int index, const PointMaps& m, const Rigid3& pose) {
  Image img = Image::Gray(m.width, m.height);
  for (size_t i = 0; i < m.normals.size(); ++i) {
    const Eigen::Vector3f& n = m.normals[i];
    if (!(n.x() == n.x())) continue;
    const Eigen::Vector3f view = (pose.translation.cast<float>() - m.vertices[i]).normalized();
    img.values()[i] = 0.1f + 0.9f * std::max(0.0f, n.dot(view));
  }
  fs::create_directories(o.preview_dir);
  WriteImage(o.preview_dir / fmt::format("{:06d}.png", index), img);
}

// The pyramid level the model is raycast at: options.raycast_level, but
// never below 320 pixels across (coarser models lose thin structure).
int RaycastLevel(const FuseOptions& o, const FramePyramid& pyr) {
  int rl = std::clamp(o.raycast_level, 0, static_cast<int>(pyr.depth.size()) - 1);
  while (rl > 0 && pyr.K[static_cast<size_t>(rl)].width < 320) --rl;
  return rl;
}

// The voxels of `blocks` (the band AllocateBand found from the raw depth)
// updated from the filtered depth (and colour), and the tracking volume's
// likewise.
void FuseFrame(const std::vector<int32_t>& blocks, const DepthMap& raw, const DepthMap& filtered, const Image* color,
               const PinholeIntrinsics& K, const Rigid3& pose, TsdfVolume* volume, TsdfVolume* tracker,
               IntegrateStats* is) {
  volume->Integrate(blocks, filtered, color, K, pose, is);
  if (tracker) {
    IntegrateStats ts;
    tracker->Integrate(tracker->AllocateBand(raw, K, pose, &ts), filtered, nullptr, K, pose, &ts);
  }
}

// After loops closed: `volume` emptied and the frames `fused` (sequence
// index, trajectory index) fused again at their corrected poses.
void Refuse(const RgbdSequence& seq, const std::vector<std::pair<size_t, size_t>>& fused, const Trajectory& traj,
            const FuseOptions& o, const DepthReadOptions& dopt, TsdfVolume* volume) {
  *volume = TsdfVolume(volume->options());
  for (const auto& [i, k] : fused) {
    const RgbdFrame& f = seq.frames[i];
    const DepthMap depth = ReadDepth(f.depth, dopt, seq.K.width, seq.K.height);
    Image color;
    if (o.use_color && !f.color.empty()) color = ReadColor(f.color, seq.K.width, seq.K.height);
    IntegrateStats is;
    const Rigid3& pose = traj.poses[k].world_from_cam;
    FuseFrame(volume->AllocateBand(depth, seq.K, pose, &is), depth, FilterDepth(depth, o.pyramid),
              color.empty() ? nullptr : &color, seq.K, pose, volume, nullptr, &is);
  }
}

}  // namespace

FuseResult Fuse(const RgbdSequence& seq, const FuseOptions& options, TsdfVolume* volume,
                const FrameCallback& on_frame) {
  FuseResult result;
  DepthReadOptions dopt = options.depth;
  dopt.scale = seq.depth_scale;
  result.suspect_scale = CheckDepthScale(seq, dopt);
  const PinholeIntrinsics& K = seq.K;
  const int n = static_cast<int>(seq.frames.size());
  const int stride = std::max(1, options.stride);

  bool have_model = false;
  Rigid3 pose = options.first_pose, prev_pose = options.first_pose, last_fused = options.first_pose;
  Eigen::Matrix<double, 6, 1> velocity = Eigen::Matrix<double, 6, 1>::Zero();  // increment per second
  double prev_time = 0;
  Rigid3 model_pose;
  PointMaps model;
  // With a region of interest the output volume holds only that region; the
  // camera is tracked against a second, whole volume (tracking_voxel).
  std::unique_ptr<TsdfVolume> tracker;
  if (!options.poses && !volume->options().roi.isEmpty()) {
    TsdfOptions t = volume->options();
    t.roi = Eigen::AlignedBox3f();
    if (options.tracking_voxel > 0) t.voxel_size = static_cast<float>(options.tracking_voxel);
    t.truncation = 0;
    tracker = std::make_unique<TsdfVolume>(t);
  }
  PinholeIntrinsics model_K = K;
  int lost_run = 0;
  std::deque<double> good_rms, good_inliers;  // the last good frames' figures
  int taken = 0;
  std::unique_ptr<LoopCloser> closer;
  if (!options.poses && options.loop.enabled) closer = std::make_unique<LoopCloser>(options.loop);
  std::vector<std::pair<size_t, size_t>> fused_frames;  // (sequence, trajectory) indices
  FramePyramid prev_pyr;                                // the last tracked frame's
  for (int i = std::max(0, options.first); i < n; i += stride) {
    if (options.count >= 0 && taken >= options.count) break;
    ++taken;
    const auto t0 = std::chrono::steady_clock::now();
    const RgbdFrame& f = seq.frames[static_cast<size_t>(i)];
    FrameRecord rec;
    rec.index = f.index;
    rec.timestamp = f.timestamp;
    DepthReadStats ds;
    const DepthMap depth = ReadDepth(f.depth, dopt, K.width, K.height, &ds);
    rec.t_read = Seconds(t0);
    rec.valid_depth = ds.valid;
    rec.rejected_depth = ds.rejected;
    const double valid_fraction = static_cast<double>(ds.valid) / static_cast<double>(depth.z.size());
    auto finish = [&] {
      rec.seconds = Seconds(t0);
      result.peak_bytes =
          std::max(result.peak_bytes, volume->MemoryBytes() + (tracker ? tracker->MemoryBytes() : int64_t{0}));
      if (on_frame) on_frame(rec);
      result.frames.push_back(rec);
    };
    if (valid_fraction < options.min_valid_fraction) {
      rec.status = "no_depth";
      rec.note = fmt::format("{:.1f}% valid depth < {:.1f}%", 100 * valid_fraction, 100 * options.min_valid_fraction);
      finish();
      continue;
    }
    auto tp = std::chrono::steady_clock::now();
    // Colour for fusion, and for tracking's photometric term.
    Image color;
    const bool color_tracking = !options.poses && options.icp.color_weight > 0 && options.icp.color_term != "off";
    if (options.use_color && !f.color.empty() && color_tracking) color = ReadColor(f.color, K.width, K.height);
    FramePyramid pyr = BuildPyramid(depth, K, options.pyramid, color.empty() ? nullptr : &color);
    rec.t_pyramid = Seconds(tp);
    tp = std::chrono::steady_clock::now();

    if (options.poses) {
      const Rigid3* p = PoseAt(*options.poses, f.timestamp);
      if (!p) {
        rec.status = "no_pose";
        rec.note = "no pose within 0.02 s in the given trajectory";
        finish();
        continue;
      }
      pose = *p;
      rec.status = "given";
    } else if (!have_model) {
      pose = options.first_pose;
      rec.status = "first";
    } else {
      // Constant-velocity prediction after a tracked frame; the last good
      // pose after a lost one (relocalisation by ICP from there, wider gates).
      const bool relocalising = lost_run > 0;
      const bool still = relocalising || options.motion_model == "static";
      // Scaled by the time since the last pose: dropped frames widen the step.
      const double dt = f.timestamp - prev_time;
      const Rigid3 guess = still ? prev_pose : ApplyIncrement(velocity * dt, prev_pose);
      IcpOptions icp = options.icp;
      if (relocalising) {
        icp.max_distance *= 2;
        for (auto& it : icp.iterations) it *= 2;
      }
      // The photometric term against the previous frame, when it was tracked.
      const PhotometricTarget photo{&prev_pyr, prev_pose};
      IcpResult r = TrackIcp(pyr, model, model_K, model_pose, guess, icp,
                             lost_run == 0 && !prev_pyr.intensity.empty() ? &photo : nullptr);
      // Against this recording's own recent figures: a residual twice the
      // median of the last good frames, or half their inlier ratio, is a
      // wrong pose even where the absolute limits pass.
      auto judge = [&](IcpResult* x) {
        if (!x->ok || good_rms.size() < 5) return;
        const double med_rms = Median(good_rms), med_in = Median(good_inliers);
        if (x->rms > options.loss_rms_factor * med_rms)
          x->failure = fmt::format("RMS residual {:.1f} mm > {:g} x the recent median {:.1f} mm", 1000 * x->rms,
                                   options.loss_rms_factor, 1000 * med_rms);
        else if (x->inlier_ratio < options.loss_inlier_factor * med_in)
          x->failure = fmt::format("inlier ratio {:.2f} < {:g} x the recent median {:.2f}", x->inlier_ratio,
                                   options.loss_inlier_factor, med_in);
        x->ok = x->failure.empty();
      };
      judge(&r);
      // Lost: placed against the keyframes near the last good pose (the
      // loop search's seeded ICP), then checked against the model seen from
      // there as any tracked frame is.
      std::string placed_by;
      if (!r.ok && closer) {
        if (const auto at = closer->Relocalise(pyr, prev_pose)) {
          const int rl = RaycastLevel(options, pyr);
          const PinholeIntrinsics& Kl = pyr.K[static_cast<size_t>(rl)];
          const PointMaps there =
              (tracker ? tracker.get() : volume)
                  ->Raycast(Kl, at->first, 0.2f, static_cast<float>(dopt.max_m), &pyr.depth[static_cast<size_t>(rl)]);
          IcpResult r2 = TrackIcp(pyr, there, Kl, at->first, at->first, options.icp);
          judge(&r2);
          if (r2.ok) {
            r = r2;
            placed_by = fmt::format("relocalised against the keyframe of frame {}", at->second);
          }
        }
      }
      rec.icp_rms = r.rms;
      rec.free_space_ratio = r.free_space_ratio;
      rec.color_pixels = r.color_pixels;
      rec.color_rms = r.color_rms;
      rec.inlier_ratio = r.inlier_ratio;
      rec.condition = r.condition;
      rec.weak_directions = r.weak_directions;
      rec.iterations = r.iterations;
      if (!r.ok) {
        rec.status = "lost";
        rec.note = r.failure;
        ++lost_run;
        if (lost_run >= options.max_lost) {
          result.stopped_early = true;
          result.stop_reason = fmt::format(
              "tracking lost for {} frames in a row (last: frame {}, {}); everything "
              "fused before is kept",
              lost_run, f.index, r.failure);
          finish();
          break;
        }
        finish();
        continue;
      }
      rec.status = relocalising || !placed_by.empty() ? "relocalised" : "tracked";
      rec.note = placed_by;
      good_rms.push_back(r.rms);
      good_inliers.push_back(r.inlier_ratio);
      if (good_rms.size() > 30) {
        good_rms.pop_front();
        good_inliers.pop_front();
      }
      // Constant velocity, except along directions the data did not constrain.
      velocity = relocalising || !placed_by.empty() || !(dt > 0)
                     ? Eigen::Matrix<double, 6, 1>::Zero().eval()
                     : (r.RemoveWeak(IncrementBetween(prev_pose, r.world_from_cam)) / dt).eval();
      pose = r.world_from_cam;
      lost_run = 0;
    }
    rec.t_track = Seconds(tp);
    tp = std::chrono::steady_clock::now();
    result.trajectory.poses.push_back({f.timestamp, pose});

    // Fuse unless the frame adds nothing: small motion and no new surface.
    IntegrateStats is;
    const std::vector<int32_t> blocks = volume->AllocateBand(depth, K, pose, &is);
    rec.new_blocks = is.blocks_new;
    const double moved = (pose.translation - last_fused.translation).norm();
    const double turned = Eigen::AngleAxisd((pose * last_fused.Inverse()).rotation).angle() * 180 / M_PI;
    const bool no_new_surface =
        static_cast<double>(is.blocks_new) <= options.skip_new_block_fraction * static_cast<double>(is.blocks_touched);
    const bool small =
        have_model && no_new_surface && moved < options.skip_translation_m && turned < options.skip_rotation_deg;
    if (small) {
      rec.fused = false;
      rec.note = fmt::format("moved {:.1f} mm / {:.2f} deg since the last fused frame, {} new blocks of {}",
                             1000 * moved, turned, is.blocks_new, is.blocks_touched);
    } else {
      if (options.use_color && !f.color.empty() && color.empty()) color = ReadColor(f.color, K.width, K.height);
      FuseFrame(blocks, depth, pyr.depth[0], color.empty() ? nullptr : &color, K, pose, volume, tracker.get(), &is);
      rec.fused = true;
      last_fused = pose;
      fused_frames.push_back({static_cast<size_t>(i), result.trajectory.size() - 1});
    }
    rec.t_fuse = Seconds(tp);
    tp = std::chrono::steady_clock::now();
    bool closed = false;
    if (closer && closer->Add(i, pyr, pose)) {
      // Every pose moves with the graph; the velocity turns with this frame.
      closed = true;
      for (size_t k = 0; k < result.trajectory.size(); ++k) result.trajectory.poses[k].world_from_cam = closer->pose(k);
      const Rigid3 moved_by = result.trajectory.poses.back().world_from_cam * pose.Inverse();
      velocity.head<3>() = moved_by.rotation * velocity.head<3>().eval();
      velocity.tail<3>() = moved_by.rotation * velocity.tail<3>().eval();
      pose = last_fused = result.trajectory.poses.back().world_from_cam;
      const LoopRecord& l = closer->loops().back();
      rec.note = fmt::format("loop closed with frame {} (moved {:.1f} mm / {:.2f} deg)", l.keyframe_frame,
                             1000 * l.correction_m, l.correction_deg);
      // The model tracking goes on against is fused again from the
      // keyframes where the loop moved this frame noticeably; below that,
      // tracking against the old model pulls the next poses back by at most
      // the threshold, which the output's fusing again at the end does not
      // inherit.
      if (l.correction_m > options.loop_refuse_m || l.correction_deg > options.loop_refuse_deg) {
        std::vector<std::pair<size_t, size_t>> keyframes;
        for (const auto& ft : fused_frames)
          if (closer->IsKeyframe(static_cast<int>(ft.first)) || ft.second + 1 == result.trajectory.size())
            keyframes.push_back(ft);
        Refuse(seq, keyframes, result.trajectory, options, dopt, tracker ? tracker.get() : volume);
        result.refused_frames += static_cast<int>(keyframes.size());
        rec.note += fmt::format("; model fused again from {} keyframes", keyframes.size());
      } else {
        closed = false;  // the old model and raycast stay
      }
    }
    rec.t_loop = Seconds(tp);
    tp = std::chrono::steady_clock::now();
    if (!options.poses && (rec.fused || !have_model || closed)) {
      const int rl = RaycastLevel(options, pyr);
      model = (tracker ? tracker.get() : volume)
                  ->Raycast(pyr.K[static_cast<size_t>(rl)], pose, 0.2f, static_cast<float>(dopt.max_m),
                            &pyr.depth[static_cast<size_t>(rl)]);
      model_K = pyr.K[static_cast<size_t>(rl)];
      if (options.preview_every > 0 && (taken - 1) % options.preview_every == 0)
        WritePreview(options, f.index, model, pose);
      model_pose = pose;
    }
    rec.t_raycast = Seconds(tp);
    have_model = true;
    prev_pose = pose;
    prev_pyr = std::move(pyr);
    if (closer) {
      result.loops = closer->loops();
      result.keyframes = closer->keyframes();
      result.loop_candidates = closer->candidates_tried();
    }
    prev_time = f.timestamp;
    finish();
  }
  if (!result.loops.empty()) {
    const auto t0 = std::chrono::steady_clock::now();
    Refuse(seq, fused_frames, result.trajectory, options, dopt, volume);
    result.refused_frames += static_cast<int>(fused_frames.size());
    result.final_refuse_seconds = Seconds(t0);
  }
  return result;
}

namespace {

void ReportLoops(const FuseResult& r, Report* report) {
  nlohmann::json loops = nlohmann::json::array();
  for (const LoopRecord& l : r.loops)
    loops.push_back({{"frame", l.frame},
                     {"keyframe_frame", l.keyframe_frame},
                     {"icp_rms_m", l.rms},
                     {"inlier_ratio", l.inlier_ratio},
                     {"correction_m", l.correction_m},
                     {"correction_deg", l.correction_deg},
                     {"seconds", l.seconds}});
  report->SetMetric("loops", loops);
  report->SetMetric("summary.keyframes", r.keyframes);
  report->SetMetric("summary.loop_candidates", r.loop_candidates);
  report->SetMetric("summary.loops", static_cast<int>(r.loops.size()));
  report->SetMetric("summary.refused_frames", r.refused_frames);
  report->SetMetric("summary.final_refuse_seconds", r.final_refuse_seconds);
  if (r.keyframes > 0 && r.loops.empty())
    report->Skip("loop closure (pose graph, fusing again)",
                 r.loop_candidates == 0
                     ? fmt::format("no keyframe of {} came back near an older one", r.keyframes)
                     : fmt::format("{} loop candidates tried, none confirmed by a second", r.loop_candidates));
}

}  // namespace

void ReportFusion(const FuseResult& r, Report* report) {
  nlohmann::json frames = nlohmann::json::array();
  int tracked = 0, lost = 0, fused = 0, no_depth = 0, not_fused = 0, weak = 0;
  double max_cond = 0, secs = 0;
  for (const FrameRecord& f : r.frames) {
    frames.push_back({{"index", f.index},
                      {"timestamp", f.timestamp},
                      {"status", f.status},
                      {"fused", f.fused},
                      {"note", f.note},
                      {"valid_depth", f.valid_depth},
                      {"rejected_depth", f.rejected_depth},
                      {"icp_rms_m", f.icp_rms},
                      {"inlier_ratio", f.inlier_ratio},
                      {"free_space_ratio", f.free_space_ratio},
                      {"color_pixels", f.color_pixels},
                      {"color_rms", f.color_rms},
                      {"condition", std::isfinite(f.condition) ? nlohmann::json(f.condition) : nlohmann::json("inf")},
                      {"weak_directions", f.weak_directions},
                      {"iterations", f.iterations},
                      {"new_blocks", f.new_blocks},
                      {"seconds", f.seconds},
                      {"seconds_per_part",
                       {{"read", f.t_read},
                        {"pyramid", f.t_pyramid},
                        {"track", f.t_track},
                        {"fuse", f.t_fuse},
                        {"raycast", f.t_raycast},
                        {"loop", f.t_loop}}}});
    tracked += f.status == "tracked" || f.status == "relocalised" || f.status == "first" || f.status == "given";
    lost += f.status == "lost";
    no_depth += f.status == "no_depth";
    fused += f.fused;
    not_fused += !f.fused && (f.status == "tracked" || f.status == "relocalised" || f.status == "given");
    weak += f.weak_directions > 0;
    if (std::isfinite(f.condition)) max_cond = std::max(max_cond, f.condition);
    secs += f.seconds;
  }
  report->SetMetric("frames", frames);
  report->SetMetric("summary.frames", static_cast<int>(r.frames.size()));
  report->SetMetric("summary.tracked", tracked);
  report->SetMetric("summary.lost", lost);
  report->SetMetric("summary.fused", fused);
  report->SetMetric("summary.no_depth", no_depth);
  report->SetMetric("summary.frames_with_weak_directions", weak);
  report->SetMetric("summary.max_condition", max_cond);
  report->SetMetric("summary.frames_per_second", secs > 0 ? static_cast<double>(r.frames.size()) / secs : 0.0);
  report->SetMetric("summary.peak_volume_bytes", r.peak_bytes);
  report->SetMetric("summary.stopped_early", r.stopped_early);
  ReportLoops(r, report);
  if (r.stopped_early) report->Warn(r.stop_reason);
  if (no_depth) report->Skip(fmt::format("{} frames", no_depth), "too little valid depth: neither tracked nor fused");
  if (not_fused)
    report->Skip(fmt::format("fusion of {} tracked frames", not_fused),
                 "they moved less than the skip thresholds and touched no new surface");
  if (lost) report->Warn(fmt::format("tracking lost in {} frames (not fused; see metrics.frames)", lost));
  if (r.suspect_scale > 0) {
    report->SetMetric("summary.suggested_depth_scale", r.suspect_scale);
    report->Warn(
        fmt::format("the depth maps' median depth is implausible for a room at this depth scale; "
                    "{} units per metre would make it plausible (--depth-scale)",
                    r.suspect_scale));
  }
}

}  // namespace mr
