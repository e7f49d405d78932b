#include "host/eol/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "host/eol/progress.h"
#include "host/io/svg_chart.h"

namespace imuforge::eol {

namespace {

using io::html_escape;
const auto esc = html_escape;
using io::fmt_num;
using Series = io::ChartSeries;
std::string chart(const std::string& title, const std::vector<Series>& series, const std::string& xlabel,
                  const std::string& ylabel, bool logy = false, double hline = NAN, int W = 760, int H = 260) {
  return io::line_chart(title, series, xlabel, ylabel, logy, hline, W, H);
}

// A small bar: value ± 2σ against ±limit (the limit is the full half-width).
std::string param_bar(double v, double s, double lim) {
  const double W = 220, C = W / 2;  // the SVG is 220 x 16 px
  double scale = lim > 0 ? lim : std::max(std::fabs(v) + 2 * s, 1e-300);
  auto X = [&](double x) { return std::clamp(C + x / scale * (W / 2 - 4), 1.0, W - 1); };
  std::string o = "<svg xmlns='http://www.w3.org/2000/svg' width='220' height='16'>";
  o += "<line x1='" + fmt_num(X(-scale)) + "' x2='" + fmt_num(X(scale)) + "' y1='8' y2='8' stroke='#ccc'/>";
  if (lim > 0) {
    o += "<line x1='" + fmt_num(X(-lim)) + "' x2='" + fmt_num(X(-lim)) + "' y1='1' y2='15' stroke='#d62728'/>";
    o += "<line x1='" + fmt_num(X(lim)) + "' x2='" + fmt_num(X(lim)) + "' y1='1' y2='15' stroke='#d62728'/>";
  }
  o += "<line x1='" + fmt_num(C) + "' x2='" + fmt_num(C) + "' y1='3' y2='13' stroke='#999'/>";
  if (std::isfinite(v) && std::isfinite(s)) {
    o += "<rect x='" + fmt_num(X(v - 2 * s)) + "' y='5' width='" + fmt_num(std::max(1.0, X(v + 2 * s) - X(v - 2 * s))) +
         "' height='6' fill='#9ecae1'/>";
    o += "<circle cx='" + fmt_num(X(v)) + "' cy='8' r='3' fill='#1f77b4'/>";
  }
  return o + "</svg>";
}

}  // namespace

std::string render_report(const ReportData& d) {
  const auto& r = d.rec;
  std::string h = "<!DOCTYPE html><html><head><meta charset='utf-8'><title>imuforge EOL " + esc(r.serial) +
                  "</title><style>body{font-family:sans-serif;margin:24px;max-width:1000px}"
                  "table{border-collapse:collapse;font-size:12px}td,th{border:1px solid #ddd;padding:2px 6px;text-align:right}"
                  "td:first-child,th:first-child{text-align:left}.pass{color:#2ca02c}.fail{color:#d62728}"
                  ".verdict{font-size:28px;font-weight:bold}h2{margin-top:28px}</style></head><body>";
  h += "<h1>End-of-line calibration: " + esc(r.serial) + "</h1>";
  h += "<div class='verdict " + std::string(r.pass ? "pass'>PASS" : "fail'>FAIL") + "</div>";
  if (!r.reasons.empty()) {
    h += "<ul>";
    for (const auto& x : r.reasons) h += "<li class='fail'>" + esc(x) + "</li>";
    h += "</ul>";
  }
  h += "<table><tr><th>station</th><td>" + esc(r.station) + "</td></tr><tr><th>fixture</th><td>" + esc(r.fixture) +
       "</td></tr><tr><th>campaign</th><td>" + esc(r.campaign) + " (sha256 " + esc(r.campaign_sha256.substr(0, 16)) +
       "…)</td></tr><tr><th>software / firmware</th><td>" + esc(r.software_version) + " / " + esc(r.firmware_version) +
       "</td></tr><tr><th>started / finished (UTC)</th><td>" + esc(r.started_utc) + " / " + esc(r.finished_utc) +
       "</td></tr><tr><th>campaign time</th><td>" + format_hms(r.campaign_time_s) + " (full schedule nominal " +
       format_hms(d.schedule_time_s) + ")" + (r.early_stop ? ", stopped early: every σ met its spec" : "") +
       "</td></tr><tr><th>segments</th><td>" + std::to_string(d.segments_used) + " of " +
       std::to_string(d.segments_total) + " scheduled" +
       (d.segments_resumed ? ", " + std::to_string(d.segments_resumed) + " recovered from the journal after a restart" : "") +
       "</td></tr><tr><th>log</th><td>" + esc(r.log_path) + "<br>sha256 " + esc(r.log_sha256) +
       "</td></tr><tr><th>table</th><td>" + std::to_string(r.table_blob.size()) + " bytes, CRC-32 " +
       fmt_num(static_cast<double>(r.table_crc32), "%08.0f") + "</td></tr><tr><th>record</th><td>" + esc(r.id) + " in " +
       esc(d.db) + "</td></tr></table>";
  if (!d.stream_note.empty()) h += "<p>" + esc(d.stream_note) + "</p>";

  h += "<h2>Parameters, σ and limits</h2><p>Bar: estimate (dot) ± 2σ (blue) against the station's ±limit (red).</p>";
  h += "<table><tr><th>parameter</th><th>value</th><th>σ</th><th>limit |value|</th><th>spec σ</th><th>ok</th><th></th></tr>";
  for (const auto& p : r.parameters)
    h += "<tr><td>" + esc(p.name) + "</td><td>" + fmt_num(p.value) + "</td><td>" + fmt_num(p.sigma) + "</td><td>" +
         (p.limit_abs > 0 ? fmt_num(p.limit_abs) : "-") + "</td><td>" + (p.sigma_spec > 0 ? fmt_num(p.sigma_spec) : "-") +
         "</td><td class='" + (p.pass ? "pass'>ok" : "fail'>FAIL") + "</td><td>" + param_bar(p.value, p.sigma, p.limit_abs) +
         "</td></tr>";
  h += "</table>";

  h += "<h2>Residuals per segment, before and after compensation</h2><p>Mean of measured − reference per segment: "
       "before = raw output, after = with the estimated model applied.</p>";
  static const char* ax[6] = {"x", "y", "z", "x", "y", "z"};
  for (int sensor = 0; sensor < 2; ++sensor) {
    for (int phase = 0; phase < 2; ++phase) {
      std::vector<Series> ss;
      for (int k = 0; k < 3; ++k) {
        Series s{std::string(sensor ? "gyro." : "accel.") + ax[k], io::chart_color(k), {}, true};
        for (const auto& sr : d.residuals)
          s.pts.push_back({static_cast<double>(sr.segment), (phase ? sr.after : sr.before)[static_cast<std::size_t>(3 * sensor + k)]});
        ss.push_back(s);
      }
      h += chart(std::string(sensor ? "gyro" : "accelerometer") + (phase ? " after compensation" : " before compensation"),
                 ss, "segment", sensor ? "rad/s" : "m/s²", false, 0.0, 760, 220);
    }
  }

  if (!d.rejections.empty()) {
    h += "<h2>Static steps left out</h2><p>The pose detector (host/poses, still_part) found no still part in these "
         "static steps, so their accelerometer rows were not used.</p><table><tr><th>segment</th><th>label</th><th>reason</th></tr>";
    for (const auto& r : d.rejections)
      h += "<tr><td>" + std::to_string(r.segment) + "</td><td>" + esc(r.label) + "</td><td>" + esc(r.reason) + "</td></tr>";
    h += "</table>";
  }

  h += "<h2>Temperature profile</h2>";
  h += chart("temperature", {{"IMU die", io::chart_color(1), d.imu_temp_C, false}, {"chamber air", io::chart_color(0), d.chamber_temp_C, false}},
             "run time (s, fixture clock)", "°C");

  h += "<h2>σ convergence</h2><p>σ / spec per parameter with a σ spec, after each segment (log scale; dashed: spec).</p>";
  {
    std::vector<Series> ss;
    for (std::size_t i = 0; i < d.names.size(); ++i) {
      if (!(static_cast<Eigen::Index>(i) < d.spec.size() && d.spec[static_cast<Eigen::Index>(i)] > 0)) continue;
      Series s{d.names[i], io::chart_color(ss.size()), {}, false};
      for (std::size_t k = 0; k < d.sigma_hist.size() && k < d.sigma_t_s.size(); ++k)
        if (static_cast<Eigen::Index>(i) < d.sigma_hist[k].size())
          s.pts.push_back({d.sigma_t_s[k], d.sigma_hist[k][static_cast<Eigen::Index>(i)] / d.spec[static_cast<Eigen::Index>(i)]});
      ss.push_back(s);
    }
    h += chart("σ / spec", ss, "run time (s, fixture clock)", "σ / spec", true, 1.0, 760, 320);
  }

  h += "<h2>Verification</h2><p>Table read back over CAN and compared byte for byte; then the firmware kernel, "
       "loaded with the read-back table, compensates the samples at each verification pose.</p>";
  h += "<table><tr><th>check</th><th>residual</th><th>limit</th><th>ok</th></tr>";
  for (const auto& v : r.verification)
    h += "<tr><td>" + esc(v.name) + "</td><td>" + fmt_num(v.residual) + "</td><td>" + (v.limit > 0 ? fmt_num(v.limit) : "-") +
         "</td><td class='" + (v.pass ? "pass'>ok" : "fail'>FAIL") + "</td></tr>";
  h += "</table><p style='color:#888'>imuforge " + esc(r.software_version) + "</p></body></html>\n";
  return h;
}

void write_file_atomic(const std::string& path, const std::string& text) {
  std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw std::runtime_error("report: cannot write " + tmp);
    f << text;
    if (!f) throw std::runtime_error("report: write failed: " + tmp);
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw std::runtime_error("report: cannot rename " + tmp + ": " + ec.message());
}

void write_report(const std::string& path, const ReportData& d) { write_file_atomic(path, render_report(d)); }


}  // namespace imuforge::eol
