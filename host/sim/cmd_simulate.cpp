// imuforge simulate: campaign (or vehicle trajectory) + sensor model -> raw log v1 (CSV or binary) + truth JSON.
#include <chrono>
#include <cstdio>
#include <fstream>

#include <CLI/CLI.hpp>

#include "host/app/cli_options.h"
#include "host/io/campaign_file.h"
#include "host/app/command.h"
#include "host/io/staged_file.h"
#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"
#include "host/sim/simulator.h"
#include "host/sim/trajectory_file.h"
#include "host/sim/vehicle_sim.h"

namespace {

int run_simulate(int argc, char** argv) {
  CLI::App app{"Simulate a campaign: true fixture motion and temperature in, raw IMU samples out.\n"
               "Writes log v1 (docs/formats.md): binary if --out ends in .bin, HDF5 if .h5 (or --format), else CSV.",
               "imuforge simulate"};
  std::string campaign_path, trajectory_path, sensor_path, out_path, truth_path, format = "auto", serial = "SIM-0001";
  std::uint64_t seed = 1;
  double rate_hz = 0, max_s = 0;
  bool no_fixture_errors = false, quiet = false;
  auto* oc = app.add_option("--campaign", campaign_path, "campaign JSON (docs/formats.md)");
  auto* ot = app.add_option("--trajectory", trajectory_path, "instead of a campaign: a vehicle trajectory (docs/formats.md)");
  oc->excludes(ot);
  ot->excludes(oc);
  app.add_option("--sensor", sensor_path, "sensor model JSON")->required();
  app.add_option("--seed", seed, "random seed (same seed -> bit-identical log)");
  app.add_option("--out", out_path, "output log (.csv, .bin or .h5)")->required();
  app.add_option("--truth", truth_path, "write the true parameters, realised turn-on bias, fixture errors, segments");
  app.add_option("--rate", rate_hz, "sample rate Hz (default: the campaign's)")->check(CLI::PositiveNumber);
  app.add_option("--max-duration", max_s, "stop after this many simulated seconds")->check(CLI::PositiveNumber);
  imuforge::app::add_log_format_option(app, format, "--format,--log-format");
  app.add_option("--serial", serial, "serial written to the log metadata");
  app.add_flag("--no-fixture-errors", no_fixture_errors, "ignore the campaign's simulated fixture errors");
  app.add_flag("--quiet", quiet, "no summary on stderr");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? imuforge::app::kExitOk : imuforge::app::kExitUsage;
  }
  using namespace imuforge;
  if (campaign_path.empty() == trajectory_path.empty()) {
    std::fprintf(stderr, "imuforge simulate: give --campaign or --trajectory\n");
    return app::kExitUsage;
  }
  io::LogEncoding enc = io::encoding_from_name(format);
  if (!trajectory_path.empty()) {
    try {
      const sim::TrajectoryFile tf = sim::load_trajectory(trajectory_path);
      const model::SensorModel m = model::load_sensor_model(sensor_path);
      io::LogWriter w(out_path, sim::vehicle_log_meta(tf, m, seed, serial), enc);
      const nlohmann::json truth = sim::simulate_vehicle_log(tf, m, seed, w);
      w.close();
      if (!truth_path.empty()) {
        std::ofstream t(truth_path);
        t << truth.dump(1) << "\n";
        if (!t) throw std::runtime_error(truth_path + ": cannot write truth file");
      }
      if (!quiet)
        std::fprintf(stderr, "simulated trajectory %s: %llu rows -> %s\n", tf.name.c_str(),
                     static_cast<unsigned long long>(truth["rows"].get<std::size_t>()), out_path.c_str());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "imuforge simulate: %s\n", e.what());
      return app::kExitFailed;
    }
    return app::kExitOk;
  }
  physics::Campaign campaign;
  model::SensorModel sensor;
  try {
    campaign = io::load_campaign(campaign_path);
    sensor = model::load_sensor_model(sensor_path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge simulate: %s\n", e.what());
    return app::exit_code_for(e);
  }
  sim::SimOptions opt;
  opt.seed = seed;
  opt.sample_rate_hz = rate_hz;
  opt.serial = serial;
  opt.use_campaign_fixture_errors = !no_fixture_errors;
  opt.max_duration_s = max_s;
  const auto t0 = std::chrono::steady_clock::now();
  sim::SimSummary sum;
  try {
    if (enc == io::LogEncoding::kAuto) enc = io::encoding_from_path(out_path);
    io::StagedFile out(out_path);
    io::LogWriter w(out.path(), sim::make_log_meta(campaign, sensor, opt), enc);
    sum = sim::simulate(campaign, sensor, opt, w);
    w.close();
    if (!truth_path.empty()) {
      io::StagedFile truth(truth_path);
      std::ofstream t(truth.path());
      t << sum.truth.dump(2) << "\n";
      t.close();
      if (!t) throw std::runtime_error(truth_path + ": cannot write truth file");
      truth.commit();
    }
    out.commit();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge simulate: %s\n", e.what());
    return app::exit_code_for(e);
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!quiet)
    std::fprintf(stderr, "simulated %.1f s (%llu rows, %d segments) in %.2f s wall (%.2f M rows/s) -> %s\n",
                 sum.duration_s, static_cast<unsigned long long>(sum.rows), sum.segments, wall,
                 static_cast<double>(sum.rows) / wall * 1e-6, out_path.c_str());
  return app::kExitOk;
}

}  // namespace

IMUFORGE_COMMAND(simulate, "simulate a campaign: true motion in, raw IMU samples out", run_simulate);
