#include "synth/rgbd_view.h"

#include <cmath>

#include <fmt/format.h>

#include "camera/camera_model.h"
#include "core/error.h"
#include "core/json.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "render/path_tracer.h"
#include "render/pt.h"

namespace mr {

Rigid3 LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitY());  // right, with y down
  if (x.norm() < 1e-9) x = Eigen::Vector3d::UnitX();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return Rigid3(Eigen::Quaterniond(R), eye);
}

Trajectory ScanPath(int frames, const Eigen::Vector3d& target, double radius, double height, double arc_deg,
                    double start_deg) {
  Trajectory t;
  for (int i = 0; i < frames; ++i) {
    const double s = frames > 1 ? static_cast<double>(i) / (frames - 1) : 0.0;
    const double a = (start_deg + arc_deg * s) * kDegToRad;
    // A hand's wobble at fixed frequencies (seconds at 30 Hz), whatever the length.
    const double time = i / 30.0;
    const Eigen::Vector3d eye =
        target + Eigen::Vector3d(radius * std::cos(a), height - target.y() + 0.05 * std::sin(kTwoPi * time / 2.5),
                                 radius * std::sin(a));
    const Eigen::Vector3d look =
        target + Eigen::Vector3d(0.2 * std::sin(kTwoPi * time / 3.3), 0, 0.2 * std::cos(kTwoPi * time / 4.1));
    t.poses.push_back({time, LookAt(eye, look)});
  }
  return t;
}

DepthMap RenderDepth(const RenderScene& scene, const PinholeIntrinsics& K, const Rigid3& world_from_cam,
                     const DepthSensorModel& sensor, uint64_t seed) {
  DepthMap clean;
  clean.width = K.width;
  clean.height = K.height;
  clean.z.assign(static_cast<size_t>(K.width) * K.height, 0.0f);
  std::vector<float> drop_p(clean.z.size(), 0.0f), cos_view(clean.z.size(), 1.0f);
  const Eigen::Matrix3d R = world_from_cam.rotation.toRotationMatrix();
  ParallelFor(0, K.height, [&](int64_t yi) {
    const int y = static_cast<int>(yi);
    for (int x = 0; x < K.width; ++x) {
      const Eigen::Vector3d dc((x - K.cx) / K.fx, (y - K.cy) / K.fy, 1.0);
      Ray ray;
      ray.origin = world_from_cam.translation.cast<float>();
      ray.direction = (R * dc).cast<float>();  // t is then the depth z
      ray.mask = kMaskReal;
      Hit h;
      if (!scene.embree().Intersect(ray, &h)) continue;
      const size_t i = static_cast<size_t>(y) * K.width + x;
      clean.z[i] = h.t;
      const Eigen::Vector3d n = scene.WorldNormal(h);
      cos_view[i] = static_cast<float>(std::abs(n.dot((R * dc).normalized())));
      const Material& m = scene.material(h.geometry_id);
      const double lum = Luminance(m.albedo);
      float p = 0;
      if (lum < 0.1) p = static_cast<float>(sensor.dark_dropout);
      if (m.IsGlossy()) p = std::max(p, static_cast<float>(sensor.glossy_dropout));
      drop_p[i] = p;
    }
  });
  DepthMap out = clean;
  const double cos_graze = std::cos(sensor.grazing_deg * kDegToRad);
  const double fb8 = sensor.native_fx * sensor.baseline_m * 8;  // disparity in 1/8 pixels times z
  ParallelFor(0, K.height, [&](int64_t yi) {
    const int y = static_cast<int>(yi);
    for (int x = 0; x < K.width; ++x) {
      const size_t i = static_cast<size_t>(y) * K.width + x;
      float z = clean.z[i];
      if (!(z > 0)) continue;
      Pcg32 rng(seed, i);
      if (z < sensor.min_m || z > sensor.max_m) {
        out.z[i] = 0;
        continue;
      }
      if (sensor.holes) {
        bool edge = false;
        // The projector sits to the right of the camera: a surface just
        // behind a nearer edge on the pixel's right lies in its shadow.
        for (int dx = 1; dx <= 2 && !edge; ++dx)
          if (x + dx < K.width) {
            const float zn = clean.z[i + static_cast<size_t>(dx)];
            edge = zn > 0 && zn < z * (1 - sensor.edge_jump);
          }
        if (edge || cos_view[i] < cos_graze || rng.NextDouble() < drop_p[i]) {
          out.z[i] = 0;
          continue;
        }
      }
      if (sensor.noise) {
        const double theta = std::acos(std::min(1.0, static_cast<double>(cos_view[i])));
        const double sz = 0.0012 + 0.0019 * Square(z - 0.4) +
                          0.0001 / std::sqrt(z) * Square(theta) / Square(std::max(0.05, kPi / 2 - theta));
        z = static_cast<float>(z + sz * NextGaussian(rng));
      }
      if (sensor.quantise) {
        const double d = std::max(1.0, std::round(fb8 / z));
        z = static_cast<float>(fb8 / d);
      }
      out.z[i] = z;
    }
  });
  return out;
}

void WriteRgbdSequence(const fs::path& dir, const RenderScene& scene, const Trajectory& path, const RgbdSynthOptions& o,
                       Report* report) {
  fs::create_directories(dir / "depth");
  if (o.color_spp > 0) fs::create_directories(dir / "rgb");
  const PinholeIntrinsics& K = o.K;
  CameraModel cam("LENSMODEL_PINHOLE", {K.fx, K.fy, K.cx, K.cy}, K.width, K.height);
  cam.Write(dir / "depth.cameramodel", "synthetic RGB-D camera (mr-synth); depth and colour share it");
  std::string depth_txt = "# depth maps: 16-bit PNG, 5000 units per metre, 0 = no return\n# timestamp filename\n";
  std::string rgb_txt = "# colour images: 8-bit sRGB PNG\n# timestamp filename\n";
  PathTracerSettings st;
  st.max_depth = 6;
  st.seed = HashCombine(o.seed, 0x72676264ULL);
  for (size_t i = 0; i < path.poses.size(); ++i) {
    const TimedPose& tp = path.poses[i];
    DepthMap d = RenderDepth(scene, K, tp.world_from_cam, o.sensor, HashCombine(o.seed, i));
    if (std::find(o.blank_frames.begin(), o.blank_frames.end(), static_cast<int>(i)) != o.blank_frames.end())
      std::fill(d.z.begin(), d.z.end(), 0.0f);
    Image codes = Image::Gray(K.width, K.height);
    for (size_t k = 0; k < d.z.size(); ++k)
      codes.values()[k] = d.z[k] > 0 ? std::min(65534.0f, std::round(d.z[k] * 5000.0f)) / 65535.0f : 0.0f;
    ImageWriteOptions wo;
    wo.pixel_type = PixelType::kUint16;
    wo.ldr_transfer = Transfer::kLinear;
    const std::string stamp = fmt::format("{:.6f}", tp.timestamp);
    WriteImage(dir / "depth" / (stamp + ".png"), codes, wo);
    depth_txt += fmt::format("{} depth/{}.png\n", stamp, stamp);
    if (o.color_spp > 0) {
      st.frame = static_cast<int>(i);
      PtFrameRenderer fr(scene, cam, tp.world_from_cam, st);
      fr.RenderPass(o.color_spp);
      Image c = fr.Real();
      for (float& v : c.values()) v = Clamp(v * static_cast<float>(o.exposure), 0.0f, 1.0f);
      ImageWriteOptions co;
      co.pixel_type = PixelType::kUint8;
      WriteImage(dir / "rgb" / (stamp + ".png"), c, co);
      rgb_txt += fmt::format("{} rgb/{}.png\n", stamp, stamp);
    }
  }
  WriteTextFile(dir / "depth.txt", depth_txt);
  if (o.color_spp > 0) WriteTextFile(dir / "rgb.txt", rgb_txt);
  WriteTum(dir / "groundtruth.txt", path);
  const DepthSensorModel& s = o.sensor;
  WriteTextFile(dir / "truth.json", Json({{"frames", static_cast<int>(path.poses.size())},
                                          {"intrinsics", {K.fx, K.fy, K.cx, K.cy, K.width, K.height}},
                                          {"depth_scale", 5000},
                                          {"color_exposure", o.exposure},
                                          {"color_spp", o.color_spp},
                                          {"sensor",
                                           {{"noise", s.noise},
                                            {"quantise", s.quantise},
                                            {"holes", s.holes},
                                            {"baseline_m", s.baseline_m},
                                            {"range_m", {s.min_m, s.max_m}},
                                            {"grazing_deg", s.grazing_deg},
                                            {"dark_dropout", s.dark_dropout},
                                            {"glossy_dropout", s.glossy_dropout}}},
                                          {"trajectory", "groundtruth.txt"}})
                                            .dump(2) +
                                        "\n");
  if (report) report->AddOutput(dir.string());
}

}  // namespace mr
