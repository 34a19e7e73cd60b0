#include "eval/plot.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include <map>
#include <sstream>

#include <fmt/ranges.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace mr {

std::vector<PlotSeries> ReadPlotSeries(const fs::path& path, const std::string& x, const std::string& y,
                                       const std::string& group) {
  const std::string csv = path.string();
  std::istringstream in(ReadTextFile(csv));
  std::string line;
  auto split = [](const std::string& l) {
    std::vector<std::string> f;
    std::stringstream ss(l);
    for (std::string field; std::getline(ss, field, ',');) f.push_back(field);
    return f;
  };
  if (!std::getline(in, line)) ThrowErrorAt(FileLoc{csv}, "is empty");
  const std::vector<std::string> header = split(line);
  auto column = [&](const std::string& name) -> int {
    for (size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return static_cast<int>(i);
    ThrowErrorAt(FileLoc{csv}, "has no column \"{}\" (it has: {})", name, fmt::join(header, ", "));
  };
  const int xi = column(x), yi = column(y), gi = group.empty() ? -1 : column(group);
  std::map<std::string, PlotSeries> groups;
  std::vector<std::string> order;
  int n = 1;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty()) continue;
    const std::vector<std::string> f = split(line);
    if (f.size() != header.size())
      ThrowErrorAt(FileLoc{csv, n}, "has {} fields, the header {}", f.size(), header.size());
    const std::string g = gi >= 0 ? f[static_cast<size_t>(gi)] : y;
    if (!groups.count(g)) {
      order.push_back(g);
      groups[g].name = g;
    }
    try {
      groups[g].points.push_back({std::stod(f[static_cast<size_t>(xi)]), std::stod(f[static_cast<size_t>(yi)])});
    } catch (const std::exception&) {
      ThrowErrorAt(FileLoc{csv, n}, "\"{}\" or \"{}\" is not a number", f[static_cast<size_t>(xi)],
                   f[static_cast<size_t>(yi)]);
    }
  }
  std::vector<PlotSeries> series;
  for (const auto& g : order) series.push_back(groups[g]);
  return series;
}

namespace {
std::string Escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<')
      o += "&lt;";
    else if (c == '>')
      o += "&gt;";
    else if (c == '&')
      o += "&amp;";
    else
      o += c;
  }
  return o;
}
// Axis ranges, ticks and the mapping to pixels, shared by the SVG and PNG plots.
struct Layout {
  PlotOptions o;
  double x0, x1, y0, y1;
  double L = 80, R = 180, T = 40, B = 60, pw = 0, ph = 0;
  double tx(double v) const { return o.log_x ? std::log10(v) : v; }
  double ty(double v) const { return o.log_y ? std::log10(v) : v; }
  double X(double v) const { return L + (tx(v) - x0) / (x1 - x0) * pw; }
  double Y(double v) const { return T + ph - (ty(v) - y0) / (y1 - y0) * ph; }
  bool Plottable(double x, double y) const {
    return !((o.log_x && !(x > 0)) || (o.log_y && !(y > 0)) || !std::isfinite(x) || !std::isfinite(y));
  }
  // Grid positions at powers of ten (log) or five steps (linear), as axis values.
  std::vector<double> Ticks(bool x_axis) const {
    const double a = x_axis ? x0 : y0, b = x_axis ? x1 : y1;
    const bool log = x_axis ? o.log_x : o.log_y;
    std::vector<double> t;
    if (log)
      for (double e = a; e <= b + 1e-9; e += 1) t.push_back(std::pow(10.0, e));
    else
      for (int i = 0; i <= 5; ++i) t.push_back(a + (b - a) * i / 5);
    return t;
  }
};

Layout MakeLayout(const fs::path& path, const std::vector<PlotSeries>& series, const PlotOptions& o) {
  Layout l;
  l.o = o;
  l.x0 = std::numeric_limits<double>::infinity();
  l.x1 = -l.x0;
  l.y0 = l.x0;
  l.y1 = -l.x0;
  for (const auto& s : series)
    for (const auto& [x, y] : s.points) {
      if (!l.Plottable(x, y)) continue;
      l.x0 = std::min(l.x0, l.tx(x));
      l.x1 = std::max(l.x1, l.tx(x));
      l.y0 = std::min(l.y0, l.ty(y));
      l.y1 = std::max(l.y1, l.ty(y));
    }
  if (!(l.x1 >= l.x0) || !(l.y1 >= l.y0)) ThrowError("nothing to plot in {}", path.string());
  if (o.log_x) {
    l.x0 = std::floor(l.x0);
    l.x1 = std::max(std::ceil(l.x1), l.x0 + 1);
  } else if (l.x1 == l.x0) {
    l.x1 = l.x0 + 1;
  }
  if (o.log_y) {
    l.y0 = std::floor(l.y0);
    l.y1 = std::max(std::ceil(l.y1), l.y0 + 1);
  } else if (l.y1 == l.y0) {
    l.y1 = l.y0 + 1;
  }
  l.pw = o.width - l.L - l.R;
  l.ph = o.height - l.T - l.B;
  return l;
}

const char* const kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"};

}  // namespace

void WriteSvgPlot(const fs::path& path, const std::vector<PlotSeries>& series, const PlotOptions& o) {
  const Layout lay = MakeLayout(path, series, o);
  const double L = lay.L, T = lay.T, pw = lay.pw, ph = lay.ph;
  auto X = [&](double v) { return lay.X(v); };
  auto Y = [&](double v) { return lay.Y(v); };
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" font-family=\"sans-serif\" "
      "font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
      o.width, o.height);
  svg += fmt::format("<text x=\"{}\" y=\"24\" font-size=\"15\">{}</text>\n", L, Escape(o.title));
  for (double v : lay.Ticks(true)) {
    const double px = X(v);
    svg += fmt::format("<line x1=\"{:.1f}\" y1=\"{}\" x2=\"{:.1f}\" y2=\"{}\" stroke=\"#ddd\"/>\n", px, T, px, T + ph);
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{:g}</text>\n", px, T + ph + 16, v);
  }
  for (double v : lay.Ticks(false)) {
    const double py = Y(v);
    svg += fmt::format("<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#ddd\"/>\n", L, py, L + pw, py);
    svg += fmt::format("<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\">{:g}</text>\n", L - 6, py + 4, v);
  }
  svg += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n", L, T, pw,
                     ph);
  svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", L + pw / 2, o.height - 16,
                     Escape(o.x_label));
  svg += fmt::format("<text x=\"16\" y=\"{}\" text-anchor=\"middle\" transform=\"rotate(-90 16 {})\">{}</text>\n",
                     T + ph / 2, T + ph / 2, Escape(o.y_label));
  for (size_t k = 0; k < series.size(); ++k) {
    const char* col = kColours[k % 8];
    std::string pts;
    for (const auto& [x, y] : series[k].points) {
      if (!lay.Plottable(x, y)) continue;
      pts += fmt::format("{:.1f},{:.1f} ", X(x), Y(y));
      svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.5\" fill=\"{}\"/>\n", X(x), Y(y), col);
    }
    svg += fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\"/>\n", pts, col);
    const double ly = T + 14 + 18 * static_cast<double>(k);
    svg += fmt::format("<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{}\" stroke-width=\"2\"/>\n",
                       L + pw + 12, ly, L + pw + 32, ly, col);
    svg += fmt::format("<text x=\"{}\" y=\"{}\">{}</text>\n", L + pw + 38, ly + 4, Escape(series[k].name));
  }
  svg += "</svg>\n";
  WriteTextFile(path, svg);
}

void WritePngPlot(const fs::path& path, const std::vector<PlotSeries>& series, const PlotOptions& o) {
  const Layout lay = MakeLayout(path, series, o);
  cv::Mat img(o.height, o.width, CV_8UC3, cv::Scalar(255, 255, 255));
  auto pt = [&](double x, double y) {
    return cv::Point(static_cast<int>(std::lround(x)), static_cast<int>(std::lround(y)));
  };
  auto colour = [](const char* hex) {
    const unsigned v = static_cast<unsigned>(std::stoul(hex + 1, nullptr, 16));
    return cv::Scalar(v & 255, (v >> 8) & 255, (v >> 16) & 255);  // BGR
  };
  const cv::Scalar grey(221, 221, 221), black(0, 0, 0);
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  auto text = [&](const std::string& s, double x, double y, double scale, bool centre, bool right) {
    int base = 0;
    const cv::Size sz = cv::getTextSize(s, font, scale, 1, &base);
    const double dx = centre ? -sz.width / 2.0 : right ? -sz.width : 0;
    cv::putText(img, s, pt(x + dx, y), font, scale, black, 1, cv::LINE_AA);
  };
  for (double v : lay.Ticks(true)) {
    cv::line(img, pt(lay.X(v), lay.T), pt(lay.X(v), lay.T + lay.ph), grey, 1);
    text(fmt::format("{:g}", v), lay.X(v), lay.T + lay.ph + 18, 0.4, true, false);
  }
  for (double v : lay.Ticks(false)) {
    cv::line(img, pt(lay.L, lay.Y(v)), pt(lay.L + lay.pw, lay.Y(v)), grey, 1);
    text(fmt::format("{:g}", v), lay.L - 6, lay.Y(v) + 4, 0.4, false, true);
  }
  cv::rectangle(img, pt(lay.L, lay.T), pt(lay.L + lay.pw, lay.T + lay.ph), black, 1);
  text(o.title, lay.L, 24, 0.55, false, false);
  text(o.x_label, lay.L + lay.pw / 2, o.height - 16, 0.45, true, false);
  text(o.y_label, 8, lay.T - 8, 0.45, false, false);
  for (size_t k = 0; k < series.size(); ++k) {
    const cv::Scalar col = colour(kColours[k % 8]);
    std::vector<cv::Point> pts;
    for (const auto& [x, y] : series[k].points)
      if (lay.Plottable(x, y)) pts.push_back(pt(lay.X(x), lay.Y(y)));
    if (pts.size() > 1) cv::polylines(img, pts, false, col, 2, cv::LINE_AA);
    for (const auto& p : pts) cv::circle(img, p, 3, col, cv::FILLED, cv::LINE_AA);
    const double ly = lay.T + 14 + 18 * static_cast<double>(k);
    cv::line(img, pt(lay.L + lay.pw + 12, ly), pt(lay.L + lay.pw + 32, ly), col, 2, cv::LINE_AA);
    text(series[k].name, lay.L + lay.pw + 38, ly + 4, 0.4, false, false);
  }
  std::vector<uchar> png;
  if (!cv::imencode(".png", img, png)) ThrowErrorAt(FileLoc{path.string()}, "cannot encode the plot as PNG");
  WriteTextFile(path, std::string(png.begin(), png.end()));
}

}  // namespace mr
