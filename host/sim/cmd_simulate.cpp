// imuforge simulate: campaign + sensor model -> raw log v1 (CSV or binary) + truth JSON.
#include <chrono>
#include <cstdio>
#include <fstream>

#include <CLI/CLI.hpp>

#include "host/io/campaign_file.h"
#include "host/app/command.h"
#include "host/io/staged_file.h"
#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"
#include "host/sim/simulator.h"

namespace {

int run_simulate(int argc, char** argv) {
  CLI::App app{"Simulate a campaign: true fixture motion and temperature in, raw IMU samples out.\n"
               "Writes log v1 (docs/formats.md): binary if --out ends in .bin (or --format bin), else CSV.",
               "imuforge simulate"};
  std::string campaign_path, sensor_path, out_path, truth_path, format = "auto", serial = "SIM-0001";
  std::uint64_t seed = 1;
  double rate_hz = 0, max_s = 0;
  bool no_fixture_errors = false, quiet = false;
  app.add_option("--campaign", campaign_path, "campaign JSON (docs/formats.md)")->required();
  app.add_option("--sensor", sensor_path, "sensor model JSON")->required();
  app.add_option("--seed", seed, "random seed (same seed -> bit-identical log)");
  app.add_option("--out", out_path, "output log (.csv or .bin)")->required();
  app.add_option("--truth", truth_path, "write the true parameters, realised turn-on bias, fixture errors, segments");
  app.add_option("--rate", rate_hz, "sample rate Hz (default: the campaign's)")->check(CLI::PositiveNumber);
  app.add_option("--max-duration", max_s, "stop after this many simulated seconds")->check(CLI::PositiveNumber);
  app.add_option("--format", format, "auto|csv|bin")->check(CLI::IsMember({"auto", "csv", "bin"}));
  app.add_option("--serial", serial, "serial written to the log metadata");
  app.add_flag("--no-fixture-errors", no_fixture_errors, "ignore the campaign's simulated fixture errors");
  app.add_flag("--quiet", quiet, "no summary on stderr");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? imuforge::app::kExitOk : imuforge::app::kExitUsage;
  }
  using namespace imuforge;
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
  io::LogEncoding enc = format == "csv" ? io::LogEncoding::kCsv
                        : format == "bin" ? io::LogEncoding::kBinary
                                          : io::LogEncoding::kAuto;
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
