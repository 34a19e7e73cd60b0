#include "jobs/planes_job.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "camera/camera_model.h"
#include "camera/trajectory.h"
#include "core/error.h"
#include "core/image.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "geometry/embree_scene.h"
#include "geometry/mesh.h"
#include "recon/albedo.h"
#include "scene/frames.h"

namespace mr {

void PlanesJobOptions::Check() const {
  planes.Check();
  if (out.empty()) throw UsageError("--out is required");
  if (poses.empty()) throw UsageError("--poses is required (the cameras fix gravity and the normals' sides)");
  if (!frames.empty() && camera.empty()) throw UsageError("--frames needs --camera");
  if (transfer != "srgb" && transfer != "linear") throw UsageError("--frames-transfer: srgb or linear");
  if (frame_stride < 1) throw UsageError("--frame-stride must be at least 1");
  if (!(max_view_deg > 0 && max_view_deg < 90)) throw UsageError("--max-view-deg must be in (0, 90)");
  if (!up.empty() && (up.size() != 3 || !Eigen::Vector3d(up[0], up[1], up[2]).allFinite() ||
                      Eigen::Vector3d(up[0], up[1], up[2]).norm() == 0))
    throw UsageError("--up: three numbers, not all zero");
  if (!(height >= 0 && std::isfinite(height))) throw UsageError("--height must be 0 (none) or positive");
  if (world != "points" && world != "first-camera" && world != "gravity")
    throw UsageError("--world: points, first-camera or gravity");
  if ((height > 0 || world != "points") && poses_out.empty())
    throw UsageError("--height and --world first-camera or gravity move the poses: give --poses-out");
  if (!(mesh.cell > 0) || !(mesh.grow >= 0)) throw UsageError("--cell must be positive and --grow not negative");
}

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

Eigen::Vector3d MeanCentre(const Trajectory& t) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const TimedPose& p : t.poses) c += p.world_from_cam.translation;
  return c / static_cast<double>(t.poses.size());
}

// The lowest level plane below `eye` (the floor where one is seen), or
// nullptr.
const Plane* SupportPlane(const PlaneSet& set, const Eigen::Vector3d& eye) {
  const Plane* lowest = nullptr;
  for (const Plane& p : set.planes)
    if (p.kind == "horizontal" && p.normal.dot(set.up) > 0 && p.normal.dot(eye) > p.offset &&
        (!lowest || p.normal.dot(eye) - p.offset > lowest->normal.dot(eye) - lowest->offset))
      lowest = &p;
  return lowest;
}

// --height: the scale that puts the cameras' mean centre `height` metres
// over the support plane.  The first detection runs in the points' own
// units, its distance gate taken relative to the scene's size (the median
// distance from the cameras' mean centre to the points, over a nominal
// 2 m).
double ScaleForHeight(const std::vector<Eigen::Vector3d>& pts, const Trajectory& poses, const PlanesJobOptions& o,
                      const PlaneOptions& po, Report* report) {
  const Eigen::Vector3d eye = MeanCentre(poses);
  std::vector<double> dist;
  for (const Eigen::Vector3d& p : pts) dist.push_back((p - eye).norm());
  std::nth_element(dist.begin(), dist.begin() + static_cast<long>(dist.size() / 2), dist.end());
  const double units_per_m = dist[dist.size() / 2] / 2.0;
  PlaneOptions first = po;
  first.distance = po.distance * units_per_m;
  std::vector<Eigen::Vector3d> centres;
  for (const TimedPose& p : poses.poses) centres.push_back(p.world_from_cam.translation);
  const PlaneSet set = DetectPlanes(pts, centres, first);
  const Plane* support = SupportPlane(set, eye);
  if (!support)
    ThrowErrorAt(FileLoc{o.points},
                 "--height: no level plane below the cameras to measure the height from "
                 "(the report lists the planes found)");
  const double h = support->normal.dot(eye) - support->offset;
  if (!(h > 0)) ThrowErrorAt(FileLoc{o.points}, "--height: the cameras are on the support plane");
  report->SetMetric("scale.measured_height_units", h);
  return o.height / h;
}

// Each vertex's albedo: the median linear colour of the frames that see it
// (in front, unoccluded by the planes, within max_view_deg of its normal);
// vertices no frame saw take their neighbours'.
void AlbedoFromFrames(const PlanesJobOptions& o, const Trajectory& poses, Mesh* mesh, Report* report) {
  const CameraModel camera = CameraModel::Read(o.camera);
  EmbreeScene scene;
  scene.AddMesh(*mesh, false);
  scene.Commit();
  const size_t n = mesh->vertex_count();
  std::vector<std::vector<Eigen::Vector3f>> seen(n);
  std::vector<char> oblique(n, 0);  // in some frame's view, but only beyond max_view_deg
  ImageReadOptions ro;
  ro.default_ldr_transfer = o.transfer == "linear" ? Transfer::kLinear : Transfer::kSrgb;
  int used = 0;
  const double cos_max = std::cos(o.max_view_deg * kDeg);
  Progress progress("albedo", static_cast<int64_t>(poses.poses.size()));
  for (size_t f = 0; f < poses.poses.size(); f += static_cast<size_t>(o.frame_stride)) {
    const fs::path path = FramePath(o.frames, static_cast<int>(f));
    if (!fs::exists(path))
      ThrowErrorAt(FileLoc{path.string()}, "frame {} of --frames is missing (--poses has {})", f, poses.poses.size());
    const Image img = ReadImage(path, ro);
    if (img.width() != camera.width() || img.height() != camera.height())
      ThrowErrorAt(FileLoc{path.string()}, "the frame is {}x{}, the camera model {}x{}", img.width(), img.height(),
                   camera.width(), camera.height());
    if (img.channels() < 3) ThrowErrorAt(FileLoc{path.string()}, "the frame has {} channels, not RGB", img.channels());
    const Rigid3 cam_from_world = poses.poses[f].world_from_cam.Inverse();
    const Eigen::Vector3d eye = poses.poses[f].world_from_cam.translation;
    std::vector<Eigen::Vector3f> colour(n);
    std::vector<char> ok(n, 0);
    ParallelFor(
        0, static_cast<int64_t>(n),
        [&](int64_t v) {
          const auto i = static_cast<size_t>(v);
          const Eigen::Vector3d p = mesh->positions[i].cast<double>();
          const Eigen::Vector3d to_eye = eye - p;
          const double d = to_eye.norm();
          if (!(mesh->normals[i].cast<double>().dot(to_eye) > 0)) return;  // behind the plane
          Eigen::Vector2d q;
          if (!camera.Project(cam_from_world * p, &q)) return;
          const int x = static_cast<int>(std::lround(q.x())), y = static_cast<int>(std::lround(q.y()));
          if (x < 0 || y < 0 || x >= img.width() || y >= img.height()) return;
          Ray ray;
          ray.origin = p.cast<float>();
          ray.direction = (to_eye / d).cast<float>();
          ray.tnear = static_cast<float>(1e-4 * std::max(1.0, d));
          ray.tfar = static_cast<float>(d * (1 - 1e-4));
          if (scene.Occluded(ray)) return;
          if (!(mesh->normals[i].cast<double>().dot(to_eye) > cos_max * d)) {
            ok[i] = 2;  // in view, but too oblique
            return;
          }
          colour[i] = Eigen::Vector3f(img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2));
          ok[i] = colour[i].allFinite() && colour[i].maxCoeff() < 0.999f;  // clipped views say nothing
        },
        1024);
    for (size_t i = 0; i < n; ++i) {
      if (ok[i] == 1) seen[i].push_back(colour[i]);
      if (ok[i] == 2) oblique[i] = 1;
    }
    ++used;
    progress.Update(static_cast<int64_t>(f) + 1);
  }
  progress.Done();
  std::vector<bool> known(n, false);
  std::vector<Eigen::Vector3d> albedo(n, Eigen::Vector3d::Constant(0.5));
  for (size_t i = 0; i < n; ++i) {
    if (seen[i].empty()) continue;
    for (int c = 0; c < 3; ++c) {
      std::vector<float> v;
      for (const Eigen::Vector3f& s : seen[i]) v.push_back(s[c]);
      std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
      albedo[i][c] = v[v.size() / 2];
    }
    known[i] = true;
  }
  int64_t isolated = 0;
  const int64_t filled = FillFromNeighbours(mesh->triangles, known, Eigen::Vector3d::Constant(0.5), &albedo, &isolated);
  mesh->colors.resize(n);
  for (size_t i = 0; i < n; ++i) mesh->colors[i] = albedo[i].cwiseMax(0).cwiseMin(1).cast<float>();
  const auto observed = std::count(known.begin(), known.end(), true);
  // A plane that the frames reach mostly at grazing angles only: its colour
  // is mostly its neighbours'.
  const std::vector<float>& plane = mesh->scalars.front().values;
  std::map<int, std::pair<int64_t, int64_t>> reach;  // plane: (seen, in view only obliquely)
  for (size_t i = 0; i < n; ++i) {
    auto& r = reach[static_cast<int>(plane[i])];
    if (known[i])
      ++r.first;
    else if (oblique[i])
      ++r.second;
  }
  for (const auto& [pi, r] : reach)
    if (r.second > r.first)
      report->Warn(
          fmt::format("albedo: plane {} is in view mostly at grazing angles: {} of its vertices are seen "
                      "only beyond {} degrees from its normal, {} within (they give the rest their colour)",
                      pi, r.second, o.max_view_deg, r.first));
  report->SetMetric("albedo.frames_used", used);
  report->SetMetric("albedo.vertices_observed", static_cast<int64_t>(observed));
  report->SetMetric("albedo.vertices_from_neighbours", filled);
  report->SetMetric("albedo.vertices_isolated", isolated);
}

// --world gravity: the first camera's frame turned about its centre so that
// up is +y, its right (x) made level: x right, y up, z towards the viewer
// (the environment's default up, docs/conventions.md).
void TurnToGravity(PlaneSet* set, std::vector<Eigen::Vector3d>* pts, Trajectory* poses) {
  const Eigen::Vector3d up = set->up;
  Eigen::Vector3d right = poses->poses.front().world_from_cam.rotation * Eigen::Vector3d::UnitX();
  right = (right - right.dot(up) * up).normalized();
  Eigen::Matrix3d r;  // rows: the new axes in the old frame
  r.row(0) = right.transpose();
  r.row(1) = up.transpose();
  r.row(2) = right.cross(up).transpose();
  const Eigen::Quaterniond q(r);
  for (Eigen::Vector3d& p : *pts) p = q * p;
  for (TimedPose& p : poses->poses) p.world_from_cam = Rigid3(q, Eigen::Vector3d::Zero()) * p.world_from_cam;
  for (std::vector<Plane>* list : {&set->planes, &set->dropped})
    for (Plane& p : *list) p.normal = q * p.normal;  // offsets: the turn is about the origin
  set->up = Eigen::Vector3d::UnitY();
}

nlohmann::json PlaneJson(const Plane& p, int kept) {
  return {{"kind", p.kind},          {"normal", {p.normal.x(), p.normal.y(), p.normal.z()}},
          {"offset", p.offset},      {"inliers", p.inliers.size()},
          {"inliers_meshed", kept},  {"rms", p.rms},
          {"turned_deg", p.tilt_deg}};
}

// The gravity hint: --up (given in the input's frame, turned by `turn`),
// else the cameras' mean up, -y of each (y down, docs/conventions.md).
Eigen::Vector3d UpHint(const PlanesJobOptions& o, const Trajectory& poses, const Eigen::Quaterniond& turn) {
  if (!o.up.empty()) return turn * Eigen::Vector3d(o.up[0], o.up[1], o.up[2]).normalized();
  Eigen::Vector3d hint = Eigen::Vector3d::Zero();
  for (const TimedPose& p : poses.poses) hint -= p.world_from_cam.rotation * Eigen::Vector3d::UnitY();
  if (hint.norm() < 1e-6 * static_cast<double>(poses.poses.size()))
    ThrowErrorAt(FileLoc{o.poses}, "the cameras' up directions cancel out: give --up");
  return hint.normalized();
}

// The planes, up and the mesh into the report, and a summary on stderr.
void ReportPlanes(const PlaneSet& set, const std::vector<int>& kept, const Mesh& room, const Eigen::Vector3d& eye,
                  double from_hint_deg, Report* report) {
  if (const Plane* support = SupportPlane(set, eye)) {
    report->SetMetric("support.plane", static_cast<int>(support - set.planes.data()));
    report->SetMetric("support.camera_height", support->normal.dot(eye) - support->offset);
  }
  report->SetMetric("up.direction", {set.up.x(), set.up.y(), set.up.z()});
  report->SetMetric("up.from", set.up_from);
  report->SetMetric("up.from_hint_deg", from_hint_deg);
  report->SetMetric("points.total", set.points);
  report->SetMetric("points.unexplained", set.unexplained);
  report->SetMetric("merged", set.merged);
  nlohmann::json planes = nlohmann::json::array();
  for (size_t i = 0; i < set.planes.size(); ++i) planes.push_back(PlaneJson(set.planes[i], kept[i]));
  report->SetMetric("planes", planes);
  nlohmann::json dropped = nlohmann::json::array();
  for (const Plane& p : set.dropped) dropped.push_back(PlaneJson(p, 0));
  report->SetMetric("dropped_slanted", dropped);
  if (!set.dropped.empty())
    spdlog::info("mr-planes: {} slanted planes left out (--keep-slanted keeps them)", set.dropped.size());
  report->SetMetric("mesh.vertices", static_cast<int64_t>(room.vertex_count()));
  report->SetMetric("mesh.triangles", static_cast<int64_t>(room.triangle_count()));
  report->SetMetric("mesh.area", room.SurfaceArea());
  spdlog::info("mr-planes: {} planes (up from {}, {:.1f} deg from the hint), {} of {} points unexplained, {:.2f} m2",
               set.planes.size(), set.up_from, from_hint_deg, set.unexplained, set.points, room.SurfaceArea());
  for (size_t i = 0; i < set.planes.size(); ++i) {
    const Plane& p = set.planes[i];
    spdlog::info(
        "  plane {}: {:10s} normal ({:+.3f}, {:+.3f}, {:+.3f}) offset {:+.3f}, {} points ({} meshed), rms {:.4f}", i,
        p.kind, p.normal.x(), p.normal.y(), p.normal.z(), p.offset, p.inliers.size(), kept[i], p.rms);
  }
}

}  // namespace

void RunPlanes(const PlanesJobOptions& o, Report* report) {
  o.Check();
  MeshReadOptions read;
  read.points = true;
  const Mesh cloud = ReadMesh(o.points, read);
  std::vector<Eigen::Vector3d> pts;
  for (const Eigen::Vector3f& p : cloud.positions) pts.push_back(p.cast<double>());
  report->AddInput(o.points);
  Trajectory poses = ReadTum(o.poses);
  if (poses.poses.empty()) ThrowErrorAt(FileLoc{o.poses}, "no poses");
  report->AddInput(o.poses);
  Eigen::Quaterniond turn = Eigen::Quaterniond::Identity();  // the input's frame to the output's
  if (o.world != "points") {
    const Rigid3 cam0_from_world = poses.poses.front().world_from_cam.Inverse();
    turn = cam0_from_world.rotation;
    for (Eigen::Vector3d& p : pts) p = cam0_from_world * p;
    for (TimedPose& p : poses.poses) p.world_from_cam = cam0_from_world * p.world_from_cam;
  }
  PlaneOptions po = o.planes;
  po.up_hint = UpHint(o, poses, turn);
  report->SetMetric("up.hint", {po.up_hint.x(), po.up_hint.y(), po.up_hint.z()});
  report->SetMetric("up.hint_from", o.up.empty() ? "cameras" : "--up");
  double scale = 1;
  if (o.height > 0) {
    scale = ScaleForHeight(pts, poses, o, po, report);
    for (Eigen::Vector3d& p : pts) p *= scale;
    for (TimedPose& p : poses.poses) p.world_from_cam.translation *= scale;
  }
  report->SetMetric("scale.factor", scale);
  std::vector<Eigen::Vector3d> centres;
  for (const TimedPose& p : poses.poses) centres.push_back(p.world_from_cam.translation);
  PlaneSet set;
  {
    ScopedTimer t(report, "planes");
    set = DetectPlanes(pts, centres, po);
  }
  const double from_hint_deg = std::acos(std::clamp(set.up.dot(po.up_hint), -1.0, 1.0)) / kDeg;
  if (o.world == "gravity") TurnToGravity(&set, &pts, &poses);
  std::vector<int> kept;
  Mesh room;
  {
    ScopedTimer t(report, "mesh");
    room = MeshPlanes(pts, set, o.mesh, &kept);
  }
  if (room.triangles.empty())
    ThrowErrorAt(FileLoc{o.points}, "no plane kept a part with {} points (--min-points)", o.mesh.min_points);
  ReportPlanes(set, kept, room, MeanCentre(poses), from_hint_deg, report);
  if (!o.frames.empty()) {
    ScopedTimer t(report, "albedo");
    AlbedoFromFrames(o, poses, &room, report);
  } else {
    report->Skip("albedo", "no --frames: the planes are written without colours (the scene's material sets them)");
  }
  std::error_code ec;
  for (const std::string& f : {o.out, o.poses_out})
    if (!f.empty() && !fs::path(f).parent_path().empty()) fs::create_directories(fs::path(f).parent_path(), ec);
  WritePly(o.out, room, "planes from a point cloud (mr-planes)");
  report->AddOutput(o.out);
  if (!o.poses_out.empty()) {
    WriteTum(o.poses_out, poses);
    report->AddOutput(o.poses_out);
  }
}

}  // namespace mr
