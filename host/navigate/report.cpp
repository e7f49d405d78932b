#include "host/navigate/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "host/io/svg_chart.h"
#include "host/nav/strapdown.h"

namespace imuforge::navigate {

using io::fmt_num;
using io::html_escape;
using nlohmann::json;

namespace {

json num(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

json stats_json(const std::vector<double>& at, const std::vector<Stats>& s) {
  json a = json::array();
  for (std::size_t i = 0; i < s.size(); ++i)
    a.push_back({{"at_s", at[i]}, {"mean", num(s[i].mean)}, {"median", num(s[i].median)}, {"p95", num(s[i].p95)},
                 {"max", num(s[i].max)}});
  return a;
}

std::string aiding_text(Aiding a) {
  return a == Aiding::kPosVel
             ? "position and velocity reset to the truth at every IMU sample before the outage; attitude aligned to "
               "the truth once at t = 0 and free from then on (not a Kalman filter)"
             : "position, velocity and attitude reset to the truth at every IMU sample before the outage (an ideal "
               "aiding filter's attitude; not a Kalman filter)";
}

}  // namespace

json nav_json(const NavReport& r) {
  const ImpactResult& res = r.result;
  json j;
  j["format"] = "imuforge-nav";
  j["version"] = 1;
  j["trajectory"] = {{"file", r.trajectory_path}, {"name", r.trajectory_name}, {"ambient_C", r.ambient_C},
                     {"distance_m", r.distance_m}, {"sample_rate_hz", r.truth ? r.truth->rate_hz : 0.0},
                     {"duration_s", r.truth ? static_cast<double>(r.truth->states.size() - 1) / r.truth->rate_hz : 0.0}};
  j["sensor"] = {{"file", r.sensor_path}, {"name", r.sensor_name}};
  j["outage"] = {{"start_s", r.opt.outage_start_s}, {"duration_s", r.opt.outage_s}};
  if (!r.outage_label.empty()) j["outage"]["segment_label"] = r.outage_label;
  j["aiding"] = {{"mode", r.opt.aiding == Aiding::kPosVel ? "pos-vel" : "pos-vel-att"}, {"description", aiding_text(r.opt.aiding)}};
  j["runs"] = r.opt.runs;
  j["seed"] = r.opt.seed;
  j["kernel"] = "firmware compensation kernel, f32 path (host build of firmware/kernel)";
  j["checkpoints_s"] = res.checkpoints_s;
  json cands = json::array();
  for (std::size_t c = 0; c < res.candidates.size(); ++c) {
    const CandidateResult& cr = res.candidates[c];
    json o = {{"name", cr.name}, {"kind", cr.kind}, {"source", cr.source}, {"not_in_table", cr.dropped}};
    o["horizontal_position_error_m"] = stats_json(res.checkpoints_s, cr.hpos);
    o["horizontal_velocity_error_mps"] = stats_json(res.checkpoints_s, cr.hvel);
    o["heading_error_deg"] = stats_json(res.checkpoints_s, cr.heading_deg);
    o["horizontal_position_error_per_s"] = {{"median_m", cr.hpos_median_m}, {"p95_m", cr.hpos_p95_m}};
    if (c < r.predicted_rms_m.size()) o["predicted_rms_m_from_sigma"] = num(r.predicted_rms_m[c]);
    cands.push_back(o);
  }
  j["candidates"] = cands;
  if (r.sens) {
    const SensitivityResult& s = *r.sens;
    json g = json::array();
    for (const auto& gs : s.groups)
      g.push_back({{"group", gs.group}, {"units", gs.units}, {"parameters", gs.n_params}, {"m_per_unit_sigma", num(gs.m_per_unit)},
                   {"sigma_alone", num(gs.sigma_alone)}, {"sigma_equal_share", num(gs.sigma_share)}});
    json jp = json::object();
    for (std::size_t i = 0; i < s.names.size(); ++i) jp[s.names[i]] = {s.J[i].x(), s.J[i].y()};
    j["sensitivity"] = {{"requirement", "RMS horizontal position error <= target after at_s of outage"},
                        {"target_m", s.target_m}, {"at_s", s.at_s}, {"floor_m", s.floor_m}, {"budget_m", s.budget_m},
                        {"groups", g}, {"jacobian_north_east_m_per_unit", jp}};
  }
  j["cost"] = {{"cpu_s", res.cpu_s}, {"wall_s", res.wall_s}, {"navigator_steps", res.nav_steps}};
  return j;
}

namespace {

// The path in north/east metres (equal aspect), the outage in red, start marked.
std::string trajectory_svg(const sim::VehicleTruth& t, double out0, double out1) {
  const int W = 560, H = 420, M = 40;
  std::vector<Eigen::Vector2d> p;
  std::vector<bool> in_out;
  const std::size_t step = std::max<std::size_t>(1, static_cast<std::size_t>(t.rate_hz / 2));
  for (std::size_t i = 0; i < t.states.size(); i += step) {
    p.push_back(nav::horizontal_offset_m(t.states[i].pos, t.states[0].pos));
    const double ts = static_cast<double>(i) / t.rate_hz;
    in_out.push_back(ts >= out0 && ts <= out1);
  }
  double n0 = 0, n1 = 0, e0 = 0, e1 = 0;
  for (const auto& q : p) {
    n0 = std::min(n0, q.x()); n1 = std::max(n1, q.x());
    e0 = std::min(e0, q.y()); e1 = std::max(e1, q.y());
  }
  const double span = std::max({n1 - n0, e1 - e0, 1.0});
  const double sc = std::min((W - 2.0 * M) / std::max(e1 - e0, 1.0), (H - 2.0 * M) / std::max(n1 - n0, 1.0));
  auto X = [&](double e) { return M + (e - e0) * sc; };
  auto Y = [&](double n) { return H - M - (n - n0) * sc; };
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
    << "' font-family='sans-serif' font-size='11'><rect x='0' y='0' width='" << W << "' height='" << H
    << "' fill='none' stroke='#ccc'/>";
  std::string a, b;
  for (std::size_t i = 0; i < p.size(); ++i) {
    std::string& d = in_out[i] ? b : a;
    const bool start = d.empty() || (i > 0 && in_out[i] != in_out[i - 1]);
    d += (start ? "M" : "L") + fmt_num(X(p[i].y()), "%.1f") + "," + fmt_num(Y(p[i].x()), "%.1f");
  }
  s << "<path d='" << a << "' fill='none' stroke='#1f77b4' stroke-width='1.5'/>";
  s << "<path d='" << b << "' fill='none' stroke='#d62728' stroke-width='3'/>";
  s << "<circle cx='" << X(0) << "' cy='" << Y(0) << "' r='4' fill='#2ca02c'/><text x='" << X(0) + 6 << "' y='" << Y(0) - 6
    << "'>start</text>";
  // Scale bar: a round length near a fifth of the span.
  double bar = std::pow(10.0, std::floor(std::log10(span / 5)));
  if (bar * 5 < span / 5) bar *= 5;
  else if (bar * 2 < span / 5) bar *= 2;
  s << "<line x1='" << M << "' x2='" << M + bar * sc << "' y1='" << H - 12 << "' y2='" << H - 12
    << "' stroke='#000' stroke-width='2'/><text x='" << M + bar * sc + 6 << "' y='" << H - 8 << "'>" << fmt_num(bar, "%g")
    << " m</text>";
  s << "<text x='" << W - M << "' y='18' text-anchor='end'>N ↑ &#160; blue: aided, red: GNSS outage</text></svg>";
  return s.str();
}

}  // namespace

std::string nav_html(const NavReport& r) {
  const ImpactResult& res = r.result;
  const std::size_t last = res.checkpoints_s.size() - 1;
  const double T = res.checkpoints_s[last];
  std::ostringstream h;
  h << "<!DOCTYPE html><html><head><meta charset='utf-8'><title>imuforge navigate: " << html_escape(r.trajectory_name)
    << "</title><style>body{font-family:sans-serif;max-width:1200px;margin:20px auto;color:#222}"
       "table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #ccc;padding:3px 7px;text-align:right}"
       "th{background:#f3f3f3}td.l,th.l{text-align:left}.verdict{font-size:1.1em;background:#f6f8fa;padding:10px;"
       "border-left:4px solid #1f77b4}.small{color:#555;font-size:0.9em}</style></head><body>";
  h << "<h1>What the calibration is worth in metres</h1>";
  h << "<p class='small'>" << html_escape(r.sensor_name) << " on trajectory <b>" << html_escape(r.trajectory_name) << "</b> ("
    << fmt_num(r.distance_m / 1000, "%.2f") << " km, ambient " << fmt_num(r.ambient_C, "%.0f") << " °C); GNSS outage "
    << fmt_num(r.opt.outage_s, "%g") << " s from t = " << fmt_num(r.opt.outage_start_s, "%g") << " s"
    << (r.outage_label.empty() ? "" : " (segment “" + html_escape(r.outage_label) + "”)") << "; " << r.opt.runs
    << " sensor realisations.</p>";

  // Verdict: the candidates ranked by median horizontal error at the last checkpoint.
  std::vector<std::size_t> order(res.candidates.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return res.candidates[a].hpos[last].median < res.candidates[b].hpos[last].median;
  });
  h << "<div class='verdict'><b>After " << fmt_num(T, "%g") << " s without GNSS</b>, median (95th percentile) horizontal error: ";
  for (std::size_t k = 0; k < order.size(); ++k) {
    const CandidateResult& c = res.candidates[order[k]];
    h << (k ? "; " : "") << "<b>" << html_escape(c.name) << "</b> " << fmt_num(c.hpos[last].median, "%.3g") << " m ("
      << fmt_num(c.hpos[last].p95, "%.3g") << " m)";
  }
  h << ".";
  const CandidateResult* unc = nullptr;
  const CandidateResult* orc = nullptr;
  const CandidateResult* best = nullptr;
  for (std::size_t k : order) {
    const CandidateResult& c = res.candidates[k];
    if (c.kind == "uncompensated") unc = &c;
    if (c.kind == "oracle") orc = &c;
    if (c.kind == "calibration" && !best) best = &c;
  }
  if (best && unc && orc)
    h << " The best calibration, <b>" << html_escape(best->name) << "</b>, takes the error from "
      << fmt_num(unc->hpos[last].median, "%.3g") << " m (uncompensated) to " << fmt_num(best->hpos[last].median, "%.3g")
      << " m; the oracle (true values of every term the table holds) reaches " << fmt_num(orc->hpos[last].median, "%.3g")
      << " m"
      << (best->hpos[last].median >= orc->hpos[last].median
              ? ", so " + fmt_num(best->hpos[last].median - orc->hpos[last].median, "%.3g") +
                    " m is left to better calibration and the rest is noise and terms the table cannot carry."
              : ". The calibration beats the oracle: the oracle is the truth of the table's terms, not the best "
                "table, and the estimates absorb part of effects the table cannot carry.");
  h << "</div>";

  h << "<h2>Errors at " ;
  for (std::size_t i = 0; i < res.checkpoints_s.size(); ++i) h << (i ? ", " : "") << fmt_num(res.checkpoints_s[i], "%g");
  h << " s into the outage</h2><table><tr><th class='l'>compensation</th>";
  for (double c : res.checkpoints_s) h << "<th>horiz. pos. " << fmt_num(c, "%g") << " s<br>median / 95th pct (m)</th>";
  h << "<th>horiz. vel. " << fmt_num(T, "%g") << " s<br>median / 95th (m/s)</th><th>heading " << fmt_num(T, "%g")
    << " s<br>median / 95th (°)</th><th>predicted RMS from σ<br>(m, " << fmt_num(T, "%g") << " s)</th><th class='l'>not in table v1</th></tr>";
  for (std::size_t c = 0; c < res.candidates.size(); ++c) {
    const CandidateResult& cr = res.candidates[c];
    h << "<tr><td class='l'><span style='color:" << io::chart_color(c) << "'>■</span> " << html_escape(cr.name) << "</td>";
    for (std::size_t i = 0; i < res.checkpoints_s.size(); ++i)
      h << "<td>" << fmt_num(cr.hpos[i].median, "%.3g") << " / " << fmt_num(cr.hpos[i].p95, "%.3g") << "</td>";
    h << "<td>" << fmt_num(cr.hvel[last].median, "%.3g") << " / " << fmt_num(cr.hvel[last].p95, "%.3g") << "</td>";
    h << "<td>" << fmt_num(cr.heading_deg[last].median, "%.3g") << " / " << fmt_num(cr.heading_deg[last].p95, "%.3g") << "</td>";
    const double pr = c < r.predicted_rms_m.size() ? r.predicted_rms_m[c] : NAN;
    h << "<td>" << (std::isfinite(pr) ? fmt_num(pr, "%.3g") : "–") << "</td><td class='l small'>";
    for (std::size_t k = 0; k < cr.dropped.size(); ++k) h << (k ? ", " : "") << html_escape(cr.dropped[k]);
    h << "</td></tr>";
  }
  h << "</table>";
  h << "<p class='small'>Predicted RMS from σ: the horizontal error at " << fmt_num(T, "%g")
    << " s that the calibration's own σ (statistical error of the estimated terms) explains, through the linear "
       "budget below. A calibration much worse than its prediction plus the oracle is biased by effects its model "
       "does not estimate (see <code>imuforge diagnose</code>).</p>";

  std::vector<io::ChartSeries> ser;
  for (std::size_t c = 0; c < res.candidates.size(); ++c) {
    const CandidateResult& cr = res.candidates[c];
    io::ChartSeries med{cr.name, io::chart_color(c), {}, false, false};
    io::ChartSeries p95{"", io::chart_color(c), {}, false, true};
    for (std::size_t s = 0; s < cr.hpos_median_m.size(); ++s) {
      med.pts.push_back({static_cast<double>(s + 1), cr.hpos_median_m[s]});
      p95.pts.push_back({static_cast<double>(s + 1), cr.hpos_p95_m[s]});
    }
    ser.push_back(med);
    ser.push_back(p95);
  }
  h << "<h2>Error growth through the outage</h2>"
    << io::line_chart("horizontal position error (solid: median, dashed: 95th percentile)", ser, "time into the outage (s)",
                      "m (log scale)", true, NAN, 1100, 420);

  if (r.truth) {
    h << "<h2>Trajectory</h2>" << trajectory_svg(*r.truth, r.opt.outage_start_s, r.opt.outage_start_s + r.opt.outage_s);
  }

  if (r.sens) {
    const SensitivityResult& s = *r.sens;
    h << "<h2>Calibration σ for “RMS horizontal error ≤ " << fmt_num(s.target_m, "%g") << " m after " << fmt_num(s.at_s, "%g")
      << " s”</h2>";
    if (s.budget_m <= 0)
      h << "<p class='verdict'>Not reachable by calibration: the oracle's RMS error is already " << fmt_num(s.floor_m, "%.3g")
        << " m (noise and terms the table cannot hold).</p>";
    else
      h << "<p>The oracle's RMS error (" << fmt_num(s.floor_m, "%.3g") << " m) leaves " << fmt_num(s.budget_m, "%.3g")
        << " m RMS to the calibration. Per group: the σ that meets it alone (every other group perfect), and with an "
           "equal share of the budget for each of the "
        << s.groups.size() << " groups. Linear budget from one-at-a-time perturbations (docs/navigation.md).</p>";
    h << "<table><tr><th class='l'>group</th><th>parameters</th><th>m per unit σ</th><th>σ alone</th><th>σ equal share</th>"
         "<th class='l'>units</th></tr>";
    for (const auto& g : s.groups)
      h << "<tr><td class='l'>" << html_escape(g.group) << "</td><td>" << g.n_params << "</td><td>" << fmt_num(g.m_per_unit, "%.3g")
        << "</td><td>" << fmt_num(g.sigma_alone, "%.3g") << "</td><td>" << fmt_num(g.sigma_share, "%.3g")
        << "</td><td class='l small'>" << html_escape(g.units) << "</td></tr>";
    h << "</table>";
  }

  h << "<h2>Method</h2><ul class='small'>";
  h << "<li>Aiding: " << html_escape(aiding_text(r.opt.aiding)) << ". From the outage start the strapdown navigator "
       "(NED, WGS-84, Earth and transport rate, coning and sculling) runs free.</li>";
  h << "<li>Every run draws a new sensor realisation (turn-on bias, white noise, bias instability, random walk; seed "
    << r.opt.seed << " + run) from the sensor file with every effect on; the same raw counts go through each "
       "candidate's coefficient table in the firmware kernel (f32 path), exactly what ships.</li>";
  h << "<li><b>uncompensated</b>: raw counts × nominal LSB. <b>oracle</b>: the sensor file's true values of every term "
       "table v1 holds (bias, scale, misalignment, their temperature polynomials, gyro g-sensitivity); it cannot know "
       "the turn-on bias of a power-up nor the terms the table lacks.</li>";
  h << "<li>Cost: " << fmt_num(res.cpu_s, "%.2f") << " s CPU, " << fmt_num(res.wall_s, "%.2f") << " s wall for "
    << res.nav_steps << " navigator steps.</li></ul></body></html>";
  return h.str();
}

void write_nav_outputs(const std::string& dir, const NavReport& r) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error(dir + ": cannot create output folder: " + ec.message());
  const std::string files[2] = {dir + "/nav.json", dir + "/report.html"};
  const std::string text[2] = {nav_json(r).dump(1) + "\n", nav_html(r)};
  for (int i = 0; i < 2; ++i) {
    std::ofstream f(files[i] + ".tmp");
    f << text[i];
    f.close();
    if (!f) {
      fs::remove(files[0] + ".tmp", ec);
      fs::remove(files[1] + ".tmp", ec);
      throw std::runtime_error(files[i] + ": write failed");
    }
  }
  for (const auto& f : files) {
    fs::rename(f + ".tmp", f, ec);
    if (ec) throw std::runtime_error(f + ": cannot rename into place: " + ec.message());
  }
}

}  // namespace imuforge::navigate
