#include "render/radiometry.h"

#include <algorithm>
#include <cmath>

#include "core/check.h"
#include "core/color.h"
#include "core/error.h"
#include "core/json.h"
#include "core/json_node.h"
#include "core/json_settings.h"

namespace mr {

namespace {

double Luma(const Rgb& v) { return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]; }

double Median(std::vector<double> v) {
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

}  // namespace

GainFit FitPlateGain(const Image& plate, const Image& rendered, const Image& room, const Image* codes,
                     const GainFitOptions& o) {
  const int w = plate.width(), h = plate.height();
  // The caller's images, checked against the camera before they are made.
  for (const Image* img : {&rendered, &room, codes})
    if (img)
      MR_CHECK_MSG(img->width() == w && img->height() == h, "gain fit: {}x{} and {}x{}", w, h, img->width(),
                   img->height());
  MR_CHECK(plate.channels() >= 3 && rendered.channels() >= 3 && (!codes || codes->channels() >= 3) &&
           room.channels() >= 1);
  GainFit fit;
  // Usable pixels summed into cells of kCell x kCell: the outlier test is
  // made on cells, whose ratios carry a kCell-th of a pixel's noise, so that
  // it removes what the room model lacks (a poster, a misregistered edge)
  // and not the tails of the render's or the plate's noise (which would
  // bias the gain: a firefly in I_r is a low ratio, a clipped tail is not
  // symmetric in log).
  constexpr int kCell = 8;
  const int cw = (w + kCell - 1) / kCell, ch = (h + kCell - 1) / kCell;
  struct Cell {
    Rgb p{0, 0, 0}, r{0, 0, 0};
    int64_t n = 0;
  };
  std::vector<Cell> cells(static_cast<size_t>(cw * ch));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!(room.at(x, y, 0) > 0)) continue;
      ++fit.room_pixels;
      Rgb p, r;
      bool finite = true, clipped = false;
      for (int c = 0; c < 3; ++c) {
        p[c] = plate.at(x, y, c);
        r[c] = rendered.at(x, y, c);
        finite = finite && std::isfinite(p[c]) && std::isfinite(r[c]);
        if (codes) {
          const double k = codes->at(x, y, c);
          finite = finite && std::isfinite(k);
          clipped = clipped || k < o.code_low || k > o.code_high;
        }
      }
      if (!finite) {
        ++fit.nonfinite;
        continue;
      }
      if (clipped) {
        ++fit.clipped;
        continue;
      }
      Cell& cell = cells[static_cast<size_t>((y / kCell) * cw + x / kCell)];
      for (int c = 0; c < 3; ++c) cell.p[c] += p[c], cell.r[c] += r[c];
      ++cell.n;
    }
  // Cells' log luminance ratios; the robust spread from the well-filled ones.
  std::vector<double> logs, spread;
  std::vector<double> cell_log(cells.size(), 0);
  int64_t usable = 0;
  for (size_t k = 0; k < cells.size(); ++k) {
    const Cell& c = cells[k];
    if (c.n == 0) continue;
    const double lp = Luma(c.p), lr = Luma(c.r);
    if (!(lp > 0) || !(lr > 0)) {  // black in the plate or unlit in the render: no ratio
      fit.outliers += c.n;
      cells[k].n = 0;
      continue;
    }
    usable += c.n;
    cell_log[k] = std::log(lp / lr);
    logs.push_back(cell_log[k]);
  }
  if (usable < o.min_pixels) {
    fit.why = fmt::format(
        "{} usable room pixels (of {} showing the room: {} clipped or too dark, {} not finite), "
        "fewer than {}",
        usable, fit.room_pixels, fit.clipped, fit.nonfinite, o.min_pixels);
    return fit;
  }
  const double med = Median(logs);
  for (size_t k = 0; k < cells.size(); ++k)
    if (cells[k].n >= kCell * kCell / 2) spread.push_back(std::abs(cell_log[k] - med));
  if (spread.empty())
    for (double v : logs) spread.push_back(std::abs(v - med));
  const double sigma = 1.4826 * Median(spread);  // of a half-full or fuller cell

  const int nt = std::max(1, o.tiles);
  std::vector<Rgb> tile_p(static_cast<size_t>(nt * nt), Rgb{0, 0, 0}), tile_r = tile_p;
  std::vector<int64_t> tile_n(static_cast<size_t>(nt * nt), 0);
  for (int cy = 0; cy < ch; ++cy)
    for (int cx = 0; cx < cw; ++cx) {
      const Cell& c = cells[static_cast<size_t>(cy * cw + cx)];
      if (c.n == 0) continue;
      // A sparse cell's ratio is noisier: its threshold grows as 1/sqrt(n).
      const double scale = std::sqrt(std::max(1.0, kCell * kCell / 2.0 / static_cast<double>(c.n)));
      if (std::abs(cell_log[static_cast<size_t>(cy * cw + cx)] - med) >
          std::max(o.outlier_sigmas * sigma * scale, 0.05)) {
        fit.outliers += c.n;
        continue;
      }
      const int px = std::min(w - 1, cx * kCell + kCell / 2), py = std::min(h - 1, cy * kCell + kCell / 2);
      const size_t t = static_cast<size_t>((py * nt / h) * nt + px * nt / w);
      for (int k = 0; k < 3; ++k) tile_p[t][k] += c.p[k], tile_r[t][k] += c.r[k];
      tile_n[t] += c.n;
      fit.pixels += c.n;
    }
  Rgb sp{0, 0, 0}, sr{0, 0, 0};
  for (size_t t = 0; t < tile_n.size(); ++t) {
    if (tile_n[t] == 0) continue;
    ++fit.tiles;
    for (int c = 0; c < 3; ++c) sp[c] += tile_p[t][c], sr[c] += tile_r[t][c];
  }
  if (fit.pixels < o.min_pixels || fit.tiles < 2) {
    fit.why = fmt::format(
        "{} room pixels in {} of {} tiles after leaving out outliers: too few to fit and to "
        "estimate the uncertainty",
        fit.pixels, fit.tiles, nt * nt);
    return fit;
  }
  for (int c = 0; c < 3; ++c) {
    if (!(sr[c] > 0) || !(sp[c] > 0)) {
      fit.why = fmt::format("channel {} is black in the {} over the room", "RGB"[c], sr[c] > 0 ? "plate" : "render");
      return fit;
    }
    fit.gain[c] = sp[c] / sr[c];
    // Delete-one-tile jackknife: each tile's pixels left out in turn.
    std::vector<double> g;
    for (size_t t = 0; t < tile_n.size(); ++t)
      if (tile_n[t] > 0 && sr[c] - tile_r[t][c] > 0) g.push_back((sp[c] - tile_p[t][c]) / (sr[c] - tile_r[t][c]));
    const double n = static_cast<double>(g.size());
    double mean = 0, var = 0;
    for (double v : g) mean += v / n;
    for (double v : g) var += (v - mean) * (v - mean);
    fit.sigma[c] = n > 1 ? std::sqrt(var * (n - 1) / n) : fit.gain[c];
  }
  fit.ok = true;
  return fit;
}

std::vector<FrameGain> SmoothGains(const std::vector<int>& frames, const std::vector<GainFit>& fits,
                                   const GainSmoothing& sm) {
  MR_CHECK_EQ(frames.size(), fits.size());
  const size_t n = frames.size();
  std::vector<FrameGain> out(n);
  std::vector<size_t> fitted;
  for (size_t i = 0; i < n; ++i) {
    out[i].frame = frames[i];
    out[i].pixels = fits[i].pixels;
    if (i > 0) MR_CHECK_GT(frames[i], frames[i - 1]);  // ascending
    if (!fits[i].ok) continue;
    out[i].fitted = true;
    out[i].fit = fits[i].gain;
    out[i].fit_sigma = fits[i].sigma;
    fitted.push_back(i);
  }
  if (fitted.empty())
    ThrowError("no frame has a radiometric fit{}", n > 0 ? fmt::format(" (frame {}: {})", frames[0], fits[0].why) : "");
  // Segments between exposure jumps, over the fitted frames.
  auto rel_sigma = [&](size_t i) {
    double s = 0;
    for (int c = 0; c < 3; ++c) s = std::max(s, fits[i].sigma[c] / fits[i].gain[c]);
    return s;
  };
  std::vector<int> segment(n, -1);
  int seg = 0;
  for (size_t k = 0; k < fitted.size(); ++k) {
    const size_t i = fitted[k];
    if (k > 0) {
      const size_t j = fitted[k - 1];
      const double d = std::abs(std::log(Luma(fits[i].gain) / Luma(fits[j].gain)));
      const double s = std::hypot(rel_sigma(i), rel_sigma(j));
      if (d > std::log(sm.jump_ratio) && d > 4 * s) {
        out[i].jump_before = true;
        ++seg;
      }
    }
    segment[i] = seg;
  }
  // Unfitted frames join the segment of the fitted frames around them (the
  // nearer one's where a jump lies between).
  for (size_t i = 0, k = 0; i < n; ++i) {
    while (k < fitted.size() && fitted[k] < i) ++k;
    if (segment[i] >= 0) continue;
    const bool has_next = k<fitted.size(), has_prev = k> 0;
    if (!has_prev) {
      segment[i] = segment[fitted[k]];
    } else if (!has_next) {
      segment[i] = segment[fitted[k - 1]];
    } else {
      const size_t p = fitted[k - 1], q = fitted[k];
      segment[i] = frames[q] - frames[i] < frames[i] - frames[p] ? segment[q] : segment[p];
    }
  }
  for (size_t i = 0; i < n; ++i) {
    // The nearest fitted frame of the segment sets the kernel's width for
    // frames far from every fit (so that they take the nearest fits).
    double nearest = 1e300;
    for (size_t j : fitted)
      if (segment[j] == segment[i]) nearest = std::min(nearest, std::abs(double(frames[j] - frames[i])));
    if (sm.time_constant <= 0 && out[i].fitted) {
      out[i].gain = out[i].fit;
      out[i].sigma = out[i].fit_sigma;
      continue;
    }
    const double tau = std::max({sm.time_constant, nearest, 0.5});
    for (int c = 0; c < 3; ++c) {
      double sw = 0, sl = 0, sv = 0;
      for (size_t j : fitted) {
        if (segment[j] != segment[i]) continue;
        const double dt = frames[j] - frames[i];
        const double rs = fits[j].sigma[c] / fits[j].gain[c];
        const double wt = std::exp(-dt * dt / (2 * tau * tau)) / (rs * rs + 1e-4);  // 1% floor: no frame dominates
        sw += wt;
        sl += wt * std::log(fits[j].gain[c]);
        sv += wt * wt * rs * rs;
      }
      out[i].gain[c] = std::exp(sl / sw);
      out[i].sigma[c] = out[i].gain[c] * std::sqrt(sv) / sw;
    }
  }
  return out;
}

void WritePlateGains(const fs::path& path, const std::vector<FrameGain>& gains, const std::string& note) {
  Json frames = Json::array();
  for (const FrameGain& g : gains)
    frames.push_back({{"frame", g.frame},
                      {"gain", g.gain},
                      {"sigma", g.sigma},
                      {"fit", g.fit},
                      {"fit_sigma", g.fit_sigma},
                      {"fitted", g.fitted},
                      {"jump_before", g.jump_before},
                      {"pixels", g.pixels}});
  const Json j = {{"version", 1}, {"kind", "mr-plate-gains"}, {"comment", note}, {"frames", frames}};
  WriteTextFile(path, j.dump(1) + "\n");
}

std::vector<FrameGain> ReadPlateGains(const fs::path& path) {
  const Json j = ReadJsonFile(path);
  const std::string name = path.string();
  JsonSettings root(JsonNode(j, "", &name));
  const JsonNode version = root.Require("version");
  const JsonNode kind = root.Require("kind");
  root.Take("comment");
  const JsonNode fr = root.Require("frames");
  root.Done();
  if (version.Integer(1, 1000) != 1) version.Fail("unsupported version (this is 1)");
  if (kind.String() != "mr-plate-gains") kind.Fail("expected \"mr-plate-gains\"");
  if (!fr.json().is_array() || fr.json().empty()) fr.Fail("expected a non-empty list of frames");
  std::vector<FrameGain> out;
  for (size_t i = 0; i < fr.json().size(); ++i) {
    const JsonNode f = fr.Index(i);
    JsonSettings keys(f);
    FrameGain g;
    const JsonNode frame = keys.Require("frame");
    g.frame = static_cast<int>(frame.Integer(0, 1 << 30));
    if (!out.empty() && g.frame <= out.back().frame) frame.Fail("frames must be ascending and unique");
    auto rgb = [](const JsonNode& n, double lo, Rgb* v) {
      const std::vector<double> x = n.Numbers(3, lo, 1e12);
      *v = {x[0], x[1], x[2]};
    };
    rgb(keys.Require("gain"), 1e-12, &g.gain);
    if (const auto n = keys.Take("sigma")) rgb(*n, 0, &g.sigma);
    if (const auto n = keys.Take("fit")) rgb(*n, 0, &g.fit);
    if (const auto n = keys.Take("fit_sigma")) rgb(*n, 0, &g.fit_sigma);
    keys.Bool("fitted", &g.fitted);
    keys.Bool("jump_before", &g.jump_before);
    if (const auto n = keys.Take("pixels")) g.pixels = n->Integer(0, int64_t{1} << 50);
    keys.Done();
    out.push_back(g);
  }
  return out;
}

}  // namespace mr
