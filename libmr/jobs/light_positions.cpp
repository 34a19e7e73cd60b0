#include "jobs/light_positions.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "core/check.h"
#include "core/color.h"
#include "core/math.h"
#include "core/spherical.h"
#include "geometry/embree_scene.h"
#include "light/light_source.h"

namespace mr {

namespace {

struct SurfacePoint {
  Eigen::Vector3d p, n;  // the point met, its surface's normal (towards the probe)
  double lum = 0;        // the map pixel's luminance
  double energy = 0;     // luminance x solid angle
  double area = 0;       // the surface area the map pixel covers there, m^2
};

// The rectangle over `core` (area-weighted): centroid, the energy-weighted
// mean normal, the in-plane principal axes; a uniform rectangle's side is
// sqrt(12) times its standard deviation along it.
Light FitRect(const std::vector<SurfacePoint>& core, const Light& named, double offset) {
  double a = 0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::Zero();
  for (const SurfacePoint& s : core) {
    a += s.area;
    c += s.area * s.p;
    n += s.energy * s.n;
  }
  c /= a;
  n.normalize();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const SurfacePoint& s : core) {
    Eigen::Vector3d q = s.p - c;
    q -= q.dot(n) * n;
    cov += s.area * q * q.transpose();
  }
  cov /= a;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Light l = named;
  l.type = LightType::kArea;
  l.shape = AreaShape::kRect;
  l.position = c + offset * n;
  l.direction = n;
  l.axis = eig.eigenvectors().col(2);
  // The pixels' centres spread a pixel less than the surface they cover
  // (variance 1/12 of a pixel's side squared): added back.
  const double px = std::sqrt(a / static_cast<double>(core.size()));
  l.width = std::sqrt(12 * std::max(0.0, eig.eigenvalues()[2]) + px * px);
  l.height = std::sqrt(12 * std::max(0.0, eig.eigenvalues()[1]) + px * px);
  l.irradiance.setZero();
  l.angular_radius_deg = 0;
  return l;
}

// The solid angle the rectangle subtends at `p`, by 16 x 16 midpoints.
double SolidAngleAt(const Light& l, const Eigen::Vector3d& p) {
  const Eigen::Vector3d t = l.axis, b = l.direction.cross(t);
  const double da = l.Area() / 256;
  double omega = 0;
  for (int j = 0; j < 16; ++j)
    for (int i = 0; i < 16; ++i) {
      const Eigen::Vector3d q =
          l.position + ((i + 0.5) / 16 - 0.5) * l.width * t + ((j + 0.5) / 16 - 0.5) * l.height * b - p;
      const double d2 = q.squaredNorm();
      omega += std::max(0.0, -q.normalized().dot(l.direction)) * da / d2;
    }
  return omega;
}

// The blob's pixels that the placed rectangle does not cover, seen from
// the probe (the lamp's glow: the lens's blur, not light in the room),
// take the radiance of the pixels bordering the blob (their mean) in the
// room's map, *fills; the light keeps the rest of the blob's power, so
// that light and map still hold the map's energy.  A mirror then shows
// the ceiling around the lamp instead of a dark ring where its glow was.
void FillAroundTheLamp(const Image& env, const ExtractedLight& x, const Light& l, const Eigen::Vector3d& probe,
                       Eigen::Vector3d* radiance, double omega,
                       std::vector<std::pair<size_t, Eigen::Vector3f>>* fills) {
  const int W = env.width(), H = env.height();
  std::vector<char> in(static_cast<size_t>(W) * H, 0);
  for (size_t p : x.pixels) in[p] = 1;
  Eigen::Vector3d border = Eigen::Vector3d::Zero();
  int nb = 0;
  for (size_t p : x.pixels) {
    const int px = static_cast<int>(p % static_cast<size_t>(W)), py = static_cast<int>(p / static_cast<size_t>(W));
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int yy = py + dy, xx = (px + dx + W) % W;
        const size_t q = static_cast<size_t>(yy) * W + static_cast<size_t>(xx);
        if (yy < 0 || yy >= H || in[q]) continue;
        in[q] = 2;  // counted once
        border += Eigen::Vector3d(env.at(xx, yy, 0), env.at(xx, yy, 1), env.at(xx, yy, 2));
        ++nb;
      }
  }
  if (nb == 0) return;
  border /= nb;
  const LightSource source(l);
  Eigen::Vector3d filled = Eigen::Vector3d::Zero();
  for (size_t p : x.pixels) {
    const int px = static_cast<int>(p % static_cast<size_t>(W)), py = static_cast<int>(p / static_cast<size_t>(W));
    const Eigen::Vector3d d = LatLongPixelToDirection(Eigen::Vector2d(px, py), W, H);
    double t = 0;
    if (source.HitArea(probe, d, INFINITY, &t).maxCoeff() > 0) continue;  // the lamp itself
    fills->emplace_back(p, border.cast<float>());
    filled += border * LatLongPixelSolidAngle(px, py, W, H);
  }
  // Never more than the blob held, channel by channel.
  *radiance = (*radiance - filled / omega).cwiseMax(0.0);
}

// A highlight on a glossy surface (a lamp mirrored in a polished counter)
// is not a light: a placed light whose mirror direction at its centre
// (the ray from the probe reflected about its surface's normal) points at
// a light of higher radiance, within that light's angular radius seen from
// there plus o.mirror_tolerance_deg, is left to the room's own radiance
// (report->reflections; the caller puts its pixels back in the map).
// Returns the luminance power of the lights so unplaced.
double MarkReflections(const Extraction& ex, const PositionOptions& o, std::vector<Light>* out,
                       PositionReport* report) {
  auto radiance = [&](size_t i) {
    return Luminance(ex.lights[i].power) / std::max(1e-12, ex.lights[i].DiscSolidAngle());
  };
  double e = 0;
  for (size_t i = 0; i < out->size(); ++i) {
    const Light& l = (*out)[i];
    if (l.type != LightType::kArea || ex.lights[i].pixels.empty()) continue;
    const Eigen::Vector3d d = (l.position - o.probe_centre).normalized();
    const Eigen::Vector3d m = d - 2 * d.dot(l.direction) * l.direction;
    for (size_t j = 0; j < out->size(); ++j) {
      if (j == i || !(radiance(j) > radiance(i))) continue;
      const Light& s = (*out)[j];
      Eigen::Vector3d to = s.direction;  // a distant light: towards it
      double radius = s.angular_radius_deg * kPi / 180;
      if (s.type == LightType::kArea) {
        to = s.position - l.position;
        radius = std::atan2(0.5 * std::hypot(s.width, s.height), to.norm());
      } else if (s.type != LightType::kDistant) {
        continue;
      }
      const double angle = std::acos(std::clamp(m.dot(to.normalized()), -1.0, 1.0));
      if (angle > radius + o.mirror_tolerance_deg * kPi / 180) continue;
      report->reflections.push_back(i);
      report->fills[i].clear();
      --report->positioned;
      e += Luminance(ex.lights[i].power);
      report->notes.push_back(fmt::format(
          "{}: a reflection of {} in the surface it lands on ({:.1f} degrees from its mirror direction): left to "
          "the room's own light",
          l.name, s.name, angle * 180 / kPi));
      break;
    }
  }
  return e;
}

}  // namespace

std::vector<Light> PositionLights(const Image& env, const Extraction& ex, const std::vector<Light>& lights,
                                  const Mesh& room, const PositionOptions& o, PositionReport* report) {
  MR_CHECK_EQ(lights.size(), ex.lights.size());
  const int W = env.width(), H = env.height();
  EmbreeScene embree;
  embree.AddMesh(room, false);
  embree.Commit();
  std::vector<Light> out = lights;
  report->fills.assign(lights.size(), {});
  double e_pos = 0, e_all = 0;
  for (size_t i = 0; i < ex.lights.size(); ++i) {
    const ExtractedLight& x = ex.lights[i];
    const double e_light = Luminance(x.power);
    e_all += e_light;
    if (x.pixels.empty()) continue;
    // Each pixel's ray from the probe's centre into the room.
    std::vector<SurfacePoint> met;
    double e_met = 0, e_total = 0;
    for (size_t pix : x.pixels) {
      const int px = static_cast<int>(pix % static_cast<size_t>(W)),
                py = static_cast<int>(pix / static_cast<size_t>(W));
      const Eigen::Vector3d d = LatLongPixelToDirection(Eigen::Vector2d(px, py), W, H);
      const double omega = LatLongPixelSolidAngle(px, py, W, H);
      SurfacePoint s;
      s.lum = LuminanceF(env.at(px, py, 0), env.at(px, py, 1), env.at(px, py, 2));
      s.energy = s.lum * omega;
      e_total += s.energy;
      Ray ray;
      ray.origin = o.probe_centre.cast<float>();
      ray.direction = d.cast<float>();
      Hit hit;
      if (!embree.Intersect(ray, &hit)) continue;
      Eigen::Vector3d n = hit.geometric_normal.cast<double>().normalized();
      if (n.dot(d) > 0) n = -n;
      s.p = o.probe_centre + static_cast<double>(hit.t) * d;
      s.n = n;
      s.area = omega * static_cast<double>(hit.t) * hit.t / std::max(1e-3, -n.dot(d));
      met.push_back(s);
      e_met += s.energy;
    }
    if (!(e_total > 0) || e_met < o.min_hit_share * e_total) {
      ++report->distant;
      report->notes.push_back(fmt::format("{}: left at infinity: {:.0f}% of its light's rays leave the room",
                                          lights[i].name, e_total > 0 ? 100 * (1 - e_met / e_total) : 100.0));
      continue;
    }
    // Its core: the pixels at least half as bright as the dimmest of the
    // brightest that hold half its energy (a lamp, not its glow; the whole
    // of a flat panel, ties and all).
    std::vector<std::pair<double, double>> by_lum;  // luminance, energy
    for (const SurfacePoint& s : met) by_lum.emplace_back(s.lum, s.energy);
    std::sort(by_lum.begin(), by_lum.end(), std::greater<>());
    double acc = 0, l_half = 0;
    for (const auto& [lum, e] : by_lum) {
      acc += e;
      l_half = lum;
      if (acc >= 0.5 * e_met) break;
    }
    std::vector<SurfacePoint> core;
    for (const SurfacePoint& s : met)
      if (s.lum >= 0.5 * l_half) core.push_back(s);
    Light l = FitRect(core, lights[i], o.offset_m);
    // The radiance that sends the probe the light it saw: the region's
    // power over the solid angle the rectangle subtends there.
    const double omega = SolidAngleAt(l, o.probe_centre);
    if (!(omega > 0)) {
      ++report->distant;
      report->notes.push_back(fmt::format("{}: left at infinity: the surface it lands on faces away", lights[i].name));
      continue;
    }
    l.radiance = x.power / omega;
    FillAroundTheLamp(env, x, l, o.probe_centre, &l.radiance, omega, &report->fills[i]);
    out[i] = l;
    ++report->positioned;
    e_pos += e_light;
    report->notes.push_back(
        fmt::format("{}: an area light {:.3f} x {:.3f} m at ({:.3f}, {:.3f}, {:.3f}) facing ({:.2f}, {:.2f}, {:.2f}), "
                    "{:.2f} m from "
                    "the probe",
                    l.name, l.width, l.height, l.position.x(), l.position.y(), l.position.z(), l.direction.x(),
                    l.direction.y(), l.direction.z(), (l.position - o.probe_centre).norm()));
  }
  e_pos -= MarkReflections(ex, o, &out, report);
  report->positioned_share = e_all > 0 ? e_pos / e_all : 0;
  report->distant_share = e_all > 0 ? 1 - report->positioned_share : 0;
  return out;
}

Image SkyOnly(const Image& map, const Mesh& room, const Eigen::Vector3d& probe_centre, SkyReport* report) {
  const int W = map.width(), H = map.height();
  EmbreeScene embree;
  embree.AddMesh(room, false);
  embree.Commit();
  std::vector<uint8_t> sky(static_cast<size_t>(W) * H, 0);
  double e_room = 0, e_all = 0;
  *report = SkyReport();
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      Ray ray;
      ray.origin = probe_centre.cast<float>();
      ray.direction = LatLongPixelToDirection(Eigen::Vector2d(x, y), W, H).cast<float>();
      Hit hit;
      const bool in_room = embree.Intersect(ray, &hit);
      sky[static_cast<size_t>(y) * W + x] = !in_room;
      const double e =
          LuminanceF(map.at(x, y, 0), map.at(x, y, 1), map.at(x, y, 2)) * LatLongPixelSolidAngle(x, y, W, H);
      e_all += e;
      if (in_room) e_room += e, ++report->room_pixels;
    }
  report->room_share = e_all > 0 ? e_room / e_all : 0;
  // The sky's radiance is taken from pixels whose 8 neighbours leave the
  // room too: a pixel on an opening's edge holds some of the wall (the
  // probe's pixel is an average over its footprint), and its mixed value
  // spread along the row made a probe far from the opening 2x worse.  Where
  // no pixel is that clear of the room, every one that leaves it is used.
  std::vector<uint8_t> source(sky.size(), 0);
  bool any_clear = false;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      bool clear = sky[static_cast<size_t>(y) * W + x] != 0;
      for (int dy = -1; dy <= 1 && clear; ++dy)
        for (int dx = -1; dx <= 1 && clear; ++dx) {
          const int yy = std::clamp(y + dy, 0, H - 1), xx = (x + dx + W) % W;
          clear = sky[static_cast<size_t>(yy) * W + xx] != 0;
        }
      source[static_cast<size_t>(y) * W + x] = clear;
      any_clear = any_clear || clear;
    }
  if (!any_clear) source = sky;
  Image out = Image::Rgb(W, H);
  std::vector<int> rows_with_sky;
  for (int y = 0; y < H; ++y) {
    std::vector<int> cols;
    for (int x = 0; x < W; ++x)
      if (source[static_cast<size_t>(y) * W + x]) cols.push_back(x);
    if (cols.empty()) continue;
    rows_with_sky.push_back(y);
    // Around the circle: each room pixel between sky pixels a and b.
    for (size_t k = 0; k < cols.size(); ++k) {
      const int a = cols[k], b = cols[(k + 1) % cols.size()];
      const int gap = ((b - a) % W + W) % W;  // W when a is the row's only sky pixel
      for (int c = 0; c < 3; ++c) out.at(a, y, c) = map.at(a, y, c);
      for (int j = 1; j < (gap == 0 ? W : gap); ++j) {
        const double t = static_cast<double>(j) / (gap == 0 ? W : gap);
        const int x = (a + j) % W;
        for (int c = 0; c < 3; ++c)
          out.at(x, y, c) = static_cast<float>((1 - t) * map.at(a, y, c) + t * map.at(b, y, c));
      }
    }
  }
  if (rows_with_sky.empty()) return Image::Rgb(W, H);  // nothing leaves the room
  for (int y = 0, k = 0; y < H; ++y) {
    while (k + 1 < static_cast<int>(rows_with_sky.size()) && std::abs(rows_with_sky[static_cast<size_t>(k) + 1] - y) <=
                                                                 std::abs(rows_with_sky[static_cast<size_t>(k)] - y))
      ++k;
    const int from = rows_with_sky[static_cast<size_t>(k)];
    if (from == y) continue;
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = out.at(x, from, c);
  }
  return out;
}

}  // namespace mr
