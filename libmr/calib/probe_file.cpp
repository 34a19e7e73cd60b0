#include "calib/probe_file.h"

#include "core/error.h"
#include "core/json_node.h"
#include "core/json_settings.h"

namespace mr {

ProbeGeometry ReadProbe(const fs::path& path) {
  const Json j = ReadJsonFile(path);
  const std::string name = path.string();
  JsonSettings root(JsonNode(j, "", &name));
  root.Header("mr-probe", "probe");
  const JsonNode camera = root.Require("camera");
  const JsonNode radius = root.Require("radius_m");
  const JsonNode centre = root.Require("centre_cam_m");
  root.Take("centre_covariance_m2");  // informational, as the three below
  const JsonNode world = root.Require("world_from_cam");
  root.Take("photographs");
  root.Take("consistency_chi2");
  root.Take("provenance");
  root.Done();
  ProbeGeometry g;
  g.path = path;
  const fs::path cam = path.parent_path() / camera.String();
  g.camera = CameraModel::Read(cam);
  g.radius_m = radius.Number(1e-6, 100);
  g.centre_cam = centre.Vec3(-1e3, 1e3);
  if (g.centre_cam.norm() <= g.radius_m) centre.Fail("the camera is inside the sphere");
  JsonSettings w(world);
  const JsonNode quaternion = w.Require("quaternion_wxyz");
  w.Take("camera_in_world_m");
  w.Take("source");
  w.Done();
  const std::vector<double> q = quaternion.Numbers(4, -1, 1);
  const Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
  if (std::abs(quat.norm() - 1) > 1e-6) quaternion.Fail(fmt::format("not a unit quaternion (norm {})", quat.norm()));
  g.world_from_cam = quat.normalized().toRotationMatrix();
  return g;
}

void WriteProbeFile(const fs::path& out, const ProbeFile& p) {
  Json cov = Json::array();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) cov.push_back(p.centre_covariance(i, j));
  const Eigen::Quaterniond& q = p.world_from_cam;
  const Json probe = {
      {"format", "mr-probe"},
      {"version", 1},
      {"camera", fs::relative(fs::absolute(p.camera), fs::absolute(out).parent_path()).generic_string()},
      {"radius_m", p.radius_m},
      {"centre_cam_m", {p.centre_cam.x(), p.centre_cam.y(), p.centre_cam.z()}},
      {"centre_covariance_m2", cov},
      {"world_from_cam",
       {{"quaternion_wxyz", {q.w(), q.x(), q.y(), q.z()}},
        {"camera_in_world_m", {p.camera_in_world.x(), p.camera_in_world.y(), p.camera_in_world.z()}},
        {"source", p.world_source}}},
      {"photographs", p.photographs},
      {"consistency_chi2", p.consistency_chi2},
      {"provenance", p.provenance}};
  WriteTextFile(out, probe.dump(2) + "\n");
}

}  // namespace mr
