// mr-fuse: KinectFusion-style reconstruction of a room from an RGB-D recording.
#include <spdlog/spdlog.h>

#include <chrono>

#include "camera/trajectory.h"
#include "cli/tool.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/report.h"
#include "recon/albedo.h"
#include "recon/fusion.h"
#include "scene/scene.h"

namespace {

Eigen::AlignedBox3f ParseRoi(const std::vector<double>& v) {
  if (v.empty()) return {};
  Eigen::AlignedBox3f b(Eigen::Vector3f(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])),
                        Eigen::Vector3f(static_cast<float>(v[3]), static_cast<float>(v[4]), static_cast<float>(v[5])));
  if (b.isEmpty()) throw mr::UsageError("--roi: the minimum corner must be below the maximum corner");
  return b;
}

// The virtual objects' world bounds, scaled by `scale` about their centre:
// the region where relighting can change the room (vct uses twice the box).
Eigen::AlignedBox3f RoiFromScene(const std::string& path, double scale) {
  const mr::Scene scene = mr::ReadScene(path, false);
  if (scene.virtuals.empty()) mr::ThrowErrorAt(mr::FileLoc{path}, "has no virtual objects to bound the region");
  Eigen::AlignedBox3d box;
  for (const auto& v : scene.virtuals) {
    const mr::Mesh m = mr::ReadMesh(v.mesh);
    for (const auto& p : m.positions) box.extend(v.world_from_object * p.cast<double>());
  }
  const Eigen::Vector3d c = box.center(), h = 0.5 * scale * box.sizes();
  return Eigen::AlignedBox3f((c - h).cast<float>(), (c + h).cast<float>());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app;
  std::string input, out, poses, first_pose = "identity", lights, env, roi_scene;
  double roi_scale = 2.0;
  std::vector<double> intrinsics, roi, skip_motion;
  mr::RgbdOpenOptions ro;
  mr::FuseOptions fo;
  mr::MeshOptions mo;
  mr::AlbedoOptions ao;
  bool no_color = false, no_bilateral = false, no_albedo = false;
  double max_depth = 8.0;
  mr::ConfigureApp(app, "mr-fuse",
                   "Reconstructs a room from an RGB-D recording, KinectFusion-style: bilateral-filtered depth on a\n"
                   "3-level pyramid, point-to-plane ICP against the model's raycast (frame to model), fusion into a\n"
                   "TSDF in hashed 8^3 voxel blocks (memory grows with the surface), and surface-nets meshing. Writes\n"
                   "OUT/room.ply (binary: positions, normals, colour = albedo, float albedo_r/g/b, observed_r/g/b and\n"
                   "confidence), OUT/trajectory.txt (TUM, camera-to-world) and OUT/fuse-report.json (per frame: ICP\n"
                   "residual, inlier ratio, condition number, weak directions, time; memory; what was skipped).\n"
                   "Layouts: TUM RGB-D (depth.txt, rgb.txt; 5000 units/m), 7-Scenes (frame-NNNNNN.depth.png; mm),\n"
                   "plain (depth/ and rgb/ beside a .cameramodel; mm). Depth codes 0 and 65535 are invalid.\n"
                   "Albedo: the viewing-angle-weighted mean colour per vertex; with --lights or --env, the colour\n"
                   "divided by the irradiance ray traced over the reconstructed room (the room's own observed\n"
                   "radiance as the bounce light), solved robustly across views with per-frame gains (Ceres).",
                   "  mr-fuse capture/rgbd --out room/ --voxel 0.01\n"
                   "  mr-fuse ../shared/data/rgbd-7scenes-kitchen --out kitchen/ --voxel 0.02 --report fuse.json\n"
                   "  mr-fuse capture/rgbd --out room/ --poses capture/rgbd/groundtruth.txt --roi -1,-1,0,1,1,2");
  app.add_option("input", input, "RGB-D recording folder")->required()->check(CLI::ExistingDirectory);
  app.add_option("--out", out, "Output folder")->required();
  app.add_option("--layout", ro.layout, "auto, tum, 7scenes or plain")->default_val("auto");
  app.add_option("--depth-scale", ro.depth_scale, "Depth units per metre (default: the layout's)");
  app.add_option("--intrinsics", intrinsics, "Depth camera fx,fy,cx,cy (pixel centres at integers)")
      ->delimiter(',')
      ->expected(4);
  app.add_option("--max-dt", ro.max_dt, "TUM colour-depth association: largest time difference (s)")->default_val(0.02);
  app.add_option("--first", fo.first, "First frame (index in the recording)")->default_val(0);
  app.add_option("--count", fo.count, "Frames to use (-1: all)")->default_val(-1);
  app.add_option("--stride", fo.stride, "Use every Nth frame")->default_val(1)->check(mr::kPositive);
  app.add_option("--voxel", fo.tsdf.voxel_size, "Voxel size (m)")->default_val(0.01)->check(mr::kPositive);
  app.add_option("--truncation", fo.tsdf.truncation, "Truncation distance (m); 0: 4 voxels, at least 1.5 cm")
      ->default_val(0);
  app.add_option("--max-weight", fo.tsdf.max_weight, "Running-average window (frames)")->default_val(128);
  app.add_option("--max-blocks", fo.tsdf.max_blocks, "Refuse to allocate more 8^3 voxel blocks (memory bound)")
      ->default_val(4000000);
  app.add_option("--max-depth", max_depth, "Ignore depth beyond (m)")->default_val(8.0);
  app.add_option("--roi", roi, "Fuse and mesh only inside xmin,ymin,zmin,xmax,ymax,zmax (world, m)")
      ->delimiter(',')
      ->expected(6);
  app.add_option("--roi-from", roi_scene, "Fuse and mesh only around this scene's virtual objects")
      ->check(CLI::ExistingFile);
  app.add_option("--roi-scale", roi_scale, "--roi-from: the objects' bounding box scaled by this")
      ->default_val(2.0)
      ->check(mr::kPositive);
  app.add_option("--tracking-voxel", fo.tracking_voxel,
                 "With --roi/--roi-from: voxel of the whole-room volume that tracking uses (default: --voxel)")
      ->default_val(0);
  app.add_option("--preview-every", fo.preview_every,
                 "Write the model's raycast, shaded, every N frames to OUT/preview/")
      ->default_val(0);
  app.add_option("--icp-iterations", fo.icp.iterations, "ICP iterations per level, finest first")
      ->delimiter(',')
      ->default_str("10,5,4");
  app.add_option("--skip-motion", skip_motion,
                 "Do not fuse tracked frames that moved less than MM,DEG since the last fused one and see no "
                 "new surface")
      ->delimiter(',')
      ->expected(2);
  app.add_option("--weak-ratio", fo.icp.weak_eigen_ratio,
                 "ICP directions whose eigenvalue is below this fraction of the largest are held to the motion prior")
      ->default_val(fo.icp.weak_eigen_ratio);
  app.add_option("--motion-model", fo.motion_model, "Tracking prediction: velocity (constant velocity) or static")
      ->default_val("velocity")
      ->check(CLI::IsMember({"velocity", "static"}));
  app.add_option("--raycast-level", fo.raycast_level,
                 "Raycast the model at this pyramid level (0: full resolution; 1: half, 4x fewer rays)")
      ->default_val(1)
      ->check(mr::InRange(0, 2));
  app.add_option("--max-lost", fo.max_lost, "Stop (keeping what is fused) after this many lost frames in a row")
      ->default_val(10);
  app.add_option("--poses", poses,
                 "Fuse with this TUM trajectory (or 'reference': the recording's) instead of tracking");
  app.add_option("--first-pose", first_pose, "identity, or 'reference': start tracking at the reference's first pose")
      ->default_val("identity");
  app.add_option("--min-weight", mo.min_weight, "Mesh voxels fused at least this often")->default_val(1.5);
  app.add_option("--min-component", mo.min_component_triangles, "Drop mesh pieces with fewer triangles")
      ->default_val(64);
  app.add_flag("--no-color", no_color, "Ignore colour images");
  app.add_flag("--no-bilateral", no_bilateral, "Do not filter depth");
  app.add_option("--lights", lights, "lights.json: de-light the albedo")->check(CLI::ExistingFile);
  app.add_option("--env", env, "Environment map (lat-long EXR): de-light the albedo")->check(CLI::ExistingFile);
  app.add_option("--albedo-stride", ao.frame_stride, "Albedo: use every Nth fused frame")->default_val(5);
  app.add_option("--albedo-rays", ao.rays, "Albedo: hemisphere rays per vertex for the irradiance")->default_val(256);
  app.add_option("--camera-scale", ao.camera_scale,
                 "Albedo: colour units per unit of radiance (mr-synth: truth.json's color_exposure)")
      ->default_val(1.0)
      ->check(mr::kPositive);
  app.add_flag("--no-albedo", no_albedo, "Skip the albedo pass (colour = fused voxel colour)");
  return mr::RunTool("mr-fuse", app, argc, argv, [&] {
    mr::Report& report = mr::ToolReport();
    if (intrinsics.size() == 4) {
      mr::PinholeIntrinsics k;
      k.fx = intrinsics[0];
      k.fy = intrinsics[1];
      k.cx = intrinsics[2];
      k.cy = intrinsics[3];
      ro.intrinsics = k;
    }
    if (!roi.empty() && !roi_scene.empty()) throw mr::UsageError("--roi and --roi-from contradict each other");
    fo.tsdf.roi = roi_scene.empty() ? ParseRoi(roi) : RoiFromScene(roi_scene, roi_scale);
    mo.roi = fo.tsdf.roi;
    if (!fo.tsdf.roi.isEmpty()) {
      report.SetMetric("roi.min", {fo.tsdf.roi.min().x(), fo.tsdf.roi.min().y(), fo.tsdf.roi.min().z()});
      report.SetMetric("roi.max", {fo.tsdf.roi.max().x(), fo.tsdf.roi.max().y(), fo.tsdf.roi.max().z()});
      report.Skip("fusion and meshing outside the region of interest",
                  roi_scene.empty()
                      ? "--roi"
                      : "outside " + std::to_string(roi_scale) + "x the virtual objects' bounds (--roi-from)");
    }
    if (fo.preview_every > 0) fo.preview_dir = mr::fs::path(out) / "preview";
    if (skip_motion.size() == 2) {
      fo.skip_translation_m = skip_motion[0] / 1000;
      fo.skip_rotation_deg = skip_motion[1];
    }
    fo.depth.max_m = max_depth;
    fo.use_color = !no_color;
    fo.pyramid.bilateral = !no_bilateral;
    if (fo.icp.iterations.empty() || fo.icp.iterations.size() > 4)
      throw mr::UsageError("--icp-iterations: give 1 to 4 counts, finest level first");
    const mr::RgbdSequence seq = mr::OpenRgbdSequence(input, ro);
    report.AddInput(input);
    if (seq.unpaired_depth)
      report.Warn(fmt::format("{} depth images have no colour image within {} s and are left out", seq.unpaired_depth,
                              ro.max_dt));
    if (!poses.empty()) {
      if (poses == "reference") {
        if (seq.reference.poses.empty())
          mr::ThrowErrorAt(mr::FileLoc{input}, "--poses reference: the recording has no reference trajectory");
        fo.poses = seq.reference;
      } else {
        fo.poses = mr::ReadTum(poses);
        report.AddInput(poses);
      }
    }
    if (first_pose == "reference") {
      if (seq.reference.poses.empty())
        mr::ThrowErrorAt(mr::FileLoc{input}, "--first-pose reference: the recording has no reference trajectory");
      fo.first_pose = seq.reference.poses.front().world_from_cam;
    } else if (first_pose != "identity") {
      throw mr::UsageError("--first-pose: identity or reference");
    }
    report.SetMetric("input.layout", seq.layout);
    report.SetMetric("input.frames", static_cast<int>(seq.frames.size()));
    report.SetMetric("input.intrinsics", {seq.K.fx, seq.K.fy, seq.K.cx, seq.K.cy, seq.K.width, seq.K.height});
    report.SetMetric("input.depth_scale", seq.depth_scale);
    spdlog::info("{}: {} frames ({} layout), {}x{}, fx {:.1f}", input, seq.frames.size(), seq.layout, seq.K.width,
                 seq.K.height, seq.K.fx);

    {
      mr::DepthReadOptions dopt = fo.depth;
      dopt.scale = seq.depth_scale;
      if (const double k = mr::CheckDepthScale(seq, dopt); k > 0)
        spdlog::warn(
            "{}: the depth maps' median depth is implausible for a room at {} units per metre; {} would make "
            "it plausible (--depth-scale)",
            input, seq.depth_scale, k);
    }
    mr::TsdfVolume volume(fo.tsdf);
    const int total = fo.count >= 0 ? fo.count : static_cast<int>(seq.frames.size());
    mr::Progress progress("fuse", total);
    int done = 0;
    auto t0 = std::chrono::steady_clock::now();
    const mr::FuseResult fr = mr::Fuse(seq, fo, &volume, [&](const mr::FrameRecord& r) {
      progress.Update(++done);
      if (r.status == "lost") spdlog::warn("frame {}: tracking lost ({})", r.index, r.note);
    });
    progress.Done();
    report.AddTiming("fusion", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    mr::ReportFusion(fr, &report);
    if (fr.trajectory.poses.empty()) mr::ThrowErrorAt(mr::FileLoc{input}, "no frame could be fused");

    t0 = std::chrono::steady_clock::now();
    std::vector<float> confidence;
    mr::MeshStats ms;
    mr::Mesh mesh = volume.ExtractMesh(mo, &confidence, &ms);
    report.AddTiming("meshing", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    if (mesh.triangles.empty())
      mr::ThrowErrorAt(
          mr::FileLoc{input},
          "the fused volume holds no surface to mesh ({} frames fused; voxels need a weight of {} or more)",
          report.metrics()["summary"]["fused"].get<int>(), mo.min_weight);
    report.SetMetric("mesh.vertices", static_cast<int64_t>(mesh.vertex_count()));
    report.SetMetric("mesh.triangles", static_cast<int64_t>(mesh.triangle_count()));
    report.SetMetric("mesh.components_dropped", ms.components_dropped);
    report.SetMetric("mesh.small_component_triangles_dropped", ms.triangles_dropped);
    report.SetMetric("mesh.degenerate_triangles_dropped", ms.degenerate_dropped);
    report.SetMetric("volume.blocks", volume.block_count());
    report.SetMetric("volume.bytes", volume.MemoryBytes());

    t0 = std::chrono::steady_clock::now();
    if (no_albedo) {
      report.Skip("albedo", "--no-albedo: vertex colour is the fused voxel colour");
    } else if (!seq.has_color() || no_color) {
      report.Skip("albedo", "the recording has no colour images (or --no-color)");
    } else {
      ao.lights = lights;
      ao.env = env;
      mr::ComputeAlbedo(seq, fr, fo.depth.max_m, ao, &mesh, &report);
      report.AddTiming("albedo", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    mesh.scalars.push_back({"confidence", std::move(confidence)});

    mr::fs::create_directories(out);
    const mr::fs::path ply = mr::fs::path(out) / "room.ply", traj = mr::fs::path(out) / "trajectory.txt";
    mr::WritePly(ply, mesh, "mr-fuse room: colour = albedo (linear); confidence = fused weight");
    mr::WriteTum(traj, fr.trajectory);
    report.AddOutput(ply.string());
    report.AddOutput(traj.string());
    report.AddOutput((mr::fs::path(out) / "fuse-report.json").string());
    report.Write(mr::fs::path(out) / "fuse-report.json");
    spdlog::info("{} frames tracked of {}, {} lost; mesh {} vertices, {} triangles; volume {:.1f} MB -> {}",
                 fr.trajectory.size(), fr.frames.size(), report.metrics()["summary"]["lost"].get<int>(),
                 mesh.vertex_count(), mesh.triangle_count(), volume.MemoryBytes() / 1e6, out);
    // A run stopped by tracking loss still succeeded with what it fused: the
    // report says where it stopped and why (exit 0; check summary.stopped_early).
    if (fr.stopped_early) spdlog::warn("{}", fr.stop_reason);
    return mr::kExitOk;
  });
}
