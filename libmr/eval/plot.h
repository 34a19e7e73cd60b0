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

// Atomic write of an SVG with one polyline (and markers) per series.
void WriteSvgPlot(const fs::path& path, const std::vector<PlotSeries>& series, const PlotOptions& options);

}  // namespace mr

namespace mr {

// The same plot rasterised to PNG (OpenCV drawing; atomic write).
void WritePngPlot(const fs::path& path, const std::vector<PlotSeries>& series, const PlotOptions& options);

}  // namespace mr
