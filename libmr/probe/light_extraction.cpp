#include "probe/light_extraction.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <queue>
#include <set>

#include <Eigen/Eigenvalues>

#include "core/check.h"
#include "core/error.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "core/sh.h"
#include "core/spherical.h"
#include "light/environment.h"

namespace mr {

namespace {

// Which of two halves a uniform u picks, the first with probability p (0:
// the first), and u rescaled to be uniform within it.
int PickHalf(double p, double* u) {
  if (*u < p) {
    *u /= p;
    return 0;
  }
  *u = (*u - p) / (1 - p);
  return 1;
}

struct MapView {
  int w = 0, h = 0;
  std::vector<Eigen::Vector3d> radiance;  // per pixel
  std::vector<double> omega, energy;      // solid angle, luminance x solid angle
  std::vector<Eigen::Vector3d> dir;
  std::vector<float> clipped;  // the map's clipped.Y (empty: none)
  double total = 0;
  Eigen::Vector3d rgb(int x, int y) const { return radiance[static_cast<size_t>(y) * w + x]; }
};

MapView View(const Image& env) {
  if (env.channels() < 3 || env.channel_names()[0] != "R" || env.channel_names()[1] != "G" ||
      env.channel_names()[2] != "B")
    ThrowError("the environment map needs R, G, B channels first");
  MapView m;
  m.w = env.width();
  m.h = env.height();
  const size_t n = static_cast<size_t>(m.w) * m.h;
  m.radiance.resize(n);
  m.omega.resize(n);
  m.energy.resize(n);
  m.dir.resize(n);
  for (int y = 0; y < m.h; ++y)
    for (int x = 0; x < m.w; ++x) {
      const size_t i = static_cast<size_t>(y) * m.w + x;
      const Eigen::Vector3d L(env.at(x, y, 0), env.at(x, y, 1), env.at(x, y, 2));
      if (!L.allFinite() || L.minCoeff() < 0)
        ThrowError("environment pixel ({}, {}) is ({}, {}, {}): radiance must be finite and non-negative", x, y, L.x(),
                   L.y(), L.z());
      m.radiance[i] = L;
      m.omega[i] = LatLongPixelSolidAngle(x, y, m.w, m.h);
      m.energy[i] = Luminance(L) * m.omega[i];
      m.dir[i] = LatLongPixelToDirection(Eigen::Vector2d(x, y), m.w, m.h);
    }
  if (const int k = env.ChannelIndex("clipped.Y"); k >= 0) {
    m.clipped.resize(n);
    for (size_t i = 0; i < n; ++i)
      m.clipped[i] = env.values()[i * static_cast<size_t>(env.channels()) + static_cast<size_t>(k)];
  }
  std::vector<double> e = m.energy;
  std::sort(e.begin(), e.end());  // small first: the sum keeps the faint sky next to a sun
  for (double v : e) m.total += v;
  return m;
}

// Double-precision summed-area tables of energy and its first and second
// moments in pixel coordinates.
struct Sat {
  int w = 0, h = 0;
  std::vector<double> e, ex, ey, exx, eyy;  // (w + 1) x (h + 1)
  explicit Sat(const MapView& m) : w(m.w), h(m.h) {
    const size_t n = static_cast<size_t>(w + 1) * (h + 1);
    for (auto* v : {&e, &ex, &ey, &exx, &eyy}) v->assign(n, 0.0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const double en = m.energy[static_cast<size_t>(y) * w + x];
        const double vals[5] = {en, en * x, en * y, en * x * x, en * y * y};
        std::vector<double>* tabs[5] = {&e, &ex, &ey, &exx, &eyy};
        for (int k = 0; k < 5; ++k) {
          std::vector<double>& t = *tabs[k];
          t[At(x + 1, y + 1)] = vals[k] + t[At(x, y + 1)] + t[At(x + 1, y)] - t[At(x, y)];
        }
      }
  }
  size_t At(int x, int y) const { return static_cast<size_t>(y) * (w + 1) + x; }
  double Sum(const std::vector<double>& t, int x0, int y0, int x1, int y1) const {
    return t[At(x1, y1)] - t[At(x0, y1)] - t[At(x1, y0)] + t[At(x0, y0)];
  }
};

struct Region {
  int x0, y0, x1, y1;
  double priority = 0;
  bool operator<(const Region& o) const { return priority < o.priority; }
};

double CosLatitude(double yc, int h) { return std::max(1e-3, std::cos(kPi * (yc / (h - 1) - 0.5))); }

// Energy-weighted spatial variance (summed, in radians^2) of a region.
double RegionVariance(const Sat& s, int x0, int y0, int x1, int y1) {
  const double E = s.Sum(s.e, x0, y0, x1, y1);
  if (!(E > 0)) return 0;
  const double cx = CosLatitude(0.5 * (y0 + y1 - 1), s.h) * kTwoPi / s.w, cy = kPi / (s.h - 1);
  const double vx = s.Sum(s.exx, x0, y0, x1, y1) - Square(s.Sum(s.ex, x0, y0, x1, y1)) / E;
  const double vy = s.Sum(s.eyy, x0, y0, x1, y1) - Square(s.Sum(s.ey, x0, y0, x1, y1)) / E;
  return std::max(0.0, vx) * cx * cx + std::max(0.0, vy) * cy * cy;
}

// Splits `r` (median or variance); false when it cannot be split.
bool Split(const Sat& s, const Region& r, bool variance, Region* a, Region* b) {
  const int wdt = r.x1 - r.x0, hgt = r.y1 - r.y0;
  if (wdt < 2 && hgt < 2) return false;
  auto halves = [&](bool along_x, int k, Region* ra, Region* rb) {
    *ra = r;
    *rb = r;
    if (along_x)
      ra->x1 = rb->x0 = k;
    else
      ra->y1 = rb->y0 = k;
  };
  if (!variance) {
    const double width = wdt * CosLatitude(0.5 * (r.y0 + r.y1 - 1), s.h) * kTwoPi / s.w, height = hgt * kPi / (s.h - 1);
    const bool along_x = hgt < 2 || (wdt >= 2 && width >= height);
    const double E = s.Sum(s.e, r.x0, r.y0, r.x1, r.y1);
    const int lo = along_x ? r.x0 + 1 : r.y0 + 1, hi = along_x ? r.x1 - 1 : r.y1 - 1;
    int best = lo;
    double best_d = std::numeric_limits<double>::infinity();
    for (int k = lo; k <= hi; ++k) {
      const double left = along_x ? s.Sum(s.e, r.x0, r.y0, k, r.y1) : s.Sum(s.e, r.x0, r.y0, r.x1, k);
      const double d = std::abs(left - 0.5 * E);
      if (d < best_d) {
        best_d = d;
        best = k;
      }
    }
    halves(along_x, best, a, b);
    return true;
  }
  double best = std::numeric_limits<double>::infinity();
  bool found = false;
  for (const bool along_x : {true, false}) {
    const int lo = along_x ? r.x0 + 1 : r.y0 + 1, hi = along_x ? r.x1 - 1 : r.y1 - 1;
    for (int k = lo; k <= hi; ++k) {
      Region ra, rb;
      halves(along_x, k, &ra, &rb);
      const double cost = RegionVariance(s, ra.x0, ra.y0, ra.x1, ra.y1) + RegionVariance(s, rb.x0, rb.y0, rb.x1, rb.y1);
      if (cost < best) {
        best = cost;
        *a = ra;
        *b = rb;
        found = true;
      }
    }
  }
  return found;
}

ExtractedLight LightOfPixels(const MapView& m, const std::vector<size_t>& pixels, bool area) {
  ExtractedLight l;
  l.area = area;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double e = 0, e_clipped = 0;
  for (size_t i : pixels) {
    l.power += m.radiance[i] * m.omega[i];
    l.solid_angle += m.omega[i];
    centroid += m.energy[i] * m.dir[i];
    e += m.energy[i];
    if (!m.clipped.empty() && m.clipped[i] > 0) e_clipped += m.energy[i];
  }
  l.clipped_share = e > 0 ? e_clipped / e : 0;
  if (centroid.norm() > 0)
    l.direction = centroid.normalized();
  else if (!pixels.empty()) {  // no energy (or it cancels): the pixels' mean direction
    for (size_t i : pixels) centroid += m.omega[i] * m.dir[i];
    l.direction = centroid.norm() > 0 ? centroid.normalized() : m.dir[pixels[0]];
  }
  return l;
}

std::vector<ExtractedLight> Cut(const MapView& m, int count, bool variance) {
  const Sat s(m);
  std::priority_queue<Region> queue;
  auto push = [&](Region r) {
    r.priority = variance ? RegionVariance(s, r.x0, r.y0, r.x1, r.y1) : s.Sum(s.e, r.x0, r.y0, r.x1, r.y1);
    queue.push(r);
  };
  push({0, 0, m.w, m.h});
  std::vector<Region> done;
  while (static_cast<int>(queue.size() + done.size()) < count && !queue.empty()) {
    const Region r = queue.top();
    queue.pop();
    Region a, b;
    if (r.priority <= 0 || !Split(s, r, variance, &a, &b)) {
      done.push_back(r);  // nothing to gain from splitting it
      continue;
    }
    push(a);
    push(b);
  }
  while (!queue.empty()) {
    done.push_back(queue.top());
    queue.pop();
  }
  std::vector<ExtractedLight> lights;
  for (const Region& r : done) {
    std::vector<size_t> px;
    for (int y = r.y0; y < r.y1; ++y)
      for (int x = r.x0; x < r.x1; ++x) px.push_back(static_cast<size_t>(y) * m.w + x);
    ExtractedLight l = LightOfPixels(m, px, false);
    if (Luminance(l.power) > 0) lights.push_back(l);
  }
  return lights;
}

// Clarberg et al.'s hierarchical warping over a 2^k x 2^k quadtree of the
// energy, the lat-long map seen through (u, v) = (px / (W-1), py / (H-1)).
std::vector<ExtractedLight> Importance(const MapView& m, int count, uint32_t seed) {
  int S = 1;
  while (S < std::max(m.w, m.h)) S *= 2;
  std::vector<std::vector<double>> levels;
  std::vector<double> base(static_cast<size_t>(S) * S);
  // Each pixel's energy spread over the cells it overlaps in (u, v) (a box
  // filter, separable): nearest-pixel lookups would give a bright pixel the
  // area of however many cell centres fall in it (2 or 3 here), biasing the
  // VPLs towards it.
  auto overlaps = [](int n_pixels, int cells) {
    // weights[cell] = {(pixel, fraction of the pixel's extent)}; pixel k
    // spans [k - 1/2, k + 1/2] clamped to [0, n - 1], cell c spans
    // [c, c + 1] (n - 1) / cells.
    std::vector<std::vector<std::pair<int, double>>> w(static_cast<size_t>(cells));
    const double scale = static_cast<double>(n_pixels - 1) / cells;
    for (int c = 0; c < cells; ++c) {
      const double a = c * scale, b = (c + 1) * scale;
      for (int k = std::max(0, static_cast<int>(std::floor(a - 0.5)));
           k <= std::min(n_pixels - 1, static_cast<int>(std::ceil(b + 0.5))); ++k) {
        const double lo = std::max(0.0, k - 0.5), hi = std::min(n_pixels - 1.0, k + 0.5);
        const double ov = std::min(b, hi) - std::max(a, lo);
        if (ov > 0 && hi > lo) w[static_cast<size_t>(c)].push_back({k, ov / (hi - lo)});
      }
    }
    return w;
  };
  const auto wx = overlaps(m.w, S), wy = overlaps(m.h, S);
  std::vector<double> rows(static_cast<size_t>(m.h) * S, 0.0);
  for (int y = 0; y < m.h; ++y)
    for (int i = 0; i < S; ++i)
      for (const auto& [x, f] : wx[static_cast<size_t>(i)])
        rows[static_cast<size_t>(y) * S + i] += f * m.energy[static_cast<size_t>(y) * m.w + x];
  for (int j = 0; j < S; ++j)
    for (const auto& [y, f] : wy[static_cast<size_t>(j)])
      for (int i = 0; i < S; ++i) base[static_cast<size_t>(j) * S + i] += f * rows[static_cast<size_t>(y) * S + i];
  // The pixel that gives each cell most of its energy: a VPL there takes its
  // colour (a cell straddling a bright and a black pixel must not give its
  // VPL the black one's, zero, radiance).
  std::vector<size_t> dominant(static_cast<size_t>(S) * S);
  for (int j = 0; j < S; ++j)
    for (int i = 0; i < S; ++i) {
      double best = -1;
      for (const auto& [y, fy] : wy[static_cast<size_t>(j)])
        for (const auto& [x, fx] : wx[static_cast<size_t>(i)]) {
          const size_t p = static_cast<size_t>(y) * m.w + x;
          const double e = fx * fy * m.energy[p];
          if (e > best) {
            best = e;
            dominant[static_cast<size_t>(j) * S + i] = p;
          }
        }
    }
  levels.push_back(base);
  for (int n = S / 2; n >= 1; n /= 2) {
    const std::vector<double>& f = levels.back();
    std::vector<double> c(static_cast<size_t>(n) * n);
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        c[static_cast<size_t>(j) * n + i] =
            f[static_cast<size_t>(2 * j) * 2 * n + 2 * i] + f[static_cast<size_t>(2 * j) * 2 * n + 2 * i + 1] +
            f[static_cast<size_t>(2 * j + 1) * 2 * n + 2 * i] + f[static_cast<size_t>(2 * j + 1) * 2 * n + 2 * i + 1];
    levels.push_back(c);
  }
  std::reverse(levels.begin(), levels.end());  // levels[k] is 2^k x 2^k
  std::vector<ExtractedLight> lights;
  if (!(levels[0][0] > 0)) return lights;
  // Each VPL carries the map's exact energy over N in luminance (the grid's
  // own total differs by its nearest-pixel lookups).
  const double total = m.total;
  for (int k = 0; k < count; ++k) {
    const std::array<float, 2> pt = Sobol2D(static_cast<uint32_t>(k), seed, seed != 0);
    double u = pt[0], v = pt[1];  // a (0, 2)-sequence: every power-of-two prefix is stratified
    int i = 0, j = 0;
    for (size_t lvl = 1; lvl < levels.size(); ++lvl) {
      const int n = 1 << lvl;
      const std::vector<double>& f = levels[lvl];
      const double a = f[static_cast<size_t>(2 * j) * n + 2 * i], b = f[static_cast<size_t>(2 * j) * n + 2 * i + 1];
      const double c = f[static_cast<size_t>(2 * j + 1) * n + 2 * i],
                   d = f[static_cast<size_t>(2 * j + 1) * n + 2 * i + 1];
      const int ci = PickHalf((a + c) / (a + b + c + d), &u);  // the left or right column
      const double top = ci == 0 ? a : b, bottom = ci == 0 ? c : d;
      const int cj = PickHalf(top / (top + bottom), &v);  // then its top or bottom cell
      i = 2 * i + ci;
      j = 2 * j + cj;
      u = std::clamp(u, 0.0, std::nextafter(1.0, 0.0));
      v = std::clamp(v, 0.0, std::nextafter(1.0, 0.0));
    }
    const double uu = (i + u) / S, vv = (j + v) / S;
    const Eigen::Vector3d dir = LatLongPixelToDirection(Eigen::Vector2d(uu * (m.w - 1), vv * (m.h - 1)), m.w, m.h);
    const size_t p = dominant[static_cast<size_t>(j) * S + i];
    const double lum = Luminance(m.radiance[p]);
    ExtractedLight l;
    l.direction = dir;
    l.power = lum > 0 ? Eigen::Vector3d(m.radiance[p] * (total / (count * lum))) : Eigen::Vector3d::Zero();
    l.solid_angle = kFourPi / count;
    lights.push_back(l);
  }
  return lights;
}

// Blob segmentation at the scale of the light: the pixels brighter than
// `threshold` times the map's mean, and those clipped in the photograph
// (clipped.Y > 0: their light is unknown above the clip), taken brightest first and joined to
// their brighter neighbours' regions (union-find); where two regions meet,
// they become one unless the light at the meeting pixel has fallen below
// `saddle` times the dimmer region's peak.  A highlight with its glow, or
// a flat panel with noise on it, is one region; two lamps whose glows
// touch are two.  The regions, brightest (by energy) first, are the
// lights, at most `count`, each a disc of its core; a region whose core is
// wider than `max_sr` (a window, a panel: a disc would misplace its light)
// stays in the map with its shape, as do the regions beyond `count`.
// *n_regions: the regions; *split: the connected components that became
// more than one light; *wide: the regions left in the map for their width.
std::vector<ExtractedLight> Blobs(const MapView& m, int count, double threshold, double saddle, double max_sr,
                                  bool keep_wide, std::vector<uint8_t>* taken, int* n_regions, int* split, int* wide) {
  const double cut = threshold * m.total / kFourPi;
  const size_t n = m.energy.size();
  std::vector<double> lum(n);
  std::vector<size_t> bright;
  for (size_t s = 0; s < n; ++s) {
    lum[s] = Luminance(m.radiance[s]);
    // A clipped pixel is a light whatever its recorded value: only its
    // lower bound is known (a lamp clipped at a value near the room's).
    if (lum[s] > cut || (!m.clipped.empty() && m.clipped[s] > 0)) bright.push_back(s);
  }
  std::sort(bright.begin(), bright.end(),
            [&](size_t a, size_t b) { return lum[a] != lum[b] ? lum[a] > lum[b] : a < b; });
  std::vector<int64_t> parent(n, -1);  // -1: not yet taken
  std::vector<double> peak(n, 0.0);    // at a region's root
  auto find = [](std::vector<int64_t>& up, int64_t i) {
    while (up[static_cast<size_t>(i)] != i)
      i = up[static_cast<size_t>(i)] = up[static_cast<size_t>(up[static_cast<size_t>(i)])];
    return i;
  };
  std::vector<int64_t> roots;
  for (size_t p : bright) {
    const int x = static_cast<int>(p % m.w), y = static_cast<int>(p / m.w);
    roots.clear();
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int yy = y + dy;
        if (yy < 0 || yy >= m.h || (dx == 0 && dy == 0)) continue;
        const size_t q = static_cast<size_t>(yy) * m.w + static_cast<size_t>((x + dx + m.w) % m.w);  // the seam wraps
        if (parent[q] < 0) continue;
        roots.push_back(find(parent, static_cast<int64_t>(q)));
      }
    const int64_t self = static_cast<int64_t>(p);
    if (roots.empty()) {
      parent[p] = self;
      peak[p] = lum[p];
      continue;
    }
    std::sort(roots.begin(), roots.end(), [&](int64_t a, int64_t b) {
      return peak[static_cast<size_t>(a)] != peak[static_cast<size_t>(b)]
                 ? peak[static_cast<size_t>(a)] > peak[static_cast<size_t>(b)]
                 : a < b;
    });
    roots.erase(std::unique(roots.begin(), roots.end()), roots.end());
    parent[p] = roots[0];
    for (size_t k = 1; k < roots.size(); ++k)
      if (lum[p] >= saddle * peak[static_cast<size_t>(roots[k])]) parent[static_cast<size_t>(roots[k])] = roots[0];
  }
  std::map<int64_t, std::vector<size_t>> regions;
  for (size_t p : bright) regions[find(parent, static_cast<int64_t>(p))].push_back(p);
  // The connected components (pixels joined through any neighbour), to
  // count those that became several lights.
  std::map<int64_t, std::set<int64_t>> comp_regions;
  {
    std::vector<int64_t> cparent(n, -1);
    for (size_t p : bright) cparent[p] = static_cast<int64_t>(p);
    for (size_t p : bright) {
      const int x = static_cast<int>(p % m.w), y = static_cast<int>(p / m.w);
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int yy = y + dy;
          if (yy < 0 || yy >= m.h) continue;
          const size_t q = static_cast<size_t>(yy) * m.w + static_cast<size_t>((x + dx + m.w) % m.w);
          if (cparent[q] < 0) continue;
          const int64_t a = find(cparent, static_cast<int64_t>(p)), b = find(cparent, static_cast<int64_t>(q));
          if (a != b) cparent[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
        }
    }
    for (const auto& [r, px] : regions) comp_regions[find(cparent, r)].insert(r);
  }
  *n_regions = static_cast<int>(regions.size());
  *split = 0;
  for (const auto& [c, rs] : comp_regions) *split += rs.size() > 1;
  std::vector<std::pair<double, int64_t>> order;
  for (const auto& [r, px] : regions) {
    double e = 0;
    for (size_t p : px) e += m.energy[p];
    order.push_back({-e, r});
  }
  std::sort(order.begin(), order.end());
  std::vector<ExtractedLight> lights;
  *wide = 0;
  for (size_t k = 0; k < order.size() && static_cast<int>(lights.size()) < count; ++k) {
    const std::vector<size_t>& px = regions[order[k].second];
    ExtractedLight l = LightOfPixels(m, px, true);
    // Its disc: twice the solid angle of the brightest pixels that hold half
    // its energy (a uniform disc's own; a lamp's glow, which holds little of
    // the energy over much of the solid angle, does not widen it).
    std::vector<size_t> by_lum = px;
    std::sort(by_lum.begin(), by_lum.end(),
              [&](size_t a, size_t b) { return lum[a] != lum[b] ? lum[a] > lum[b] : a < b; });
    const double total = Luminance(l.power);
    double acc = 0, omega = 0;
    for (size_t p : by_lum) {
      if (acc >= 0.5 * total) break;
      acc += lum[p] * m.omega[p];
      omega += m.omega[p];
    }
    l.disc_solid_angle = std::min(l.solid_angle, 2 * omega);
    l.pixels = px;
    // A clipped core is as wide as the lens's blur made the clip, not the
    // light (a lamp 300 x over the clip on a 75-px ball: 0.065 sr): it is
    // a light up to 4 x max_sr (a clipped window wider still stays in the map).
    const double wide_sr = l.clipped_share > 0.5 ? 4 * max_sr : max_sr;
    if (l.disc_solid_angle > wide_sr && !keep_wide) {  // a window, a panel: no disc; the map keeps its shape
      ++*wide;
      continue;
    }
    lights.push_back(l);
    for (size_t p : px) (*taken)[p] = 1;
  }
  return lights;
}

// The map less what the lights took (`taken`), its luminance share and its
// SH projection.
void FillResidual(const MapView& m, const std::vector<uint8_t>& taken, int sh_order, Extraction* ex) {
  ex->residual = Image::Rgb(m.w, m.h);
  double left = 0;
  for (int y = 0; y < m.h; ++y)
    for (int x = 0; x < m.w; ++x) {
      const size_t i = static_cast<size_t>(y) * m.w + x;
      if (taken[i]) continue;
      for (int c = 0; c < 3; ++c) ex->residual.at(x, y, c) = static_cast<float>(m.radiance[i][c]);
      left += m.energy[i];
    }
  ex->taken_fraction = m.total > 0 ? 1 - left / m.total : 0;
  const int nsh = ShCount(sh_order);
  ex->residual_sh.assign(static_cast<size_t>(nsh), Eigen::Vector3d::Zero());
  std::vector<double> basis(static_cast<size_t>(nsh));
  for (size_t i = 0; i < m.energy.size(); ++i) {
    if (taken[i]) continue;
    ShEvaluate(m.dir[i], sh_order, basis.data());
    for (int k = 0; k < nsh; ++k)
      ex->residual_sh[static_cast<size_t>(k)] += m.radiance[i] * (basis[static_cast<size_t>(k)] * m.omega[i]);
  }
}

}  // namespace

void ExtractOptions::Check() const {
  if (method != "median-cut" && method != "variance-cut" && method != "importance" && method != "blobs")
    throw UsageError(fmt::format("method \"{}\" is not median-cut, variance-cut, importance or blobs", method));
  if (count < 1 || count > 1 << 20) throw UsageError(fmt::format("count {} not in [1, 2^20]", count));
  if (!(threshold > 0)) throw UsageError("threshold must be positive");
  if (!(saddle > 0 && saddle <= 1)) throw UsageError(fmt::format("saddle {} is not in (0, 1]", saddle));
  if (!(max_blob_sr > 0)) throw UsageError("max_blob_sr must be positive");
  if (sh_order < 1 || sh_order > kMaxShOrder) throw UsageError(fmt::format("sh_order must be 1..{}", kMaxShOrder));
}

Extraction ExtractLights(const Image& env, const ExtractOptions& o) {
  o.Check();
  const auto t0 = std::chrono::steady_clock::now();
  const MapView m = View(env);
  Extraction ex;
  std::vector<uint8_t> taken(m.energy.size(), 0);
  if (o.method == "median-cut" || o.method == "variance-cut") {
    ex.lights = Cut(m, o.count, o.method == "variance-cut");
    std::fill(taken.begin(), taken.end(), 1);
  } else if (o.method == "importance") {
    ex.lights = Importance(m, o.count, o.seed);
    std::fill(taken.begin(), taken.end(), 1);
  } else {
    ex.lights = Blobs(m, o.count, o.threshold, o.saddle, o.max_blob_sr, o.keep_wide, &taken, &ex.regions,
                      &ex.split_components, &ex.wide_regions);
  }
  FillResidual(m, taken, o.sh_order, &ex);
  ex.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return ex;
}

void ReturnToResidual(const Image& env, const std::vector<bool>& drop, int sh_order, Extraction* ex) {
  MR_CHECK_EQ(drop.size(), ex->lights.size());
  const MapView m = View(env);
  std::vector<uint8_t> taken(m.energy.size(), 0);
  std::vector<ExtractedLight> kept;
  for (size_t i = 0; i < drop.size(); ++i) {
    MR_CHECK(!ex->lights[i].pixels.empty());  // blobs' lights know their pixels
    if (drop[i]) continue;
    for (size_t p : ex->lights[i].pixels) taken[p] = 1;
    kept.push_back(std::move(ex->lights[i]));
  }
  ex->lights = std::move(kept);
  FillResidual(m, taken, sh_order, ex);
}

void ReplaceResidual(const Image& map, int sh_order, Extraction* ex) {
  const double taken = ex->taken_fraction;
  const MapView m = View(map);
  FillResidual(m, std::vector<uint8_t>(m.energy.size(), 0), sh_order, ex);
  ex->taken_fraction = taken;
}

std::vector<int> MatchLights(const std::vector<ExtractedLight>& previous, const std::vector<int>& previous_ids,
                             const std::vector<ExtractedLight>& current, double max_angle_deg, int* next_id,
                             int* matched) {
  if (previous.size() != previous_ids.size()) ThrowError("{} ids for {} lights", previous_ids.size(), previous.size());
  struct Pair {
    double angle;
    size_t cur, prev;
  };
  std::vector<Pair> pairs;
  const double max_angle = max_angle_deg * kDegToRad;
  for (size_t c = 0; c < current.size(); ++c)
    for (size_t p = 0; p < previous.size(); ++p) {
      const double a = std::acos(std::clamp(current[c].direction.dot(previous[p].direction), -1.0, 1.0));
      if (a <= max_angle) pairs.push_back({a, c, p});
    }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return a.angle != b.angle ? a.angle < b.angle : (a.cur != b.cur ? a.cur < b.cur : a.prev < b.prev);
  });
  std::vector<int> ids(current.size(), -1);
  std::vector<char> used(previous.size(), 0);
  int kept = 0;
  for (const Pair& pr : pairs) {
    if (ids[pr.cur] >= 0 || used[pr.prev]) continue;
    ids[pr.cur] = previous_ids[pr.prev];
    used[pr.prev] = 1;
    ++kept;
  }
  for (int& id : ids)
    if (id < 0) id = (*next_id)++;
  if (matched) *matched = kept;
  return ids;
}

std::vector<Light> ToLights(const Extraction& e, const std::string& prefix, const std::vector<int>* ids) {
  if (ids && ids->size() != e.lights.size()) ThrowError("{} ids for {} lights", ids->size(), e.lights.size());
  std::vector<Light> out;
  for (size_t i = 0; i < e.lights.size(); ++i) {
    const ExtractedLight& x = e.lights[i];
    Light l;
    l.name = fmt::format("{}{}", prefix, ids ? (*ids)[i] : static_cast<int>(i));
    l.type = LightType::kDistant;
    l.is_virtual = false;  // from the probe: part of the real scene
    l.direction = x.direction;
    // A disc of its disc solid angle, 2 pi (1 - cos r) = omega, and the same
    // mean radiance; lights.json's irradiance is what it gives a surface
    // facing it, radiance x pi sin^2 r (the power for a delta).
    const double disc = x.DiscSolidAngle();
    const double r = x.area ? std::acos(std::clamp(1 - disc / kTwoPi, -1.0, 1.0)) : 0;
    l.angular_radius_deg = r / kDegToRad;
    l.irradiance = x.area && disc > 0 ? Eigen::Vector3d(x.power * (kPi * Square(std::sin(r)) / disc)) : x.power;
    l.solid_angle_sr = std::min(x.solid_angle, kFourPi);
    if (x.clipped_share > 0)
      l.strength_note = fmt::format(
          "a lower bound: {:.0f}% of its energy comes from pixels clipped in the photograph (their light above the "
          "clip estimated from the glow, or not at all)",
          100 * x.clipped_share);
    out.push_back(l);
  }
  return out;
}

std::vector<Eigen::Vector3d> SphereNormals(int n) {
  std::vector<Eigen::Vector3d> out;
  const double golden = kPi * (3 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double y = 1 - (i + 0.5) * 2.0 / n, r = std::sqrt(std::max(0.0, 1 - y * y));
    out.emplace_back(r * std::cos(golden * i), y, r * std::sin(golden * i));
  }
  return out;
}

std::vector<double> MapIrradiance(const Image& env, const std::vector<Eigen::Vector3d>& normals) {
  const MapView m = View(env);
  std::vector<double> out(normals.size());
  ParallelFor(0, static_cast<int64_t>(normals.size()), [&](int64_t k) {
    double e = 0;
    for (size_t i = 0; i < m.energy.size(); ++i)
      e += m.energy[i] * std::max(0.0, normals[static_cast<size_t>(k)].dot(m.dir[i]));
    out[static_cast<size_t>(k)] = e;
  });
  return out;
}

std::vector<double> LightsIrradiance(const Extraction& e, const std::vector<Eigen::Vector3d>& normals,
                                     bool with_residual) {
  const int order = static_cast<int>(std::lround(std::sqrt(static_cast<double>(e.residual_sh.size()))));
  // The clamped cosine's SH coefficients (Ramamoorthi and Hanrahan 2001).
  auto A = [](int l) {
    if (l == 0) return kPi;
    if (l == 1) return 2 * kPi / 3;
    if (l % 2 == 1) return 0.0;
    double f = 1;  // l! / (2^l ((l/2)!)^2)
    for (int i = 1; i <= l / 2; ++i) f *= static_cast<double>(l / 2 + i) / (4.0 * i);
    return 2 * kPi * ((l / 2) % 2 == 0 ? 1.0 : -1.0) * -1.0 / ((l + 2.0) * (l - 1.0)) * f;
  };
  std::vector<double> out(normals.size(), 0.0);
  std::vector<double> basis(e.residual_sh.size());
  // Area lights as the renderer sees them: uniform discs of their solid
  // angle, integrated over 16 x 16 stratified directions.
  std::vector<std::vector<Eigen::Vector3d>> disc(e.lights.size());
  for (size_t i = 0; i < e.lights.size(); ++i) {
    const ExtractedLight& l = e.lights[i];
    if (!l.area || !(l.DiscSolidAngle() > 0)) continue;
    const double cos_r = std::clamp(1 - l.DiscSolidAngle() / kTwoPi, -1.0, 1.0);
    Eigen::Vector3d t, b;
    CoordinateSystem(l.direction, &t, &b);
    for (int a = 0; a < 16; ++a)
      for (int c = 0; c < 16; ++c) {
        const double z = 1 - (a + 0.5) / 16 * (1 - cos_r), phi = kTwoPi * (c + 0.5) / 16;
        const double s = std::sqrt(std::max(0.0, 1 - z * z));
        disc[i].push_back(z * l.direction + s * std::cos(phi) * t + s * std::sin(phi) * b);
      }
  }
  for (size_t k = 0; k < normals.size(); ++k) {
    double v = 0;
    for (size_t i = 0; i < e.lights.size(); ++i) {
      const ExtractedLight& l = e.lights[i];
      if (disc[i].empty()) {
        v += Luminance(l.power) * std::max(0.0, normals[k].dot(l.direction));
        continue;
      }
      double cs = 0;
      for (const Eigen::Vector3d& d : disc[i]) cs += std::max(0.0, normals[k].dot(d));
      v += Luminance(l.power) * cs / static_cast<double>(disc[i].size());
    }
    if (with_residual && order > 0) {
      ShEvaluate(normals[k], order, basis.data());
      for (int l = 0; l < order; ++l)
        for (int mm = -l; mm <= l; ++mm) {
          const size_t idx = static_cast<size_t>(l * (l + 1) + mm);
          v += A(l) * Luminance(e.residual_sh[idx]) * basis[idx];
        }
    }
    out[k] = v;
  }
  return out;
}

IrradianceError CompareIrradiance(const std::vector<double>& e, const std::vector<double>& ref) {
  IrradianceError r;
  double se = 0, sr = 0, mr = 0, me = 0;
  for (size_t i = 0; i < e.size(); ++i) {
    se += Square(e[i] - ref[i]);
    sr += Square(ref[i]);
    me = std::max(me, std::abs(e[i] - ref[i]));
    mr = std::max(mr, ref[i]);
  }
  r.rms_relative = sr > 0 ? std::sqrt(se / sr) : 0;
  r.max_relative = mr > 0 ? me / mr : 0;
  return r;
}

double MapEnergy(const Image& env) { return View(env).total; }

Image DownsampleEnergy(const Image& env, int width) {
  const MapView m = View(env);
  const int W = width, H = width / 2;
  Image out = Image::Rgb(W, H);
  std::vector<Eigen::Vector3d> sum(static_cast<size_t>(W) * H, Eigen::Vector3d::Zero());
  std::vector<double> om(sum.size(), 0.0);
  for (int y = 0; y < m.h; ++y)
    for (int x = 0; x < m.w; ++x) {
      const size_t i = static_cast<size_t>(y) * m.w + x;
      const Eigen::Vector2d q = DirectionToLatLongPixel(m.dir[i], W, H);
      const int ox = std::clamp(static_cast<int>(std::lround(q.x())), 0, W - 1),
                oy = std::clamp(static_cast<int>(std::lround(q.y())), 0, H - 1);
      sum[static_cast<size_t>(oy) * W + ox] += m.radiance[i] * m.omega[i];
      om[static_cast<size_t>(oy) * W + ox] += m.omega[i];
    }
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t o = static_cast<size_t>(y) * W + x;
      Eigen::Vector3d L;
      if (om[o] > 0) {
        // Radiance such that the output pixel holds the inputs' energy.
        L = sum[o] / LatLongPixelSolidAngle(x, y, W, H);
      } else {
        const Eigen::Vector2d q =
            DirectionToLatLongPixel(LatLongPixelToDirection(Eigen::Vector2d(x, y), W, H), m.w, m.h);
        L = m.rgb(std::clamp(static_cast<int>(std::lround(q.x())), 0, m.w - 1),
                  std::clamp(static_cast<int>(std::lround(q.y())), 0, m.h - 1));
      }
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = static_cast<float>(L[c]);
    }
  return out;
}

}  // namespace mr
