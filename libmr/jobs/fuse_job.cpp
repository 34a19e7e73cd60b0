#include "jobs/fuse_job.h"

#include <spdlog/spdlog.h>

#include <chrono>

#include "camera/trajectory.h"
#include "core/error.h"
#include "core/progress.h"
#include "geometry/mesh.h"
#include "scene/scene.h"

namespace mr {

namespace {

double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

Eigen::AlignedBox3f RoiBox(const std::vector<double>& v) {
  if (v.empty()) return {};
  return Eigen::AlignedBox3f(
      Eigen::Vector3f(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])),
      Eigen::Vector3f(static_cast<float>(v[3]), static_cast<float>(v[4]), static_cast<float>(v[5])));
}

// The virtual objects' world bounds, scaled by `scale` about their centre:
// the region where relighting can change the room (vct uses twice the box).
Eigen::AlignedBox3f RoiFromScene(const std::string& path, double scale) {
  const Scene scene = ReadScene(path, false);
  if (scene.virtuals.empty()) ThrowErrorAt(FileLoc{path}, "has no virtual objects to bound the region");
  Eigen::AlignedBox3d box;
  for (const auto& v : scene.virtuals) {
    const Mesh m = ReadMesh(v.mesh);
    for (const auto& p : m.positions) box.extend(v.world_from_object * p.cast<double>());
  }
  const Eigen::Vector3d c = box.center(), h = 0.5 * scale * box.sizes();
  return Eigen::AlignedBox3f((c - h).cast<float>(), (c + h).cast<float>());
}

// The options as Fuse takes them: the region of interest (said in the
// report), the motion skip, the depth range, the colour and filter flags.
FuseOptions FuseOptionsOf(const FuseJobOptions& o, Report* report) {
  FuseOptions fo = o.fuse;
  fo.tsdf.roi = o.roi_scene.empty() ? RoiBox(o.roi) : RoiFromScene(o.roi_scene, o.roi_scale);
  if (!fo.tsdf.roi.isEmpty()) {
    report->SetMetric("roi.min", {fo.tsdf.roi.min().x(), fo.tsdf.roi.min().y(), fo.tsdf.roi.min().z()});
    report->SetMetric("roi.max", {fo.tsdf.roi.max().x(), fo.tsdf.roi.max().y(), fo.tsdf.roi.max().z()});
    report->Skip("fusion and meshing outside the region of interest",
                 o.roi_scene.empty()
                     ? "--roi"
                     : "outside " + std::to_string(o.roi_scale) + "x the virtual objects' bounds (--roi-from)");
  }
  if (fo.preview_every > 0) fo.preview_dir = fs::path(o.out) / "preview";
  if (o.skip_motion.size() == 2) {
    fo.skip_translation_m = o.skip_motion[0] / 1000;
    fo.skip_rotation_deg = o.skip_motion[1];
  }
  fo.depth.max_m = o.max_depth;
  fo.use_color = !o.no_color;
  fo.pyramid.bilateral = !o.no_bilateral;
  fo.loop.enabled = !o.no_loop_closure;
  if (o.no_loop_closure) report->Skip("loop closure", "--no-loop-closure");
  return fo;
}

// The recording, opened and described; the poses to fuse with (given, or
// the recording's reference) and where tracking starts.
RgbdSequence OpenRecording(const FuseJobOptions& o, FuseOptions* fo, Report* report) {
  RgbdOpenOptions ro = o.rgbd;
  if (o.intrinsics.size() == 4)
    ro.intrinsics =
        PinholeIntrinsics{.fx = o.intrinsics[0], .fy = o.intrinsics[1], .cx = o.intrinsics[2], .cy = o.intrinsics[3]};
  const RgbdSequence seq = OpenRgbdSequence(o.input, ro);
  report->AddInput(o.input);
  if (seq.unpaired_depth)
    report->Warn(fmt::format("{} depth images have no colour image within {} s and are left out", seq.unpaired_depth,
                             ro.max_dt));
  if (o.poses == "reference") {
    if (seq.reference.poses.empty())
      ThrowErrorAt(FileLoc{o.input}, "--poses reference: the recording has no reference trajectory");
    fo->poses = seq.reference;
  } else if (!o.poses.empty()) {
    fo->poses = ReadTum(o.poses);
    report->AddInput(o.poses);
  }
  if (o.first_pose == "reference") {
    if (seq.reference.poses.empty())
      ThrowErrorAt(FileLoc{o.input}, "--first-pose reference: the recording has no reference trajectory");
    fo->first_pose = seq.reference.poses.front().world_from_cam;
  }
  report->SetMetric("input.layout", seq.layout);
  report->SetMetric("input.frames", static_cast<int>(seq.frames.size()));
  report->SetMetric("input.intrinsics", {seq.K.fx, seq.K.fy, seq.K.cx, seq.K.cy, seq.K.width, seq.K.height});
  report->SetMetric("input.depth_scale", seq.depth_scale);
  spdlog::info("{}: {} frames ({} layout), {}x{}, fx {:.1f}", o.input, seq.frames.size(), seq.layout, seq.K.width,
               seq.K.height, seq.K.fx);
  DepthReadOptions dopt = fo->depth;
  dopt.scale = seq.depth_scale;
  if (const double k = CheckDepthScale(seq, dopt); k > 0)
    spdlog::warn(
        "{}: the depth maps' median depth is implausible for a room at {} units per metre; {} would make "
        "it plausible (--depth-scale)",
        o.input, seq.depth_scale, k);
  return seq;
}

// Tracking and fusion into `volume`, with progress.
FuseResult FuseRecording(const std::string& input, const RgbdSequence& seq, const FuseOptions& fo, TsdfVolume* volume,
                         Report* report) {
  const int total = fo.count >= 0 ? fo.count : static_cast<int>(seq.frames.size());
  Progress progress("fuse", total);
  int done = 0;
  const auto t0 = std::chrono::steady_clock::now();
  const FuseResult fr = Fuse(seq, fo, volume, [&](const FrameRecord& r) {
    progress.Update(++done);
    if (r.status == "lost") spdlog::warn("frame {}: tracking lost ({})", r.index, r.note);
  });
  progress.Done();
  report->AddTiming("fusion", SecondsSince(t0));
  ReportFusion(fr, report);
  if (fr.trajectory.poses.empty()) ThrowErrorAt(FileLoc{input}, "no frame could be fused");
  return fr;
}

// The surface, with each vertex's fused weight as its confidence.
Mesh MeshVolume(const FuseJobOptions& o, const TsdfVolume& volume, const Eigen::AlignedBox3f& roi,
                std::vector<float>* confidence, Report* report) {
  const auto t0 = std::chrono::steady_clock::now();
  MeshOptions mo = o.mesh;
  mo.roi = roi;
  MeshStats ms;
  Mesh mesh = volume.ExtractMesh(mo, confidence, &ms);
  report->AddTiming("meshing", SecondsSince(t0));
  if (mesh.triangles.empty())
    ThrowErrorAt(FileLoc{o.input},
                 "the fused volume holds no surface to mesh ({} frames fused; voxels need a weight of {} or more)",
                 report->metrics()["summary"]["fused"].get<int>(), mo.min_weight);
  report->SetMetric("mesh.vertices", static_cast<int64_t>(mesh.vertex_count()));
  report->SetMetric("mesh.triangles", static_cast<int64_t>(mesh.triangle_count()));
  report->SetMetric("mesh.components_dropped", ms.components_dropped);
  report->SetMetric("mesh.small_component_triangles_dropped", ms.triangles_dropped);
  report->SetMetric("mesh.degenerate_triangles_dropped", ms.degenerate_dropped);
  report->SetMetric("volume.blocks", volume.block_count());
  report->SetMetric("volume.bytes", volume.MemoryBytes());
  return mesh;
}

}  // namespace

void FuseJobOptions::Check() const {
  if (rgbd.layout != "auto" && rgbd.layout != "tum" && rgbd.layout != "7scenes" && rgbd.layout != "plain")
    throw UsageError(fmt::format("--layout: \"{}\" is not one of auto, tum, 7scenes, plain", rgbd.layout));
  if (!intrinsics.empty() && intrinsics.size() != 4) throw UsageError("--intrinsics: give fx,fy,cx,cy");
  if (!roi.empty() && roi.size() != 6) throw UsageError("--roi: give xmin,ymin,zmin,xmax,ymax,zmax");
  if (!roi.empty() && !roi_scene.empty()) throw UsageError("--roi and --roi-from contradict each other");
  if (!roi.empty() && RoiBox(roi).isEmpty())
    throw UsageError("--roi: the minimum corner must be below the maximum corner");
  if (!skip_motion.empty() && skip_motion.size() != 2) throw UsageError("--skip-motion: give MM,DEG");
  if (fuse.icp.iterations.empty() || fuse.icp.iterations.size() > 4)
    throw UsageError("--icp-iterations: give 1 to 4 counts, finest level first");
  if (first_pose != "identity" && first_pose != "reference") throw UsageError("--first-pose: identity or reference");
  if (fuse.stride < 1) throw UsageError("--stride must be at least 1");
  if (!(fuse.tsdf.voxel_size > 0)) throw UsageError("--voxel must be positive");
  if (!(roi_scale > 0)) throw UsageError("--roi-scale must be positive");
  if (!(albedo.camera_scale > 0)) throw UsageError("--camera-scale must be positive");
  if (fuse.raycast_level < 0 || fuse.raycast_level > 2) throw UsageError("--raycast-level must be 0, 1 or 2");
}

void RunFuse(const FuseJobOptions& o, Report* report) {
  o.Check();
  FuseOptions fo = FuseOptionsOf(o, report);
  const RgbdSequence seq = OpenRecording(o, &fo, report);
  TsdfVolume volume(fo.tsdf);
  const FuseResult fr = FuseRecording(o.input, seq, fo, &volume, report);
  std::vector<float> confidence;
  Mesh mesh = MeshVolume(o, volume, fo.tsdf.roi, &confidence, report);

  const auto t0 = std::chrono::steady_clock::now();
  if (o.no_albedo) {
    report->Skip("albedo", "--no-albedo: vertex colour is the fused voxel colour");
  } else if (!seq.has_color() || o.no_color) {
    report->Skip("albedo", "the recording has no colour images (or --no-color)");
  } else {
    AlbedoOptions ao = o.albedo;
    ao.lights = o.lights;
    ao.env = o.env;
    ComputeAlbedo(seq, fr, fo.depth.max_m, ao, &mesh, report);
    report->AddTiming("albedo", SecondsSince(t0));
  }
  mesh.scalars.push_back({"confidence", std::move(confidence)});

  fs::create_directories(o.out);
  const fs::path ply = fs::path(o.out) / "room.ply", traj = fs::path(o.out) / "trajectory.txt";
  WritePly(ply, mesh, "mr-fuse room: colour = albedo (linear); confidence = fused weight");
  WriteTum(traj, fr.trajectory);
  report->AddOutput(ply.string());
  report->AddOutput(traj.string());
  report->AddOutput((fs::path(o.out) / "fuse-report.json").string());
  report->Write(fs::path(o.out) / "fuse-report.json");
  spdlog::info("{} frames tracked of {}, {} lost; mesh {} vertices, {} triangles; volume {:.1f} MB -> {}",
               fr.trajectory.size(), fr.frames.size(), report->metrics()["summary"]["lost"].get<int>(),
               mesh.vertex_count(), mesh.triangle_count(), volume.MemoryBytes() / 1e6, o.out);
  if (fr.stopped_early) spdlog::warn("{}", fr.stop_reason);
}

}  // namespace mr
