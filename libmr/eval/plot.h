// Small SVG line plots for error-vs-count and error-vs-time curves (no
// plotting dependency: the file is a few hundred lines of SVG).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/file.h"

namespace mr {

struct PlotSeries {
  std::string name;
  std::vector<std::pair<double, double>> points;  // (x, y), both > 0 on log axes
};

struct PlotOptions {
  std::string title, x_label, y_label;
  bool log_x = true, log_y = true;
  int width = 720, height = 480;
};

// Series from columns of a CSV table with a header line: y against x, one
// series per value of column `group` (empty: one series named y), in order
// of first appearance.  Errors name the file and line.
std::vector<PlotSeries> ReadPlotSeries(const fs::path& csv, const std::string& x, const std::string& y,
                                       const std::string& group);

// Atomic write of an SVG with one polyline (and markers) per series.
void WriteSvgPlot(const fs::path& path, const std::vector<PlotSeries>& series, const PlotOptions& options);

}  // namespace mr

namespace mr {

// The same plot rasterised to PNG (OpenCV drawing; atomic write).
void WritePngPlot(const fs::path& path, const std::vector<PlotSeries>& series, const PlotOptions& options);

}  // namespace mr
