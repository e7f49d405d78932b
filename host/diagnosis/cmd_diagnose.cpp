// `imuforge diagnose`: where a model departs from real data, which catalog effect explains it, and how far
// the held-out gap shrinks (docs/diagnosis.md).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "host/app/command.h"
#include "host/diagnosis/diagnose.h"
#include "host/diagnosis/sources.h"
#include "host/diagnosis/table_errors.h"
#include "host/estimator/estimator.h"
#include "host/io/campaign_file.h"
#include "host/io/staged_file.h"
#include "host/poses/detect.h"
#include "host/model/sensor_model.h"
#include "host/solver/fixture.h"

namespace {

using namespace imuforge;

// "gyro.timing.latency_s" / "accel.bias_temp.x.t1@plateau2" -> "gyro.timing" / "accel.bias_temp".
std::string effect_key_of(const std::string& param) {
  const auto a = param.find('.');
  const auto b = a == std::string::npos ? a : param.find_first_of(".@", a + 1);
  return param.substr(0, b);
}

// Observable is not determined. A component the solve of the emitted model would pin no better than the range
// a real part can have (its σ, under the log's static noise, at or beyond diagnosis::plausible_limit,
// docs/error-model.md) is left out as an unobservable one is: the effect is emitted without it, or left out
// whole when it has no other. Found on campaign-eol with ±300 °/s runs about x and y: their centripetal 1 m/s²
// on z makes accel scale_nonlinearity's z.k3 observable beside the ±1 g faces (where k3·f³ = g²·f is the
// scale), but only just: the solve reported rank 79/79 at condition 1.65e10, z.k3 ± 6e-4 (limit 1e-4) and
// accel.scale.z −0.46 ± 0.06; without z.k3, condition 502. Returns whether it left anything out.
bool leave_out_undetermined(nlohmann::json& mj, const std::vector<std::string>& names, const estimator::NormalEquations& ne,
                            const std::set<std::string>& added, const diagnosis::DiagnosisResult& r) {
  const Eigen::MatrixXd cov = estimator::covariance_from_information(ne.info, names);
  std::map<std::string, std::vector<std::size_t>> all, weak;  // per added effect: its parameters, the undetermined
  std::vector<double> sigma(names.size()), limit(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string key = effect_key_of(names[i]);
    if (!added.count(key)) continue;
    all[key].push_back(i);
    const model::ParamId id = model::find_param(names[i].substr(0, names[i].find('@')));
    if (id < 0) continue;
    sigma[i] = std::sqrt(std::max(cov(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)), 0.0));
    limit[i] = diagnosis::plausible_limit(model::param_info(id));
    if (!(sigma[i] < limit[i])) weak[key].push_back(i);
  }
  for (const auto& [key, idx] : weak) {
    nlohmann::json left = nlohmann::json::array(), keep = nlohmann::json::array(), solve = nlohmann::json::array(),
                   estimate = nlohmann::json::array();
    for (std::size_t i : all[key]) {
      const bool w = std::find(idx.begin(), idx.end(), i) != idx.end();
      (w ? left : keep).push_back(names[i].substr(key.size() + 1));
      if (!w) continue;
      solve.push_back({{"name", names[i]}, {"sigma", sigma[i]}, {"plausible_limit", limit[i]}});
      for (const auto& pe : r.final_params)
        if (pe.name == names[i]) estimate.push_back({{"name", pe.name}, {"axis", pe.axis}, {"value", pe.value}, {"sigma", pe.sigma}});
    }
    const std::string reason =
        "not determined by `imuforge solve` in fixture mode on this log: observable on the dwell rows it reads, but its "
        "standard error there reaches the range a real part can have (docs/error-model.md, plausibility limits)";
    std::string ls;
    for (const auto& c : left) ls += (ls.empty() ? "" : ", ") + c.get<std::string>();
    if (!keep.empty()) {
      mj["effects"][key]["components"] = keep;
      mj["_diagnosis"]["not_emitted"].push_back(
          {{"effect", key}, {"components_left_out", left}, {"reason", reason}, {"unobservable", nlohmann::json::array()},
           {"solve_sigma", solve}, {"diagnosis_estimate", estimate}});
      std::fprintf(stderr, "imuforge diagnose: --emit-model: %s emitted without %s (not determined by the fixture solver on this log)\n",
                   key.c_str(), ls.c_str());
    } else {
      mj["effects"].erase(key);
      mj["_diagnosis"]["not_emitted"].push_back({{"effect", key}, {"reason", reason}, {"unobservable", nlohmann::json::array()},
                                                 {"solve_sigma", solve}, {"diagnosis_estimate", estimate}});
      std::fprintf(stderr, "imuforge diagnose: --emit-model: %s left out (not determined by the fixture solver on this log)\n", key.c_str());
    }
  }
  return !weak.empty();
}

// The emitted model is for `imuforge solve --model` on the same log (docs/diagnosis.md, "Closed loop").
// In fixture mode the solver reads dwell rows only (host/solver/fixture.h) and takes u̇ = 0 there (it
// does not differentiate the reference: exact on a dwell, where the table stands or turns at a constant
// rate), so a timing term −(λ + ε t)·u̇ carries no information and the four timing parameters would make
// the solve rank-deficient. The diagnosis itself estimates timing from the motion between
// dwells. So the emitted model is checked with the solver's own accumulator and the shared estimator's
// observability analysis: an effect added by the diagnosis with a parameter the solver cannot observe on
// this log is left out, and "_diagnosis.not_emitted" says which, why (the solver's unobservable
// directions) and what the diagnosis estimated for it. Effects of the base model are never touched.

void keep_solver_identifiable(nlohmann::json& mj, const std::string& log_path, const std::set<std::string>& added,
                              const diagnosis::DiagnosisResult& r) {
  nlohmann::json& notes = mj["_diagnosis"]["not_emitted"];
  notes = nlohmann::json::array();
  // An effect is left out only when it appears in an unobservable direction (a component ≥ 0.05 of the
  // scaled null vector, as printed). The per-parameter flag (any component above 1e-3) is not used: in a
  // degenerate null space (timing's exact zeros beside another exact collinearity) the eigen-solver mixes in
  // weakly observable parameters at that level, and a size effect the solver does observe was left out.
  // An effect only some of whose components lie in those directions (scale_nonlinearity's k3·f³ = g²·f on the
  // ±1 g faces, beside its k2·f², which the faces do observe) is emitted once without them ("components"), and
  // left out whole only when its remaining components still appear in one.
  std::set<std::string> cut;
  for (std::size_t pass = 0; pass <= 2 * added.size(); ++pass) {
    const model::ModelSpec spec = model::model_spec_from_json(mj);
    io::LogReader log(log_path);
    solver::FixtureAccumulator acc(spec, log.meta());
    io::LogRow row;
    while (log.next(row)) acc.add(row);
    acc.finish();
    const std::vector<std::string> names = acc.names();
    const estimator::NormalEquations ne = acc.normal_equations(acc.static_noise_sigma());
    const estimator::Observability obs = estimator::analyse_observability(ne.info, names);
    if (obs.rank == obs.n_params) {
      if (!leave_out_undetermined(mj, names, ne, added, r)) break;
      continue;
    }
    std::set<std::string> drop;
    for (const std::string& d : obs.unobservable)
      for (const std::string& key : added)
        if (d.find(key + ".") != std::string::npos) drop.insert(key);
    if (drop.empty()) {
      mj["_diagnosis"]["solver_rank_deficient"] = obs.unobservable;  // the base model's own, left as given
      break;
    }
    // The parameter names each printed direction holds ("0.707*accel.scale.x - 0.707*accel.scale_nonlinearity.x.k3").
    std::vector<std::set<std::string>> dir_terms;
    for (const std::string& d : obs.unobservable) {
      std::set<std::string>& t = dir_terms.emplace_back();
      std::istringstream is(d);
      for (std::string tok; is >> tok;)
        if (const auto star = tok.find('*'); star != std::string::npos) t.insert(tok.substr(star + 1));
    }
    for (const std::string& key : drop) {
      std::vector<std::string> all, bad;  // the effect's parameters, and those in an unobservable direction
      bool zero = true;                   // its regressor is zero on every row the solver reads
      for (std::size_t i = 0; i < names.size(); ++i) {
        if (effect_key_of(names[i]) != key) continue;
        all.push_back(names[i]);
        if (ne.info(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)) > 0.0) zero = false;
        if (std::any_of(dir_terms.begin(), dir_terms.end(), [&](const std::set<std::string>& t) { return t.count(names[i]) > 0; }))
          bad.push_back(names[i]);
      }
      nlohmann::json dirs = nlohmann::json::array();
      std::set<std::string> partner_set;  // the other parameters those directions hold
      for (std::size_t k = 0; k < dir_terms.size(); ++k) {
        if (obs.unobservable[k].find(key + ".") == std::string::npos) continue;
        dirs.push_back(obs.unobservable[k]);
        for (const std::string& n : dir_terms[k])
          if (effect_key_of(n) != key) partner_set.insert(n);
      }
      std::string partners;
      for (const auto& n : partner_set) partners += (partners.empty() ? "" : ", ") + n;
      nlohmann::json estimate = nlohmann::json::array();
      const bool part = !zero && !cut.count(key) && !bad.empty() && bad.size() < all.size();
      for (const auto& pe : r.final_params)
        if (effect_key_of(pe.name) == key && (!part || std::find(bad.begin(), bad.end(), pe.name) != bad.end()))
          estimate.push_back({{"name", pe.name}, {"axis", pe.axis}, {"value", pe.value}, {"sigma", pe.sigma}});
      if (part) {
        nlohmann::json keep = nlohmann::json::array(), left = nlohmann::json::array();
        for (const std::string& n : all)
          (std::find(bad.begin(), bad.end(), n) == bad.end() ? keep : left).push_back(n.substr(key.size() + 1));
        mj["effects"][key]["components"] = keep;
        cut.insert(key);
        notes.push_back({{"effect", key},
                         {"components_left_out", left},
                         {"reason", "unobservable for `imuforge solve` in fixture mode on this log: on the dwell rows it reads, "
                                    "these components cannot be told apart from " +
                                        (partners.empty() ? std::string("the effect's other components") : partners) +
                                        "; the others are emitted"},
                         {"unobservable", dirs},
                         {"diagnosis_estimate", estimate}});
        std::string ls;
        for (const auto& c : left) ls += (ls.empty() ? "" : ", ") + c.get<std::string>();
        std::fprintf(stderr, "imuforge diagnose: --emit-model: %s emitted without %s (not observable by the fixture solver on this log)\n",
                     key.c_str(), ls.c_str());
        continue;
      }
      mj["effects"].erase(key);
      // Why: a regressor that is zero on every row the solver reads (timing: u̇ = 0 on a dwell), or one that
      // is collinear there with other parameters (e.g. scale_nonlinearity's k3·f³ = g²·f on ±1 g faces).
      const std::string reason =
          zero ? "unobservable for `imuforge solve` in fixture mode on this log: it uses dwell rows only and takes u-dot = 0 "
                 "there, so the effect's regressor is zero"
               : "unobservable for `imuforge solve` in fixture mode on this log: on the dwell rows it reads, the effect "
                 "cannot be told apart from " +
                     (partners.empty() ? std::string("itself (its own components are collinear)") : partners);
      notes.push_back({{"effect", key}, {"reason", reason}, {"unobservable", dirs}, {"diagnosis_estimate", estimate}});
      std::fprintf(stderr, "imuforge diagnose: --emit-model: %s left out (not observable by the fixture solver on this log)\n",
                   key.c_str());
    }
  }
}

int run_diagnose(int argc, char** argv) {
  CLI::App app{"Sim-to-real gap diagnosis: where the residual lies, which unmodelled catalog effect explains it, "
               "and how far the held-out gap shrinks (docs/diagnosis.md)",
               argv[0]};
  std::string log_path, model_path, sim_path, out_dir, mode = "auto", cv = "auto", sensor_path;
  diagnosis::Options opt;
  bool explain_poses = false;
  app.add_option("--log", log_path, "log to diagnose (log v1: CSV, binary or HDF5)")->required();
  app.add_option("--model", model_path, "model spec JSON in use (docs/formats.md), a cal.json with a \"model\", or 'basic'")->required();
  app.add_option("--sim", sim_path, "simulation log of the same campaign: its static Allan curve is the claimed noise, "
                                    "and it supplies references the real log lacks");
  std::string campaign_path;
  app.add_option("--campaign", campaign_path,
                 "campaign the log was taken with: its table geometry lets the diagnosis estimate the table's axis tilts and "
                 "encoder zeros with the base model and re-evaluate the reference at them (needs the log's table angles)");
  app.add_option("--sensor", sensor_path, "sensor model JSON: its white_noise densities are the claimed noise");
  app.add_option("--out", out_dir, "output folder (diagnosis.json, report.html)")->required();
  app.add_flag("--explain-poses", explain_poses,
               "reference-free: print every stretch of the recording (start, end, duration, mean, verdict/reason)");
  app.add_option("--mode", mode, "fixture | reference-free | auto (reference-free when the log has no reference)")
      ->check(CLI::IsMember({"auto", "fixture", "reference-free"}));
  app.add_option("--cv", opt.cv, "withholding: segment (K-fold by segment) | plateau (leave-one-plateau-out) | auto")
      ->check(CLI::IsMember({"auto", "segment", "plateau"}));
  app.add_option("--folds", opt.folds, "K for K-fold by segment")->check(CLI::Range(2, 100));
  app.add_option("--alpha", opt.alpha, "family-wise significance level (Bonferroni across candidates)")->check(CLI::Range(1e-12, 0.5));
  app.add_option("--max-steps", opt.max_steps, "forward-selection steps (each followed by a backward pass)")->check(CLI::Range(0, 50));
  std::string emit_model;
  app.add_option("--emit-model", emit_model, "write the model in use plus the selected effects (model spec JSON) here");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? app::kExitOk : app::kExitUsage;
  }

  try {
    diagnosis::BaseModel base;
    if (model_path == "basic") {
      base = diagnosis::basic_model();
    } else {
      nlohmann::json j = io::read_json_file(model_path);
      if (j.is_object() && j.contains("model") && j["model"].is_object()) j = j["model"];  // a cal.json
      try {
        base = diagnosis::base_model_from_spec(model::model_spec_from_json(j));
      } catch (const std::exception& e) {
        std::fprintf(stderr, "imuforge diagnose: %s: %s\n", model_path.c_str(), e.what());
        return app::exit_code_for(e);
      }
    }
    if (!sensor_path.empty()) {
      model::SensorModel sm = model::load_sensor_model(sensor_path);
      const char* ax[6] = {"accel.white_noise.x", "accel.white_noise.y", "accel.white_noise.z",
                           "gyro.white_noise.x",  "gyro.white_noise.y",  "gyro.white_noise.z"};
      const auto eff = sm.effective_params();
      for (int a = 0; a < 6; ++a) {
        const double v = eff.get(ax[a]);
        if (v > 0) opt.claimed_N[static_cast<std::size_t>(a)] = v;
      }
    }

    diagnosis::LogSource real(log_path);
    if (!campaign_path.empty()) {
      physics::Campaign c;
      try {
        c = io::load_campaign(campaign_path);  // its errors name the file
      } catch (const std::exception& e) {
        std::fprintf(stderr, "imuforge diagnose: --campaign: %s\n", e.what());
        return app::exit_code_for(e);
      }
      try {
        opt.table = diagnosis::table_of_campaign(c, real.meta().table_axes, "--campaign " + campaign_path);
      } catch (const diagnosis::DiagnosisError& e) {
        std::fprintf(stderr, "imuforge diagnose: %s (%s)\n", e.what(), log_path.c_str());
        return app::kExitUsage;
      }
    }
    std::unique_ptr<diagnosis::LogSource> sim;
    std::unique_ptr<diagnosis::PairedSource> paired;
    diagnosis::SampleSource* src = &real;
    if (!sim_path.empty()) {
      sim = std::make_unique<diagnosis::LogSource>(sim_path);
      opt.sim_allan = diagnosis::static_allan(*sim, opt);
      paired = std::make_unique<diagnosis::PairedSource>(real, *sim);
      src = paired.get();
    }
    // Reference-free when asked, or when no row carries a reference.
    bool any_ref = false;
    {
      src->rewind();
      diagnosis::Sample s;
      while (src->next(s))
        if (s.has_ref) {
          any_ref = true;
          break;
        }
    }
    std::unique_ptr<diagnosis::ReferenceFreeSource> rf;
    std::unique_ptr<diagnosis::ReferenceSegmentSource> segs;
    if (opt.table.known && (mode == "reference-free" || !any_ref)) {
      std::fprintf(stderr, "imuforge diagnose: --campaign needs a log with a fixture reference; %s is diagnosed reference-free\n", log_path.c_str());
      return app::kExitUsage;
    }
    if (mode == "reference-free" || (mode == "auto" && !any_ref)) {
      rf = std::make_unique<diagnosis::ReferenceFreeSource>(*src, real.meta().gravity_mps2, poses::DetectOptions{},
                                                            real.meta().accel_lsb_mps2, real.meta().gyro_lsb_rad_s,
                                                            real.meta().sample_rate_hz);
      src = rf.get();
      if (explain_poses) std::printf("%s", poses::explain_table(rf->detection()).c_str());
      std::printf("reference-free: %d static poses (%.0f s); gravity-magnitude fit with %d parameters: RMS over poses %.4g -> %.4g m/s^2\n",
                  rf->info().poses, rf->info().static_s, rf->info().calibrated_params, rf->info().accel_rms_before, rf->info().accel_rms_after);
      std::string added;
      for (const auto& t : rf->info().terms_added) added += (added.empty() ? "" : ", ") + t;
      std::printf("reference-free term selection (as solve): added [%s]; %s\n", added.c_str(), rf->info().terms_note.c_str());
    } else if (mode == "fixture" && !any_ref) {
      std::fprintf(stderr, "imuforge diagnose: %s has no reference columns; use --mode reference-free or --sim\n", log_path.c_str());
      return app::kExitFailed;
    }

    if (!rf && any_ref) {
      segs = std::make_unique<diagnosis::ReferenceSegmentSource>(*src);
      if (segs->changes()) src = segs.get();
    }
    opt.output_lsb = {real.meta().accel_lsb_mps2, real.meta().gyro_lsb_rad_s};
    diagnosis::DiagnosisResult r = diagnosis::diagnose(*src, base, opt);
    if (segs && segs->derived())
      r.warnings.push_back("the log's segment column carries no schedule (" + std::to_string(segs->logged_segments()) +
                           " dwell indices): " + std::to_string(segs->derived_segments()) +
                           " segments cut at the steps and kinks of the reference, which the folds withhold whole");
    else if (segs && segs->split_segments() > 0)
      r.warnings.push_back("the reference steps or kinks " + std::to_string(segs->split_segments()) +
                           " times within a logged segment: each part withheld as a dwell of its own");
    if (rf) r.warnings.push_back("reference-free mode: references are pseudo-references from the gravity direction of each static pose; "
                                 "errors along a pose's own direction and all rate-dependent effects are invisible");
    // A simulated or real table is never perfect: without its geometry its axis tilts and encoder zeros stay in
    // the residual (campaign-eol's automotive log: read as accel scale_asymmetry, 1 false effect).
    if (!rf && !opt.table.known && real.meta().table_axes > 0)
      r.warnings.push_back("the log carries the rate table's reported angles (" + std::to_string(real.meta().table_axes) +
                           " axes) but no --campaign was given: the table's axis tilts and encoder zeros are not estimated "
                           "and stay in the residual, where they can read as accelerometer effects; --campaign C.json "
                           "estimates them (docs/diagnosis.md § 6, \"Fixture errors\")");
    std::error_code ec;
    std::filesystem::create_directories(out_dir, ec);
    if (ec) {
      std::fprintf(stderr, "imuforge diagnose: cannot create '%s': %s\n", out_dir.c_str(), ec.message().c_str());
      return app::kExitFailed;
    }
    if (!emit_model.empty()) {
      // The base model file as given (or the basic model), plus every selected deterministic effect the
      // solver can identify on this log (keep_solver_identifiable).
      nlohmann::json mj;
      if (model_path == "basic") {
        mj = {{"format", "imuforge-model"}, {"version", 1}, {"name", "basic"}, {"T_ref_C", 25.0}, {"effects", nlohmann::json::object()}};
        for (const auto& e : base.effect_names) mj["effects"][e] = nlohmann::json::object();
      } else {
        mj = io::read_json_file(model_path);
        if (mj.is_object() && mj.contains("model") && mj["model"].is_object()) mj = nlohmann::json(mj["model"]);
      }
      if (mj["effects"].is_array()) {  // ["accel.bias", ...] -> {"accel.bias": {}, ...}
        nlohmann::json o = nlohmann::json::object();
        for (const auto& e : mj["effects"]) o[e.get<std::string>()] = nlohmann::json::object();
        mj["effects"] = o;
      }
      std::set<std::string> added;
      for (const auto& st : r.selected) {
        const std::string key = st.sensor + "." + st.effect;
        if (!mj["effects"].contains(key)) added.insert(key);
        mj["effects"][key] = nlohmann::json::object();
        // The components of the diagnosis's final fit: an effect whose components on one axis were withdrawn
        // (a stand-in there for an out-of-catalog function, "kept on …" in the warnings) is emitted without
        // them, so the solver does not fit that function with them again.
        if (!added.count(key)) continue;
        std::set<std::string> comps;
        for (const auto& pe : r.final_params)
          if (effect_key_of(pe.name) == key) comps.insert(pe.name.substr(key.size() + 1, pe.name.find('@') - key.size() - 1));
        nlohmann::json one = {{"format", "imuforge-model"}, {"version", 1}, {"effects", {{key, nlohmann::json::object()}}}};
        const std::size_t all = model::model_spec_from_json(one).parameters().size();
        if (!comps.empty() && comps.size() < all) mj["effects"][key]["components"] = comps;
      }
      mj["name"] = mj.value("name", std::string("model")) + "+diagnosis";
      // The threshold the diagnosis built temp_hysteresis's d(t) at, so the solver builds the same one.
      bool has_hyst = false;
      for (const auto& [key, v] : mj["effects"].items()) has_hyst = has_hyst || key.find("temp_hysteresis") != std::string::npos;
      if (has_hyst && !r.hysteresis_threshold_given && !mj.contains("hysteresis_threshold_C"))
        mj["hysteresis_threshold_C"] = r.hysteresis_threshold_C;
      // The solver leaves dwell rows within its dwell guard of a reference change out, so that a late or early
      // time stamp does not read the motion into a dwell (solver::DwellGuard). A timing shift the guard would
      // not cover (the largest |λ + 1e-6·ε·t| over the log, at either end) gets a guard 1.5× that, in 0.1 s.
      {
        const double shift_s = diagnosis::max_timing_shift_s(r);
        const double guard_s = solver::dwell_guard_of(model::model_spec_from_json(mj));
        if (guard_s > 0 && shift_s > 0.8 * guard_s) {
          const double g = std::ceil(15.0 * shift_s) / 10.0;
          mj["dwell_guard_s"] = g;
          mj["_diagnosis"]["dwell_guard"] = {{"max_timing_shift_s", shift_s}, {"guard_s", g}, {"was_s", guard_s}};
          std::fprintf(stderr,
                       "imuforge diagnose: --emit-model: timing shift up to %.3g s over the log; dwell_guard_s %.3g s "
                       "(was %.3g s) so the solver's dwell means stay clear of the motion\n",
                       shift_s, g, guard_s);
        }
      }
      if (!rf && sim_path.empty()) {
        try {
          keep_solver_identifiable(mj, log_path, added, r);
        } catch (const std::exception& e) {  // e.g. a model the fixture solver refuses for another reason
          mj["_diagnosis"]["solver_check"] = std::string("not done: ") + e.what();
        }
      }
      io::StagedFile staged(emit_model);  // never a partial model file
      {
        std::ofstream o(staged.path());
        o << mj.dump(2) << "\n";
        if (!o) {
          std::fprintf(stderr, "imuforge diagnose: cannot write %s\n", emit_model.c_str());
          return app::kExitFailed;
        }
      }
      staged.commit();
    }
    nlohmann::json j = diagnosis::to_json(r);
    j["inputs"] = {{"log", log_path}, {"model", model_path}, {"sim", sim_path}, {"mode", rf ? "reference-free" : "fixture"}};
    {
      std::ofstream o(out_dir + "/diagnosis.json");
      o << j.dump(2) << "\n";
      if (!o) {
        std::fprintf(stderr, "imuforge diagnose: cannot write %s/diagnosis.json\n", out_dir.c_str());
        return app::kExitFailed;
      }
    }
    {
      std::ofstream o(out_dir + "/report.html");
      o << diagnosis::report_html(r);
      if (!o) {
        std::fprintf(stderr, "imuforge diagnose: cannot write %s/report.html\n", out_dir.c_str());
        return app::kExitFailed;
      }
    }
    std::fputs(diagnosis::summary_text(r).c_str(), stdout);
    std::printf("wrote %s/diagnosis.json and %s/report.html\n", out_dir.c_str(), out_dir.c_str());
    return app::kExitOk;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge diagnose: %s\n", e.what());
    return app::exit_code_for(e);
  }
}

}  // namespace

IMUFORGE_COMMAND(diagnose, "sim-to-real gap: where, which unmodelled effect, how far it shrinks (held-out)", run_diagnose);
