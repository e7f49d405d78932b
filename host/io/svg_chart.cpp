#include "host/io/svg_chart.h"

#include <algorithm>
#include <cstdio>

namespace imuforge::io {

std::string html_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string fmt_num(double x, const char* f) {
  if (std::isnan(x)) return "n/a";
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  char b[64];
  std::snprintf(b, sizeof b, f, x);
  return b;
}

namespace {
const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b",
                         "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};

}  // namespace

const char* chart_color(std::size_t i) { return kColors[i % (sizeof kColors / sizeof kColors[0])]; }

std::string line_chart(const std::string& title, const std::vector<ChartSeries>& series, const std::string& xlabel,
                       const std::string& ylabel, bool logy, double hline, int W, int H) {
  auto esc = html_escape;
  auto fmt = [](double x, const char* f = "%.4g") { return fmt_num(x, f); };
  const double L = 70, R = 150, T = 24, B = 36;
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  auto ty = [&](double y) { return logy ? std::log10(y) : y; };
  for (const auto& s : series)
    for (auto [x, y] : s.pts) {
      if (!std::isfinite(x) || !std::isfinite(y) || (logy && y <= 0)) continue;
      x0 = std::min(x0, x); x1 = std::max(x1, x);
      y0 = std::min(y0, ty(y)); y1 = std::max(y1, ty(y));
    }
  if (std::isfinite(hline) && (!logy || hline > 0)) { y0 = std::min(y0, ty(hline)); y1 = std::max(y1, ty(hline)); }
  std::string o = "<svg xmlns='http://www.w3.org/2000/svg' width='" + std::to_string(W) + "' height='" +
                  std::to_string(H) + "' viewBox='0 0 " + std::to_string(W) + " " + std::to_string(H) +
                  "' font-family='sans-serif' font-size='11'>";
  o += "<text x='" + std::to_string(W / 2) + "' y='14' text-anchor='middle' font-weight='bold'>" + esc(title) + "</text>";
  if (!(x1 >= x0) || !(y1 >= y0)) return o + "<text x='20' y='60'>no data</text></svg>";
  if (x1 == x0) { x0 -= 1; x1 += 1; }
  if (y1 == y0) { y0 -= 1; y1 += 1; }
  double pad = 0.05 * (y1 - y0);
  y0 -= pad; y1 += pad;
  auto X = [&](double x) { return L + (x - x0) / (x1 - x0) * (W - L - R); };
  auto Y = [&](double y) { return H - B - (ty(y) - y0) / (y1 - y0) * (H - T - B); };
  o += "<rect x='" + fmt(L) + "' y='" + fmt(T) + "' width='" + fmt(W - L - R) + "' height='" + fmt(H - T - B) +
       "' fill='none' stroke='#999'/>";
  for (int i = 0; i <= 4; ++i) {
    double yv = y0 + (y1 - y0) * i / 4.0;
    double py = H - B - (H - T - B) * i / 4.0;
    o += "<line x1='" + fmt(L) + "' x2='" + fmt(W - R) + "' y1='" + fmt(py) + "' y2='" + fmt(py) + "' stroke='#eee'/>";
    o += "<text x='" + fmt(L - 4) + "' y='" + fmt(py + 4) + "' text-anchor='end'>" + fmt(logy ? std::pow(10, yv) : yv, "%.3g") + "</text>";
    double xv = x0 + (x1 - x0) * i / 4.0;
    double px = L + (W - L - R) * i / 4.0;
    o += "<text x='" + fmt(px) + "' y='" + fmt(H - B + 14) + "' text-anchor='middle'>" + fmt(xv, "%.4g") + "</text>";
  }
  o += "<text x='" + fmt(L + (W - L - R) / 2) + "' y='" + fmt(H - 4.0) + "' text-anchor='middle'>" + esc(xlabel) + "</text>";
  o += "<text x='12' y='" + fmt(T + (H - T - B) / 2) + "' transform='rotate(-90 12 " + fmt(T + (H - T - B) / 2) +
       ")' text-anchor='middle'>" + esc(ylabel) + "</text>";
  if (std::isfinite(hline) && (!logy || hline > 0))
    o += "<line x1='" + fmt(L) + "' x2='" + fmt(W - R) + "' y1='" + fmt(Y(hline)) + "' y2='" + fmt(Y(hline)) +
         "' stroke='#000' stroke-dasharray='5,4'/>";
  int li = 0;
  for (const auto& s : series) {
    std::string path;
    for (auto [x, y] : s.pts) {
      if (!std::isfinite(x) || !std::isfinite(y) || (logy && y <= 0)) continue;
      path += (path.empty() ? "M" : "L") + fmt(X(x), "%.1f") + "," + fmt(Y(y), "%.1f");
      if (s.markers) o += "<circle cx='" + fmt(X(x), "%.1f") + "' cy='" + fmt(Y(y), "%.1f") + "' r='2' fill='" + s.color + "'/>";
    }
    if (!s.markers && !path.empty())
      o += "<path d='" + path + "' fill='none' stroke='" + s.color + "' stroke-width='1.3'" +
           (s.dashed ? " stroke-dasharray='4,3'" : "") + "/>";
    if (li < 16 && !s.name.empty()) {
      double ly = T + 10 + 13 * li;
      o += "<rect x='" + fmt(W - R + 8) + "' y='" + fmt(ly - 8) + "' width='10' height='3' fill='" + s.color + "'/>";
      o += "<text x='" + fmt(W - R + 22) + "' y='" + fmt(ly - 3) + "'>" + esc(s.name) + "</text>";
    }
    if (!s.name.empty()) ++li;
  }
  return o + "</svg>";
}

}  // namespace imuforge::io
