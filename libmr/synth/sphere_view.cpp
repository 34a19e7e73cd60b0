#include "synth/sphere_view.h"

#include <cmath>

#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"

namespace mr {

void AddRelativeNoise(Image* img, double sigma, uint64_t seed) {
  if (!(sigma > 0)) return;
  const int W = img->width(), C = img->channels();
  ParallelFor(0, img->height(), [&](int64_t y) {
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < C; ++c) {
        Pcg32 rng(seed, (static_cast<uint64_t>(y) * W + x) * static_cast<uint64_t>(C) + static_cast<uint64_t>(c));
        float& v = img->at(x, static_cast<int>(y), c);
        v = static_cast<float>(std::max(0.0, v * (1 + sigma * NextGaussian(rng))));
      }
  });
}

Image RenderSphereView(const EnvironmentMap& env, const CameraModel& camera, const Eigen::Vector3d& centre,
                       double radius, const SphereViewOptions& o) {
  const int W = camera.width(), H = camera.height(), S = std::max(1, o.supersample);
  const double c2 = centre.squaredNorm() - radius * radius;
  Image img = Image::Rgb(W, H);
  ParallelFor(0, H, [&](int64_t y) {
    Eigen::Vector3d prev;  // the last ray along the row: the next one starts from it
    bool have_prev = false;
    for (int x = 0; x < W; ++x) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (int sy = 0; sy < S; ++sy)
        for (int sx = 0; sx < S; ++sx) {
          const Eigen::Vector2d q(x - 0.5 + (sx + 0.5) / S, static_cast<double>(y) - 0.5 + (sy + 0.5) / S);
          Eigen::Vector3d d;
          have_prev = have_prev ? camera.UnprojectNear(q, prev, &d) : camera.Unproject(q, &d);
          if (!have_prev) continue;  // outside the lens: black
          prev = d;
          d.normalize();
          // |t d - c| = r: t^2 - 2 (d.c) t + |c|^2 - r^2 = 0, the nearer root.
          const double b = d.dot(centre), disc = b * b - c2;
          Eigen::Vector3d dir = d;
          double scale = 1;
          if (disc >= 0 && b > 0) {
            const double t = c2 / (b + std::sqrt(disc));  // the nearer root, without cancellation
            const Eigen::Vector3d n = (t * d - centre) / radius;
            dir = d - 2 * d.dot(n) * n;
            scale = o.reflectance;
            const Eigen::Vector3d p = t * d;
            // The reflected ray meets the camera's body (a sphere at the origin)?
            const double pb = p.dot(dir), pc = p.squaredNorm() - Square(o.camera_body_radius);
            if (o.camera_body_radius > 0 && pb < 0 && pb * pb - pc >= 0) {
              sum += Eigen::Vector3d::Constant(scale * o.camera_body_radiance);
              continue;
            }
          }
          sum += scale * env.Eval(o.world_from_cam * dir);
        }
      sum *= o.exposure / (S * S);
      for (int c = 0; c < 3; ++c) img.at(x, static_cast<int>(y), c) = static_cast<float>(std::max(0.0, sum[c]));
    }
  });
  AddRelativeNoise(&img, o.noise_sigma, o.seed);
  return img;
}

Image RenderEnvironmentView(const EnvironmentMap& env, const CameraModel& camera, const SphereViewOptions& options) {
  // A sphere of radius 0 is never hit.
  return RenderSphereView(env, camera, Eigen::Vector3d(0, 0, 1), 0.0, options);
}

}  // namespace mr
