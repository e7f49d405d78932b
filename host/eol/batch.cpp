#include "host/eol/batch.h"

#include "host/io/svg_chart.h"

#include <time.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>
#include <thread>

#include "host/eol/passfail.h"
#include "host/eol/report.h"
#include "host/eol/schedule.h"
#include "host/estimator/robust.h"
#include "host/io/log.h"
#include "host/solver/consider.h"
#include "host/solver/fixture.h"

namespace imuforge::eol {

using io::html_escape;

namespace {

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

using io::fmt_num;

using estimator::median;

void solve_one(const BatchUnit& u, const StationConfig& st, const model::ModelSpec& spec, const physics::Campaign& camp,
               UnitOutcome& out) {
  const double cpu0 = thread_cpu_s();
  out.slot = u.slot;
  out.serial = u.serial;
  out.log_path = u.log_path;
  try {
    // The unit's nest: its nominal mount and lever arm, and its own mount tolerance.
    physics::Campaign c = camp;
    StationConfig s = st;
    if (st.slot(u.slot)) narrow_to_slot(s, c, u.slot);  // the same narrowing as the live station runner
    UnitSolve us = solve_unit_log(u.log_path, s, spec, c);
    out.estimate = std::move(us.estimate);
    out.sigma_noise = std::move(us.sigma_noise);
    out.solved = true;
    std::vector<records::ParameterRecord> params;
    const Eigen::VectorXd sig = out.estimate.sigma();
    for (std::size_t i = 0; i < out.estimate.names.size(); ++i)
      params.push_back({out.estimate.names[i], out.estimate.value[static_cast<long>(i)], sig[static_cast<long>(i)], 0, 0, true});
    std::vector<records::VerificationRecord> none;
    std::vector<std::string> extra;
    if (!us.consider_error.empty()) extra.push_back(us.consider_error);
    const Verdict v = evaluate(st, params, none, extra, /*require_verification=*/false);
    out.pass = v.pass;
    out.reasons = v.reasons;
    out.params = params;
    nlohmann::json cal;
    cal["serial"] = u.serial;
    cal["slot"] = u.slot;
    cal["log"] = u.log_path;
    cal["parameters"] = nlohmann::json::array();
    for (std::size_t i = 0; i < params.size(); ++i) {
      nlohmann::json p = {{"name", params[i].name}, {"value", params[i].value}, {"sigma", params[i].sigma},
                          {"pass", params[i].pass}};
      if (out.sigma_noise.size() == sig.size()) p["sigma_noise"] = out.sigma_noise[static_cast<long>(i)];
      cal["parameters"].push_back(p);
    }
    cal["fixture_tolerance"] = us.fixture_section;
    cal["dwell_scatter"] = us.dwell_scatter;
    out.cal = cal;
  } catch (const std::exception& e) {
    out.solved = false;
    out.pass = false;
    out.reasons = {std::string("no calibration: ") + e.what()};
  }
  out.cpu_s = thread_cpu_s() - cpu0;
}

}  // namespace

UnitSolve solve_unit_log(const std::string& log_path, const StationConfig& st, const model::ModelSpec& spec,
                         const physics::Campaign& camp) {
  io::LogReader lr(log_path);
  solver::FixtureAccumulator acc(spec, lr.meta());
  io::LogRow row;
  while (lr.next(row)) acc.add(row);
  acc.finish();
  solver::Sigma6 noise = acc.static_noise_sigma();
  if (st.accel_noise_mps2 > 0)
    for (int c = 0; c < 3; ++c) noise[static_cast<std::size_t>(c)] = st.accel_noise_mps2;
  if (st.gyro_noise_rad_s > 0)
    for (int c = 3; c < 6; ++c) noise[static_cast<std::size_t>(c)] = st.gyro_noise_rad_s;
  UnitSolve us;
  // As `imuforge solve`: the covariance carries the dwell means' drift (docs/calibration.md, "Dwell drift"), so a
  // drifting unit's σ, and its pass against a σ spec, are not claimed from white noise.
  solver::SegmentScatter sc;
  solver::ChannelDrifts drifts;
  us.estimate = solver::solve_fixture_widened(acc, noise, &sc, &drifts).estimate;
  us.dwell_scatter = solver::dwell_scatter_json(&sc, solver::dwell_scatter_of(spec), drifts);
  us.fixture_section = solver::fixture_tolerance_not_stated();
  if (st.fixture_tolerance.is_null()) return us;
  try {
    const solver::FixtureTolerance tol =
        solver::fixture_tolerance_from_json(st.fixture_tolerance, static_cast<int>(camp.axes.size()), "station " + st.name);
    const solver::ConsiderResult cr = solver::consider_fixture_tolerance(lr, spec, camp, us.estimate, noise, tol);
    us.fixture_section = solver::apply_consider(us.estimate, cr, tol, &us.sigma_noise);
  } catch (const solver::SolverError& e) {
    // σ without the stated fixture would claim a precision the station does not have: no pass.
    us.fixture_section = {{"stated", true}, {"error", e.what()}};
    us.consider_error = std::string("fixture tolerance: ") + e.what();
  }
  return us;
}

BatchOutcome solve_batch(const std::vector<BatchUnit>& units, const StationConfig& st, const model::ModelSpec& spec,
                         const physics::Campaign& camp, const BatchOptions& opt) {
  if (units.empty()) throw std::invalid_argument("batch: no units");
  std::set<std::string> slots;
  for (const auto& u : units)
    if (!slots.insert(u.slot).second) throw std::invalid_argument("batch: slot '" + u.slot + "' listed twice");
  BatchOutcome b;
  b.units.resize(units.size());
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  b.threads = static_cast<int>(std::min<std::size_t>(opt.threads > 0 ? static_cast<std::size_t>(opt.threads) : hw, units.size()));
  const auto t0 = std::chrono::steady_clock::now();
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t i = next++; i < units.size(); i = next++) solve_one(units[i], st, spec, camp, b.units[i]);
  };
  std::vector<std::thread> pool;
  for (int k = 1; k < b.threads; ++k) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  b.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const auto& u : b.units) b.passed += u.pass ? 1 : 0;
  mark_outliers(b, opt);
  return b;
}

void mark_outliers(BatchOutcome& b, const BatchOptions& opt) {
  b.spread.clear();
  const UnitOutcome* ref = nullptr;
  for (const auto& u : b.units)
    if (u.solved) {
      ref = &u;
      break;
    }
  if (!ref) return;
  const auto names = ref->estimate.names;
  for (auto& u : b.units) u.outliers.clear();
  for (std::size_t i = 0; i < names.size(); ++i) {
    ParameterSpread s;
    s.name = names[i];
    std::vector<double> v;
    for (const auto& u : b.units) {
      const int k = u.solved ? u.estimate.index_of(names[i]) : -1;
      if (k >= 0 && std::isfinite(u.estimate.value[k])) v.push_back(u.estimate.value[k]);
    }
    s.n = static_cast<int>(v.size());
    if (v.empty()) {
      b.spread.push_back(s);
      continue;
    }
    s.median = median(v);
    std::vector<double> dev;
    for (double x : v) dev.push_back(std::fabs(x - s.median));
    s.robust_sigma = estimator::kMadToSigma * median(dev);
    b.spread.push_back(s);
    if (s.n < opt.min_units_for_outliers) continue;
    for (auto& u : b.units) {
      const int k = u.solved ? u.estimate.index_of(names[i]) : -1;
      if (k < 0) continue;
      const double d = std::fabs(u.estimate.value[k] - s.median);
      // Far from the batch in its spread AND beyond the unit's own σ (a batch of identical parts has
      // a MAD of pure noise; a 5-MAD excursion within 3σ is not a finding).
      if (d > opt.outlier_k * s.robust_sigma && d > 3.0 * std::sqrt(u.estimate.covariance(k, k))) u.outliers.push_back(names[i]);
    }
  }
}

std::string record_batch(records::RecordStore& store, const BatchOutcome& b,
                         const BatchProvenance& prov) {
  store.ensure_schema();
  // The provenance both record kinds share.
  auto stamp = [&](auto& r) {
    r.station = prov.station;
    r.campaign = prov.campaign;
    r.campaign_sha256 = prov.campaign_sha256;
    r.software_version = IMUFORGE_VERSION;
    r.started_utc = prov.started_utc;
    r.finished_utc = prov.finished_utc;
  };
  records::BatchRecord br;
  stamp(br);
  br.id = prov.batch_id;
  br.units_passed = b.passed;
  for (const auto& u : b.units) {
    if (u.recorded) {
      br.units.push_back({u.slot, u.serial, u.record_id, u.pass, u.reasons, u.outliers});
      continue;
    }
    records::CalibrationRecord rec;
    rec.id = u.record_id;
    stamp(rec);
    rec.serial = u.serial;
    rec.fixture = u.slot;
    rec.pass = u.pass;
    rec.reasons = u.reasons;
    rec.log_path = u.log_path;
    rec.parameters = u.params;
    const std::string id = store.insert(rec);
    br.units.push_back({u.slot, u.serial, id, u.pass, u.reasons, u.outliers});
  }
  return store.insert_batch(br);
}

nlohmann::json batch_to_json(const BatchOutcome& b) {
  nlohmann::json j;
  j["units_total"] = b.units.size();
  j["units_passed"] = b.passed;
  j["threads"] = b.threads;
  j["wall_s"] = b.wall_s;
  j["units"] = nlohmann::json::array();
  for (const auto& u : b.units)
    j["units"].push_back({{"slot", u.slot}, {"serial", u.serial}, {"pass", u.pass}, {"reasons", u.reasons},
                          {"outliers", u.outliers}, {"cpu_s", u.cpu_s}});
  j["spread"] = nlohmann::json::array();
  for (const auto& s : b.spread)
    j["spread"].push_back({{"name", s.name}, {"n", s.n}, {"median", s.median}, {"robust_sigma", s.robust_sigma}});
  return j;
}

// "slot03 (serial 3)", or the slot alone when the unit never told its serial (a dead node).
static std::string unit_label(const UnitOutcome& u) {
  return u.serial.empty() ? u.slot : u.slot + " (serial " + u.serial + ")";
}

// One parameter's strip chart: every solved unit a dot (red: outlier, hollow: failed unit), the
// median and the ±k robust σ band.
static std::string strip(const ParameterSpread& s, const BatchOutcome& b, double k) {
  const int W = 300, H = 46, L = 8, R = 8;
  double lo = s.median - k * s.robust_sigma, hi = s.median + k * s.robust_sigma;
  for (const auto& u : b.units) {
    const int i = u.solved ? u.estimate.index_of(s.name) : -1;
    if (i < 0 || !std::isfinite(u.estimate.value[i])) continue;
    lo = std::min(lo, u.estimate.value[i]);
    hi = std::max(hi, u.estimate.value[i]);
  }
  if (!(hi > lo)) {
    lo -= 1e-12;
    hi += 1e-12;
  }
  auto x = [&](double v) { return L + (W - L - R) * (v - lo) / (hi - lo); };
  std::string o = "<svg xmlns='http://www.w3.org/2000/svg' width='" + std::to_string(W) + "' height='" + std::to_string(H) + "'>";
  o += "<rect x='" + fmt_num(x(s.median - k * s.robust_sigma), "%.1f") + "' y='8' width='" +
       fmt_num(std::max(1.0, x(s.median + k * s.robust_sigma) - x(s.median - k * s.robust_sigma)), "%.1f") +
       "' height='22' fill='#e8f0fa'/>";
  o += "<line x1='" + fmt_num(x(s.median), "%.1f") + "' x2='" + fmt_num(x(s.median), "%.1f") + "' y1='6' y2='32' stroke='#1f77b4'/>";
  int row = 0;
  for (const auto& u : b.units) {
    const int i = u.solved ? u.estimate.index_of(s.name) : -1;
    if (i < 0 || !std::isfinite(u.estimate.value[i])) continue;
    const bool out = std::find(u.outliers.begin(), u.outliers.end(), s.name) != u.outliers.end();
    const double y = 12 + 14 * ((row++ % 3) / 2.0);
    o += "<circle cx='" + fmt_num(x(u.estimate.value[i]), "%.1f") + "' cy='" + fmt_num(y, "%.1f") + "' r='" + (out ? "4" : "2.5") +
         "' fill='" + (out ? "#d62728" : u.pass ? "#333" : "none") + "' stroke='" + (out ? "#d62728" : "#333") + "'><title>" +
         html_escape(unit_label(u)) + "</title></circle>";
  }
  o += "<text x='" + std::to_string(L) + "' y='44' font-size='9'>" + fmt_num(lo) + "</text><text x='" + std::to_string(W - R) +
       "' y='44' font-size='9' text-anchor='end'>" + fmt_num(hi) + "</text></svg>";
  return o;
}

std::string render_batch_report(const BatchOutcome& b, const std::string& title) {
  const BatchOptions def;
  std::string h = "<!DOCTYPE html><html><head><meta charset='utf-8'><title>" + html_escape(title) +
                  "</title><style>body{font-family:sans-serif;margin:24px;max-width:1200px}"
                  "table{border-collapse:collapse;font-size:12px}td,th{border:1px solid #ddd;padding:2px 6px;text-align:left}"
                  ".pass{color:#2ca02c}.fail{color:#d62728}.warn{color:#b8860b}.verdict{font-size:28px;font-weight:bold}"
                  ".grid{display:grid;grid-template-columns:repeat(3,1fr);gap:6px 18px;font-size:11px}h2{margin-top:28px}"
                  "</style></head><body>";
  h += "<h1>" + html_escape(title) + "</h1>";
  const int n = static_cast<int>(b.units.size());
  int suspicious = 0;
  for (const auto& u : b.units) suspicious += (u.pass && !u.outliers.empty()) ? 1 : 0;
  h += "<div class='verdict " + std::string(b.passed == n ? "pass" : "fail") + "'>" + std::to_string(b.passed) + " of " +
       std::to_string(n) + " units PASS</div><ul>";
  for (const auto& u : b.units)
    if (!u.pass)
      h += "<li class='fail'><b>" + html_escape(unit_label(u)) + "</b> FAIL: " +
           html_escape(u.reasons.empty() ? "" : u.reasons[0]) +
           (u.reasons.size() > 1 ? " (+" + std::to_string(u.reasons.size() - 1) + " more)" : "") + "</li>";
  for (const auto& u : b.units)
    if (!u.outliers.empty()) {
      std::string list;
      for (const auto& p : u.outliers) list += (list.empty() ? "" : ", ") + p;
      h += "<li class='warn'><b>" + html_escape(unit_label(u)) + "</b> " + (u.pass ? "passes but is " : "") +
           "far from its batch (> " + fmt_num(def.outlier_k, "%.0f") + " robust σ): " + html_escape(list) + "</li>";
    }
  h += "</ul><p>" + std::to_string(suspicious) + " passing unit(s) suspicious. Solved on " + std::to_string(b.threads) +
       " thread(s) in " + fmt_num(b.wall_s, "%.1f") + " s wall.</p>";
  h += "<h2>Units</h2><table><tr><th>slot</th><th>serial</th><th>verdict</th><th>reasons</th><th>outlying parameters</th>"
       "<th>solve CPU s</th></tr>";
  for (const auto& u : b.units) {
    std::string r, o;
    for (const auto& x : u.reasons) r += (r.empty() ? "" : "<br>") + html_escape(x);
    for (const auto& x : u.outliers) o += (o.empty() ? "" : ", ") + html_escape(x);
    const std::string slot = u.report_href.empty() ? html_escape(u.slot)
                                                   : "<a href='" + html_escape(u.report_href) + "'>" + html_escape(u.slot) + "</a>";
    h += "<tr><td>" + slot + "</td><td>" + html_escape(u.serial) + "</td><td class='" +
         (u.pass ? "pass'>PASS" : "fail'>FAIL") + "</td><td>" + r + "</td><td class='warn'>" + o + "</td><td>" +
         fmt_num(u.cpu_s, "%.2f") + "</td></tr>";
  }
  h += "</table><h2>Spread of each parameter over the batch</h2><p>Dot: a unit (hollow: failed, red: outlier); "
       "line: batch median; band: ±" + fmt_num(def.outlier_k, "%.0f") + " robust σ (1.4826 × MAD).</p><div class='grid'>";
  for (const auto& s : b.spread)
    h += "<div><b>" + html_escape(s.name) + "</b> median " + fmt_num(s.median) + ", robust σ " + fmt_num(s.robust_sigma) + "<br>" +
         strip(s, b, def.outlier_k) + "</div>";
  h += "</div></body></html>\n";
  return h;
}

}  // namespace imuforge::eol
