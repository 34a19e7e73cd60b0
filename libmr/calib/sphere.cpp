#include "calib/sphere.h"

#include <ceres/ceres.h>
#include <ceres/manifold.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "core/color.h"
#include "core/error.h"
#include "core/math.h"

namespace mr {

namespace {

// Luminance, lightly smoothed, and its log: a step of the sphere's
// reflectance is the same size in the log whatever the exposure or the
// dynamic range; the linear one places the step without the log's bias
// towards the darker side.
struct LuminanceImage {
  cv::Mat raw, linear, log;  // raw: unsmoothed
};

// Smoothed by a Gaussian of 1 px, linear and log (floored at 1e-6 of the peak).
LuminanceImage Smoothed(cv::Mat L, float peak) {
  LuminanceImage out;
  out.raw = L.clone();
  cv::GaussianBlur(L, out.linear, cv::Size(0, 0), 1.0);
  const float floor = 1e-6f * peak;
  for (auto it = L.begin<float>(); it != L.end<float>(); ++it) *it = std::log(std::max(floor, *it));
  cv::GaussianBlur(L, out.log, cv::Size(0, 0), 1.0);
  return out;
}

LuminanceImage LogLuminance(const Image& photo, const std::string& name) {
  const int W = photo.width(), H = photo.height();
  cv::Mat L(H, W, CV_32F);
  float peak = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      float v = 0;
      if (photo.channels() >= 3)
        v = LuminanceF(photo.at(x, y, 0), photo.at(x, y, 1), photo.at(x, y, 2));
      else
        v = photo.at(x, y, 0);
      if (!std::isfinite(v)) ThrowErrorAt(FileLoc{name}, "pixel ({}, {}) is not finite", x, y);
      L.at<float>(y, x) = v;
      peak = std::max(peak, v);
    }
  if (!(peak > 0)) ThrowErrorAt(FileLoc{name}, "the photograph is black");
  return Smoothed(L, peak);
}

// A mask's levels in between as coverage in sRGB code values: how an 8-bit
// mask is painted and antialiased (its decoded linear values would move the
// rim by about 0.2 px towards the darker level, opposite ways for the two
// polarities).
LuminanceImage MaskCoverage(const cv::Mat& raw, double lo, double hi) {
  cv::Mat c(raw.size(), CV_32F);
  for (int y = 0; y < raw.rows; ++y)
    for (int x = 0; x < raw.cols; ++x)
      c.at<float>(y, x) = LinearToSrgb(static_cast<float>((raw.at<float>(y, x) - lo) / (hi - lo)));
  LuminanceImage out = Smoothed(c, 1.0f);
  out.raw = raw;
  return out;
}

double Bilinear(const cv::Mat& L, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int xx, int yy) { return static_cast<double>(L.at<float>(yy, xx)); };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
         fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

struct Edge {
  Eigen::Vector2d px;
  Eigen::Vector3d ray;
  double px_per_rad = 0;  // the lens's local scale there
};

// Along each normal, within +-band px: the strongest log-luminance step,
// refined by a parabola through its neighbours.  Curve points whose search
// would leave the image are not visible; `visible` counts the others.
std::vector<Edge> SearchEdges(const LuminanceImage& lum, const CameraModel& camera,
                              const std::vector<Eigen::Vector2d>& p, const std::vector<Eigen::Vector2d>& n,
                              const std::vector<char>& ok, double band, int polarity, int* visible) {
  const cv::Mat& L = lum.log;
  const double step = 0.5;
  const int m = static_cast<int>(std::ceil(band / step));
  std::vector<Edge> out;
  *visible = 0;
  for (size_t k = 0; k < p.size(); ++k) {
    if (!ok[k]) continue;
    // The search segment, clipped to the image: the curve point must be 2 px
    // inside it, with 2 px of search on either side.
    auto inside = [&](const Eigen::Vector2d& q) {
      return q.x() >= 1 && q.y() >= 1 && q.x() <= L.cols - 2 && q.y() <= L.rows - 2;
    };
    int lo = 0, hi = 0;  // sample indices i in [-m-1, m+1] inside the image
    while (lo > -m - 1 && inside(p[k] + (lo - 1) * step * n[k])) --lo;
    while (hi < m + 1 && inside(p[k] + (hi + 1) * step * n[k])) ++hi;
    if (!inside(p[k]) || lo > -5 || hi < 5) continue;
    ++*visible;
    std::vector<double> v(static_cast<size_t>(2 * m + 3), 0.0);
    for (int i = lo; i <= hi; ++i) {
      const Eigen::Vector2d q = p[k] + i * step * n[k];
      v[static_cast<size_t>(i + m + 1)] = Bilinear(L, q.x(), q.y());
    }
    // g[i] ~ dL/ds at s = (i - m) * step, where both neighbours are in the image.
    const int g_lo = lo + m + 1, g_hi = hi + m - 1;  // the valid g indices
    std::vector<double> g(static_cast<size_t>(2 * m + 1), 0.0);
    double gmax = 0;
    for (int i = g_lo; i <= g_hi; ++i) {
      // Outward positive (polarity +1): the sphere reflects less than all
      // (reflectance < 1), so at the rim the log luminance drops going
      // inwards whatever the scene does further in.  A mask or a ball lit
      // brighter than its background steps the other way (polarity -1).
      g[static_cast<size_t>(i)] = std::max(0.0, polarity * (v[static_cast<size_t>(i + 2)] - v[static_cast<size_t>(i)]));
      gmax = std::max(gmax, g[static_cast<size_t>(i)]);
    }
    // The outermost strong step: the reflection just inside the rim is the
    // whole hemisphere behind the sphere squeezed into a thin ring, full of
    // steps as strong as the rim's (a sun's far stronger); taking the
    // strongest would pull the rim inwards.  "Strong": half the strongest,
    // or half of what a reflectance of 0.6 gives after the smoothing (0.2),
    // whichever is less.
    const double strong = 0.5 * std::min(gmax, 0.2);
    int best = -1;
    for (int i = g_hi - 1; i >= g_lo + 1 && best < 0; --i) {
      const double gi = g[static_cast<size_t>(i)];
      if (gi >= strong && gi >= g[static_cast<size_t>(i - 1)] && gi > g[static_cast<size_t>(i + 1)]) best = i;
    }
    if (best < 0 || gmax < 0.02) continue;  // no step (< 2%) inside the band
    // Placed on the linear luminance: its steepest point within a pixel of
    // the log's.
    std::vector<double> gl(g.size(), 0.0);
    for (int i = std::max(g_lo, best - 3); i <= std::min(g_hi, best + 3); ++i) {
      const Eigen::Vector2d q0 = p[k] + (i - m - 1) * step * n[k], q1 = p[k] + (i - m + 1) * step * n[k];
      gl[static_cast<size_t>(i)] =
          std::max(0.0, polarity * (Bilinear(lum.linear, q1.x(), q1.y()) - Bilinear(lum.linear, q0.x(), q0.y())));
    }
    int lin = best;
    for (int i = std::max(g_lo + 1, best - 2); i <= std::min(g_hi - 1, best + 2); ++i)
      if (gl[static_cast<size_t>(i)] > gl[static_cast<size_t>(lin)]) lin = i;
    if (lin > g_lo && lin < g_hi) {
      best = lin;
      g = gl;
    }
    const double gm = g[static_cast<size_t>(best - 1)], g0 = g[static_cast<size_t>(best)],
                 gp = g[static_cast<size_t>(best + 1)];
    const double den = gm - 2 * g0 + gp;
    const double off = den < 0 ? Clamp(0.5 * (gm - gp) / den, -0.5, 0.5) : 0.0;
    Edge e;
    e.px = p[k] + ((best - m) + off) * step * n[k];
    Eigen::Vector3d r1;
    if (!camera.Unproject(e.px, &e.ray) || !camera.Unproject(e.px + n[k], &r1)) continue;
    e.ray.normalize();
    const double ang = std::atan2(e.ray.cross(r1.normalized()).norm(), e.ray.dot(r1.normalized()));
    if (!(ang > 0)) continue;
    e.px_per_rad = 1 / ang;
    out.push_back(e);
  }
  return out;
}

// The angle between u and the axis a, less the half-angle.
struct ConeResidual {
  Eigen::Vector3d u;
  template <typename T>
  bool operator()(const T* a, const T* alpha, T* r) const {
    const T dot = a[0] * u.x() + a[1] * u.y() + a[2] * u.z();
    const T cx = a[1] * u.z() - a[2] * u.y(), cy = a[2] * u.x() - a[0] * u.z(), cz = a[0] * u.y() - a[1] * u.x();
    r[0] = ceres::atan2(ceres::sqrt(cx * cx + cy * cy + cz * cz), dot) - alpha[0];
    return true;
  }
};

double AngleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

void Basis(const Eigen::Vector3d& a, Eigen::Vector3d* e1, Eigen::Vector3d* e2) {
  *e1 = (std::abs(a.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(a).normalized();
  *e2 = a.cross(*e1);
}

// Robust cone fit: axis and half-angle, Cauchy loss at `scale` radians.
void FitCone(const std::vector<Edge>& edges, double scale, Eigen::Vector3d* axis, double* alpha) {
  double a[3] = {axis->x(), axis->y(), axis->z()};
  double al = *alpha;
  ceres::Problem problem;
  for (const Edge& e : edges)
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ConeResidual, 1, 3, 1>(new ConeResidual{e.ray}),
                             new ceres::CauchyLoss(scale), a, &al);
  problem.SetManifold(a, new ceres::SphereManifold<3>());
  problem.SetParameterLowerBound(&al, 0, 1e-6);
  problem.SetParameterUpperBound(&al, 0, 0.5 * kPi - 1e-6);
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::DENSE_QR;
  o.max_num_iterations = 100;
  o.function_tolerance = 1e-12;
  o.parameter_tolerance = 1e-12;
  o.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(o, &problem, &summary);
  *axis = Eigen::Vector3d(a[0], a[1], a[2]).normalized();
  *alpha = al;
}

// The fitted cone's silhouette in the image: points, outward normals and
// whether the lens images them.
void Silhouette(const CameraModel& camera, const Eigen::Vector3d& axis, double alpha, int n,
                std::vector<Eigen::Vector2d>* p, std::vector<Eigen::Vector2d>* normals, std::vector<char>* ok) {
  Eigen::Vector3d e1, e2;
  Basis(axis, &e1, &e2);
  p->assign(static_cast<size_t>(n), Eigen::Vector2d::Zero());
  normals->assign(static_cast<size_t>(n), Eigen::Vector2d::Zero());
  ok->assign(static_cast<size_t>(n), 0);
  Eigen::Vector2d centre(NAN, NAN);
  const bool centre_ok = camera.Project(axis, &centre);
  for (int k = 0; k < n; ++k) {
    const double phi = kTwoPi * k / n;
    const Eigen::Vector3d v = std::cos(alpha) * axis + std::sin(alpha) * (std::cos(phi) * e1 + std::sin(phi) * e2);
    Eigen::Vector2d q;
    (*ok)[static_cast<size_t>(k)] = camera.Project(v, &q);
    (*p)[static_cast<size_t>(k)] = q;
  }
  for (int k = 0; k < n; ++k) {
    const size_t prev = static_cast<size_t>((k + n - 1) % n), next = static_cast<size_t>((k + 1) % n);
    if (!(*ok)[static_cast<size_t>(k)] || !(*ok)[prev] || !(*ok)[next]) {
      (*ok)[static_cast<size_t>(k)] = 0;
      continue;
    }
    const Eigen::Vector2d t = (*p)[next] - (*p)[prev];
    Eigen::Vector2d nn(t.y(), -t.x());
    if (nn.norm() == 0) {
      (*ok)[static_cast<size_t>(k)] = 0;
      continue;
    }
    nn.normalize();
    // Outward: away from the axis's image (the curve's inside).
    if (centre_ok && nn.dot((*p)[static_cast<size_t>(k)] - centre) < 0) nn = -nn;
    (*normals)[static_cast<size_t>(k)] = nn;
  }
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Samples of a circle: points and outward normals.
void CirclePoints(const Eigen::Vector3d& c, int n, std::vector<Eigen::Vector2d>* p, std::vector<Eigen::Vector2d>* nrm) {
  p->resize(static_cast<size_t>(n));
  nrm->resize(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    const double phi = kTwoPi * k / n;
    (*nrm)[static_cast<size_t>(k)] = Eigen::Vector2d(std::cos(phi), std::sin(phi));
    (*p)[static_cast<size_t>(k)] = c.head<2>() + c.z() * (*nrm)[static_cast<size_t>(k)];
  }
}

struct FirstCircle {
  Eigen::Vector3d circle = Eigen::Vector3d::Zero();  // x, y, r px
  int polarity = 1;                                  // +1: darker inside the rim
};

// Hough candidates (OpenCV), each scored by the share of its whole outline
// where the image steps at the rim one way: a sphere seen whole beats a
// long arc of the scene (a fish-eye's horizon is a circle too).  A mirror
// darkens inwards (polarity +1) and is searched first; a ball brighter
// than its surroundings (-1) only where that finds none on a quarter of
// its outline (a mirror's reflection just inside its rim steps both ways,
// so the two are not compared candidate by candidate).
FirstCircle HoughCircle(const LuminanceImage& lum, const CameraModel& camera, const std::string& name) {
  const cv::Mat& L = lum.log;
  // 8 bits over the 1st to 99th percentile of the log luminance: a sun
  // must not flatten the rest.
  std::vector<float> v(L.begin<float>(), L.end<float>());
  std::sort(v.begin(), v.end());
  const double lo = v[v.size() / 100], hi = std::max(lo + 1e-3, static_cast<double>(v[v.size() * 99 / 100]));
  cv::Mat g8;
  L.convertTo(g8, CV_8U, 255 / (hi - lo), -255 * lo / (hi - lo));
  cv::medianBlur(g8, g8, 5);
  const int m = std::min(L.rows, L.cols);
  double best_score = 0;
  FirstCircle best;
  for (int polarity : {1, -1}) {
    for (double votes : {60.0, 40.0, 25.0, 15.0}) {
      std::vector<cv::Vec3f> circles;
      cv::HoughCircles(g8, circles, cv::HOUGH_GRADIENT, 1.0, m / 10.0, 80, votes, std::max(6, m / 40),
                       std::max(L.rows, L.cols) / 2);
      for (size_t i = 0; i < std::min<size_t>(circles.size(), 8); ++i) {
        const Eigen::Vector3d c(circles[i][0], circles[i][1], circles[i][2]);
        const int n = Clamp(static_cast<int>(kTwoPi * c.z() / 2), 64, 720);
        std::vector<Eigen::Vector2d> p, nrm;
        CirclePoints(c, n, &p, &nrm);
        int visible = 0;
        const double score =
            static_cast<double>(SearchEdges(lum, camera, p, nrm, std::vector<char>(static_cast<size_t>(n), 1),
                                            std::max(2.0, 0.05 * c.z()), polarity, &visible)
                                    .size()) /
            n;
        if (score > best_score) {
          best_score = score;
          best = {c, polarity};
        }
      }
      if (best_score > 0.5) break;
    }
    if (best_score >= 0.25) break;
  }
  if (best_score < 0.25)
    ThrowErrorAt(FileLoc{name},
                 "no circular silhouette found (Hough transform); give the sphere's circle with --circle x,y,r");
  return best;
}

// A silhouette mask: 90% of the pixels exactly at the darkest or the
// brightest level, each level at least 0.1% (a photograph's noise never
// does this; the rest is a mask's antialiased rim).  The sphere is the class with fewer pixels on the
// image's border, its largest connected region the silhouette.
struct MaskRegion {
  cv::Mat region;  // CV_8U, 255 on the silhouette
  FirstCircle first;
  double area = 0;        // px
  double lo = 0, hi = 0;  // the two levels
};

std::optional<MaskRegion> FindMask(const cv::Mat& raw, const std::string& name) {
  double lo = 0, hi = 0;
  cv::minMaxLoc(raw, &lo, &hi);
  if (!(hi > lo)) return std::nullopt;
  int64_t at_lo = 0, at_hi = 0;
  for (auto it = raw.begin<float>(); it != raw.end<float>(); ++it) {
    at_lo += *it == lo;
    at_hi += *it == hi;
  }
  const double n = static_cast<double>(raw.total());
  if (at_lo + at_hi < 0.9 * n || at_lo < 1e-3 * n || at_hi < 1e-3 * n) return std::nullopt;
  const cv::Mat bright = raw > 0.5 * (lo + hi);
  int64_t border_bright = 0, border = 0;
  for (int y = 0; y < raw.rows; ++y)
    for (int x = 0; x < raw.cols; ++x)
      if (y == 0 || x == 0 || y == raw.rows - 1 || x == raw.cols - 1) {
        ++border;
        border_bright += bright.at<uint8_t>(y, x) != 0;
      }
  MaskRegion m;
  m.lo = lo;
  m.hi = hi;
  m.first.polarity = 2 * border_bright <= border ? -1 : 1;  // a bright ball steps down going outwards
  const cv::Mat ball = m.first.polarity < 0 ? bright : ~bright;
  cv::Mat labels, stats, centroids;
  const int k = cv::connectedComponentsWithStats(ball, labels, stats, centroids, 8, CV_32S);
  int best = 0;
  for (int i = 1; i < k; ++i)
    if (best == 0 || stats.at<int>(i, cv::CC_STAT_AREA) > stats.at<int>(best, cv::CC_STAT_AREA)) best = i;
  if (best == 0) ThrowErrorAt(FileLoc{name}, "is a mask with no region in it");
  m.area = stats.at<int>(best, cv::CC_STAT_AREA);
  m.region = labels == best;
  m.first.circle =
      Eigen::Vector3d(centroids.at<double>(best, 0), centroids.at<double>(best, 1), std::sqrt(m.area / kPi));
  return m;
}

// The mask against the fitted sphere's silhouette: the share of the
// region's pixels more than 2 px outside or inside the fitted outline.
// A disc under any lens leaves none but the corners of its pixels.
double MaskMismatch(const MaskRegion& mask, const CameraModel& camera, const Eigen::Vector3d& axis, double alpha) {
  std::vector<Eigen::Vector2d> p, nrm;
  std::vector<char> ok;
  Silhouette(camera, axis, alpha, 720, &p, &nrm, &ok);
  std::vector<cv::Point> poly;
  for (size_t i = 0; i < p.size(); ++i)
    if (ok[i])
      poly.emplace_back(static_cast<int>(std::lround(p[i].x() * 8)), static_cast<int>(std::lround(p[i].y() * 8)));
  if (poly.size() < 3) return 1;
  cv::Mat fitted = cv::Mat::zeros(mask.region.size(), CV_8U);
  cv::fillPoly(fitted, std::vector<std::vector<cv::Point>>{poly}, cv::Scalar(255), cv::LINE_8, 3);
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5));
  cv::Mat grown, shrunk;
  cv::dilate(fitted, grown, kernel);
  cv::erode(fitted, shrunk, kernel);
  const double outside = cv::countNonZero(mask.region & ~grown), missing = cv::countNonZero(shrunk & ~mask.region);
  return (outside + missing) / std::max(1.0, mask.area);
}

}  // namespace

void SphereOptions::Check() const {
  if (!(radius_m > 0)) throw UsageError("the sphere's radius must be positive");
  if (!(min_visible >= 0 && min_visible <= 1))
    throw UsageError(fmt::format("--min-visible {} is outside [0, 1]", min_visible));
  if (samples < 1) throw UsageError(fmt::format("{} edge samples: at least 1", samples));
}

SphereFit FitMirrorSphere(const Image& photo, const CameraModel& camera, const SphereOptions& o,
                          const std::string& name) {
  o.Check();
  if (photo.width() != camera.width() || photo.height() != camera.height())
    ThrowErrorAt(FileLoc{name}, "is {}x{}; the camera model is for {}x{}", photo.width(), photo.height(),
                 camera.width(), camera.height());
  LuminanceImage L = LogLuminance(photo, name);
  SphereFit fit;
  // The first circle and the rim's polarity: a mask's region, a given
  // circle, or the Hough transform.
  const std::optional<MaskRegion> mask = FindMask(L.raw, name);
  if (mask) L = MaskCoverage(L.raw, mask->lo, mask->hi);
  int polarity = mask ? mask->first.polarity : 1;
  if (o.circle) {
    fit.first_circle = *o.circle;
  } else if (mask) {
    fit.first_circle = mask->first.circle;
  } else {
    const FirstCircle fc = HoughCircle(L, camera, name);
    fit.first_circle = fc.circle;
    polarity = fc.polarity;
  }
  const Eigen::Vector3d c0 = fit.first_circle;
  if (!(c0.z() >= 4))
    ThrowErrorAt(FileLoc{name}, "the sphere's circle has a radius of {:.1f} px; at least 4 px are needed", c0.z());
  // Samples about 2 px apart along the silhouette: neighbours' edge errors
  // are then nearly independent, which the covariance assumes.
  const int n = Clamp(static_cast<int>(kTwoPi * c0.z() / 2), 64, std::max(64, o.samples * 2));
  // Pass 1: along the first circle's radii, within a fifth of its radius.
  std::vector<Eigen::Vector2d> p, nrm;
  std::vector<char> ok(static_cast<size_t>(n), 1);
  CirclePoints(c0, n, &p, &nrm);
  int visible = 0;
  const double band1 = std::max(3.0, 0.2 * c0.z());
  std::vector<Edge> edges = SearchEdges(L, camera, p, nrm, ok, band1, polarity, &visible);
  if (o.circle && !mask && edges.size() < std::max<size_t>(12, static_cast<size_t>(n / 4))) {
    // A given circle says nothing of the polarity: as the Hough transform,
    // brighter inside only where darker finds under a quarter of the rim.
    int visible_b = 0;
    std::vector<Edge> b = SearchEdges(L, camera, p, nrm, ok, band1, -1, &visible_b);
    if (b.size() > edges.size()) {
      edges = std::move(b);
      polarity = -1;
    }
  }
  fit.polarity = polarity;
  fit.silhouette = fmt::format("{}: the sphere {} than its surroundings",
                               mask       ? (o.circle ? "a mask, from the circle given" : "a mask")
                               : o.circle ? "the circle given"
                                          : "the Hough transform",
                               polarity > 0 ? "darker" : "brighter");
  if (edges.size() < 12)
    ThrowErrorAt(FileLoc{name}, "only {} edge points found around the sphere's circle ({:.0f}, {:.0f}, r {:.0f} px)",
                 edges.size(), c0.x(), c0.y(), c0.z());
  // Seed: the mean edge ray and the mean angle to it.
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  {
    Eigen::Vector3d centre_ray;
    if (camera.Unproject(c0.head<2>(), &centre_ray))
      axis = centre_ray.normalized();
    else
      for (const Edge& e : edges) axis += e.ray;
    axis.normalize();
  }
  double alpha = 0;
  for (const Edge& e : edges) alpha += AngleBetween(e.ray, axis);
  alpha /= static_cast<double>(edges.size());
  std::vector<double> res;
  double px_per_rad = 0;
  for (int pass = 0; pass < 3; ++pass) {
    px_per_rad = Median([&] {
      std::vector<double> v;
      for (const Edge& e : edges) v.push_back(e.px_per_rad);
      return v;
    }());
    FitCone(edges, 1.5 / px_per_rad, &axis, &alpha);
    res.clear();
    for (const Edge& e : edges) res.push_back(AngleBetween(e.ray, axis) - alpha);
    std::vector<double> absres;
    for (double r : res) absres.push_back(std::abs(r));
    const double sigma = 1.4826 * Median(absres);
    if (pass == 2) break;
    // Along the fitted cone's own silhouette, in a band of a few sigma.
    Silhouette(camera, axis, alpha, n, &p, &nrm, &ok);
    const double band = Clamp(4 * sigma * px_per_rad, 2.0, std::max(2.0, 0.1 * c0.z()));
    edges = SearchEdges(L, camera, p, nrm, ok, band, polarity, &visible);
    fit.visible_fraction = static_cast<double>(visible) / n;
    if (fit.visible_fraction < o.min_visible)
      ThrowErrorAt(FileLoc{name},
                   "only {:.0f}% of the sphere's silhouette is inside the image; at least {:.0f}% is needed (move "
                   "the sphere away from the image's edge)",
                   100 * fit.visible_fraction, 100 * o.min_visible);
    if (edges.size() < 12)
      ThrowErrorAt(FileLoc{name}, "only {} edge points found along the fitted silhouette", edges.size());
  }
  // Inliers: within 3 robust sigma (at least 0.5 px).
  std::vector<double> absres;
  for (double r : res) absres.push_back(std::abs(r));
  const double thresh = std::max(3 * 1.4826 * Median(absres), 0.5 / px_per_rad);
  std::vector<Eigen::Vector3d> inl;
  double sum2 = 0;
  for (size_t i = 0; i < edges.size(); ++i)
    if (std::abs(res[i]) <= thresh) {
      inl.push_back(edges[i].ray);
      fit.edges.push_back(edges[i].px);
      sum2 += res[i] * res[i];
    }
  fit.edge_points = static_cast<int>(edges.size());
  fit.inliers = static_cast<int>(inl.size());
  if (alpha > 60 * kDegToRad)
    ThrowErrorAt(FileLoc{name},
                 "the silhouette found spans {:.0f} degrees: that is no sphere in front of the camera; "
                 "give the sphere's circle with --circle x,y,r",
                 2 * alpha / kDegToRad);
  if (fit.inliers < 12)
    ThrowErrorAt(FileLoc{name}, "only {} of {} edge points agree on one sphere", fit.inliers, fit.edge_points);
  if (mask) {
    fit.mask_mismatch = MaskMismatch(*mask, camera, axis, alpha);
    if (fit.mask_mismatch > 0.02)
      ThrowErrorAt(FileLoc{name},
                   "is a mask, but its region is no sphere's silhouette: {:.1f}% of it lies more than 2 px from the "
                   "fitted outline (at most 2% for a disc)",
                   100 * fit.mask_mismatch);
  }
  // Neighbouring edge points err together (the texture of the reflection
  // near the rim, the blur): the residuals' autocorrelation along the
  // silhouette, summed while positive, inflates the variance by the number
  // of points that act as one (the integrated autocorrelation time).
  std::vector<double> ri;
  for (size_t i = 0; i < edges.size(); ++i)
    if (std::abs(res[i]) <= thresh) ri.push_back(res[i]);
  {
    double mean = 0, var0 = 0;
    for (double r : ri) mean += r / static_cast<double>(ri.size());
    for (double& r : ri) {
      r -= mean;
      var0 += r * r / static_cast<double>(ri.size());
    }
    fit.correlation = 1;
    for (size_t lag = 1; lag <= 16 && lag < ri.size() && var0 > 0; ++lag) {
      double c = 0;
      for (size_t i = 0; i + lag < ri.size(); ++i) c += ri[i] * ri[i + lag];
      const double rho = c / (static_cast<double>(ri.size()) * var0);
      if (rho <= 0) break;
      fit.correlation += 2 * rho;
    }
  }
  const double s2 = fit.correlation * sum2 / std::max(1, fit.inliers - 3);
  fit.rms_rad = std::sqrt(sum2 / fit.inliers);
  fit.rms_px = fit.rms_rad * px_per_rad;
  fit.axis = axis;
  fit.half_angle = alpha;
  fit.radius_m = o.radius_m;
  // Covariance: theta = (d1, d2, alpha), the axis turned by d1 e1 + d2 e2.
  Eigen::Vector3d e1, e2;
  Basis(axis, &e1, &e2);
  auto residuals = [&](const Eigen::Vector3d& th) {
    const Eigen::Vector3d a = (axis + th.x() * e1 + th.y() * e2).normalized();
    Eigen::VectorXd r(static_cast<Eigen::Index>(inl.size()));
    for (size_t i = 0; i < inl.size(); ++i) r[static_cast<Eigen::Index>(i)] = AngleBetween(inl[i], a) - th.z();
    return r;
  };
  auto centre_of = [&](const Eigen::Vector3d& th) {
    return Eigen::Vector3d((axis + th.x() * e1 + th.y() * e2).normalized() * o.radius_m / std::sin(th.z()));
  };
  const Eigen::Vector3d th0(0, 0, alpha);
  Eigen::MatrixXd J(static_cast<Eigen::Index>(inl.size()), 3);
  Eigen::Matrix3d G;
  for (int j = 0; j < 3; ++j) {
    const double h = 1e-7;
    Eigen::Vector3d a = th0, b = th0;
    a[j] += h;
    b[j] -= h;
    J.col(j) = (residuals(a) - residuals(b)) / (2 * h);
    G.col(j) = (centre_of(a) - centre_of(b)) / (2 * h);
  }
  const Eigen::Matrix3d cov_th = s2 * (J.transpose() * J).ldlt().solve(Eigen::Matrix3d::Identity());
  fit.sigma_half_angle = std::sqrt(std::max(0.0, cov_th(2, 2)));
  fit.centre = centre_of(th0);
  fit.covariance = G * cov_th * G.transpose();
  return fit;
}

SphereFit CombineSphereFits(const std::vector<SphereFit>& fits, double* chi2) {
  MR_CHECK(!fits.empty());
  if (fits.size() == 1) {
    if (chi2) *chi2 = 0;
    return fits[0];
  }
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& f : fits) {
    const Eigen::Matrix3d I = f.covariance.ldlt().solve(Eigen::Matrix3d::Identity());
    info += I;
    b += I * f.centre;
  }
  SphereFit out = fits[0];
  out.covariance = info.ldlt().solve(Eigen::Matrix3d::Identity());
  out.centre = out.covariance * b;
  out.axis = out.centre.normalized();
  out.half_angle = std::asin(std::min(1.0, out.radius_m / out.centre.norm()));
  out.edge_points = out.inliers = 0;
  out.edges.clear();
  for (const auto& f : fits) {
    out.edge_points += f.edge_points;
    out.inliers += f.inliers;
  }
  if (chi2) {
    *chi2 = 0;
    for (const auto& f : fits) {
      const Eigen::Vector3d d = f.centre - out.centre;
      *chi2 += d.dot(f.covariance.ldlt().solve(d));
    }
  }
  return out;
}

}  // namespace mr
