// mr-planes: a room from a video without depth: the planes its sparse
// points support.
#include "cli/tool.h"
#include "jobs/planes_job.h"

int main(int argc, char** argv) {
  CLI::App app;
  mr::ConfigureApp(app, "mr-planes",
                   "The room as the planes a point cloud supports: COLMAP's sparse points of a video "
                   "(mr-register --points-out)\n"
                   "become the floor, table tops and walls. Planes are found one after another by RANSAC, "
                   "turned to gravity (up:\n"
                   "the normal of the largest plane near the cameras' mean up, or --up; planes within "
                   "--snap-deg of level or\n"
                   "upright made exactly so), and meshed as a grid of cells within --grow of their points "
                   "(holes filled, parts with\n"
                   "fewer than --min-points dropped); with --frames each vertex takes the median colour the "
                   "frames saw there\n"
                   "(unoccluded, not clipped) as its albedo. A model in COLMAP's own units is scaled to "
                   "metres by --height, the\n"
                   "cameras' mean height over the support plane. The report lists every plane.",
                   "  mr-planes work/points.ply --poses work/poses.tum --camera camera.cameramodel \\\n"
                   "      --frames video/%05d.jpg --out work/room.ply");
  mr::PlanesJobOptions o;
  mr::PlaneOptions& po = o.planes;
  mr::PlaneMeshOptions& mo = o.mesh;
  app.add_option("POINTS", o.points, "Point cloud (PLY, OBJ: its vertices), in metres unless --height")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--poses", o.poses, "The frames' poses (TUM, world_from_cam, one per frame)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--camera", o.camera, "The frames' .cameramodel (with --frames)")->check(CLI::ExistingFile);
  app.add_option("--frames", o.frames, "printf pattern of the frames (video/%05d.jpg): the albedo");
  app.add_option("--frames-transfer", o.transfer, "8/16-bit frames: srgb (decoded) or linear")
      ->default_val("srgb")
      ->check(CLI::IsMember({"srgb", "linear"}));
  app.add_option("--frame-stride", o.frame_stride, "Albedo from every Nth frame")
      ->default_val(1)
      ->check(mr::InRange(1, 100000));
  app.add_option("--max-view-deg", o.max_view_deg, "Albedo: leave out views more oblique than this")->default_val(80);
  app.add_option("--up", o.up, "Gravity hint X,Y,Z (default: the cameras' mean up, -y of each)")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--height", o.height,
                 "Scale points and poses so the cameras' mean centre is this many metres over the lowest level "
                 "plane below them, the floor where one is seen (0: the points are in metres)")
      ->default_val(0);
  app.add_option("--out", o.out, "The room's mesh (PLY, albedo as vertex colours)")->required();
  app.add_option("--world", o.world,
                 "Frame of the outputs: points (the input's), first-camera (the first pose's camera frame, "
                 "as mr-fuse's room) or gravity (that frame turned so that up is +y, the scene's default up); "
                 "--up is in the input's frame")
      ->default_val("points")
      ->check(CLI::IsMember({"points", "first-camera", "gravity"}));
  app.add_option("--poses-out", o.poses_out, "The poses as written (scaled by --height, moved by --world)");
  app.add_option("--distance", po.distance, "Inlier distance to a plane (m)")->default_val(po.distance);
  app.add_option("--min-points", po.min_points, "Points a plane and each of its parts needs")
      ->default_val(po.min_points);
  app.add_option("--min-fraction", po.min_fraction, "Fraction of all points a plane needs")
      ->default_val(po.min_fraction);
  app.add_option("--max-planes", po.max_planes, "At most this many planes")->default_val(po.max_planes);
  app.add_option("--hypotheses", po.hypotheses, "RANSAC hypotheses per plane")->default_val(po.hypotheses);
  app.add_option("--up-hint-deg", po.up_hint_deg, "The plane that fixes up lies within this of the hint")
      ->default_val(po.up_hint_deg);
  app.add_option("--snap-deg", po.snap_deg, "Planes within this of level or upright are made exactly so")
      ->default_val(po.snap_deg);
  app.add_option("--seed", po.seed, "RANSAC's seed")->default_val(po.seed);
  app.add_option("--merge-distance", po.merge_distance,
                 "Level (or upright, same-facing) planes closer than this (m) are one surface: merged (0: never)")
      ->default_val(po.merge_distance);
  app.add_flag("--keep-slanted", po.keep_slanted,
               "Keep planes neither level nor upright (dropped by default: in a room they are mostly fits across "
               "two surfaces)");
  app.add_option("--cell", mo.cell, "Grid spacing of the meshed planes (m)")->default_val(mo.cell);
  app.add_option("--grow", mo.grow, "Surface reaches this far from a plane's points (m)")->default_val(mo.grow);
  return mr::RunTool("mr-planes", app, argc, argv, [&] {
    o.mesh.min_points = o.planes.min_points;
    mr::RunPlanes(o, &mr::ToolReport());
    return mr::kExitOk;
  });
}
