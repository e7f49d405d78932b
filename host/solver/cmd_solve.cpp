// `imuforge solve`: calibration from a log (docs/calibration.md).
#include <algorithm>
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <string>

#include "host/app/command.h"
#include "host/io/campaign_file.h"
#include "host/io/input_error.h"
#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/solver/calfile.h"
#include "host/solver/consider.h"
#include "host/solver/fixture.h"
#include "host/solver/fixture_errors.h"
#include "host/solver/online.h"
#include "host/poses/detect.h"
#include "host/solver/reference_free.h"
#include "host/solver/repeatability.h"
#include "host/solver/sha256.h"
#include "host/solver/table_out.h"
#include "host/solver/traditional.h"

using namespace imuforge;
using namespace imuforge::solver;

namespace {

struct Args {
  std::string log, model, mode = "fixture", method = "inverse", out, table, serial, noise = "static";
  std::string stop_sigma, campaign, rotation_check;
  bool online = false;
  poses::DetectOptions detect;
  bool explain_poses = false;
  bool no_term_selection = false;
  std::vector<std::string> logs;
};

Sigma6 noise_from_model(const model::ModelSpec& spec) {
  const auto it = spec.extra.find("noise_sigma");
  if (it == spec.extra.end())
    throw SolverError("--noise model: the model file has no \"noise_sigma\": {\"accel\": [3], \"gyro\": [3]}");
  Sigma6 s{};
  for (int t = 0; t < 2; ++t) {
    const char* key = t ? "gyro" : "accel";
    const auto a = it->find(key);
    if (a == it->end() || !a->is_array() || a->size() != 3)
      throw SolverError(std::string("model \"noise_sigma.") + key + "\" must be an array of 3 numbers");
    for (int j = 0; j < 3; ++j) {
      if (!(*a)[static_cast<size_t>(j)].is_number())
        throw SolverError(std::string("model \"noise_sigma.") + key + "\" must hold numbers");
      s[static_cast<size_t>(3 * t + j)] = (*a)[static_cast<size_t>(j)].get<double>();
    }
  }
  return s;
}

// Noise of the first dwell only: the online estimator must fix its weights before the campaign ends.
Sigma6 noise_from_first_dwell(io::LogReader& log) {
  io::LogRow r;
  int seg = -1;
  double s1[6] = {}, s2[6] = {};
  long long n = 0;
  const double lsb[2] = {log.meta().accel_lsb_mps2, log.meta().gyro_lsb_rad_s};
  while (log.next(r)) {
    if (r.segment < 0 || !r.has_ref) {
      if (n > 10) break;
      continue;
    }
    if (seg >= 0 && r.segment != seg) break;
    seg = r.segment;
    for (int c = 0; c < 6; ++c) {
      const double y = r.raw[c] * lsb[c / 3];
      s1[c] += y;
      s2[c] += y * y;
    }
    ++n;
  }
  log.rewind();
  if (n < 10) throw SolverError("online mode: the first dwell is too short to estimate the noise; use --noise model");
  Sigma6 s{};
  for (int c = 0; c < 6; ++c) s[static_cast<size_t>(c)] = std::sqrt(std::max(0.0, (s2[c] - s1[c] * s1[c] / n) / (n - 1)));
  return s;
}

// sigma_noise (optional): the noise-only σ, printed beside the honest one.
void print_estimate(const Estimate& e, bool with_sigma, const Eigen::VectorXd& sigma_noise = {}) {
  const Eigen::VectorXd s = with_sigma ? e.sigma() : Eigen::VectorXd();
  if (with_sigma && sigma_noise.size() == s.size() && s.size() > 0)
    std::printf("  %-28s %13s    %-9s  %s\n", "parameter", "value", "σ", "(σ noise only)");
  for (size_t i = 0; i < e.names.size(); ++i) {
    const long k = static_cast<long>(i);
    if (with_sigma && sigma_noise.size() == s.size())
      std::printf("  %-28s % .6e  ± %.2e  (%.2e)\n", e.names[i].c_str(), e.value[k], s[k], sigma_noise[k]);
    else if (with_sigma)
      std::printf("  %-28s % .6e  ± %.2e\n", e.names[i].c_str(), e.value[k], s[k]);
    else
      std::printf("  %-28s % .6e\n", e.names[i].c_str(), e.value[static_cast<long>(i)]);
  }
}

// Honest σ (consider.h): widens res.estimate by the fixture tolerance the model states, or records that
// σ covers the noise only.
void apply_fixture_tolerance(CalibrationResult& res, io::LogReader& log, const model::ModelSpec& spec, const Args& a,
                             const Sigma6& sigma) {
  const std::string where = "model '" + a.model + "'";
  if (spec.extra.find("fixture_tolerance") == spec.extra.end()) {
    res.extra["fixture_tolerance"] = fixture_tolerance_not_stated();
    if (log.meta().table_axes > 0)
      std::printf("note: %s states no \"fixture_tolerance\": σ below covers the sensor noise only, not the fixture's "
                  "tilts, zeros and mount (docs/calibration.md, 'Honest σ')\n", where.c_str());
    return;
  }
  if (a.campaign.empty())
    throw SolverError(where + " states \"fixture_tolerance\": pass --campaign C.json (the table geometry) so the solver "
                      "can carry the tolerance into σ");
  physics::Campaign c;
  try {
    c = io::load_campaign(a.campaign);
  } catch (const std::exception& e) {
    throw SolverError("campaign '" + a.campaign + "': " + e.what());
  }
  const auto tol = fixture_tolerance_of(spec, static_cast<int>(c.axes.size()), where);
  ConsiderResult cr;
  try {
    cr = consider_fixture_tolerance(log, spec, c, res.estimate, sigma, *tol);
  } catch (const SolverError& e) {
    throw SolverError(std::string("fixture_tolerance: ") + e.what());
  }
  res.extra["fixture_tolerance"] = apply_consider(res.estimate, cr, *tol, &res.sigma_noise);
  std::printf("fixture tolerance: %zu fixture parameters considered; σ covers noise and fixture\n", cr.considered.size());
}

// cal.json's "dwell_scatter" and one line on the channels whose drift between dwells σ carries
// (docs/calibration.md, "Dwell drift"). sc: the dwell-mean ratios where the mode has them.
void report_drift(CalibrationResult& res, const SegmentScatter* sc, const ChannelDrifts& drifts, bool widen) {
  res.extra["dwell_scatter"] = dwell_scatter_json(sc, widen, drifts);
  std::string loud;
  for (int c = 0; c < kNumChannels; ++c) {
    const estimator::DwellDrift& d = drifts[static_cast<size_t>(c)];
    if (!d.adopted) continue;
    char b[200];
    std::snprintf(b, sizeof b, "%s%s (offsets σ %.3g, wander σ %.3g over τ %.0f s, flicker σ %.3g per state)",
                  loud.empty() ? "" : ", ", channel_name(c), std::sqrt(d.offset_var), std::sqrt(d.gm_var), d.gm_tau_s,
                  std::sqrt(d.flicker_var));
    loud += b;
  }
  if (!loud.empty())
    std::printf("dwell drift: the dwell means wander past white noise on %s; σ carries it\n", loud.c_str());
  else if (!widen)
    std::printf("dwell drift: not fitted (\"dwell_scatter\": false); σ from white noise alone\n");
}

void write_json(const std::string& path, const nlohmann::json& j) {
  std::ofstream f(path);
  if (!f) throw SolverError("cannot write '" + path + "'");
  f << j.dump(2) << "\n";
  if (!f) throw SolverError("write error on '" + path + "'");
}

int run_solve(int argc, char** argv) {
  CLI::App app{"Calibrate: estimate the model's parameters with covariance from a log (docs/calibration.md)"};
  Args a;
  app.add_option("--log", a.logs, "log v1 (CSV, binary or HDF5); reference-free: repeat for several recordings of one unit "
                                  "(calibrated each and together, spread vs sigma, cross-application)")
      ->required();
  app.add_option("--model", a.model, "model file (docs/examples/model-basic.json, model-thermal.json)")->required();
  app.add_option("--mode", a.mode, "reference mode")->check(CLI::IsMember({"fixture", "fixture+errors", "reference-free"}));
  app.add_option("--method", a.method, "inverse (weighted least squares) or traditional (six-position, CW/CCW)")
      ->check(CLI::IsMember({"inverse", "traditional"}));
  app.add_option("--out", a.out, "cal.json to write");
  app.add_option("--table", a.table, "also write the firmware coefficient table (needs --serial)");
  app.add_option("--serial", a.serial, "device serial for the table");
  app.add_option("--noise", a.noise, "noise weights: static (within-dwell variance) or model (\"noise_sigma\")")
      ->check(CLI::IsMember({"static", "model"}));
  app.add_flag("--online", a.online, "recursive estimation segment by segment (fixture mode)");
  app.add_option("--stop-sigma", a.stop_sigma, "σ spec (docs/examples/spec-sigma.json): report when every σ meets it");
  app.add_option("--campaign", a.campaign, "campaign file: table geometry for fixture+errors and for the model's fixture_tolerance");
  app.add_option("--rotation-check", a.rotation_check,
                 "reference-free: a log with one known rotation; prints the integrated angle before/after");
  app.add_option("--static-window", a.detect.window_s, "reference-free: window of the static detector, s")
      ->check(CLI::PositiveNumber);
  app.add_option("--static-min", a.detect.min_dwell_s, "reference-free: minimum dwell of a pose, s")->check(CLI::PositiveNumber);
  app.add_option("--static-settle", a.detect.settle_s, "reference-free: margin dropped after motion, s")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--static-k", a.detect.k_accel, "reference-free: still accelerometer below k x its per-axis noise floor")
      ->check(CLI::PositiveNumber);
  app.add_flag("--explain-poses", a.explain_poses,
               "reference-free: print every stretch of the recording (start, end, duration, mean, verdict/reason)");
  app.add_flag("--no-term-selection", a.no_term_selection,
               "reference-free: keep the 9 basic accelerometer terms (no cross-validated extra catalog terms)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? app::kExitOk : app::kExitUsage;
  }
  a.log = a.logs.front();
  if (a.logs.size() > 1 && a.mode != "reference-free") {
    std::fprintf(stderr, "imuforge solve: several --log are compared in reference-free mode only\n");
    return app::kExitUsage;
  }
  if (!a.table.empty() && a.serial.empty()) {
    std::fprintf(stderr, "imuforge solve: --table needs --serial\n");
    return app::kExitUsage;
  }
  if (!a.stop_sigma.empty() && !a.online) {
    std::fprintf(stderr, "imuforge solve: --stop-sigma needs --online\n");
    return app::kExitUsage;
  }
  if (a.online && a.mode != "fixture") {
    std::fprintf(stderr, "imuforge solve: --online works in fixture mode (the linear problem)\n");
    return app::kExitUsage;
  }
  if (a.out.empty() && !a.online) {
    std::fprintf(stderr, "imuforge solve: --out is required\n");
    return app::kExitUsage;
  }

  model::ModelSpec spec;
  nlohmann::json spec_json;
  spec_json = io::read_json_file(a.model);
  try {
    spec = model::model_spec_from_json(spec_json);
  } catch (const std::exception& e) {
    throw io::InputError(a.model + ": " + e.what());
  }

  io::LogReader log(a.log);
  CalibrationResult res;
  res.mode = a.mode;
  res.method = a.method;
  res.model = spec_json;
  res.T_ref_C = spec.T_ref_C;
  res.log_path = a.log;
  res.log_sha256 = sha256_file_hex(a.log);

  if (a.mode == "reference-free") {
    if (a.method == "traditional") throw SolverError("the traditional method needs a fixture (six positions, CW/CCW)");
    RawRecording rec = read_recording(log);
    ReferenceFreeOptions rfo;
    rfo.detect = a.detect;
    rfo.select_terms = !a.no_term_selection;
    rfo.for_table = !a.table.empty();
    if (a.explain_poses) std::printf("%s: %s", a.log.c_str(), poses::explain_table(poses::detect_poses(rec, a.detect)).c_str());
    std::vector<RawRecording> more;  // the other recordings of --log
    for (std::size_t k = 1; k < a.logs.size(); ++k) {
      io::LogReader lk(a.logs[k]);
      more.push_back(read_recording(lk));
      if (a.explain_poses)
        std::printf("%s: %s", a.logs[k].c_str(), poses::explain_table(poses::detect_poses(more.back(), a.detect)).c_str());
    }
    std::vector<const RawRecording*> all = {&rec};
    for (const auto& m : more) all.push_back(&m);
    ReferenceFreeResult r;
    if (all.size() > 1) {
      Repeatability rep = repeatability(all, a.logs, spec, rfo);
      std::printf("%s", rep.report(a.logs).c_str());
      for (const auto& w : rep.warnings) std::fprintf(stderr, "imuforge solve: warning: %s\n", w.c_str());
      res.extra["repeatability"] = rep.to_json(a.logs);
      std::vector<std::string> hashes;
      for (const auto& l : a.logs) hashes.push_back(sha256_file_hex(l));
      res.extra["logs_sha256"] = hashes;
      r = std::move(rep.joint);
      std::printf("joint calibration (all %zu recordings): ", all.size());
    } else {
      r = solve_reference_free(rec, spec, rfo);
    }
    res.estimate = r.estimate;
    res.observability = r.observability;
    res.residual_rms = r.residual_rms;
    res.noise_sigma = r.residual_rms;
    res.noise_source = "within-pose scatter";
    res.samples = 0;
    for (const RawRecording* x : all) res.samples += static_cast<long long>(x->y.size());
    res.observability.unobservable.clear();
    res.extra["reference_free"] = reference_free_summary(r, rec);
    std::printf("reference-free: %zu static poses, gravity %.5f m/s² (%s)\n", r.intervals.size(), r.gravity_mps2,
                rec.gravity_source.c_str());
    std::printf("  gravity-magnitude residual RMS: before %.4e m/s², after %.4e m/s²\n", r.gravity_rms_before,
                r.gravity_rms_after);
    if (r.terms_tried)
      std::printf("  extra accelerometer terms by leave-poses-out cross-validation (%zu folds): %s; held-out RMS %.4e -> "
                  "%.4e m/s²\n", poses::kHeldoutFolds, r.terms_added.empty() ? "none" : nlohmann::json(r.terms_added).dump().c_str(),
                  r.heldout_rms_basic, r.heldout_rms_selected);
    else
      std::printf("  extra accelerometer terms: %s\n", r.terms_note.c_str());
    std::printf("  gravity-direction residual RMS across rotations: before %.4e, after %.4e (%d transitions; %d left "
                "out: gyro clipped at the %d-bit full scale)\n", r.rotation_rms_before, r.rotation_rms_after, r.transitions_used,
                r.transitions_clipped, rec.gyro_bits);
    if (!a.rotation_check.empty()) {
      io::LogReader l2(a.rotation_check);
      RawRecording r2 = read_recording(l2);
      const RotationCheck rc = rotation_check(r2, r.estimate);
      std::printf("  rotation check (%s): nominal %.3f°, calibrated %.3f° ± %.3f° about [%.3f %.3f %.3f]\n",
                  a.rotation_check.c_str(), rc.angle_nominal_deg, rc.angle_deg, rc.angle_sigma_deg, rc.axis.x(),
                  rc.axis.y(), rc.axis.z());
      res.extra["rotation_check"] = {{"log", a.rotation_check},
                                     {"angle_nominal_deg", rc.angle_nominal_deg},
                                     {"angle_calibrated_deg", rc.angle_deg},
                                     {"angle_calibrated_sigma_deg", rc.angle_sigma_deg},
                                     {"axis", {rc.axis.x(), rc.axis.y(), rc.axis.z()}}};
    }
    print_estimate(res.estimate, true);
  } else if (a.mode == "fixture+errors") {
    if (a.campaign.empty()) throw SolverError("fixture+errors needs --campaign C.json for the table geometry");
    FixtureErrorsResult r = solve_fixture_errors(log, spec, a.campaign);
    res.estimate = r.estimate;
    res.observability = r.observability;
    res.residual_rms = r.residual_rms;
    res.noise_sigma = r.noise_sigma;
    res.noise_source = "static";
    res.samples = r.samples;
    // Which frame the misalignments are in follows from the gauge (fixture_errors.h).
    const char* frame = r.mount_estimated ? "body: the frame the model's triangular misalignment defines (mount rotation estimated)"
                                   : "platform: the mount rotation is fixed at zero, misalignments include it";
    res.extra["fixture_errors"] = {{"nuisance", r.nuisance_names}, {"fixed_by_gauge", r.fixed},
                                   {"assumed_zero", r.assumed_zero}, {"iterations", r.iterations}, {"misalignment_frame", frame}};
    if (!r.fixed.empty())
      std::printf("fixture+errors: fixed at 0 (inseparable from others): %s\n", nlohmann::json(r.fixed).dump().c_str());
    std::printf("fixture+errors: misalignment frame: %s\n", frame);
    report_drift(res, nullptr, r.drifts, dwell_scatter_of(spec));
    apply_fixture_tolerance(res, log, spec, a, r.noise_sigma);
    print_estimate(res.estimate, true, res.sigma_noise);
  } else {
    // fixture (inverse or traditional), optionally online
    Sigma6 sigma{};
    bool sigma_known = false;
    if (a.noise == "model") {
      sigma = noise_from_model(spec);
      sigma_known = true;
    } else if (a.online) {
      sigma = noise_from_first_dwell(log);
      sigma_known = true;
    }
    std::unique_ptr<OnlineCalibrator> oc;
    SigmaSpec sspec;
    int first_met = -1;
    nlohmann::json history = nlohmann::json::array();
    if (a.online) {
      if (!a.stop_sigma.empty()) sspec = load_sigma_spec(a.stop_sigma);
      oc = std::make_unique<OnlineCalibrator>(spec, log.meta(), sigma);
      oc->on_update = [&](const SegmentSummary& s, const Estimate& e) {
        const bool done = oc->complete();
        if (a.stop_sigma.empty()) {
          std::printf("segment %4d  T %6.2f °C  %s\n", s.segment, s.T_C, done ? "all parameters observable" : "not yet observable");
          history.push_back({{"segment", s.segment}, {"observable", done}});
          return;
        }
        const SigmaCheck c = check_sigma(e, sspec);
        if (c.all_met && first_met < 0) first_met = s.segment;
        std::printf("segment %4d  T %6.2f °C  σ meets spec: %3d/%3d  worst σ/spec %8.3g  %s\n", s.segment, s.T_C, c.n_met,
                    c.n_limited, c.worst_ratio, c.all_met ? "ALL MET" : "");
        history.push_back({{"segment", s.segment}, {"met", c.n_met}, {"limited", c.n_limited},
                           {"worst_ratio", std::isfinite(c.worst_ratio) ? nlohmann::json(c.worst_ratio) : nlohmann::json()},
                           {"all_met", c.all_met}});
      };
    }
    FixtureAccumulator acc_local(spec, log.meta());
    FixtureAccumulator& acc = oc ? const_cast<FixtureAccumulator&>(oc->accumulator()) : acc_local;
    io::LogRow row;
    while (log.next(row)) {
      if (oc) oc->add(row);
      else acc.add(row);
    }
    if (oc) oc->finish();
    else acc.finish();
    if (!sigma_known) sigma = acc.static_noise_sigma();
    res.noise_source = a.noise == "model" ? "model" : (a.online ? "first dwell" : "static");
    res.samples = acc.samples_used();
    FixtureSolution sol;
    bool have_inverse = false;
    std::string inverse_error;
    // σ from the static noise assumes it white from dwell to dwell. Bias instability, a random walk or an effect
    // the model lacks make the dwell means wander: on such a channel the covariance carries the wander fitted to
    // the dwell means (docs/calibration.md, "Dwell drift"); the estimate does not move.
    SegmentScatter sc;
    ChannelDrifts drifts;
    try {
      sol = solve_fixture_widened(acc, sigma, &sc, &drifts);
      have_inverse = true;
    } catch (const SolverError& e) {
      if (a.method == "inverse") throw;
      inverse_error = e.what();
    }
    if (have_inverse) report_drift(res, &sc, drifts, dwell_scatter_of(spec));
    if (oc) {
      const Estimate rec = oc->estimate();
      double worst = 0;
      // By name: per-plateau slots are matched to the batch's (they coincide after the last segment).
      for (size_t i = 0; i < rec.names.size(); ++i) {
        const int k = have_inverse ? sol.estimate.index_of(rec.names[i]) : -1;
        worst = k < 0 ? std::numeric_limits<double>::infinity()
                      : std::max(worst, std::abs(rec.value[static_cast<long>(i)] - sol.estimate.value[k]) /
                                            sol.estimate.sigma()[k]);
      }
      std::printf("online: %d segments; recursive vs batch: max |Δ|/σ = %.2e\n", oc->segments(), worst);
      if (!a.stop_sigma.empty()) {
        if (first_met >= 0) std::printf("online: every σ meets the spec from segment %d on\n", first_met);
        else std::printf("online: the σ spec is never met in this log\n");
      }
      res.extra["online"] = {{"segments", oc->segments()},
                             {"first_segment_meeting_spec", first_met >= 0 ? nlohmann::json(first_met) : nlohmann::json()},
                             {"recursive_vs_batch_max_sigma", worst},
                             {"history", history}};
    }
    if (have_inverse) {
      res.observability = sol.observability;
      res.residual_rms = sol.residual_rms;
      res.noise_sigma = sol.noise_sigma;
    }
    res.extra["dwell_guard"] = {{"guard_s", acc.dwell_guard_s()}, {"samples_left_out", acc.guarded_samples()}};
    if (acc.guarded_samples() > 0)
      std::printf("dwell guard: %lld dwell samples within %.2g s of a reference change left out (model \"dwell_guard_s\")\n",
                  acc.guarded_samples(), acc.dwell_guard_s());
    if (acc.has_per_plateau()) {
      nlohmann::json pl = nlohmann::json::array();
      for (const auto& p : acc.plateaus()) pl.push_back({{"T_C", p.T_C}, {"samples", p.samples}});
      res.extra["plateaus"] = pl;
      res.extra["transit_samples"] = acc.transit_samples();
      if (acc.transit_samples() > 0)
        std::printf("per-plateau model: %lld samples in segments whose temperature moved > 3 °C left out\n",
                    acc.transit_samples());
    }
    if (a.method == "traditional") {
      TraditionalResult tr = solve_traditional(acc.segments(), spec.T_ref_C);
      res.estimate = tr.estimate;
      res.has_covariance = false;
      res.has_residuals = false;
      nlohmann::json cmp = nlohmann::json::array();
      std::printf("traditional (six-position + CW/CCW at %.1f °C) vs inverse problem:\n", tr.plateau_T_C);
      std::printf("  %-24s %14s %14s %11s %8s\n", "parameter", "traditional", "inverse", "σ(inverse)", "Δ/σ");
      for (size_t i = 0; i < tr.estimate.names.size(); ++i) {
        const std::string& nm = tr.estimate.names[i];
        const double tv = tr.estimate.value[static_cast<long>(i)];
        const int k = have_inverse ? sol.estimate.index_of(nm) : -1;
        if (k < 0) {
          std::printf("  %-24s % .7e %14s\n", nm.c_str(), tv, "-");
          cmp.push_back({{"name", nm}, {"traditional", tv}});
          continue;
        }
        const double iv = sol.estimate.value[k], is = sol.estimate.sigma()[k];
        std::printf("  %-24s % .7e % .7e %11.3e %8.2f\n", nm.c_str(), tv, iv, is, (tv - iv) / is);
        cmp.push_back({{"name", nm}, {"traditional", tv}, {"inverse", iv}, {"inverse_sigma", is}, {"diff_over_sigma", (tv - iv) / is}});
      }
      res.extra["comparison"] = {{"plateau_T_C", tr.plateau_T_C}, {"parameters", cmp}};
      if (!have_inverse) res.extra["comparison"]["inverse_error"] = inverse_error;
    } else {
      res.estimate = sol.estimate;
      std::printf("fixture mode: %lld samples, rank %d/%d, condition %.3g\n", sol.samples, sol.observability.rank,
                  sol.observability.n_params, sol.observability.condition_number);
      for (int c = 0; c < kNumChannels; ++c)
        std::printf("  %-8s noise σ %.3e  residual RMS %.3e\n", channel_name(c), sol.noise_sigma[static_cast<size_t>(c)],
                    sol.residual_rms[static_cast<size_t>(c)]);
      apply_fixture_tolerance(res, log, spec, a, sigma);
      print_estimate(res.estimate, true, res.sigma_noise);
    }
  }

  if (!a.table.empty()) {
    TableReport tr = write_coefficient_table(res, log, a.table, a.serial);
    res.extra["table"] = tr.to_json();
    std::printf("table: %s (%zu bytes); quantisation adds %.4f σ of sensor noise (worst channel %s, limit 0.1)\n",
                a.table.c_str(), tr.bytes, tr.worst_ratio, tr.worst_channel.c_str());
    if (!tr.ok) {
      if (!a.out.empty()) write_json(a.out, calibration_to_json(res));
      std::fprintf(stderr, "imuforge solve: table REJECTED: quantisation adds %.4f σ (> 0.1 σ) on %s\n", tr.worst_ratio,
                   tr.worst_channel.c_str());
      return app::kExitFailed;
    }
  }
  if (!a.out.empty()) {
    write_json(a.out, calibration_to_json(res));
    std::printf("wrote %s\n", a.out.c_str());
  }
  return app::kExitOk;
}

}  // namespace

IMUFORGE_COMMAND(solve, "calibrate: parameters with covariance from a log (fixture, fixture+errors, reference-free)",
                 run_solve);
