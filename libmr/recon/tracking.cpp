#include "recon/tracking.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "core/parallel.h"

namespace mr {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

DepthMap Halve(const DepthMap& d, double sigma) {
  DepthMap h;
  h.width = d.width / 2;
  h.height = d.height / 2;
  h.z.assign(static_cast<size_t>(h.width) * h.height, 0.0f);
  const float gate = static_cast<float>(3 * sigma);
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      float ref = 0, sum = 0;
      int n = 0;
      for (int k = 0; k < 4; ++k) {
        const float v = d.at(2 * x + (k & 1), 2 * y + (k >> 1));
        if (!(v > 0)) continue;
        if (ref == 0) ref = v;
        if (std::abs(v - ref) > gate) continue;
        sum += v;
        ++n;
      }
      h.at(x, y) = n ? sum / static_cast<float>(n) : 0.0f;
    }
  return h;
}

PointMaps ToMaps(const DepthMap& d, const PinholeIntrinsics& K, double max_jump) {
  PointMaps m;
  m.width = d.width;
  m.height = d.height;
  const size_t n = static_cast<size_t>(d.width) * d.height;
  const Eigen::Vector3f nan = Eigen::Vector3f::Constant(kNaN);
  m.vertices.assign(n, nan);
  m.normals.assign(n, nan);
  for (int y = 0; y < d.height; ++y)
    for (int x = 0; x < d.width; ++x) {
      const float z = d.at(x, y);
      if (z > 0)
        m.vertices[static_cast<size_t>(y) * d.width + x] =
            Eigen::Vector3f(static_cast<float>((x - K.cx) / K.fx) * z, static_cast<float>((y - K.cy) / K.fy) * z, z);
    }
  for (int y = 1; y + 1 < d.height; ++y)
    for (int x = 1; x + 1 < d.width; ++x) {
      const size_t i = static_cast<size_t>(y) * d.width + x;
      const float z = d.at(x, y);
      if (!(z > 0)) continue;
      const float zl = d.at(x - 1, y), zr = d.at(x + 1, y), zu = d.at(x, y - 1), zd = d.at(x, y + 1);
      const float jump = static_cast<float>(max_jump) * z;
      if (!(zl > 0 && zr > 0 && zu > 0 && zd > 0) || std::abs(zr - zl) > 2 * jump || std::abs(zd - zu) > 2 * jump)
        continue;
      const Eigen::Vector3f dx = m.vertices[i + 1] - m.vertices[i - 1];
      const Eigen::Vector3f dy = m.vertices[i + d.width] - m.vertices[i - d.width];
      Eigen::Vector3f nrm = dy.cross(dx);
      if (nrm.squaredNorm() <= 0) continue;
      nrm.normalize();
      if (nrm.dot(m.vertices[i]) > 0) nrm = -nrm;  // toward the camera
      m.normals[i] = nrm;
    }
  return m;
}

// Linear luminance, NaN where a channel is clipped (8-bit colour at 1).
std::vector<float> Luminance(const Image& c) {
  std::vector<float> y(static_cast<size_t>(c.width()) * c.height());
  for (int v = 0; v < c.height(); ++v)
    for (int u = 0; u < c.width(); ++u) {
      const float r = c.at(u, v, 0), g = c.at(u, v, 1), b = c.at(u, v, 2);
      y[static_cast<size_t>(v) * c.width() + u] =
          std::max({r, g, b}) >= 0.999f ? kNaN : 0.2126f * r + 0.7152f * g + 0.0722f * b;
    }
  return y;
}

// 2x2 means of the pixels that are not NaN.
std::vector<float> HalveIntensity(const std::vector<float>& in, int w, int h) {
  const int hw = w / 2, hh = h / 2;
  std::vector<float> out(static_cast<size_t>(hw) * hh);
  for (int y = 0; y < hh; ++y)
    for (int x = 0; x < hw; ++x) {
      float sum = 0;
      int n = 0;
      for (int k = 0; k < 4; ++k) {
        const float v = in[static_cast<size_t>(2 * y + (k >> 1)) * w + 2 * x + (k & 1)];
        if (v == v) {
          sum += v;
          ++n;
        }
      }
      out[static_cast<size_t>(y) * hw + x] = n ? sum / static_cast<float>(n) : kNaN;
    }
  return out;
}

}  // namespace

DepthMap FilterDepth(const DepthMap& depth, const PyramidOptions& options) {
  DepthMap d0 = depth;
  if (!options.bilateral) return d0;
  cv::Mat in(depth.height, depth.width, CV_32F, const_cast<float*>(depth.z.data()));
  cv::Mat out;
  const int diameter = 7;  // KinectFusion's window; sigma_space weights within it
  cv::bilateralFilter(in, out, diameter, options.sigma_depth_m, options.sigma_space_px);
  for (int y = 0; y < depth.height; ++y)
    for (int x = 0; x < depth.width; ++x) d0.at(x, y) = depth.at(x, y) > 0 ? out.at<float>(y, x) : 0.0f;
  return d0;
}

FramePyramid BuildPyramid(const DepthMap& depth, const PinholeIntrinsics& K, const PyramidOptions& options,
                          const Image* color) {
  FramePyramid p;
  DepthMap d0 = FilterDepth(depth, options);
  for (float z : d0.z) p.valid += z > 0;
  p.depth.push_back(std::move(d0));
  p.K.push_back(K);
  for (int l = 1; l < options.levels; ++l) {
    p.depth.push_back(Halve(p.depth.back(), options.sigma_depth_m));
    p.K.push_back(K.Level(l));
  }
  if (color && color->width() == depth.width && color->height() == depth.height && color->channels() >= 3) {
    p.intensity.push_back(Luminance(*color));
    for (size_t l = 1; l < p.depth.size(); ++l)
      p.intensity.push_back(HalveIntensity(p.intensity.back(), p.depth[l - 1].width, p.depth[l - 1].height));
  }
  p.maps.resize(p.depth.size());
  ParallelFor(0, static_cast<int64_t>(p.depth.size()), [&](int64_t l) {
    p.maps[static_cast<size_t>(l)] =
        ToMaps(p.depth[static_cast<size_t>(l)], p.K[static_cast<size_t>(l)], options.max_depth_jump);
  });
  return p;
}

Rigid3 ApplyIncrement(const Eigen::Matrix<double, 6, 1>& xi, const Rigid3& world_from_cam) {
  const Eigen::Vector3d w = xi.head<3>();
  const double a = w.norm();
  const Eigen::Quaterniond q = a > 1e-12 ? Eigen::Quaterniond(Eigen::AngleAxisd(a, w / a))
                                         : Eigen::Quaterniond(1, 0.5 * w.x(), 0.5 * w.y(), 0.5 * w.z()).normalized();
  return Rigid3(q * world_from_cam.rotation, world_from_cam.translation + xi.tail<3>());
}

Eigen::Matrix<double, 6, 1> IncrementBetween(const Rigid3& from, const Rigid3& to) {
  const Eigen::AngleAxisd aa(to.rotation * from.rotation.conjugate());
  Eigen::Matrix<double, 6, 1> xi;
  xi.head<3>() = aa.axis() * aa.angle();
  xi.tail<3>() = to.translation - from.translation;
  return xi;
}

namespace {

struct Normal6 {
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
  double r2 = 0, depth_sum = 0;
  int64_t inliers = 0;
};

// One chunk's weighted rows J^T w J (upper triangle) and -J^T w r, summed in
// double in the order the pixels come.
struct Rows6 {
  double upper[21] = {}, rhs[6] = {};
  void Add(const float J[6], float w, float r) {
    int k = 0;
    for (int a = 0; a < 6; ++a) {
      const double wa = static_cast<double>(w * J[a]);
      for (int bb = a; bb < 6; ++bb) upper[k++] += wa * J[bb];
      rhs[a] -= wa * r;
    }
  }
  void Into(Normal6* n) const {
    int k = 0;
    for (int a = 0; a < 6; ++a) {
      for (int bb = a; bb < 6; ++bb, ++k) n->A(a, bb) = n->A(bb, a) = upper[k];
      n->b(a) = rhs[a];
    }
  }
};

// The chunks' systems added in their fixed order (deterministic whatever
// the thread count).
Normal6 Sum(const std::vector<Normal6>& part) {
  Normal6 s;
  for (const Normal6& p : part) {
    s.A += p.A;
    s.b += p.b;
    s.r2 += p.r2;
    s.depth_sum += p.depth_sum;
    s.inliers += p.inliers;
  }
  return s;
}

// One linearisation at `pose` over the level's pixels.
Normal6 Accumulate(const PointMaps& src, const PointMaps& model, const PinholeIntrinsics& mK,
                   const Rigid3& model_from_world, const Rigid3& pose, double max_dist, double cos_angle,
                   double huber) {
  const Eigen::Matrix3f R = pose.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f t = pose.translation.cast<float>();
  const Eigen::Matrix3f Rm = model_from_world.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f tm = model_from_world.translation.cast<float>();
  const int rows = src.height;
  constexpr int kChunk = 8;
  const int chunks = (rows + kChunk - 1) / kChunk;
  std::vector<Normal6> part(static_cast<size_t>(chunks));
  const float fx = static_cast<float>(mK.fx), fy = static_cast<float>(mK.fy), cx = static_cast<float>(mK.cx),
              cy = static_cast<float>(mK.cy);
  const float max_d2 = static_cast<float>(max_dist * max_dist), cos_a = static_cast<float>(cos_angle);
  const float hub = static_cast<float>(huber);
  ParallelFor(0, chunks, [&](int64_t ci) {
    Normal6& acc = part[static_cast<size_t>(ci)];
    Rows6 eq;
    for (int y = static_cast<int>(ci) * kChunk; y < std::min(rows, static_cast<int>(ci + 1) * kChunk); ++y)
      for (int x = 0; x < src.width; ++x) {
        const size_t i = static_cast<size_t>(y) * src.width + x;
        const Eigen::Vector3f& vs = src.normals[i];
        if (!(vs.x() == vs.x())) continue;
        const Eigen::Vector3f p = R * src.vertices[i] + t;
        const Eigen::Vector3f pm = Rm * p + tm;
        if (pm.z() <= 0) continue;
        const float uf = fx * pm.x() / pm.z() + cx + 0.5f, vf = fy * pm.y() / pm.z() + cy + 0.5f;
        if (!(uf >= 0 && vf >= 0 && uf < static_cast<float>(model.width) && vf < static_cast<float>(model.height)))
          continue;
        const size_t j =
            static_cast<size_t>(static_cast<int>(vf)) * model.width + static_cast<size_t>(static_cast<int>(uf));
        const Eigen::Vector3f& N = model.normals[j];
        if (!(N.x() == N.x())) continue;
        const Eigen::Vector3f diff = p - model.vertices[j];
        if (diff.squaredNorm() > max_d2) continue;
        if ((R * vs).dot(N) < cos_a) continue;
        const float r = N.dot(diff);
        const float w = std::abs(r) <= hub ? 1.0f : hub / std::abs(r);
        const Eigen::Vector3f c = (p - t).cross(N);  // lever arm from the camera centre
        const float J[6] = {c.x(), c.y(), c.z(), N.x(), N.y(), N.z()};
        eq.Add(J, w, r);
        acc.r2 += static_cast<double>(r) * r;
        acc.depth_sum += src.vertices[i].z();
        ++acc.inliers;
      }
    eq.Into(&acc);
  });
  return Sum(part);
}

// Bilinear sample of a level's intensity with its central-difference
// gradient at (u, v); false near the border or where a tap is NaN.
bool SampleIntensity(const std::vector<float>& I, int w, int h, float u, float v, float* value, float* gx, float* gy) {
  if (!(u >= 1 && v >= 1 && u < static_cast<float>(w - 2) && v < static_cast<float>(h - 2))) return false;
  auto bil = [&](float x, float y) {
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
    const float* r0 = &I[static_cast<size_t>(y0) * w + x0];
    const float* r1 = r0 + w;
    return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
  };
  *value = bil(u, v);
  *gx = 0.5f * (bil(u + 1, v) - bil(u - 1, v));
  *gy = 0.5f * (bil(u, v + 1) - bil(u, v - 1));
  return *value == *value && *gx == *gx && *gy == *gy;
}

// The photometric normal equations at level l: each pixel of the frame
// with depth and intensity, moved by `pose` and seen from the previous
// frame, against the previous frame's intensity there (bilinear), where the
// previous frame's depth agrees within `occlusion`.  Residual I_prev - I,
// Huber weights; rows as Accumulate's (rotation about the camera centre).
Normal6 AccumulatePhoto(const FramePyramid& cur, size_t l, const PhotometricTarget& tg, const Rigid3& pose,
                        double huber, double occlusion) {
  const FramePyramid& prev = *tg.frame;
  const PointMaps& src = cur.maps[l];
  const std::vector<float>& Ic = cur.intensity[l];
  const std::vector<float>& Ip = prev.intensity[l];
  const DepthMap& Dp = prev.depth[l];
  const PinholeIntrinsics& K = prev.K[l];
  const Eigen::Matrix3f R = pose.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f t = pose.translation.cast<float>();
  const Eigen::Matrix3f Rp = tg.world_from_cam.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f tp = tg.world_from_cam.translation.cast<float>();
  const float fx = static_cast<float>(K.fx), fy = static_cast<float>(K.fy), cx = static_cast<float>(K.cx),
              cy = static_cast<float>(K.cy), hub = static_cast<float>(huber), occ = static_cast<float>(occlusion);
  constexpr int kChunk = 8;
  const int chunks = (src.height + kChunk - 1) / kChunk;
  std::vector<Normal6> part(static_cast<size_t>(chunks));
  ParallelFor(0, chunks, [&](int64_t ci) {
    Normal6& acc = part[static_cast<size_t>(ci)];
    Rows6 eq;
    for (int y = static_cast<int>(ci) * kChunk; y < std::min(src.height, static_cast<int>(ci + 1) * kChunk); ++y)
      for (int x = 0; x < src.width; ++x) {
        const size_t i = static_cast<size_t>(y) * src.width + x;
        if (!src.valid(i) || !(Ic[i] == Ic[i])) continue;
        const Eigen::Vector3f pw = R * src.vertices[i] + t;
        const Eigen::Vector3f pp = Rp.transpose() * (pw - tp);
        if (pp.z() <= 0) continue;
        const float u = fx * pp.x() / pp.z() + cx, v = fy * pp.y() / pp.z() + cy;
        float I, gx, gy;
        if (!SampleIntensity(Ip, Dp.width, Dp.height, u, v, &I, &gx, &gy)) continue;
        const float dz = Dp.at(static_cast<int>(u + 0.5f), static_cast<int>(v + 0.5f));
        if (!(dz > 0) || std::abs(dz - pp.z()) > occ) continue;
        const float r = I - Ic[i];
        const float iz = 1 / pp.z();
        // d(I_prev)/d(p_prev), then turned into the world.
        const Eigen::Vector3f dp(gx * fx * iz, gy * fy * iz, -(gx * fx * pp.x() + gy * fy * pp.y()) * iz * iz);
        const Eigen::Vector3f d = Rp * dp;
        const Eigen::Vector3f c = (pw - t).cross(d);
        const float J[6] = {c.x(), c.y(), c.z(), d.x(), d.y(), d.z()};
        const float w = std::abs(r) <= hub ? 1.0f : hub / std::abs(r);
        eq.Add(J, w, r);
        acc.r2 += static_cast<double>(r) * r;
        ++acc.inliers;
      }
    eq.Into(&acc);
  });
  return Sum(part);
}

// The fraction of the frame's points (level 0, moved by `pose`) that land
// in space the model saw empty: nearer to the model's camera, along its
// ray, than the model's surface there by more than `margin`.  Over the
// points that land on model pixels with a surface.
double FreeSpaceRatio(const PointMaps& src, const PointMaps& model, const PinholeIntrinsics& mK,
                      const Rigid3& model_from_world, const Rigid3& pose, double margin) {
  const Eigen::Matrix3f R = pose.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f t = pose.translation.cast<float>();
  const Eigen::Matrix3f Rm = model_from_world.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f tm = model_from_world.translation.cast<float>();
  const float fx = static_cast<float>(mK.fx), fy = static_cast<float>(mK.fy), cx = static_cast<float>(mK.cx),
              cy = static_cast<float>(mK.cy), m = static_cast<float>(margin);
  int64_t landed = 0, empty = 0;
  for (size_t i = 0; i < src.vertices.size(); ++i) {
    if (!src.valid(i)) continue;
    const Eigen::Vector3f pm = Rm * (R * src.vertices[i] + t) + tm;
    if (pm.z() <= 0) continue;
    const float u = fx * pm.x() / pm.z() + cx + 0.5f, v = fy * pm.y() / pm.z() + cy + 0.5f;
    if (!(u >= 0 && v >= 0 && u < static_cast<float>(model.width) && v < static_cast<float>(model.height))) continue;
    const size_t j = static_cast<size_t>(v) * model.width + static_cast<size_t>(u);
    if (!model.valid(j)) continue;
    ++landed;
    empty += pm.z() < (Rm * model.vertices[j] + tm).z() - m;
  }
  return landed ? static_cast<double>(empty) / static_cast<double>(landed) : 0.0;
}

// Whether the depth term alone leaves a direction weak (rotations scaled by
// the mean depth, as TrackIcp's analysis).
bool DepthIsWeak(const Normal6& s, double ratio) {
  const double L = std::max(0.1, s.depth_sum / static_cast<double>(s.inliers));
  Eigen::Matrix<double, 6, 1> scale;
  scale << 1 / L, 1 / L, 1 / L, 1, 1, 1;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(scale.asDiagonal() * s.A * scale.asDiagonal());
  return eig.eigenvalues()(0) < ratio * std::max(eig.eigenvalues()(5), 1e-30);
}

}  // namespace

IcpResult TrackIcp(const FramePyramid& frame, const PointMaps& model, const PinholeIntrinsics& model_K,
                   const Rigid3& model_pose, const Rigid3& guess, const IcpOptions& options,
                   const PhotometricTarget* photo) {
  IcpResult res;
  Rigid3 pose = guess;
  const Rigid3 model_from_world = model_pose.Inverse();
  const double cos_angle = std::cos(options.max_angle_deg * M_PI / 180);
  const int levels = std::min<int>(static_cast<int>(frame.maps.size()), static_cast<int>(options.iterations.size()));
  bool used_color = false;
  const bool use_color = photo && photo->frame && options.color_weight > 0 && options.color_term != "off" &&
                         frame.intensity.size() == frame.maps.size() &&
                         photo->frame->intensity.size() == frame.maps.size();
  for (int l = levels - 1; l >= 0; --l) {
    const double gate = options.max_distance * std::pow(2.0, l);
    for (int it = 0; it < options.iterations[static_cast<size_t>(l)]; ++it) {
      Normal6 s = Accumulate(frame.maps[static_cast<size_t>(l)], model, model_K, model_from_world, pose, gate,
                             cos_angle, options.huber);
      if (s.inliers < 6) break;
      if (use_color && (options.color_term == "always" || DepthIsWeak(s, options.weak_eigen_ratio))) {
        const Normal6 ph =
            AccumulatePhoto(frame, static_cast<size_t>(l), *photo, pose, options.color_huber, options.color_occlusion);
        s.A += options.color_weight * ph.A;
        s.b += options.color_weight * ph.b;
        used_color = true;
      }
      ++res.iterations;
      // Scale rotations by the mean depth so that all six are in metres.
      const double L = std::max(0.1, s.depth_sum / static_cast<double>(s.inliers));
      Eigen::Matrix<double, 6, 1> scale;
      scale << 1 / L, 1 / L, 1 / L, 1, 1, 1;
      const Eigen::Matrix<double, 6, 6> As = scale.asDiagonal() * s.A * scale.asDiagonal();
      const Eigen::Matrix<double, 6, 1> bs = scale.asDiagonal() * s.b;
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(As);
      const Eigen::Matrix<double, 6, 1> lam = eig.eigenvalues();
      const double lmax = std::max(lam(5), 1e-30);
      // The prior: the increment that takes `pose` to the prediction, scaled.
      Eigen::Matrix<double, 6, 1> prior = IncrementBetween(pose, guess);
      prior.head<3>() *= L;
      // Directions the data barely constrain are regularised towards the
      // motion prior: their eigenvalues are lifted to the floor, the lift
      // pulling to the prior's increment (Tikhonov in the weak subspace only;
      // well-constrained directions are untouched).
      Eigen::Matrix<double, 6, 6> Ar = As;
      Eigen::Matrix<double, 6, 1> br = bs;
      int weak = 0;
      const double floor = options.weak_eigen_ratio * lmax;
      std::vector<Eigen::Matrix<double, 6, 1>> weak_dirs;
      for (int k = 0; k < 6; ++k) {
        if (lam(k) >= floor) continue;
        ++weak;
        const Eigen::Matrix<double, 6, 1> v = eig.eigenvectors().col(k);
        const double lift = floor - std::max(lam(k), 0.0);
        Ar += lift * v * v.transpose();
        br += lift * v * v.dot(prior);
        weak_dirs.push_back(v);
      }
      if (l == 0) {
        res.weak_basis = weak_dirs;
        res.weak_scale = scale;
      }
      const Eigen::Matrix<double, 6, 1> xs = Ar.ldlt().solve(br);
      Eigen::Matrix<double, 6, 1> xi = scale.asDiagonal() * xs;
      if (!xi.allFinite()) break;
      pose = ApplyIncrement(xi, pose);
      if (l == 0) {
        res.condition = lam(0) > 0 ? lmax / lam(0) : std::numeric_limits<double>::infinity();
        res.weak_directions = weak;
      }
      if (xi.head<3>().norm() < 1e-5 && xi.tail<3>().norm() < 1e-5) break;  // 0.01 mm, 2 arc seconds
    }
  }
  // Final figures at level 0 against the final pose.
  const Normal6 f =
      Accumulate(frame.maps[0], model, model_K, model_from_world, pose, options.max_distance, cos_angle, options.huber);
  int64_t valid = 0;
  for (size_t i = 0; i < frame.maps[0].normals.size(); ++i)
    valid += frame.maps[0].normals[i].x() == frame.maps[0].normals[i].x();
  res.world_from_cam = pose;
  if (used_color) {
    const Normal6 ph = AccumulatePhoto(frame, 0, *photo, pose, options.color_huber, options.color_occlusion);
    res.color_pixels = ph.inliers;
    res.color_rms = ph.inliers ? std::sqrt(ph.r2 / static_cast<double>(ph.inliers)) : 0;
  }
  res.inlier_ratio = valid ? static_cast<double>(f.inliers) / static_cast<double>(valid) : 0;
  res.rms = f.inliers ? std::sqrt(f.r2 / static_cast<double>(f.inliers)) : 0;
  if (res.condition == 0 && f.inliers >= 6) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(f.A);
    res.condition = eig.eigenvalues()(0) > 0 ? eig.eigenvalues()(5) / eig.eigenvalues()(0)
                                             : std::numeric_limits<double>::infinity();
  }
  res.free_space_ratio =
      FreeSpaceRatio(frame.maps[0], model, model_K, model_from_world, pose, options.free_space_margin);
  const Rigid3 jump = pose * guess.Inverse();
  const double jump_m = (pose.translation - guess.translation).norm();
  const double jump_deg = Eigen::AngleAxisd(jump.rotation).angle() * 180 / M_PI;
  if (valid == 0)
    res.failure = "no valid depth";
  else if (res.inlier_ratio < options.min_inlier_ratio)
    res.failure = fmt::format("inlier ratio {:.2f} < {:.2f}", res.inlier_ratio, options.min_inlier_ratio);
  else if (res.rms > options.max_rms)
    res.failure = fmt::format("RMS residual {:.3f} m > {:.3f} m", res.rms, options.max_rms);
  else if (res.free_space_ratio > options.max_free_space)
    res.failure = fmt::format("{:.0f}% of the points land in space the model saw empty (> {:.0f}%)",
                              100 * res.free_space_ratio, 100 * options.max_free_space);
  else if (jump_m > options.max_jump_m || jump_deg > options.max_jump_deg)
    res.failure = fmt::format("moved {:.3f} m / {:.1f} deg from the prediction", jump_m, jump_deg);
  res.ok = res.failure.empty();
  return res;
}

}  // namespace mr
