// Report helpers shared by every HTML report (end-of-line, navigation): HTML escaping, number
// formatting and a line chart as inline SVG (no scripts, no external resources).
#pragma once

#include <cmath>
#include <string>
#include <utility>
#include <vector>

namespace imuforge::io {

std::string html_escape(const std::string& s);
// printf-style; "n/a" for NaN, "inf"/"-inf" for infinities.
std::string fmt_num(double x, const char* f = "%.4g");

struct ChartSeries {
  std::string name, color;
  std::vector<std::pair<double, double>> pts;
  bool markers = false;
  bool dashed = false;
};

// A categorical palette (10 colours).
const char* chart_color(std::size_t i);

// A line chart as inline SVG. logy: log10 axis (non-positive points dropped). hline: a dashed level.
// Series with an empty name get no legend entry.
std::string line_chart(const std::string& title, const std::vector<ChartSeries>& series, const std::string& xlabel,
                       const std::string& ylabel, bool logy = false, double hline = NAN, int W = 760, int H = 260);

}  // namespace imuforge::io
