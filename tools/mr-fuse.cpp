// mr-fuse: KinectFusion-style reconstruction of a room from an RGB-D recording.
#include "cli/tool.h"
#include "jobs/fuse_job.h"

int main(int argc, char** argv) {
  CLI::App app;
  mr::FuseJobOptions o;
  mr::RgbdOpenOptions& ro = o.rgbd;
  mr::FuseOptions& fo = o.fuse;
  mr::MeshOptions& mo = o.mesh;
  mr::AlbedoOptions& ao = o.albedo;
  mr::ConfigureApp(
      app, "mr-fuse",
      "Reconstructs a room from an RGB-D recording, KinectFusion-style: bilateral-filtered depth on a\n"
      "3-level pyramid, point-to-plane ICP against the model's raycast (frame to model; a photometric\n"
      "term where depth alone leaves a direction weak), loop closure (keyframes, loops verified by ICP\n"
      "and confirmed by two other keyframes, a Ceres pose graph, the volume fused again), fusion into a\n"
      "TSDF in hashed 8^3 voxel blocks (memory grows with the surface), and surface-nets meshing. Writes\n"
      "OUT/room.ply (binary: positions, normals, colour = albedo, float albedo_r/g/b, observed_r/g/b and\n"
      "confidence), OUT/trajectory.txt (TUM, camera-to-world) and OUT/fuse-report.json (per frame: ICP\n"
      "residual, inlier ratio, condition number, weak directions, time; memory; what was skipped).\n"
      "Layouts: TUM RGB-D (depth.txt, rgb.txt; 5000 units/m), 7-Scenes (frame-NNNNNN.depth.png; mm),\n"
      "plain (depth/ and rgb/ beside a .cameramodel; mm; groundtruth.txt, TUM). Depth codes 0 and 65535 are invalid.\n"
      "Albedo: the viewing-angle-weighted mean colour per vertex; with --lights or --env, the colour\n"
      "divided by the irradiance ray traced over the reconstructed room (the room's own observed\n"
      "radiance as the bounce light), solved robustly across views with per-frame gains (Ceres).",
      "  mr-fuse capture/rgbd --out room/ --voxel 0.01\n"
      "  mr-fuse ../shared/data/rgbd-7scenes-kitchen --out kitchen/ --voxel 0.02 --report fuse.json\n"
      "  mr-fuse capture/rgbd --out room/ --poses capture/rgbd/groundtruth.txt --roi -1,-1,0,1,1,2");
  app.add_option("input", o.input, "RGB-D recording folder")->required()->check(CLI::ExistingDirectory);
  app.add_option("--out", o.out, "Output folder")->required();
  app.add_option("--layout", ro.layout, "auto, tum, 7scenes or plain")->default_val("auto");
  app.add_option("--depth-scale", ro.depth_scale, "Depth units per metre (default: the layout's)");
  app.add_option("--intrinsics", o.intrinsics, "Depth camera fx,fy,cx,cy (pixel centres at integers)")
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
  app.add_option("--max-depth", o.max_depth, "Ignore depth beyond (m)")->default_val(8.0);
  app.add_option("--roi", o.roi, "Fuse and mesh only inside xmin,ymin,zmin,xmax,ymax,zmax (world, m)")
      ->delimiter(',')
      ->expected(6);
  app.add_option("--roi-from", o.roi_scene, "Fuse and mesh only around this scene's virtual objects")
      ->check(CLI::ExistingFile);
  app.add_option("--roi-scale", o.roi_scale, "--roi-from: the objects' bounding box scaled by this")
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
  app.add_option("--skip-motion", o.skip_motion,
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
  app.add_option("--color-term", fo.icp.color_term,
                 "Tracking's photometric term (the previous frame's intensity): weak (only in steps where depth "
                 "alone leaves a direction weak), always, or off")
      ->default_val(fo.icp.color_term)
      ->check(CLI::IsMember({"weak", "always", "off"}));
  app.add_option("--color-weight", fo.icp.color_weight,
                 "Weight of the photometric term against point-to-plane ICP (metres against intensity)")
      ->default_val(fo.icp.color_weight)
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--no-loop-closure", o.no_loop_closure,
               "Track without looking for loops (no keyframes, pose graph or fusing again)");
  app.add_option("--loop-radius", fo.loop.search_radius_m,
                 "Look for loops among keyframes whose tracked pose is within this many metres (and "
                 "--loop-angle degrees) of a new keyframe's; also the largest drift a loop can undo")
      ->default_val(fo.loop.search_radius_m)
      ->check(mr::kPositive);
  app.add_option("--loop-angle", fo.loop.search_angle_deg, "See --loop-radius (degrees)")
      ->default_val(fo.loop.search_angle_deg)
      ->check(mr::kPositive);
  app.add_option("--loop-min-gap", fo.loop.min_frame_gap, "A loop joins frames at least this many frames apart")
      ->default_val(fo.loop.min_frame_gap)
      ->check(mr::kPositive);
  app.add_option("--max-lost", fo.max_lost, "Stop (keeping what is fused) after this many lost frames in a row")
      ->default_val(10);
  app.add_option("--poses", o.poses,
                 "Fuse with this TUM trajectory (or 'reference': the recording's) instead of tracking");
  app.add_option("--first-pose", o.first_pose, "identity, or 'reference': start tracking at the reference's first pose")
      ->default_val("identity");
  app.add_option("--min-weight", mo.min_weight, "Mesh voxels fused at least this often")->default_val(1.5);
  app.add_option("--min-component", mo.min_component_triangles, "Drop mesh pieces with fewer triangles")
      ->default_val(64);
  app.add_flag("--no-color", o.no_color, "Ignore colour images");
  app.add_flag("--no-bilateral", o.no_bilateral, "Do not filter depth");
  app.add_option("--lights", o.lights, "lights.json: de-light the albedo")->check(CLI::ExistingFile);
  app.add_option("--env", o.env, "Environment map (lat-long EXR): de-light the albedo")->check(CLI::ExistingFile);
  app.add_option("--albedo-stride", ao.frame_stride, "Albedo: use every Nth fused frame")->default_val(5);
  app.add_option("--albedo-rays", ao.rays, "Albedo: hemisphere rays per vertex for the irradiance")->default_val(256);
  app.add_option("--camera-scale", ao.camera_scale,
                 "Albedo: colour units per unit of radiance (mr-synth: truth.json's color_exposure)")
      ->default_val(1.0)
      ->check(mr::kPositive);
  app.add_flag("--no-albedo", o.no_albedo, "Skip the albedo pass (colour = fused voxel colour)");
  return mr::RunTool("mr-fuse", app, argc, argv, [&] {
    mr::RunFuse(o, &mr::ToolReport());
    return mr::kExitOk;
  });
}
