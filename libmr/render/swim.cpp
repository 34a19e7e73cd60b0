#include "render/swim.h"

#include <cmath>
#include <limits>

#include "core/optical_flow.h"
#include "geometry/mesh.h"
#include "render/render_scene.h"

namespace mr {

SwimMeter::SwimMeter(const Scene& scene, const CameraModel& camera)
    : scene_(scene), camera_(camera), up_(scene.lighting.world_from_env * Eigen::Vector3d::UnitY()) {
  for (const SceneVirtual& v : scene.virtuals) {
    const Mesh m = ReadVirtualMesh(v);
    if (m.positions.empty()) continue;
    Object o{v.name, &v, {}, {}};
    for (const auto& p : m.positions) o.vertices.push_back(p.cast<double>());
    objects_.push_back(std::move(o));
  }
}

std::optional<Eigen::Vector2d> SwimMeter::Contact(const Object& o, int f, const Rigid3& world_from_cam) const {
  const Eigen::Affine3d t = o.v->WorldFromObjectAt(f);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Eigen::Vector3d& p : o.vertices) {
    const double h = up_.dot(t * p);
    lo = std::min(lo, h), hi = std::max(hi, h);
  }
  if (!(hi > lo)) return std::nullopt;  // hidden (scale 0) or flat
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  int n = 0;
  for (const Eigen::Vector3d& p : o.vertices) {
    const Eigen::Vector3d w = t * p;
    if (up_.dot(w) <= lo + 0.01 * (hi - lo)) c += w, ++n;
  }
  Eigen::Vector2d q;
  if (n == 0 || !camera_.Project(world_from_cam.Inverse() * (c / n), &q)) return std::nullopt;
  if (q.x() < 0 || q.y() < 0 || q.x() > camera_.width() - 1 || q.y() > camera_.height() - 1) return std::nullopt;
  return q;
}

Json SwimMeter::Frame(int f, const Rigid3& world_from_cam, const Image& plate) {
  Json out = nullptr;
  if (!objects_.empty() && last_frame_ == f - 1) {
    const FlowField flow = MatchImages(last_plate_, plate, nullptr);
    out = Json::object();
    for (Object& o : objects_) {
      if (!o.v->WorldFromObjectAt(f - 1).isApprox(o.v->WorldFromObjectAt(f), 1e-12)) continue;  // it moves
      const std::optional<Eigen::Vector2d> from = Contact(o, f - 1, last_pose_), to = Contact(o, f, world_from_cam);
      if (!from || !to) continue;
      // The plate's motion around the contact point: the median of the
      // measurable flow within 24 px (the table under the object; a lone
      // pixel's flow can be the flow's failure).
      Eigen::Vector2f moved;
      if (!flow.MedianNear(from->x(), from->y(), 24, 20, &moved)) {
        ++o.unmeasured;
        continue;
      }
      const double swim = (*to - *from - moved.cast<double>()).norm();
      o.swims.push_back(swim);
      out[o.name] = swim;
    }
  }
  last_frame_ = f;
  last_plate_ = plate;
  last_pose_ = world_from_cam;
  return out;
}

Json SwimMeter::Summary() const {
  Json out = Json::object();
  for (const Object& o : objects_) {
    if (o.swims.empty()) continue;
    double sq = 0, worst = 0;
    for (double s : o.swims) sq += s * s, worst = std::max(worst, s);
    out[o.name] = {{"rms_px", std::sqrt(sq / static_cast<double>(o.swims.size()))},
                   {"max_px", worst},
                   {"frames", o.swims.size()},
                   {"unmeasured", o.unmeasured}};
  }
  return out;
}

}  // namespace mr
