// A test "renderer" without light transport: each pixel's ray through the
// camera at `world_from_cam` meets the scene's real geometry, and the pixel
// (R = G = B) is shade(the point met); pixels that meet nothing stay 0.  For
// tests of geometry and texture alone (registration, swim).
#pragma once

#include <functional>

#include "camera/camera_model.h"
#include "camera/pose.h"
#include "core/image.h"
#include "render/render_scene.h"

namespace mr::test {

inline Image RayCastImage(const RenderScene& rs, const CameraModel& camera, const Rigid3& world_from_cam,
                          const std::function<double(const Eigen::Vector3d&)>& shade) {
  Image img(camera.width(), camera.height(), {"R", "G", "B"});
  for (int y = 0; y < camera.height(); ++y)
    for (int x = 0; x < camera.width(); ++x) {
      Eigen::Vector3d dir;
      if (!camera.Unproject(Eigen::Vector2d(x, y), &dir)) continue;
      Ray ray;
      ray.origin = world_from_cam.translation.cast<float>();
      ray.direction = (world_from_cam.rotation * dir).normalized().cast<float>();
      ray.mask = kMaskReal;
      Hit hit;
      if (!rs.embree().Intersect(ray, &hit)) continue;
      const float v = static_cast<float>(
          shade(world_from_cam.translation + static_cast<double>(hit.t) * ray.direction.cast<double>()));
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = v;
    }
  return img;
}

}  // namespace mr::test
