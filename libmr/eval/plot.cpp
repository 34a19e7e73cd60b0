#include "eval/plot.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "core/error.h"

namespace mr {

namespace {
std::string Escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else o += c;
  }
  return o;
}
}  // namespace

void WriteSvgPlot(const fs::path& path, const std::vector<PlotSeries>& series, const PlotOptions& o) {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  auto tx = [&](double v) { return o.log_x ? std::log10(v) : v; };
  auto ty = [&](double v) { return o.log_y ? std::log10(v) : v; };
  for (const auto& s : series)
    for (const auto& [x, y] : s.points) {
      if ((o.log_x && !(x > 0)) || (o.log_y && !(y > 0)) || !std::isfinite(x) || !std::isfinite(y)) continue;
      x0 = std::min(x0, tx(x));
      x1 = std::max(x1, tx(x));
      y0 = std::min(y0, ty(y));
      y1 = std::max(y1, ty(y));
    }
  if (!(x1 >= x0) || !(y1 >= y0)) ThrowError("nothing to plot in {}", path.string());
  if (o.log_x) {
    x0 = std::floor(x0);
    x1 = std::max(std::ceil(x1), x0 + 1);
  } else if (x1 == x0) x1 = x0 + 1;
  if (o.log_y) {
    y0 = std::floor(y0);
    y1 = std::max(std::ceil(y1), y0 + 1);
  } else if (y1 == y0) y1 = y0 + 1;
  const double L = 80, R = 180, T = 40, B = 60;
  const double pw = o.width - L - R, ph = o.height - T - B;
  auto X = [&](double v) { return L + (tx(v) - x0) / (x1 - x0) * pw; };
  auto Y = [&](double v) { return T + ph - (ty(v) - y0) / (y1 - y0) * ph; };
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" font-family=\"sans-serif\" "
      "font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
      o.width, o.height);
  svg += fmt::format("<text x=\"{}\" y=\"24\" font-size=\"15\">{}</text>\n", L, Escape(o.title));
  // Grid and tick labels at powers of ten (log) or five steps (linear).
  auto ticks = [&](double a, double b, bool log) {
    std::vector<double> t;
    if (log)
      for (double e = a; e <= b + 1e-9; e += 1) t.push_back(e);
    else
      for (int i = 0; i <= 5; ++i) t.push_back(a + (b - a) * i / 5);
    return t;
  };
  for (double e : ticks(x0, x1, o.log_x)) {
    const double v = o.log_x ? std::pow(10.0, e) : e, px = X(v);
    svg += fmt::format("<line x1=\"{:.1f}\" y1=\"{}\" x2=\"{:.1f}\" y2=\"{}\" stroke=\"#ddd\"/>\n", px, T, px, T + ph);
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{:g}</text>\n", px, T + ph + 16, v);
  }
  for (double e : ticks(y0, y1, o.log_y)) {
    const double v = o.log_y ? std::pow(10.0, e) : e, py = Y(v);
    svg += fmt::format("<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#ddd\"/>\n", L, py, L + pw, py);
    svg += fmt::format("<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\">{:g}</text>\n", L - 6, py + 4, v);
  }
  svg += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n", L, T, pw, ph);
  svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", L + pw / 2, o.height - 16, Escape(o.x_label));
  svg += fmt::format("<text x=\"16\" y=\"{}\" text-anchor=\"middle\" transform=\"rotate(-90 16 {})\">{}</text>\n",
                     T + ph / 2, T + ph / 2, Escape(o.y_label));
  const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"};
  for (size_t k = 0; k < series.size(); ++k) {
    const char* col = colours[k % 8];
    std::string pts;
    for (const auto& [x, y] : series[k].points) {
      if ((o.log_x && !(x > 0)) || (o.log_y && !(y > 0))) continue;
      pts += fmt::format("{:.1f},{:.1f} ", X(x), Y(y));
      svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.5\" fill=\"{}\"/>\n", X(x), Y(y), col);
    }
    svg += fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\"/>\n", pts, col);
    const double ly = T + 14 + 18 * static_cast<double>(k);
    svg += fmt::format("<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{}\" stroke-width=\"2\"/>\n", L + pw + 12, ly,
                       L + pw + 32, ly, col);
    svg += fmt::format("<text x=\"{}\" y=\"{}\">{}</text>\n", L + pw + 38, ly + 4, Escape(series[k].name));
  }
  svg += "</svg>\n";
  WriteTextFile(path, svg);
}

}  // namespace mr
