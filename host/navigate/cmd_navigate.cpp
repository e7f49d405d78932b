// `imuforge navigate`: what a calibration is worth in metres (docs/navigation.md).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "host/app/command.h"
#include "host/model/sensor_model.h"
#include "host/nav/strapdown.h"
#include "host/navigate/candidates.h"
#include "host/navigate/impact.h"
#include "host/navigate/report.h"
#include "host/navigate/sensitivity.h"
#include "host/sim/trajectory_file.h"
#include "host/sim/vehicle_sim.h"
#include "host/solver/calfile.h"

using namespace imuforge;

namespace {

// "START:DURATION" in seconds, or a segment label ("tunnel").
void parse_outage(const std::string& s, const physics::VehicleTrajectory& tr, double& start, double& dur, std::string& label) {
  const auto c = s.find(':');
  if (c == std::string::npos) {
    sim::labelled_span(tr, s, start, dur);
    label = s;
    return;
  }
  try {
    std::size_t p1 = 0, p2 = 0;
    start = std::stod(s.substr(0, c), &p1);
    dur = std::stod(s.substr(c + 1), &p2);
    if (p1 != c || p2 != s.size() - c - 1) throw std::invalid_argument("trailing characters");
  } catch (const std::exception&) {
    throw std::invalid_argument("--outage '" + s + "': expected START:DURATION in seconds (e.g. 300:60) or a segment label");
  }
}

int run_navigate(int argc, char** argv) {
  CLI::App app{"Navigation impact: horizontal error through a GNSS outage per calibration, Monte Carlo over sensor "
               "realisations (docs/navigation.md)",
               "imuforge navigate"};
  std::string traj_path, sensor_path, out_dir, outage = "tunnel", aiding = "pos-vel";
  std::vector<std::string> cals;
  int runs = 100, threads = 0;
  unsigned long long seed = 1;
  double spec_m = NAN, spec_at_s = NAN, ambient_C = NAN;
  app.add_option("--trajectory", traj_path, "trajectory file (docs/formats.md, docs/examples/trajectory-urban.json)")->required();
  app.add_option("--sensor", sensor_path, "sensor model file: the part being navigated (docs/examples/sensor-*.json)")->required();
  app.add_option("--cal", cals, "calibration file (cal.json from imuforge solve); repeat to compare");
  app.add_option("--outage", outage, "START:DURATION in seconds, or the label of a trajectory segment (default: tunnel)");
  app.add_option("--runs", runs, "sensor realisations")->check(CLI::Range(1, 100000));
  app.add_option("--seed", seed, "first seed (run r uses seed + r)");
  app.add_option("--out", out_dir, "output folder: nav.json and report.html")->required();
  app.add_option("--threads", threads, "worker threads (0: all cores)")->check(CLI::Range(0, 256));
  app.add_option("--aiding", aiding, "before the outage: pos-vel (reset position and velocity) or pos-vel-att (also attitude)")
      ->check(CLI::IsMember({"pos-vel", "pos-vel-att"}));
  app.add_option("--ambient-c", ambient_C, "override the trajectory's ambient temperature (°C)")->check(CLI::Range(-59.0, 124.0));
  app.add_option("--spec-m", spec_m, "report the calibration σ per parameter group that meets RMS horizontal error <= this (m)");
  app.add_option("--spec-at", spec_at_s, "time into the outage for --spec-m (s; default: the outage end, at most 60)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? app::kExitOk : app::kExitUsage;
  }
  try {
    sim::TrajectoryFile tf = sim::load_trajectory(traj_path);
    if (std::isfinite(ambient_C)) tf.ambient_C = ambient_C;
    const model::SensorModel sensor = model::load_sensor_model(sensor_path);
    navigate::ImpactOptions opt;
    std::string label;
    parse_outage(outage, tf.trajectory, opt.outage_start_s, opt.outage_s, label);
    opt.runs = runs;
    opt.seed = seed;
    opt.threads = threads;
    opt.aiding = aiding == "pos-vel" ? navigate::Aiding::kPosVel : navigate::Aiding::kPosVelAtt;
    const sim::VehicleTruth truth = sim::vehicle_truth(tf, sensor);
    const navigate::RawFormat fmt = navigate::raw_format(sensor);
    opt.accel_shift = fmt.accel_shift;
    opt.gyro_shift = fmt.gyro_shift;

    std::vector<navigate::Candidate> cands;
    cands.push_back(navigate::uncompensated_candidate(fmt));
    std::vector<solver::Estimate> estimates(1);
    for (const auto& c : cals) {
      cands.push_back(navigate::calibration_candidate(c, fmt, truth.temp_C));
      std::ifstream f(c);
      estimates.push_back(solver::calibration_from_json(nlohmann::json::parse(f)));
    }
    cands.push_back(navigate::oracle_candidate(sensor, fmt, truth.temp_C));
    estimates.emplace_back();
    for (const auto& c : cands)
      if (!c.dropped.empty()) {
        std::fprintf(stderr, "imuforge navigate: %s: not in table v1, not shipped:", c.name.c_str());
        for (const auto& d : c.dropped) std::fprintf(stderr, " %s", d.c_str());
        std::fprintf(stderr, "\n");
      }

    navigate::NavReport rep;
    rep.trajectory_path = traj_path;
    rep.trajectory_name = tf.name;
    rep.sensor_path = sensor_path;
    rep.sensor_name = sensor.name;
    rep.ambient_C = tf.ambient_C;
    rep.outage_label = label;
    rep.truth = &truth;
    for (std::size_t i = 1; i < truth.states.size(); ++i)
      rep.distance_m += nav::horizontal_offset_m(truth.states[i].pos, truth.states[i - 1].pos).norm();
    rep.opt = opt;
    rep.result = navigate::run_impact(truth, sensor, cands, opt);

    const double at = std::isfinite(spec_at_s) ? spec_at_s : rep.result.checkpoints_s.back();
    // Predicted RMS from each calibration's σ needs the sensitivity; compute it when asked for or when
    // any calibration carries σ.
    bool any_sigma = false;
    for (const auto& e : estimates)
      for (Eigen::Index i = 0; i < e.covariance.rows(); ++i) any_sigma = any_sigma || std::isfinite(e.covariance(i, i));
    if (std::isfinite(spec_m) || any_sigma) {
      double floor_m = 0;
      const auto& orc = rep.result.candidates.back();  // RMS of the oracle at `at`
      const std::size_t sec = static_cast<std::size_t>(std::lround(at));
      if (sec >= 1 && sec <= orc.hpos_m.front().size()) {
        double s2 = 0;
        for (const auto& run : orc.hpos_m) s2 += static_cast<double>(run[sec - 1]) * run[sec - 1];
        floor_m = std::sqrt(s2 / static_cast<double>(orc.hpos_m.size()));
      }
      navigate::SensitivityResult sens =
          navigate::sensitivity(truth, sensor, opt, std::isfinite(spec_m) ? spec_m : 1.0, at, floor_m);
      for (const auto& e : estimates) rep.predicted_rms_m.push_back(e.names.empty() ? NAN : sens.predicted_rms_m(e));
      if (std::isfinite(spec_m)) rep.sens = std::move(sens);  // the budget section only when asked for
    }
    navigate::write_nav_outputs(out_dir, rep);

    const std::size_t last = rep.result.checkpoints_s.size() - 1;
    std::printf("imuforge navigate: %s, %s, outage %g s at %g s, %d runs\n", tf.name.c_str(), sensor.name.c_str(), opt.outage_s,
                opt.outage_start_s, runs);
    std::printf("  %-28s", "horizontal error (m)");
    for (double c : rep.result.checkpoints_s) std::printf("   %4g s median/p95", c);
    std::printf("   heading %g s (deg)\n", rep.result.checkpoints_s.back());
    for (const auto& c : rep.result.candidates) {
      std::printf("  %-28s", c.name.c_str());
      for (const auto& s : c.hpos) std::printf("   %8.3g / %-8.3g", s.median, s.p95);
      std::printf("   %.3g / %.3g\n", c.heading_deg[last].median, c.heading_deg[last].p95);
    }
    std::printf("  cost: %.2f s CPU, %.2f s wall, %llu navigator steps\n", rep.result.cpu_s, rep.result.wall_s,
                static_cast<unsigned long long>(rep.result.nav_steps));
    std::printf("  report: %s/report.html\n", out_dir.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge navigate: error: %s\n", e.what());
    return app::kExitFailed;
  }
  return app::kExitOk;
}

}  // namespace

IMUFORGE_COMMAND(navigate, "navigation impact of calibrations through a GNSS outage (Monte Carlo)", run_navigate);
