#include "hdr/exposure_merge.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <Eigen/Dense>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include "core/check.h"
#include "core/error.h"
#include "core/math.h"
#include "core/parallel.h"

namespace mr {

namespace {

constexpr double kLumWeights[3] = {kLumaR, kLumaG, kLumaB};

double LumWeight(int c, int nc) { return nc == 3 ? kLumWeights[c] : 1.0 / nc; }

int CodeBits(const std::string& pixel_type) {
  if (pixel_type == "uint8") return 8;
  if (pixel_type == "uint16") return 16;
  return 0;  // float: no quantisation
}

// Float inputs have no code range: their clipping level is their maximum
// when enough pixels sit on it (a plateau), else nothing is clipped.
double FloatWhite(const Image& img) {
  const auto& v = img.values();
  float mx = 0;
  for (float x : v) mx = std::max(mx, x);
  if (!(mx > 0)) return 0;
  size_t at = 0;
  for (float x : v) at += x >= 0.999f * mx;
  return at * 1000 >= v.size() ? mx : 0;
}

struct Sample {
  double value = 0, variance = 0, code = 0;
  int state = 0;  // 0 usable, 1 dark, 2 saturated, 3 not seen
};

struct ExposureModel {
  const Exposure* e = nullptr;
  bool linear_float = false;
  double white = 1;  // clipping level of float inputs (0 = none)
  double q = 0;      // code step
};

}  // namespace

void ExposureMergeOptions::Check() const {
  if (!(low >= 0 && low < high && high <= 1))
    throw UsageError(fmt::format("need 0 <= low < high <= 1, got low {} high {}", low, high));
  if (!(read_noise > 0) || !(shot_noise >= 0)) throw UsageError("noise sigmas must be positive");
  if (!(ghost_sigma > 0)) throw UsageError("ghost_sigma must be positive");
  if (!(model_error >= 0)) throw UsageError("model_error must be >= 0");
}

double ExposureFromMetadata(const std::map<std::string, std::string>& a, std::string* how) {
  auto number = [&](const char* key) -> double {
    auto it = a.find(key);
    if (it == a.end()) return 0;
    try {
      return std::stod(it->second);
    } catch (...) {
      return 0;
    }
  };
  const double t = number("ExposureTime");
  if (!(t > 0)) return 0;
  double e = t;
  std::string h = fmt::format("ExposureTime {} s", t);
  double iso = number("Exif:PhotographicSensitivity");
  if (!(iso > 0)) iso = number("Exif:ISOSpeedRatings");
  if (iso > 0) {
    e *= iso / 100;
    h += fmt::format(", ISO {}", iso);
  }
  const double n = number("FNumber");
  if (n > 0) {
    e /= n * n;
    h += fmt::format(", f/{}", n);
  }
  if (how) *how = h;
  return e;
}

Exposure ReadExposure(const fs::path& path, double time_s, std::string* how) {
  ImageReadOptions opt;
  opt.use_file_transfer = false;
  opt.default_ldr_transfer = Transfer::kLinear;  // codes / max
  ImageFileInfo info;
  Exposure e;
  e.name = path.string();
  e.codes = ReadImage(path, opt, &info);
  e.pixel_type = info.pixel_type;
  std::string h = "given";
  e.time_s = time_s > 0 ? time_s : ExposureFromMetadata(info.attributes, &h);
  if (!(e.time_s > 0)) ThrowErrorAt(FileLoc{e.name}, "has no ExposureTime in its metadata: give --exposures FILE");
  if (how) *how = h;
  return e;
}

std::vector<Eigen::Vector2i> AlignExposures(std::vector<Exposure>* bracket, int max_bits) {
  std::vector<Exposure>& b = *bracket;
  if (b.size() < 2) return std::vector<Eigen::Vector2i>(b.size(), Eigen::Vector2i::Zero());
  std::vector<size_t> by_time(b.size());
  for (size_t i = 0; i < b.size(); ++i) by_time[i] = i;
  std::stable_sort(by_time.begin(), by_time.end(), [&](size_t x, size_t y) { return b[x].time_s < b[y].time_s; });
  const size_t ref = by_time[b.size() / 2];
  // Photographs of different sizes are compared on their common central
  // crop (padding would add edges that move with the crop, not the scene).
  int W = std::numeric_limits<int>::max(), H = W;
  for (const Exposure& e : b) {
    W = std::min(W, e.codes.width());
    H = std::min(H, e.codes.height());
  }
  auto offset = [&](const Exposure& e) {
    return Eigen::Vector2i((e.codes.width() - W) / 2, (e.codes.height() - H) / 2);
  };
  auto grey = [&](const Exposure& e) {
    const Eigen::Vector2i o = offset(e);
    cv::Mat m(H, W, CV_8UC1);
    const int nc = e.codes.channels();
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        double g = 0;
        for (int c = 0; c < nc; ++c) g += e.codes.at(x + o.x(), y + o.y(), c);
        m.at<uint8_t>(y, x) = static_cast<uint8_t>(std::clamp(std::lround(255 * g / nc), 0L, 255L));
      }
    return m;
  };
  const cv::Mat ref_img = grey(b[ref]);
  const Eigen::Vector2i o_ref = offset(b[ref]);
  // The pyramid's coarsest level must keep some 16 pixels across, or its
  // shift is noise that the finer levels cannot undo.
  const int bits = std::clamp(static_cast<int>(std::floor(std::log2(std::min(W, H) / 16.0))), 1, max_bits);
  cv::Ptr<cv::AlignMTB> mtb = cv::createAlignMTB(bits, 4, true);
  std::vector<Eigen::Vector2i> shifts(b.size(), Eigen::Vector2i::Zero());
  const int rw = b[ref].codes.width(), rh = b[ref].codes.height();
  for (size_t i = 0; i < b.size(); ++i) {
    Exposure& e = b[i];
    Eigen::Vector2i s = Eigen::Vector2i::Zero();
    if (i != ref) {
      const cv::Point p = mtb->calculateShift(ref_img, grey(e));
      s = Eigen::Vector2i(p.x, p.y);
    }
    // Reference pixel q shows what exposure i has at q - o_ref + o_i - s.
    const Eigen::Vector2i d = offset(e) - o_ref - s;
    shifts[i] = -d;
    if (i == ref) continue;
    Image out(rw, rh, e.codes.channel_names());
    std::vector<uint8_t> valid(static_cast<size_t>(rw) * rh, 0);
    for (int y = 0; y < rh; ++y)
      for (int x = 0; x < rw; ++x) {
        const int sx = x + d.x(), sy = y + d.y();
        if (sx < 0 || sy < 0 || sx >= e.codes.width() || sy >= e.codes.height()) continue;
        if (!e.Valid(static_cast<int64_t>(sy) * e.codes.width() + sx)) continue;
        valid[static_cast<size_t>(y) * rw + x] = 1;
        for (int c = 0; c < e.codes.channels(); ++c) out.at(x, y, c) = e.codes.at(sx, sy, c);
      }
    e.codes = std::move(out);
    e.valid = std::move(valid);
  }
  return shifts;
}

namespace {

// A uniform disc source of radius `a` at `centre`, blurred by a Gaussian of
// `s` px, per unit energy, at pixel p: the disc sampled at up to 12 x 12
// points.
struct DiscKernel {
  std::vector<Eigen::Vector2d> points;
  double s = 1;
  DiscKernel(const Eigen::Vector2d& centre, double a, double s_px) : s(s_px) {
    constexpr int kN = 12;
    for (int j = 0; j < kN && a > 0; ++j)
      for (int i = 0; i < kN; ++i) {
        const Eigen::Vector2d q(a * (2 * (i + 0.5) / kN - 1), a * (2 * (j + 0.5) / kN - 1));
        if (q.squaredNorm() <= a * a) points.push_back(centre + q);
      }
    if (points.empty()) points.push_back(centre);
  }
  double operator()(double x, double y) const {
    double k = 0;
    for (const Eigen::Vector2d& q : points) k += std::exp(-(Square(x - q.x()) + Square(y - q.y())) / (2 * s * s));
    return k / (2 * kPi * s * s * static_cast<double>(points.size()));
  }
};

// A censored region's source, from the unsaturated pixels around it in the
// shortest exposure (radiance `rad`, channel c), which the lens's blur
// lights.  B is the median of an outer annulus; the blur s is the known
// lens's `psf` or (when 0) the spread the ring shows (ln(I - B) as a line
// in r^2 over the pixels the source dominates: a point source's, so no
// smaller than the true blur).  The source is a uniform disc of radius a;
// for each a its energy Q_a is fitted to the ring by least squares in
// relative terms, and the largest a whose blurred disc still reaches half
// the strict bound at every censored pixel is kept (half: the ring's fit
// leaves the model low at the region's edge; looser only lowers Q).  A wider source lights the ring
// with less energy, and the true source is one of the feasible ones, so Q
// is a lower bound of its energy as long as the blur is not
// underestimated.  Returns false when fewer than 6 pixels carry the
// source's spread or no disc saturates the region.
bool FitCensoredRegion(const Image& rad, const std::vector<uint8_t>& usable, const std::vector<int64_t>& region,
                       const std::vector<double>& bound, const Eigen::Vector2d& centre, int c, double psf, double* Q,
                       double* s_out, double* a_out) {
  const int w = rad.width(), h = rad.height();
  double r_censored = 0;
  for (int64_t p : region) r_censored = std::max(r_censored, std::hypot(p % w - centre.x(), p / w - centre.y()));
  const double r_outer = 2 * r_censored + 8;
  std::vector<std::pair<int64_t, double>> near;  // pixel, value
  std::vector<double> annulus;
  const int R = static_cast<int>(std::ceil(r_outer));
  const int cx = static_cast<int>(std::lround(centre.x())), cy = static_cast<int>(std::lround(centre.y()));
  for (int y = std::max(0, cy - R); y <= std::min(h - 1, cy + R); ++y)
    for (int x = std::max(0, cx - R); x <= std::min(w - 1, cx + R); ++x) {
      const int64_t p = static_cast<int64_t>(y) * w + x;
      if (!usable[static_cast<size_t>(p)]) continue;
      const double r2 = Square(x - centre.x()) + Square(y - centre.y());
      if (r2 > r_outer * r_outer) continue;
      if (r2 > Square(0.75 * r_outer)) annulus.push_back(rad.at(x, y, c));
      near.push_back({p, rad.at(x, y, c)});
    }
  if (annulus.size() < 8) return false;
  std::nth_element(annulus.begin(), annulus.begin() + static_cast<std::ptrdiff_t>(annulus.size() / 2), annulus.end());
  const double B = std::max(0.0, annulus[annulus.size() / 2]);
  std::vector<std::pair<int64_t, double>> lit;
  for (const auto& pv : near)
    if (pv.second > 3 * B + 1e-30) lit.push_back(pv);
  if (lit.size() < 6) return false;
  double s = psf;
  if (!(s > 0)) {
    Eigen::Matrix2d AtA = Eigen::Matrix2d::Zero();
    Eigen::Vector2d Atb = Eigen::Vector2d::Zero();
    for (const auto& [p, v] : lit) {
      const Eigen::Vector2d row(1.0, Square(p % w - centre.x()) + Square(p / w - centre.y()));
      AtA += row * row.transpose();
      Atb += row * std::log(v - B);
    }
    if (std::abs(AtA.determinant()) < 1e-12) return false;
    const Eigen::Vector2d x = AtA.ldlt().solve(Atb);
    if (!(x[1] < 0)) return false;
    s = std::sqrt(-0.5 / x[1]);
  }
  bool found = false;
  for (double a = 0; a <= r_censored + 1e-9; a += 0.25) {
    const DiscKernel K(centre, a, s);
    double num = 0, den = 0;
    for (const auto& [p, v] : lit) {
      const double k = K(static_cast<double>(p % w), static_cast<double>(p / w));
      const double wgt = 1.0 / Square(v);
      num += wgt * k * (v - B);
      den += wgt * k * k;
    }
    if (!(den > 0)) continue;
    const double q = num / den;
    bool saturates = q > 0;
    for (size_t i = 0; i < region.size() && saturates; ++i)
      saturates = B + q * K(static_cast<double>(region[i] % w), static_cast<double>(region[i] / w)) >= 0.5 * bound[i];
    if (!saturates) continue;
    *Q = q;
    *a_out = a;
    found = true;
  }
  *s_out = s;
  return found;
}

}  // namespace

Image MergeExposures(std::vector<Exposure> bracket, const CameraResponse& response, const ExposureMergeOptions& o,
                     MergeReport* report) {
  o.Check();
  MergeReport rep;
  if (bracket.empty()) ThrowError("no exposures to merge");
  std::stable_sort(bracket.begin(), bracket.end(),
                   [](const Exposure& a, const Exposure& b) { return a.time_s < b.time_s; });
  // A photograph given twice adds no information but would halve its variance.
  for (size_t i = 1; i < bracket.size();) {
    if (bracket[i].time_s == bracket[i - 1].time_s && bracket[i].codes.values() == bracket[i - 1].codes.values()) {
      rep.warnings.push_back(
          fmt::format("{} and {} are the same photograph: used once", bracket[i - 1].name, bracket[i].name));
      bracket.erase(bracket.begin() + static_cast<std::ptrdiff_t>(i));
    } else {
      ++i;
    }
  }
  const Image& first = bracket[0].codes;
  const int w = first.width(), h = first.height(), nc = first.channels();
  for (const Exposure& e : bracket) {
    if (e.codes.width() != w || e.codes.height() != h || e.codes.channels() != nc)
      ThrowError("{}: {}x{}x{} while {} is {}x{}x{} (align hand-held brackets of different sizes first)", e.name,
                 e.codes.width(), e.codes.height(), e.codes.channels(), bracket[0].name, w, h, nc);
    if (!(e.time_s > 0) || !std::isfinite(e.time_s)) ThrowError("{}: exposure {} is not positive", e.name, e.time_s);
    rep.order.push_back(e.name);
  }
  if (static_cast<int>(response.channels.size()) != nc)
    ThrowError("the response has {} channels, the photographs {}", response.channels.size(), nc);
  std::vector<ExposureModel> models(bracket.size());
  for (size_t j = 0; j < bracket.size(); ++j) {
    ExposureModel& m = models[j];
    m.e = &bracket[j];
    const int bits = CodeBits(bracket[j].pixel_type);
    m.linear_float = bits == 0;
    m.q = bits ? 1.0 / ((1 << bits) - 1) : 0;
    if (m.linear_float) {
      m.white = FloatWhite(bracket[j].codes);
      for (float v : bracket[j].codes.values())
        if (v < 0) ThrowError("{}: negative linear pixel value {}", bracket[j].name, v);
    }
  }
  std::vector<double> saturation_exposure(static_cast<size_t>(nc));
  for (int c = 0; c < nc; ++c) saturation_exposure[static_cast<size_t>(c)] = response.Exposure(c, 1.0);
  auto sample = [&](size_t j, int64_t p, int c) {
    const ExposureModel& m = models[j];
    Sample s;
    if (!m.e->Valid(p)) {
      s.state = 3;
      return s;
    }
    const double z = m.e->codes.values()[static_cast<size_t>(p * nc + c)];
    const double t = m.e->time_s;
    s.code = z;
    if (m.linear_float) {
      const double white = m.white > 0 ? m.white : 1.0;
      const double zn = z / white;
      if (m.white > 0 && zn >= o.high)
        s.state = 2;
      else if (m.white > 0 && zn <= o.low)
        s.state = 1;
      s.value = z / t;
      s.variance = white * white * (Square(o.read_noise) + o.shot_noise * std::max(zn, 0.0)) / (t * t);
      return s;
    }
    if (z >= o.high)
      s.state = 2;
    else if (z <= o.low)
      s.state = 1;
    const double X = response.Exposure(c, z);
    const double Xsat = saturation_exposure[static_cast<size_t>(c)];
    const double slope = response.ExposureSlope(c, z);
    s.value = X / t;
    s.variance =
        (Xsat * Xsat * (Square(o.read_noise) + o.shot_noise * X / Xsat) + slope * slope * m.q * m.q / 12) / (t * t);
    return s;
  };
  // The reference for ghosts: the exposure with the most usable samples.
  {
    int64_t best = -1;
    for (size_t j = 0; j < bracket.size(); ++j) {
      int64_t usable = 0;
      for (int64_t p = 0; p < first.pixel_count(); p += 7)
        for (int c = 0; c < nc; ++c) usable += sample(j, p, c).state == 0;
      if (usable > best) {
        best = usable;
        rep.reference = static_cast<int>(j);
      }
    }
  }
  std::vector<std::string> names = first.channel_names();
  for (const std::string& c : first.channel_names()) names.push_back("variance." + c);
  names.push_back("saturated.Y");
  names.push_back("ghost.Y");
  Image out(w, h, names);
  const int no = out.channels();
  std::vector<uint8_t> censored(static_cast<size_t>(w) * h * static_cast<size_t>(nc), 0);
  std::vector<uint8_t> dark(static_cast<size_t>(w) * h, 0), ghost(static_cast<size_t>(w) * h, 0);
  const size_t m = bracket.size();
  ParallelFor(0, h, [&](int64_t y) {
    std::vector<Sample> s(m);
    for (int x = 0; x < w; ++x) {
      const int64_t p = y * w + x;
      float* px = &out.values()[static_cast<size_t>(p * no)];
      double chi2 = 0;
      int dof = 0;
      bool all_dark = true;
      for (int c = 0; c < nc; ++c) {
        double sw = 0, swx = 0;
        int n = 0, saturated = 0, seen = 0;
        for (size_t j = 0; j < m; ++j) {
          s[j] = sample(j, p, c);
          if (s[j].state == 3) continue;
          ++seen;
          saturated += s[j].state == 2;
          if (s[j].state != 0) continue;
          const double wgt = 1.0 / std::max(s[j].variance, 1e-300);
          sw += wgt;
          swx += wgt * s[j].value;
          ++n;
        }
        double value, var;
        if (n > 0) {
          value = swx / sw;
          var = 1.0 / sw;
          all_dark = false;
          for (size_t j = 0; j < m; ++j)
            if (s[j].state == 0) chi2 += Square(s[j].value - value) / (s[j].variance + Square(o.model_error * value));
          dof += n - 1;
        } else if (seen > 0 && saturated == seen) {
          // Saturated in every exposure that saw it: censored.  The lower
          // bound; regions are fitted below.
          size_t shortest = 0;
          while (s[shortest].state == 3) ++shortest;
          value = s[shortest].value;
          var = 0;
          censored[static_cast<size_t>(p * nc + c)] = 1;
          all_dark = false;
        } else if (seen > 0) {
          // Dark in every exposure that saw it (or dark in long and
          // saturated in short ones, which only a moving scene gives): the
          // longest dark exposure, with its variance.
          size_t j = m;
          while (j-- > 0)
            if (s[j].state == 1) break;
          value = s[j].code > 0 ? std::max(0.0, s[j].value) : 0.0;  // code 0: nothing measured
          var = s[j].variance;
        } else {
          value = 0;
          var = 0;
        }
        px[c] = static_cast<float>(value);
        px[nc + c] = static_cast<float>(var);
      }
      dark[static_cast<size_t>(p)] = all_dark;
      if (o.ghosts && dof > 0 && chi2 / dof > o.ghost_sigma * o.ghost_sigma) {
        // Ghost: the reference exposure alone when it saw this pixel
        // unsaturated, else the best exposed sample.
        ghost[static_cast<size_t>(p)] = 1;
        for (int c = 0; c < nc; ++c) {
          Sample best;
          double best_var = std::numeric_limits<double>::infinity();
          const Sample r = sample(static_cast<size_t>(rep.reference), p, c);
          if (r.state == 0) {
            best = r;
          } else {
            for (size_t j = 0; j < m; ++j) {
              const Sample q = sample(j, p, c);
              if (q.state == 0 && q.variance < best_var) {
                best = q;
                best_var = q.variance;
              }
            }
          }
          if (best.state == 0 && best.variance > 0) {
            px[c] = static_cast<float>(best.value);
            px[nc + c] = static_cast<float>(best.variance);
          }
        }
      }
      px[2 * nc + 1] = ghost[static_cast<size_t>(p)];
    }
  });
  // Censored regions: connected components of pixels censored in any channel.
  cv::Mat mask(h, w, CV_8UC1, cv::Scalar(0));
  for (int64_t p = 0; p < first.pixel_count(); ++p) {
    bool any = false;
    for (int c = 0; c < nc; ++c) any = any || censored[static_cast<size_t>(p * nc + c)];
    if (any) {
      mask.at<uint8_t>(static_cast<int>(p / w), static_cast<int>(p % w)) = 1;
      out.values()[static_cast<size_t>(p * no + 2 * nc)] = 1;
      ++rep.censored_pixels;
    }
    rep.black_pixels += dark[static_cast<size_t>(p)];
    rep.ghost_pixels += ghost[static_cast<size_t>(p)];
  }
  rep.pixels = first.pixel_count();
  if (rep.censored_pixels > 0) {
    cv::Mat labels, stats, centroids;
    const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
    std::vector<std::vector<int64_t>> regions(static_cast<size_t>(n));
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int l = labels.at<int>(y, x);
        if (l > 0) regions[static_cast<size_t>(l)].push_back(static_cast<int64_t>(y) * w + x);
      }
    // The shortest exposure's radiance and where it is usable.
    size_t shortest = 0;
    Image rad(w, h, first.channel_names());
    std::vector<std::vector<uint8_t>> usable(static_cast<size_t>(nc), std::vector<uint8_t>(static_cast<size_t>(w) * h));
    for (int64_t p = 0; p < first.pixel_count(); ++p)
      for (int c = 0; c < nc; ++c) {
        const Sample s = sample(shortest, p, c);
        rad.values()[static_cast<size_t>(p * nc + c)] = static_cast<float>(s.value);
        usable[static_cast<size_t>(c)][static_cast<size_t>(p)] = s.state == 0 || s.state == 1;
      }
    for (int l = 1; l < n; ++l) {
      CensoredRegion reg;
      reg.pixels = static_cast<int>(regions[static_cast<size_t>(l)].size());
      reg.centre = Eigen::Vector2d(centroids.at<double>(l, 0), centroids.at<double>(l, 1));
      for (int64_t p : regions[static_cast<size_t>(l)])
        for (int c = 0; c < nc && c < 3; ++c) reg.lower_bound[c] += out.values()[static_cast<size_t>(p * no + c)];
      reg.estimate = reg.lower_bound;
      if (o.fit_censored) {
        bool all = true;
        double blur = 0;
        for (int c = 0; c < nc && c < 3; ++c) {
          std::vector<int64_t> reg_c;
          for (int64_t p : regions[static_cast<size_t>(l)])
            if (censored[static_cast<size_t>(p * nc + c)]) reg_c.push_back(p);
          if (reg_c.empty()) continue;
          double lower = 0;
          for (int64_t p : reg_c) lower += out.values()[static_cast<size_t>(p * no + c)];
          double Q = 0, s = 0, radius = 0;
          std::vector<double> bound;
          for (int64_t p : reg_c) bound.push_back(out.values()[static_cast<size_t>(p * no + c)]);
          if (!FitCensoredRegion(rad, usable[static_cast<size_t>(c)], reg_c, bound, reg.centre, c, o.psf_sigma_px, &Q,
                                 &s, &radius)) {
            all = false;
            continue;
          }
          blur = std::max(blur, s);
          reg.source_radius_px = std::max(reg.source_radius_px, radius);
          const DiscKernel K(reg.centre, radius, s);
          double e = 0;
          for (int64_t p : reg_c) {
            const double model = Q * K(static_cast<double>(p % w), static_cast<double>(p / w));
            float& v = out.values()[static_cast<size_t>(p * no + c)];
            v = static_cast<float>(std::max<double>(v, model));
            e += v;
          }
          // Pixels of the region censored in other channels only keep theirs.
          reg.estimate[c] = reg.lower_bound[c] - lower + e;
        }
        reg.fitted = all;
        reg.blur_px = blur;
        if (!all)
          reg.why_not =
              "the unsaturated pixels around it do not constrain a blurred source (too few, no spread, or no "
              "source that saturates the region)";
      }
      rep.regions.push_back(reg);
    }
    double total = 0, lb = 0, est = 0;
    for (int64_t p = 0; p < first.pixel_count(); ++p)
      for (int c = 0; c < nc; ++c) total += LumWeight(c, nc) * out.values()[static_cast<size_t>(p * no + c)];
    for (const CensoredRegion& r : rep.regions)
      for (int c = 0; c < nc && c < 3; ++c) {
        lb += LumWeight(c, nc) * r.lower_bound[c];
        est += LumWeight(c, nc) * r.estimate[c];
      }
    rep.censored_lower_bound_fraction = total > 0 ? lb / total : 0;
    rep.censored_added_fraction = total > 0 ? (est - lb) / total : 0;
  }
  for (float v : out.values()) MR_CHECK_MSG(std::isfinite(v), "the merge produced a non-finite value");
  if (report) *report = rep;
  return out;
}

}  // namespace mr
