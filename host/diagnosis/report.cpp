// diagnosis.json, the text summary and the self-contained report.html (inline SVG, no scripts).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "host/diagnosis/diagnose.h"

namespace imuforge::diagnosis {

namespace {

nlohmann::json num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

nlohmann::json gap_json(const Gap& g, const Gap* before) {
  nlohmann::json j = nlohmann::json::object();
  for (int a = 0; a < kNumAxes; ++a) {
    const auto u = static_cast<std::size_t>(a);
    nlohmann::json e = {{"gap", num(g.gap[u])}, {"heldout_rms", num(g.rms[u])}, {"noise_floor", num(g.floor[u])},
                        {"heldout_chi2_dof", num(g.chi2_dof[u])}};
    if (std::isfinite(g.chi2_dof_wander[u])) e["gls_chi2_dof_under_wander"] = g.chi2_dof_wander[u];
    if (before) {
      const double g0 = before->gap[u];
      e["shrink_pct"] = g0 > 0 ? num(100.0 * (1.0 - std::max(g.gap[u], 0.0) / g0)) : nlohmann::json(nullptr);
    }
    j[axis_name(a)] = e;
  }
  return j;
}

// temp_hysteresis's threshold profile: [{threshold_C, likelihood_ratio}].
nlohmann::json hysteresis_profile_json(const std::vector<std::pair<double, double>>& profile) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& [thr, lr] : profile) a.push_back({{"threshold_C", num(thr)}, {"likelihood_ratio", num(lr)}});
  return a;
}

nlohmann::json params_json(const std::vector<ParamEstimate>& v) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& p : v) a.push_back({{"name", p.name}, {"axis", p.axis}, {"value", num(p.value)}, {"sigma", num(p.sigma)}});
  return a;
}

// A component fitted on an axis the verdict names unexplained: the out-of-catalog residual there projects on
// its column, so its value carries part of that residual and its σ (noise only) does not cover it. It is
// reported, flagged, and not read as a finding (`varied16` mixed-angle2: gyro.g_sensitivity.yz on the
// unexplained gyro.y read 1.56e-5 ± 1.3e-7 for a true 0, 122 σ).
bool on_unexplained_axis(const DiagnosisResult& r, const ParamEstimate& p) {
  for (const auto& u : r.unexplained)
    if (u.axis == p.axis) return true;
  return false;
}

std::string fmt(const char* f, double x) {
  char b[64];
  std::snprintf(b, sizeof b, f, x);
  return b;
}

// "a" or "a..b": the 5σ magnitudes a candidate's components would have shown at on this log (units of each
// component, docs/error-model.md), so "not selected" reads as "not there above this size".
std::string detectable_range(const CandidateScore& c) {
  if (c.min_detectable.empty()) return "";
  const auto [lo, hi] = std::minmax_element(c.min_detectable.begin(), c.min_detectable.end());
  return *lo == *hi ? fmt("%.2g", *lo) : fmt("%.2g", *lo) + ".." + fmt("%.2g", *hi);
}

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else if (c == '"') o += "&quot;";
    else o += c;
  }
  return o;
}

std::string unit_of(int a) { return a < 3 ? "m/s^2" : "rad/s"; }

// What became of a ranked candidate by the end (the ranking's "significant" is the first step's).
std::string outcome(const DiagnosisResult& r, const CandidateScore& c) {
  const std::string& sensor = c.sensor;
  const std::string& effect = c.effect;
  const std::string key = sensor + "." + effect;
  // One of a pair the campaign cannot tell apart (DiagnosisResult::ambiguous): the table says so on both rows, so
  // a reader does not take the chosen one for a finding the other was ruled out by.
  for (const auto& st : r.selected)
    if (st.sensor == sensor && st.effect == effect) {
      for (const auto& a : r.ambiguous)
        if (a.chosen == key)
          return "selected, ambiguous with " + a.alternative + " (" + ambiguity_reason(a) + "; the campaign does not tell them apart)";
      return st.from_reference_steps ? "selected (from the reference steps)" : "selected";
    }
  for (const auto& a : r.ambiguous)
    if (a.alternative == key)
      return "not selected: ambiguous with " + a.chosen + ", chosen: " + ambiguity_reason(a) +
             " (the campaign does not tell them apart)";
  for (const auto& [k, why] : r.withdrawn_by_check)
    if (k == key) return "withdrawn: " + why;
  for (const auto& u : r.unexplained)
    if (std::find(u.withdrawn.begin(), u.withdrawn.end(), key) != u.withdrawn.end())
      return "withdrawn: leaves " + u.axis + " unexplained";
  if (std::find(r.dropped.begin(), r.dropped.end(), key) != r.dropped.end()) return "dropped by a backward step";
  // The refusals that a small p would otherwise leave unexplained to a reader of the table.
  if (c.one_turn_p >= 0 && !c.significant) return "not selected: one temperature turn, a drift explains it";
  if (c.heat_cool_p >= 0 && c.heat_cool_p < 0.01) return "not selected: differs between heating and cooling";
  if (c.final_p >= 0) {
    // In-sample gain without held-out gain at the first step, scored again against the final model (diagnose.cpp).
    const double level0 = r.alpha_per_candidate();
    if (c.final_p >= level0)
      return "not selected: in-sample gain only, the signal of effects selected later (against the final model p " +
             fmt("%.2g", c.final_p) + ", level " + fmt("%.2g", level0) + ")";
    return "not selected: in-sample gain only, none on withheld segments (held-out shrink " + fmt("%.0f", c.final_shrink_pct) +
           " % against the final model): what it fits does not carry to withheld segments";
  }
  return "not selected";
}

}  // namespace

// One sentence under the verdict when the reference it is judged against is not the logged one: re-evaluated at the
// rate table's axis errors (--campaign). Empty otherwise.
static std::string reference_note(const DiagnosisResult& r) {
  if (!r.fixture_known || r.fixture_iterations == 0) return "";
  std::string list;
  for (int m = 0; m < r.fixture_est.n; ++m) {
    const auto um = static_cast<std::size_t>(m);
    if (!(std::fabs(r.fixture_error_rad[um]) > 2.0 * r.fixture_est.sigma_rad[um])) continue;
    list += (list.empty() ? "" : ", ") + physics::axis_error_name(m / 3, m % 3) + " " + fmt("%.3g", 1e3 * r.fixture_error_rad[um]) +
            " +/- " + fmt("%.2g", 1e3 * r.fixture_est.sigma_rad[um]) + " mrad";
  }
  return "Judged against the reference re-evaluated at the rate table's axis errors this log shows (--campaign" +
         (list.empty() ? std::string(")") : "; " + list + ")") + ", not as logged.";
}

std::vector<std::string> verdict_lines(const DiagnosisResult& r) {
  std::vector<std::string> out;
  for (int a = 0; a < kNumAxes; ++a) {
    const auto u = static_cast<std::size_t>(a);
    const std::string an = axis_name(a);
    const std::string sensor = a < 3 ? "accel" : "gyro";
    const Unexplained* ue = nullptr;
    for (const auto& x : r.unexplained)
      if (x.axis == an && x.basis != "glitches" && x.basis != "dropouts") ue = &x;
    std::string line = an + ": ";
    // Glitches lead: they are what the log shows beyond the model whatever the rest says, and the rest was judged
    // with them replaced (glitches.h).
    const auto& gl = r.glitches[u];
    if (gl.count > 0) {
      const std::string what_alone = "a bit error on the bus or in the converter", what_shared = "a knock or a corrupted frame";
      line += "departs from the model in " + std::to_string(gl.count) + " isolated sample" + (gl.count > 1 ? "s" : "") + " (" +
              (gl.count > 1 ? fmt("%.0f", gl.median_sigma) + " sigma (median) and up to " : std::string()) + fmt("%.0f", gl.max_sigma) +
              " sigma off the lines through the neighbours, up to " + fmt("%.3g", gl.max_abs) + " " + unit_of(a) +
              (gl.count > 1 ? ", between " + fmt("%.1f", gl.first_t_s) + " and " + fmt("%.1f", gl.last_t_s) + " s"
                            : ", at " + fmt("%.1f", gl.first_t_s) + " s") +
              "): " +
              (gl.shared == 0           ? std::string(gl.count > 1 ? "each " : "") + "alone on this axis, " + what_alone
               : gl.shared == gl.count ? std::string(gl.count > 1 ? "each " : "") + "at an instant where other axes jump too, " + what_shared
                                       : std::to_string(gl.shared) + " at an instant where other axes jump too (" + what_shared + "), the rest alone (" +
                                             what_alone + ")") +
              ", not the sensor's physics; replaced by the line through " + (gl.count > 1 ? "their" : "its") + " neighbours before the fit; with " +
              (gl.count > 1 ? "them" : "it") + " replaced, ";
    }
    // Dropouts lead likewise (dropouts.h).
    const auto& dr = r.dropouts[u];
    if (dr.runs > 0) {
      const bool many = dr.runs > 1;
      // Runs of both failed words are counted apart (the first run's word leads).
      const long long first_runs = dr.runs - dr.other_runs;
      line += "reads exactly " + fmt("%.6g", dr.value) + " " + unit_of(a) + " in " + std::to_string(first_runs) + " run" + (first_runs > 1 ? "s" : "") +
              (dr.other_runs > 0 ? " and " + fmt("%.6g", dr.other_value) + " " + unit_of(a) + " in " + std::to_string(dr.other_runs) + ","
                                 : std::string()) +
              " of " + (many ? "up to " : "") + std::to_string(dr.longest) + " row" + (dr.longest > 1 ? "s" : "") +
              (many ? " (" + std::to_string(dr.rows) + " in all, between " + fmt("%.1f", dr.first_t_s) + " and " + fmt("%.1f", dr.last_t_s) + " s)"
                    : " (at " + fmt("%.1f", dr.first_t_s) + " s)") +
              " while the rows either side stand " + (many ? "at least " : "") + fmt("%.0f", dr.min_z) +
              " sigma (of a row's noise) away from " + (dr.other_runs > 0 ? "them" : "it") +
              ": reads that failed (a data register read while it was rewritten, a cleared or "
              "floating bus, a frame the logger filled), not the sensor's physics; bridged by the line between " +
              (many ? "their" : "its") + " neighbours before the fit; with " + (many ? "them" : "it") + " bridged, ";
    }
    if (ue && ue->basis == "stuck_bit") {
      const auto& sb = r.stuck_bits[u];
      int more = 0;
      for (int b = sb.bit + 1; b < 64; ++b) more += static_cast<int>((sb.mask >> b) & 1u);
      line += "not explained by any effect in the catalog, nor by the sensor's noise: bit " + std::to_string(sb.bit) + " of its output word (" +
              fmt("%.3g", std::ldexp(sb.step, sb.bit)) + " " + unit_of(a) + ") reads " + (sb.high ? "1" : "0") + " in all " +
              std::to_string(sb.rows) + " samples, while the bit under it changed " + std::to_string(sb.below_toggles) +
              " times and the bit over it " + std::to_string(sb.above_toggles) + " times between neighbouring codes" +
              (more > 0 ? " (and " + std::to_string(more) + " more bit" + (more > 1 ? "s" : "") + " above it)" : std::string()) +
              ": a stuck bit in the converter or on the bus (missing codes), not the sensor's physics; every sample is off by 0 or that much, "
              "depending on its code (held-out chi2/dof " + fmt("%.3g", ue->chi2_dof_after) + ")";
    } else if (ue && ue->basis == "temp_motion") {
      const auto& m = r.temp_motion[u];
      line += "not explained by any effect in the catalog, nor by the sensor's noise: its static dwells scatter " +
              fmt("%.2g", std::sqrt(m.ratio)) + "x more (Allan deviation at " + fmt("%.3g", m.tau_s) +
              " s, z " + fmt("%.0f", m.z) + ") while the die's temperature moves than while it holds, which no noise of the " +
              "sensor does: a function of the temperature or of the chamber's action that no catalog effect has (held-out chi2/dof " +
              fmt("%.3g", ue->chi2_dof_after) + ", within the threshold: the dwells' noise model took it in as bias instability)";
    } else if (ue && ue->basis == "axis_timing") {
      const auto& at = r.axis_timing[u];
      const double d_ms = 1e3 * (at.latency_s - at.others_s);
      line += "not explained by any effect in the catalog: its output is " + fmt("%.3g", std::fabs(d_ms)) + " ms " + (d_ms >= 0 ? "later" : "earlier") +
              " than the other two axes' (" + fmt("%.3g", 1e3 * at.latency_s) + " +- " + fmt("%.2g", 1e3 * at.sigma_s) + " ms against " +
              fmt("%.3g", 1e3 * at.others_s) + " +- " + fmt("%.2g", 1e3 * at.others_sigma_s) +
              " ms), where the catalog's timing is one for the triad: an axis sampled at an instant of its own (a multiplexed converter)" +
              (at.triad_withdrawn ? "; the triad's timing it was read as is withdrawn" : "") + " (held-out chi2/dof " + fmt("%.3g", ue->chi2_dof_after) + ")";
    } else if (ue) {
      line += "not explained by any effect in the catalog";
      // "segment" leads only when no logged input comes within 80 % of it (residual_signature): the residual then
      // steps from segment to segment, and "follows segment" would read as if the segment index were an input.
      if (!ue->signature.empty() && ue->signature.front().input == "segment") {
        line += "; the residual steps from segment to segment and follows no logged input closely (r = " +
                fmt("%.2f", ue->signature.front().correlation) + " with its own segment means";
        if (ue->signature.size() > 1)
          line += "; nearest: " + ue->signature[1].input + ", r = " + fmt("%.2f", ue->signature[1].correlation);
        line += ")";
      } else if (!ue->signature.empty()) {
        line += "; the residual follows " + ue->signature.front().input + " (r = " + fmt("%.2f", ue->signature.front().correlation) + ")";
      }
      line += " (held-out chi2/dof " + fmt("%.3g", ue->chi2_dof_after) +
              (ue->basis == "wander" ? ", within the threshold; named on the whole log's residual" : "") + ")";
      // Why it is not read as noise either (the whole log's wander, diagnose.h Options::wander_*).
      const auto& w = r.wander[u];
      if (w.beyond_limit && w.beyond_reason == "too_large")
        line += "; as noise it would take a bias wander " + fmt("%.2g", w.measured.limit_ratio) + "x what the static dwells show";
      else if (w.beyond_limit && w.beyond_reason == "jump")
        line += "; not a stationary bias wander either: a bias step of " + fmt("%.1f", w.measured.max_abs_z) + " sigma";
      else if (w.beyond_limit && w.beyond_reason == "periodic")
        line += "; not a stationary bias wander either: what is left under one carries a line of period " +
                fmt("%.0f", w.measured.line_period_s) + " s (false-alarm p " + fmt("%.1g", w.measured.line_p) + ")";
      else if (w.beyond_limit && w.beyond_reason == "sinusoid")
        line += "; not a stationary bias wander either: a sinusoid of period " + fmt("%.0f", w.sinusoid.period_s) +
                " s explains the whole log's residual better (-2 log L gain " + fmt("%.0f", w.sinusoid.gain) + " against " +
                fmt("%.0f", w.measured.gain) + " for a " + (w.kind == "flicker" ? "flicker" : "random walk") + ")";
      else if (w.beyond_limit && w.beyond_reason == "modulated")
        line += "; not a stationary bias wander either: a sinusoid of period " + fmt("%.0f", w.sinusoid.mod_period_s) +
                " s whose amplitude changes through the log (its own in each of " + std::to_string(w.sinusoid.mod_windows) +
                " stretches) explains the whole log's residual beside a " + (w.kind == "flicker" ? "flicker" : "random walk") +
                " (likelihood ratio " + fmt("%.0f", w.modulated_gain) + ")";
      else if (w.beyond_limit && w.beyond_reason == "input")
        line += "; not a stationary bias wander either: what is left grows with the input (its spread " +
                fmt("%.0f", w.measured.hetero_ratio) + "x larger where the rate or the axis' own input is largest; Breusch-Pagan LM " +
                fmt("%.0f", w.measured.hetero_lm) + ")";
      else if (w.beyond_limit && w.beyond_reason == "follows")
        line += "; not a stationary bias wander either: " + w.follows_input + " explains the whole log's residual beside a " +
                (w.kind == "flicker" ? "flicker" : "random walk") + " " + fmt("%.2g", w.measured.ratio) +
                "x the dwells' (likelihood ratio " + fmt("%.0f", w.follows.gain) + " over " + std::to_string(w.follows.n_functions) +
                " functions of the logged inputs asked)";
      else if (w.beyond_limit && (w.beyond_reason == "drift" || w.beyond_reason == "settling"))
        line += "; not a stationary bias wander either: the bias " +
                (w.beyond_reason == "drift"
                     ? "drifts linearly by " + fmt("%.3g", w.trend.slope_per_s * 3600.0) + " " + unit_of(a) + " per hour"
                     : "settles by " + fmt("%.3g", w.trend.settle_amplitude) + " " + unit_of(a) + " from the start of the log, time constant " +
                           fmt("%.0f", w.trend.settle_tau_s) + " s,") +
                " which a " + (w.kind == "flicker" ? "flicker" : "random walk") + " " + fmt("%.2g", w.measured.ratio) +
                "x the dwells' does not explain (likelihood ratio " +
                fmt("%.0f", w.beyond_reason == "drift" ? w.trend.gain : w.trend.settle_gain) + ")";
    } else {
      std::vector<std::string> by, details;  // details: what a selected effect's nonlinear parameters read
      for (const auto& st : r.selected)
        if (st.sensor == sensor) by.push_back(st.effect);
      if (!std::isfinite(r.gap_after.chi2_dof[u])) {
        line += "too short to tell (fewer than 3 segments: nothing can be withheld)";
      } else if (by.empty()) {
        line += "at noise with the model as given";
      } else {
        // A timing says how late the output is, and, with a resolved clock, how far it has drifted by the end of
        // the log (the final values include the shift the reference was re-evaluated at; diagnose.cpp). A timing
        // read off the reference steps is one line per sensor (axis "gyro"/"accel").
        auto timing_phrase = [&]() -> std::string {
          const ParamEstimate *lat = nullptr, *ppm = nullptr;
          for (const auto& pe : r.final_params) {
            if (pe.axis != an && pe.axis != sensor) continue;
            if (pe.name == sensor + ".timing.latency_s") lat = &pe;
            if (pe.name == sensor + ".timing.ppm") ppm = &pe;
          }
          if (!lat) return "";
          std::string t = "timing " + fmt("%.3g", 1e3 * std::fabs(lat->value)) + " +- " + fmt("%.2g", 1e3 * lat->sigma) + " ms " +
                          (lat->value >= 0 ? "late" : "early");
          if (ppm && std::fabs(ppm->value) > 3.0 * ppm->sigma) {
            const double end_s = lat->value + ppm->value * 1e-6 * r.duration_s;
            t += ", clock " + fmt("%+.4g", ppm->value) + " +- " + fmt("%.2g", ppm->sigma) + " ppm, " + fmt("%.3g", std::fabs(end_s)) + " s " +
                 (end_s >= 0 ? "late" : "early") + " by the end";
          }
          return t;
        };
        line += "explained by";
        for (std::size_t i = 0; i < by.size(); ++i) {
          line += (i ? ", " : " ") + by[i];
          if (by[i] == "timing") {
            const std::string t = timing_phrase();
            if (!t.empty()) details.push_back(t);
          }
          // The threshold its d(t) turns at is part of what temp_hysteresis says (diagnose.cpp: given or profiled).
          if (by[i] == "temp_hysteresis")
            details.push_back("temp_hysteresis turning " + fmt("%.2g", r.hysteresis_threshold_C) + " C past each temperature extreme" +
                              (r.hysteresis_profile.empty() ? "" : " (threshold profiled)"));
        }
        // The rotation the gyro cross-coupling's terms were evaluated at belongs to its explanation (diagnose.cpp).
        if (r.mount_iterations > 0 && a >= 3)
          line += " in the case, which sits rotated by (" + fmt("%.2g", 1e3 * r.mount_rotation_rad[0]) + ", " +
                  fmt("%.2g", 1e3 * r.mount_rotation_rad[1]) + ", " + fmt("%.2g", 1e3 * r.mount_rotation_rad[2]) + ") mrad on the fixture";
      }
      if (std::isfinite(r.gap_after.chi2_dof[u])) {
        line += " (held-out chi2/dof " + fmt("%.3g", r.gap_after.chi2_dof[u]);
        // What the claim is judged on where the whole log's wander is adopted (diagnose.h Gap::chi2_dof_wander).
        if (std::isfinite(r.gap_after.chi2_dof_wander[u]))
          line += "; " + fmt("%.3g", r.gap_after.chi2_dof_wander[u]) + " in a GLS fit under the whole-log wander";
        line += ")";
        for (const auto& d : details) line += "; " + d;
      }
    }
    const auto& m = r.stoch[u];
    if (m.gm_sigma > 0) line += "; drift: Gauss-Markov sigma " + fmt("%.3g", m.gm_sigma) + ", tau " + fmt("%.3g", m.gm_tau_s) + " s";
    if (m.bank_sigma > 0) line += "; flicker bias instability B " + fmt("%.3g", m.flicker_B);
    if (r.wander[u].adopted)
      line += "; whole-log bias wander " + fmt("%.2g", r.wander[u].measured.ratio) + "x the static dwells' (" +
              (r.wander[u].kind == "flicker" ? "flicker B " : "rate random walk ") + fmt("%.3g", r.wander[u].value) +
              (!std::isfinite(r.wander[u].walk_flicker_B) ? std::string()
               : r.wander[u].walk_flicker_B > 0 ? " with flicker B " + fmt("%.3g", r.wander[u].walk_flicker_B) + " in place of the dwells'"
                                                 : std::string(", which replaces the dwells' flicker")) +
              (r.wander[u].measured.below_likelihood ? ", within the dwells' upper limit" : "") + ")";
    if (m.K > 0) line += "; rate random walk " + fmt("%.3g", m.K);
    // A coarse output step is a noise finding too: it caps how well any static mean can be read.
    const auto& q = r.quant[u];
    if (q.coarse())
      line += "; output step " + fmt("%.3g", q.step) + " with " + fmt("%.2g", q.noise_sigma / q.step) +
              " step of noise ahead of it: each static mean keeps a rounding bias (sigma " + fmt("%.2g", std::sqrt(r.stoch[u].seg_bias_var)) + ")";
    // A line or a jump the whole log's residual carries within that rounding (diagnose.cpp: not named unexplained).
    if (r.wander[u].within_rounding)
      line += std::string("; the whole log's residual carries ") +
              (r.wander[u].beyond_reason == "periodic" ? "a line of period " + fmt("%.0f", r.wander[u].measured.line_period_s) + " s"
               : r.wander[u].beyond_reason == "sinusoid" ? "a sinusoid of period " + fmt("%.0f", r.wander[u].sinusoid.period_s) + " s"
               : r.wander[u].beyond_reason == "modulated" ? "a sinusoid of period " + fmt("%.0f", r.wander[u].sinusoid.mod_period_s) + " s whose amplitude changes through the log"
               : r.wander[u].beyond_reason == "drift"    ? "a linear drift of " + fmt("%.2g", r.wander[u].trend.slope_per_s * 3600.0) + " " + unit_of(a) + " per hour"
               : r.wander[u].beyond_reason == "settling" ? "a settling of time constant " + fmt("%.0f", r.wander[u].trend.settle_tau_s) + " s"
               : r.wander[u].beyond_reason == "input"    ? std::string("a residual that grows with the input")
               : r.wander[u].beyond_reason == "follows"  ? "a residual that follows " + r.wander[u].follows_input
                                                       : std::string("a bias step")) +
              (r.wander[u].shape_rms > 0
                   ? ", within the rounding (what it takes has rms " + fmt("%.2g", r.wander[u].shape_rms) + ", under twice its sigma)"
                   : ", within the rounding (residual rms " + fmt("%.2g", r.wander[u].residual_rms) + ", under twice its sigma)");
    out.push_back(line);
  }
  return out;
}

nlohmann::json to_json(const DiagnosisResult& r) {
  nlohmann::json j;
  j["format"] = "imuforge-diagnosis";
  j["format_version"] = 1;
  j["software_version"] = IMUFORGE_VERSION;
  j["data"] = {{"samples", r.n_samples}, {"samples_used", r.n_used}, {"duration_s", r.duration_s},
               {"sample_rate_hz", r.sample_rate_hz}, {"blocks", r.n_blocks}, {"static_blocks", r.n_static_blocks},
               {"segments", r.n_units}};
  j["verdict"] = verdict_lines(r);
  j["base_model"] = r.base_effects;
  j["validation"] = {{"cv", r.cv_mode}, {"folds", r.folds}, {"alpha_familywise", r.alpha},
                     {"correction", "bonferroni"},
                     {"alpha_per_candidate", r.alpha_per_candidate()}};
  j["gap_before"] = gap_json(r.gap_before, nullptr);
  nlohmann::json rk = nlohmann::json::array();
  for (const auto& c : r.ranking) {
    nlohmann::json e = {{"effect", c.effect}, {"sensor", c.sensor}, {"excitable", c.excitable}};
    if (c.excitable) {
      e["score"] = num(c.score);
      e["p_value"] = num(c.p_value);
      e["lr"] = num(c.lr);
      e["dof"] = c.dof;
      e["delta_bic"] = num(c.delta_bic);
      e["heldout_chi2_gain"] = num(c.heldout_chi2_gain);
      e["heldout_shrink_pct"] = num(c.heldout_shrink_pct);
      e["significant"] = c.significant;
      e["magnitude"] = params_json(c.magnitude);
      e["outcome"] = outcome(r, c);
      nlohmann::json md = nlohmann::json::array();
      for (std::size_t k = 0; k < c.min_detectable.size() && k < c.magnitude.size(); ++k)
        md.push_back({{"name", c.magnitude[k].name}, {"axis", c.magnitude[k].axis}, {"value", num(c.min_detectable[k])}});
      e["min_detectable_5sigma"] = md;
    } else {
      e["score"] = nullptr;
      e["p_value"] = nullptr;
      e["delta_bic"] = nullptr;
      e["heldout_shrink_pct"] = nullptr;
      e["magnitude"] = nlohmann::json::array();
      e["note"] = "cannot be excited by this campaign: cannot be ruled out";
    }
    if (!c.not_excitable.empty()) e["not_excitable"] = c.not_excitable;
    if (c.heat_cool_p >= 0) {
      e["heating_cooling_p"] = num(c.heat_cool_p);
      if (c.heat_cool_p < 0.01)
        e["note"] = "the rate coefficient differs between heating and cooling: a drift along one ramp, not a temp_rate effect";
    }
    if (c.final_p >= 0) {
      e["final_model_p"] = num(c.final_p);
      e["final_model_heldout_shrink_pct"] = num(c.final_shrink_pct);
    }
    if (std::isfinite(c.hysteresis_threshold_C))
      e["hysteresis_threshold"] = {{"C", num(c.hysteresis_threshold_C)}, {"effective_tests", num(c.hysteresis_tests)},
                                   {"profile", hysteresis_profile_json(c.hysteresis_profile)}};
    if (c.one_turn_p >= 0) {
      e["one_turn_p"] = num(c.one_turn_p);
      if (!c.significant)  // tested only when it qualified otherwise: the one-turn test refused it
        e["note"] = "the temperature turns once: one offset between two stretches, which the log's own bias wander explains as well";
    }
    if (!c.implausible.empty()) {
      e["implausible"] = c.implausible;
      e["note"] = "magnitude outside the plausible range of docs/error-model.md: flagged, not a finding";
    }
    rk.push_back(e);
  }
  j["ranking"] = rk;
  nlohmann::json sel = nlohmann::json::array();
  for (const auto& s : r.selected)
    sel.push_back({{"effect", s.effect}, {"sensor", s.sensor}, {"p_value", num(s.p_value)}, {"lr", num(s.lr)},
                   {"from_reference_steps", s.from_reference_steps}, {"gap_after", gap_json(s.gap_after, &r.gap_before)}});
  j["selected"] = sel;
  j["dropped_by_backward_step"] = r.dropped;
  nlohmann::json amb = nlohmann::json::array();
  for (const auto& a : r.ambiguous)
    amb.push_back({{"chosen", a.chosen}, {"alternative", a.alternative}, {"lr_chosen", num(a.lr_chosen)},
                   {"lr_alternative", num(a.lr_alternative)}, {"dof_chosen", a.dof_chosen},
                   {"dof_alternative", a.dof_alternative}, {"delta_aic", num(a.delta_aic)},
                   {"components_chosen", a.components_chosen}, {"components_alternative", a.components_alternative},
                   {"nested", a.nested}});
  j["ambiguous"] = amb;
  nlohmann::json sens = nlohmann::json::array();
  for (const auto& v : r.sensitivity)
    sens.push_back({{"name", v.name}, {"axis", v.axis}, {"value", num(v.value)}, {"sigma", num(v.sigma)},
                    {"value_with_alternative", num(v.value_with)}, {"shift_sigma", num(v.shift_sigma)},
                    {"alternative", v.alternative}, {"p_alternative", num(v.p_alternative)}});
  j["magnitude_sensitivity"] = sens;
  // Stochastic terms the static dwells support (each cleared Δχ² > 10 on the Allan curve) and that the
  // likelihood carried: the stochastic sibling of `selected`.
  nlohmann::json ss = nlohmann::json::array();
  for (int a = 0; a < kNumAxes; ++a) {
    const auto& m = r.stoch[static_cast<std::size_t>(a)];
    if (m.gm_sigma > 0) ss.push_back({{"effect", "gauss_markov"}, {"axis", axis_name(a)}, {"sigma", num(m.gm_sigma)}, {"tau_s", num(m.gm_tau_s)}});
    if (m.bank_sigma > 0)
      ss.push_back({{"effect", "flicker"}, {"axis", axis_name(a)}, {"value", num(m.flicker_B)},
                    {"tau_min_s", num(m.bank_tau_s.front())}, {"tau_max_s", num(m.bank_tau_s.back())}});
    if (m.K > 0) ss.push_back({{"effect", "rate_random_walk"}, {"axis", axis_name(a)}, {"value", num(m.K)}});
    if (m.Q > 0) ss.push_back({{"effect", "quantization"}, {"axis", axis_name(a)}, {"value", num(m.Q)}});
  }
  j["selected_stochastic"] = ss;
  nlohmann::json un = nlohmann::json::array();
  for (const auto& x : r.unexplained) {
    nlohmann::json sig = nlohmann::json::array();
    for (const auto& e : x.signature) sig.push_back({{"input", e.input}, {"correlation", num(e.correlation)}});
    un.push_back({{"axis", x.axis}, {"chi2_dof_after", num(x.chi2_dof_after)}, {"signature", sig}, {"withdrawn", x.withdrawn}, {"basis", x.basis}});
  }
  j["unexplained"] = un;
  nlohmann::json gl = nlohmann::json::object();
  for (int a = 0; a < kNumAxes; ++a) {
    const auto& g = r.glitches[static_cast<std::size_t>(a)];
    if (g.count == 0) continue;
    gl[axis_name(a)] = {{"count", g.count},           {"shared", g.shared},          {"rows_checked", g.rows_checked}, {"max_sigma", num(g.max_sigma)},
                        {"median_sigma", num(g.median_sigma)}, {"max_abs", num(g.max_abs)},       {"first_t_s", num(g.first_t_s)},
                        {"last_t_s", num(g.last_t_s)},  {"t_s", g.t_s}};
  }
  j["glitches"] = gl;
  nlohmann::json drj = nlohmann::json::object();
  for (int a = 0; a < kNumAxes; ++a) {
    const auto& d = r.dropouts[static_cast<std::size_t>(a)];
    if (d.runs == 0) continue;
    drj[axis_name(a)] = {{"runs", d.runs},           {"rows", d.rows},           {"longest", d.longest}, {"value", num(d.value)},
                         {"other_value", num(d.other_value)}, {"other_runs", d.other_runs},
                         {"min_z", num(d.min_z)}, {"first_t_s", num(d.first_t_s)}, {"last_t_s", num(d.last_t_s)}, {"t_s", d.t_s}};
  }
  j["dropouts"] = drj;
  // Every quantised axis (its output step known), stuck bit or not.
  nlohmann::json sbj = nlohmann::json::object();
  for (int a = 0; a < kNumAxes; ++a) {
    const auto& sb = r.stuck_bits[static_cast<std::size_t>(a)];
    if (!(sb.step > 0)) continue;
    nlohmann::json bits = nlohmann::json::array();
    for (int b = 0; b < 64; ++b)
      if ((sb.mask >> b) & 1u) bits.push_back(b);
    sbj[axis_name(a)] = {{"step", num(sb.step)},          {"rows", sb.rows},   {"stuck", bits}, {"high", sb.high},
                         {"below_toggles", sb.below_toggles}, {"above_toggles", sb.above_toggles}};
  }
  j["stuck_bits"] = sbj;
  // Every axis whose dwells could be compared (both records reached a common τ), flagged or not.
  nlohmann::json tm = nlohmann::json::object();
  for (int a = 0; a < kNumAxes; ++a) {
    const auto& m = r.temp_motion[static_cast<std::size_t>(a)];
    if (!(m.moving_s > 0 && m.holding_s > 0)) continue;
    tm[axis_name(a)] = {{"flagged", m.flagged},   {"ratio", num(m.ratio)},          {"tau_s", num(m.tau_s)},
                        {"z", num(m.z)},           {"edf_moving", num(m.edf_moving)}, {"edf_holding", num(m.edf_holding)},
                        {"moving_s", num(m.moving_s)}, {"holding_s", num(m.holding_s)}};
  }
  j["temp_motion"] = tm;
  nlohmann::json atj = nlohmann::json::object();
  for (int a = 0; a < kNumAxes; ++a) {
    const auto& at = r.axis_timing[static_cast<std::size_t>(a)];
    if (!(at.sigma_s > 0)) continue;
    atj[axis_name(a)] = {{"odd", at.odd},
                         {"latency_s", num(at.latency_s)},
                         {"sigma_s", num(at.sigma_s)},
                         {"others_s", num(at.others_s)},
                         {"others_sigma_s", num(at.others_sigma_s)},
                         {"triad_withdrawn", at.triad_withdrawn}};
  }
  j["axis_timing"] = atj;
  if (r.mount_iterations > 0)
    j["mount_rotation"] = {{"rad", {num(r.mount_rotation_rad[0]), num(r.mount_rotation_rad[1]), num(r.mount_rotation_rad[2])}},
                           {"sigma_rad", {num(r.mount_est.sigma_rad[0]), num(r.mount_est.sigma_rad[1]), num(r.mount_est.sigma_rad[2])}},
                           {"iterations", r.mount_iterations}};
  if (r.fixture_known) {
    // The rate table's axis errors the reference was re-evaluated at (--campaign), named as the fixture+errors
    // solver names its nuisance parameters; sigma: the last estimate's (prior included), iterations 0: none used.
    nlohmann::json fx = nlohmann::json::array();
    for (int m = 0; m < r.fixture_est.n; ++m)
      fx.push_back({{"name", physics::axis_error_name(m / 3, m % 3)},
                    {"rad", num(r.fixture_error_rad[static_cast<std::size_t>(m)])},
                    {"sigma_rad", num(r.fixture_est.sigma_rad[static_cast<std::size_t>(m)])}});
    j["fixture_errors"] = {{"parameters", fx}, {"iterations", r.fixture_iterations}, {"last_correction_chi2", num(r.fixture_est.chi2)}};
  }
  j["timing_shift"] = {{"accel", {{"latency_s", num(r.timing_shift_latency_s[0])}, {"ppm", num(r.timing_shift_ppm[0])}}},
                       {"gyro", {{"latency_s", num(r.timing_shift_latency_s[1])}, {"ppm", num(r.timing_shift_ppm[1])}}},
                       {"iterations", r.timing_iterations}};
  nlohmann::json steps;
  for (int si = 0; si < 2; ++si) {
    const auto& st = r.step_reading[static_cast<std::size_t>(si)];
    steps[si == 0 ? "accel" : "gyro"] = {{"n", st.n_steps}, {"read_late", st.n_late}, {"read_early", st.n_early}, {"sign", st.sign}};
  }
  j["reference_steps"] = steps;
  j["hysteresis_threshold"] = {{"C", num(r.hysteresis_threshold_C)},
                               {"source", r.hysteresis_threshold_given ? "given" : r.hysteresis_profile.empty() ? "default" : "profiled"},
                               {"effective_tests", num(r.hysteresis_effective_tests)},
                               {"profile", hysteresis_profile_json(r.hysteresis_profile)}};
  j["gap_after"] = gap_json(r.gap_after, &r.gap_before);
  j["parameters"] = params_json(r.final_params);
  for (std::size_t i = 0; i < r.final_params.size(); ++i)
    if (on_unexplained_axis(r, r.final_params[i])) j["parameters"][i]["on_unexplained_axis"] = true;
  nlohmann::json st = nlohmann::json::array();
  for (const auto& s : r.stochastic)
    st.push_back({{"effect", s.effect}, {"axis", s.axis}, {"value", num(s.value)}, {"sigma", num(s.sigma)},
                  {"delta_chi2", num(s.delta_chi2)}, {"p_value", num(s.p_value)}, {"significant", s.significant},
                  {"baseline", s.against_filter ? "white + output filter (short Gauss-Markov)" : "white"}});
  j["stochastic"] = st;
  nlohmann::json noise = nlohmann::json::object();
  for (int a = 0; a < kNumAxes; ++a) {
    const auto u = static_cast<std::size_t>(a);
    nlohmann::json pts = nlohmann::json::array();
    for (const auto& p : r.allan[u]) pts.push_back({num(p.tau_s), num(std::sqrt(p.avar)), num(p.edf)});
    const auto& t = r.noise[u].terms;
    const auto& m = r.stoch[u];
    noise[axis_name(a)] = {{"Q", num(t.Q)}, {"N", num(t.N)}, {"B", num(t.B)}, {"K", num(t.K)},
                           {"claimed_N", num(r.claimed_N[u])}, {"allan", pts},
                           {"likelihood_model", {{"N", num(m.N)}, {"Q", num(m.Q)}, {"gm_sigma", num(m.gm_sigma)},
                                                 {"gm_tau_s", num(m.gm_tau_s)}, {"flicker_B", num(m.flicker_B)}, {"flicker_B_upper", num(m.flicker_B_upper)},
                                                 {"K", num(m.K)}}},
                           {"whole_log_wander", {{"kind", r.wander[u].kind}, {"value", num(r.wander[u].value)},
                                                 {"ratio", num(r.wander[u].measured.ratio)}, {"limit_ratio", num(r.wander[u].measured.limit_ratio)}, {"gain", num(r.wander[u].measured.gain)}, {"below_likelihood", r.wander[u].measured.below_likelihood}, {"gain_over_point", num(r.wander[u].measured.gain_seen)}, {"max_abs_z", num(r.wander[u].measured.max_abs_z)}, {"jump_persist_z", num(r.wander[u].measured.jump_persist_z)}, {"whiteness_p", num(r.wander[u].measured.whiteness_p)},
                                                 {"autocorr_sq", num(r.wander[u].measured.autocorr_sq)}, {"line_p", num(r.wander[u].measured.line_p)},
                                                 {"line_period_s", num(r.wander[u].measured.line_period_s)},
                                                 {"hetero_lm", num(r.wander[u].measured.hetero_lm)}, {"hetero_p", num(r.wander[u].measured.hetero_p)}, {"hetero_ratio", num(r.wander[u].measured.hetero_ratio)},
                                                 {"sinusoid_gain", num(r.wander[u].sinusoid.gain)}, {"sinusoid_period_s", num(r.wander[u].sinusoid.period_s)},
                                                 {"modulated_period_s", num(r.wander[u].sinusoid.mod_period_s)}, {"modulated_stretches", r.wander[u].sinusoid.mod_windows},
                                                 {"modulated_lr", num(r.wander[u].modulated_gain)},
                                                 {"drift_lr", num(r.wander[u].trend.gain)}, {"drift_per_h", num(r.wander[u].trend.slope_per_s * 3600.0)},
                                                 {"settling_lr", num(r.wander[u].trend.settle_gain)}, {"settling_tau_s", num(r.wander[u].trend.settle_tau_s)},
                                                 {"settling_amplitude", num(r.wander[u].trend.settle_amplitude)},
                                                 {"follows_input", r.wander[u].follows_input}, {"follows_lr", num(r.wander[u].follows.gain)},
                                                 {"follows_functions", r.wander[u].follows.n_functions},
                                                 {"walk_flicker_B", num(r.wander[u].walk_flicker_B)}, {"beyond_limit", r.wander[u].beyond_limit}, {"beyond_reason", r.wander[u].beyond_reason}, {"adopted", r.wander[u].adopted}}},
                           {"output_step", {{"step", num(r.quant[u].step)}, {"noise_sigma", num(r.quant[u].noise_sigma)},
                                            {"mean_bias_sigma", num(std::sqrt(r.stoch[u].seg_bias_var))},
                                            {"structure_within_rounding", r.wander[u].within_rounding},
                                            {"residual_rms", num(r.wander[u].residual_rms)},
                                            {"shape_rms", num(r.wander[u].shape_rms)}}}};
  }
  j["noise"] = noise;
  nlohmann::json cells = nlohmann::json::array();
  for (const auto& c : r.cells)
    cells.push_back({{"axis", axis_name(c.axis)}, {"condition", c.condition}, {"label", c.label}, {"n", c.n_blocks},
                     {"mean", num(c.mean)}, {"z", num(c.z)}, {"chi2_dof", num(c.chi2_dof)}});
  j["cells"] = cells;
  j["warnings"] = r.warnings;
  return j;
}

std::string summary_text(const DiagnosisResult& r) {
  std::ostringstream o;
  o << "imuforge diagnose: " << r.n_used << " of " << r.n_samples << " samples used, " << fmt("%.1f", r.duration_s) << " s at "
    << fmt("%.1f", r.sample_rate_hz) << " Hz; " << r.n_blocks << " blocks in " << r.n_units << " segments; " << r.folds
    << "-fold by " << r.cv_mode << "\n";
  o << "VERDICT\n";
  for (const auto& l : verdict_lines(r)) o << "  " << l << "\n";
  if (const std::string note = reference_note(r); !note.empty()) o << "  " << note << "\n";
  o << "base model:";
  for (const auto& e : r.base_effects) o << " " << e;
  o << "\n\nWHERE: held-out gap (RMS of withheld block residuals above the modelled noise floor)\n";
  for (int a = 0; a < kNumAxes; ++a) {
    const auto u = static_cast<std::size_t>(a);
    o << "  " << axis_name(a) << ": gap " << fmt("%10.3e", r.gap_before.gap[u]) << "  floor " << fmt("%10.3e", r.gap_before.floor[u])
      << "  chi2/dof " << fmt("%7.2f", r.gap_before.chi2_dof[u]) << "  " << unit_of(a) << "\n";
  }
  std::vector<Cell> worst;
  for (const auto& c : r.cells)
    if (c.condition != "segment") worst.push_back(c);
  std::sort(worst.begin(), worst.end(), [](const Cell& x, const Cell& y) { return std::fabs(x.z) > std::fabs(y.z); });
  o << "  worst cells (axis, condition, |z|):\n";
  for (std::size_t i = 0; i < std::min<std::size_t>(5, worst.size()); ++i)
    o << "    " << axis_name(worst[i].axis) << "  " << worst[i].condition << " " << worst[i].label << "  z=" << fmt("%.1f", worst[i].z)
      << "  chi2/dof=" << fmt("%.2f", worst[i].chi2_dof) << "\n";
  o << "\nWHICH: candidate effects (best first; significant at family-wise alpha=" << r.alpha << ", Bonferroni)\n";
  for (const auto& c : r.ranking) {
    if (!c.excitable) continue;
    o << "  " << (c.significant ? "* " : "  ") << c.sensor << "." << c.effect << "  -log10p=" << fmt("%.1f", c.score)
      << "  dBIC=" << fmt("%.1f", c.delta_bic) << "  held-out shrink=" << fmt("%.0f", c.heldout_shrink_pct) << "%";
    if (!c.min_detectable.empty()) o << "  5sigma-detectable " << detectable_range(c);
    // What became of it, where that is news: a significant candidate not selected, or any reason outcome() gives.
    const std::string oc = outcome(r, c);
    if (oc != "selected" && (c.significant || oc != "not selected")) o << "  -> " << oc;
    o << "\n";
  }
  std::vector<std::string> unexc;
  for (const auto& c : r.ranking)
    if (!c.excitable) unexc.push_back(c.sensor + "." + c.effect);
  if (!unexc.empty()) {
    o << "  not excited by this campaign (cannot be ruled out):";
    for (const auto& s : unexc) o << " " << s;
    o << "\n";
  }
  for (const auto& s : r.stochastic)
    if (s.significant) o << "  * stochastic " << s.axis << "." << s.effect << " = " << fmt("%.3g", s.value) << " +/- " << fmt("%.2g", s.sigma) << " (Allan)\n";
  o << "\nHOW FAR: greedy forward selection\n";
  if (r.selected.empty()) o << "  nothing significant beyond the model\n";
  for (const auto& s : r.selected) {
    o << "  + " << s.sensor << "." << s.effect
      << (s.from_reference_steps ? std::string(" (from the reference steps)") : " (p=" + fmt("%.2g", s.p_value) + ")") << ": gap";
    const int a0 = s.sensor == "accel" ? 0 : 3;
    for (int a = a0; a < a0 + 3; ++a)
      o << " " << axis_name(a) << "=" << fmt("%.3e", s.gap_after.gap[static_cast<std::size_t>(a)]) << " ("
        << fmt("%.0f", s.shrink_pct[static_cast<std::size_t>(a)]) << "% shrink)";
    o << "\n";
  }
  // Magnitudes from the final joint fit (every selected effect and the base model together), not the
  // ranking's first-step fit: an effect fitted alone absorbs what the others explain (on campaign-eol the
  // gyro latency alone reads 4-9 ms, jointly 0.50 ms).
  for (const auto& s : r.selected) {
    const std::string key = s.sensor + "." + s.effect + ".";
    o << "  magnitude of " << s.sensor << "." << s.effect
      << (s.from_reference_steps ? " (the reference steps' line):\n" : " (final joint fit):\n");
    for (const auto& m : r.final_params)
      if (m.name.rfind(key, 0) == 0)
        o << "    " << m.name << " [" << m.axis << "] = " << fmt("%.4g", m.value) << " +/- " << fmt("%.2g", m.sigma)
          << (on_unexplained_axis(r, m) ? "  (axis unexplained: takes part of the out-of-catalog residual there; not a finding)" : "")
          << "\n";
  }
  o << "gap after:";
  for (int a = 0; a < kNumAxes; ++a) o << " " << axis_name(a) << "=" << fmt("%.3e", r.gap_after.gap[static_cast<std::size_t>(a)]);
  o << "\n";
  for (const auto& w : r.warnings) o << "warning: " << w << "\n";
  return o.str();
}

// ---- HTML with inline SVG -------------------------------------------------------------------------
namespace {

std::string color_for_z(double z) {
  const double t = std::clamp(z / 10.0, -1.0, 1.0);
  int rr = 255, gg = 255, bb = 255;
  if (t > 0) {
    gg = bb = static_cast<int>(255 * (1 - t));
  } else {
    rr = gg = static_cast<int>(255 * (1 + t));
  }
  char b[16];
  std::snprintf(b, sizeof b, "#%02x%02x%02x", rr, gg, bb);
  return b;
}

std::string heatmap_svg(const DiagnosisResult& r) {
  if (r.cells.empty()) return "<p>No cell could be scored: nothing was withheld (too short to tell).</p>";
  // Columns: every non-segment cell label (segments summarised by the worst one per axis).
  std::vector<std::pair<std::string, std::string>> cols;
  for (const auto& c : r.cells) {
    if (c.condition == "segment") continue;
    auto key = std::make_pair(c.condition, c.label);
    if (std::find(cols.begin(), cols.end(), key) == cols.end()) cols.push_back(key);
  }
  cols.push_back({"segment", "worst"});
  std::map<std::pair<int, std::pair<std::string, std::string>>, const Cell*> at;
  for (const auto& c : r.cells) {
    if (c.condition == "segment") {
      auto k = std::make_pair(c.axis, std::make_pair(std::string("segment"), std::string("worst")));
      if (!at.count(k) || std::fabs(c.z) > std::fabs(at[k]->z)) at[k] = &c;
    } else {
      at[{c.axis, {c.condition, c.label}}] = &c;
    }
  }
  const int cw = 26, ch = 24, left = 70, top = 120;
  const int W = left + cw * static_cast<int>(cols.size()) + 20, H = top + ch * kNumAxes + 40;
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H << "' font-family='sans-serif' font-size='10'>";
  for (std::size_t i = 0; i < cols.size(); ++i) {
    const int x = left + cw * static_cast<int>(i) + cw / 2;
    s << "<text transform='translate(" << x << "," << top - 4 << ") rotate(-60)'>" << esc(cols[i].first + ": " + cols[i].second) << "</text>";
  }
  for (int a = 0; a < kNumAxes; ++a) {
    s << "<text x='4' y='" << top + ch * a + 16 << "'>" << axis_name(a) << "</text>";
    for (std::size_t i = 0; i < cols.size(); ++i) {
      auto it = at.find({a, cols[i]});
      const int x = left + cw * static_cast<int>(i), y = top + ch * a;
      if (it == at.end()) {
        s << "<rect x='" << x << "' y='" << y << "' width='" << cw - 1 << "' height='" << ch - 1 << "' fill='#eee'/>";
        continue;
      }
      const Cell& c = *it->second;
      s << "<rect x='" << x << "' y='" << y << "' width='" << cw - 1 << "' height='" << ch - 1 << "' fill='" << color_for_z(c.z)
        << "'><title>" << esc(std::string(axis_name(a)) + " " + c.condition + " " + c.label) << ": z=" << fmt("%.2f", c.z)
        << " chi2/dof=" << fmt("%.2f", c.chi2_dof) << " mean=" << fmt("%.3g", c.mean) << " n=" << c.n_blocks << "</title></rect>";
      if (std::fabs(c.z) >= 3) s << "<text x='" << x + 2 << "' y='" << y + 15 << "' font-size='8'>" << fmt("%.0f", c.z) << "</text>";
    }
  }
  s << "<text x='" << left << "' y='" << H - 10 << "'>colour: z = mean/SE of held-out residuals (blue -10 ... white 0 ... red +10); "
    << "frequency cells: (AVAR/claimed - 1) scaled by its edf</text>";
  s << "</svg>";
  return s.str();
}

struct Axes {
  double x0, x1, y0, y1;
  int W = 640, H = 300, L = 70, Rm = 20, T = 20, Bm = 40;
  bool logx = false, logy = false;
  double tx(double x) const {
    const double a = logx ? std::log10(x0) : x0, b = logx ? std::log10(x1) : x1, v = logx ? std::log10(x) : x;
    return L + (v - a) / (b - a) * (W - L - Rm);
  }
  double ty(double y) const {
    const double a = logy ? std::log10(y0) : y0, b = logy ? std::log10(y1) : y1, v = logy ? std::log10(y) : y;
    return H - Bm - (v - a) / (b - a) * (H - T - Bm);
  }
};

std::string frame(const Axes& ax, const std::string& xl, const std::string& yl) {
  std::ostringstream s;
  s << "<rect x='" << ax.L << "' y='" << ax.T << "' width='" << ax.W - ax.L - ax.Rm << "' height='" << ax.H - ax.T - ax.Bm
    << "' fill='none' stroke='#000'/>";
  for (int i = 0; i <= 4; ++i) {
    const double fx = i / 4.0;
    double x = ax.logx ? std::pow(10, std::log10(ax.x0) + fx * (std::log10(ax.x1) - std::log10(ax.x0))) : ax.x0 + fx * (ax.x1 - ax.x0);
    double y = ax.logy ? std::pow(10, std::log10(ax.y0) + fx * (std::log10(ax.y1) - std::log10(ax.y0))) : ax.y0 + fx * (ax.y1 - ax.y0);
    // Centred under its tick, but the last one ends at the picture's edge: centred, a label like "1.23e+03" ran
    // past the right margin and was cut.
    if (i < 4)
      s << "<text x='" << ax.tx(x) << "' y='" << ax.H - ax.Bm + 14 << "' text-anchor='middle'>" << fmt("%.3g", x) << "</text>";
    else
      s << "<text x='" << ax.W - 2 << "' y='" << ax.H - ax.Bm + 14 << "' text-anchor='end'>" << fmt("%.3g", x) << "</text>";
    s << "<text x='2' y='" << ax.ty(y) + 3 << "'>" << fmt("%.3g", y) << "</text>";
  }
  s << "<text x='" << ax.W / 2 << "' y='" << ax.H - 6 << "'>" << esc(xl) << "</text>";
  s << "<text x='4' y='12'>" << esc(yl) << "</text>";
  return s.str();
}

std::string scatter_svg(const DiagnosisResult& r) {
  if (r.scatter.empty()) return "<p>No top effect: nothing to plot.</p>";
  Axes ax{};
  ax.x0 = 1e300;
  ax.x1 = -1e300;
  ax.y0 = 1e300;
  ax.y1 = -1e300;
  for (const auto& p : r.scatter) {
    ax.x0 = std::min(ax.x0, p.x);
    ax.x1 = std::max(ax.x1, p.x);
    ax.y0 = std::min({ax.y0, p.before, p.after});
    ax.y1 = std::max({ax.y1, p.before, p.after});
  }
  if (ax.x1 <= ax.x0) { ax.x0 -= 1; ax.x1 += 1; }
  if (ax.y1 <= ax.y0) { ax.y0 -= 1e-9; ax.y1 += 1e-9; }
  const double py = 0.05 * (ax.y1 - ax.y0), px = 0.05 * (ax.x1 - ax.x0);
  ax.y0 -= py; ax.y1 += py; ax.x0 -= px; ax.x1 += px;
  ax.T = 34;  // the legend sits above the frame: inside, it covered the points in the top corner
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << ax.W << "' height='" << ax.H << "' font-family='sans-serif' font-size='10'>";
  s << frame(ax, r.plot_variable, "held-out block residual, " + r.plot_axis);
  if (ax.y0 < 0 && ax.y1 > 0) s << "<line x1='" << ax.L << "' x2='" << ax.W - ax.Rm << "' y1='" << ax.ty(0) << "' y2='" << ax.ty(0) << "' stroke='#999'/>";
  for (const auto& p : r.scatter) s << "<circle cx='" << ax.tx(p.x) << "' cy='" << ax.ty(p.before) << "' r='2.5' fill='#d33' fill-opacity='0.6'/>";
  for (const auto& p : r.scatter) s << "<circle cx='" << ax.tx(p.x) << "' cy='" << ax.ty(p.after) << "' r='2.5' fill='#33d' fill-opacity='0.6'/>";
  s << "<text x='" << ax.L << "' y='" << ax.T - 6 << "' fill='#d33'>&#9679; before (model as given)</text>";
  s << "<text x='" << ax.L + 170 << "' y='" << ax.T - 6 << "' fill='#33d'>&#9679; after (selected effects added)</text>";
  s << "</svg>";
  return s.str();
}

std::string allan_svg(const DiagnosisResult& r, int a) {
  const auto& pts = r.allan[static_cast<std::size_t>(a)];
  if (pts.size() < 2) return "<p>" + std::string(axis_name(a)) + ": no static record long enough for an Allan deviation.</p>";
  Axes ax{};
  ax.W = 320;
  ax.H = 240;
  ax.logx = ax.logy = true;
  ax.x0 = pts.front().tau_s;
  ax.x1 = pts.back().tau_s;
  ax.y0 = 1e300;
  ax.y1 = 0;
  for (const auto& p : pts) {
    ax.y0 = std::min(ax.y0, std::sqrt(p.avar));
    ax.y1 = std::max(ax.y1, std::sqrt(p.avar));
  }
  const auto& sim = r.sim_allan[static_cast<std::size_t>(a)];
  const double cN = r.claimed_N[static_cast<std::size_t>(a)];
  auto claim = [&](double tau) {
    if (std::isfinite(cN)) return cN / std::sqrt(tau);
    return 0.0;
  };
  for (const auto& p : pts) {
    if (claim(p.tau_s) > 0) { ax.y0 = std::min(ax.y0, claim(p.tau_s)); ax.y1 = std::max(ax.y1, claim(p.tau_s)); }
  }
  for (const auto& p : sim) { ax.y0 = std::min(ax.y0, std::sqrt(p.avar)); ax.y1 = std::max(ax.y1, std::sqrt(p.avar)); }
  ax.y0 /= 1.5;
  ax.y1 *= 1.5;
  if (ax.x1 <= ax.x0) ax.x1 = ax.x0 * 2;
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << ax.W << "' height='" << ax.H << "' font-family='sans-serif' font-size='9'>";
  s << frame(ax, "tau (s)", std::string(axis_name(a)) + " Allan deviation (" + unit_of(a) + ")");
  auto poly = [&](const std::vector<std::pair<double, double>>& v, const char* col, const char* dash) {
    s << "<polyline fill='none' stroke='" << col << "' stroke-dasharray='" << dash << "' points='";
    for (auto& [x, y] : v)
      if (y > 0 && x >= ax.x0 && x <= ax.x1) s << ax.tx(x) << "," << ax.ty(y) << " ";
    s << "'/>";
  };
  std::vector<std::pair<double, double>> meas, fit, cl, sm;
  for (const auto& p : pts) {
    meas.push_back({p.tau_s, std::sqrt(p.avar)});
    // The noise model the likelihood carries (white, quantization, Gauss-Markov, flicker, random walk): the
    // four IEEE 952 power laws alone cannot bend with an output filter and drew a flat line through it.
    const StochasticModel& st = r.stoch[static_cast<std::size_t>(a)];
    const double model_avar = st.n_points > 0 ? st.avar(p.tau_s) : r.noise[static_cast<std::size_t>(a)].terms.avar(p.tau_s);
    fit.push_back({p.tau_s, std::sqrt(model_avar)});
    if (claim(p.tau_s) > 0) cl.push_back({p.tau_s, claim(p.tau_s)});
  }
  for (const auto& p : sim) sm.push_back({p.tau_s, std::sqrt(p.avar)});
  poly(meas, "#000", "");
  poly(fit, "#d33", "4,2");
  if (!cl.empty()) poly(cl, "#33d", "2,2");
  if (!sm.empty()) poly(sm, "#3a3", "6,3");
  for (const auto& p : pts) s << "<circle cx='" << ax.tx(p.tau_s) << "' cy='" << ax.ty(std::sqrt(p.avar)) << "' r='2'/>";
  s << "</svg>";
  return s.str();
}

}  // namespace

std::string report_html(const DiagnosisResult& r) {
  std::ostringstream h;
  h << "<!DOCTYPE html><html><head><meta charset='utf-8'><title>imuforge diagnosis</title>"
    << "<style>body{font-family:sans-serif;max-width:1100px;margin:1em auto}table{border-collapse:collapse}"
    << "td,th{border:1px solid #ccc;padding:2px 6px;font-size:12px}pre{background:#f6f6f6;padding:8px;white-space:pre-wrap}ul.verdict li{font-size:15px;margin:3px 0}ul.caveats li{font-size:13px;margin:2px 0}</style></head><body>";
  h << "<h1>Sim-to-real gap diagnosis</h1>";
  // Verdict first: one line per axis; then the evidence.
  h << "<h2>Verdict</h2><ul class=\"verdict\">";
  for (const auto& l : verdict_lines(r)) h << "<li>" << esc(l) << "</li>";
  h << "</ul>";
  if (const std::string note = reference_note(r); !note.empty()) h << "<p>" << esc(note) << "</p>";
  // What the verdict rests on (an effect the campaign cannot exclude, a reference re-evaluated at a timing shift,
  // table errors left unestimated) stays in sight, not only inside the collapsed text.
  if (!r.warnings.empty()) {
    h << "<details open><summary>Caveats (" << r.warnings.size() << ")</summary><ul class=\"caveats\">";
    for (const auto& w : r.warnings) h << "<li>" << esc(w) << "</li>";
    h << "</ul></details>";
  }
  h << "<details><summary>Full text summary</summary><pre>" << esc(summary_text(r)) << "</pre></details>";
  // The heat map scrolls inside its box when it is wider than the page.
  h << "<h2>Where: held-out residuals per axis and condition</h2><div style=\"overflow-x:auto;max-width:100%\">" << heatmap_svg(r)
    << "</div>";
  if (r.ranking.empty()) h << "<h2>Which: ranking</h2><p>No effect was scored: nothing can be withheld from this log (too short to tell).</p>";
  else h << "<h2>Which: ranking</h2><table><tr><th>#</th><th>effect</th><th>-log10 p</th><th>p</th><th>dBIC</th><th>held-out shrink %</th><th title='at the first step, against the model as given'>significant (step 1)</th><th>outcome</th><th title='the magnitude each component would show at 5 sigma on this log'>5&sigma; detectable</th></tr>";
  int i = 0;
  for (const auto& c : r.ranking) {
    ++i;
    h << "<tr><td>" << i << "</td><td>" << esc(c.sensor + "." + c.effect) << "</td>";
    if (c.excitable)
      h << "<td>" << fmt("%.2f", c.score) << "</td><td>" << fmt("%.3g", c.p_value) << "</td><td>" << fmt("%.1f", c.delta_bic)
        << "</td><td>" << fmt("%.0f", c.heldout_shrink_pct) << "</td><td>" << (c.significant ? "yes" : "no") << "</td><td>"
        << esc(outcome(r, c)) << "</td><td>" << esc(detectable_range(c)) << "</td></tr>";
    else
      h << "<td colspan='7'>not excited by this campaign: cannot be ruled out</td></tr>";
  }
  if (!r.ranking.empty()) h << "</table>";
  if (r.plot_variable.empty()) h << "<h2>Residuals before and after</h2>" << scatter_svg(r);
  else h << "<h2>Residuals before and after, against " << esc(r.plot_variable) << " (" << esc(r.plot_axis) << ")</h2>" << scatter_svg(r);
  h << "<h2>Allan deviation of static residuals</h2><p>black: measured; red dashed: the fitted noise model the likelihood carries (IEEE 952 white, quantization and rate random walk, a Gauss-Markov term, flicker); blue dotted: white noise "
       "the model claims; green dashed: simulation of the same campaign (--sim).</p>";
  for (int a = 0; a < kNumAxes; ++a) h << allan_svg(r, a);
  h << "</body></html>\n";
  return h.str();
}

}  // namespace imuforge::diagnosis
