// A 16-unit batch on the end-of-line campaign (issue 14 figures): every unit its own part (sensor-matched
// with a 20 % part-to-part spread of every parameter, its own noise seed), one dead (no log), one far
// from its batch (accel.scale.x +0.025). Solved with `solve_batch` on the thread pool, fixture tolerance
// stated; prints per-unit verdicts, solve CPU per unit, the process's peak RSS, and writes the report.
//   eol_bench_batch [units=16] [rate_hz=50] [threads=0] [out_dir=/tmp/imuforge-batch]
#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>

#include "host/eol/batch.h"
#include "host/eol/report.h"
#include "host/io/campaign_file.h"
#include "host/sim/simulator.h"

using namespace imuforge;
using nlohmann::json;
namespace fs = std::filesystem;

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 16;
  const double rate = argc > 2 ? std::atof(argv[2]) : 50.0;
  const int threads = argc > 3 ? std::atoi(argv[3]) : 0;
  const fs::path dir = argc > 4 ? argv[4] : "/tmp/imuforge-batch";
  fs::create_directories(dir);
  json c = json::parse(std::ifstream(IMUFORGE_SOURCE_DIR "/docs/examples/campaign-eol.json"));
  c["sample_rate_hz"] = rate;
  const physics::Campaign camp = io::campaign_from_json(c);
  const model::ModelSpec spec = model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-thermal.json");
  const model::SensorModel base = model::load_sensor_model(IMUFORGE_SOURCE_DIR "/docs/examples/sensor-matched.json");
  json stj = {{"name", "bench-batch"},
              {"fixture_tolerance", {{"axes", {{"tilt_sigma_deg", 0.002}, {"zero_sigma_deg", 0.003}}}, {"mount_sigma_deg", 0.01}}}};
  stj["limits"]["parameters"] = {{"accel.bias", {{"abs", 1.0}}}, {"accel.scale", {{"abs", 0.05}, {"sigma", 1e-3}}},
                                 {"accel.misalign", {{"abs", 0.03}, {"sigma", 5e-4}}}, {"gyro.bias", {{"abs", 0.5}}},
                                 {"gyro.scale", {{"abs", 0.05}, {"sigma", 1e-3}}}, {"gyro.misalign", {{"abs", 0.03}, {"sigma", 5e-4}}}};
  const eol::StationConfig st = eol::station_from_json(stj, dir.string());
  std::mt19937_64 rng(2026);
  std::normal_distribution<double> n01;
  std::vector<eol::BatchUnit> units;
  const int dead = n > 6 ? 6 : -1, outlier = n > 11 ? 11 : -1;
  double sim_s = 0;
  for (int u = 0; u < n; ++u) {
    char slot[16];
    std::snprintf(slot, sizeof slot, "slot%02d", u + 1);
    const std::string log = (dir / (std::string(slot) + ".bin")).string();
    units.push_back({slot, "SN-" + std::to_string(2000 + u), log});
    fs::remove(log);
    model::SensorModel m = base;
    for (model::ParamId id : spec.parameters()) {
      const std::string nm = model::param_info(id).name;
      m.params.set(nm, m.params.get(nm) * (1.0 + 0.2 * n01(rng)));
    }
    if (u == outlier) m.params.set("accel.scale.x", m.params.get("accel.scale.x") + 0.025);
    if (u == dead) continue;
    sim::SimOptions opt;
    opt.seed = 700 + static_cast<std::uint64_t>(u);
    io::LogWriter w(log, sim::make_log_meta(camp, m, opt));
    sim_s = sim::simulate(camp, m, opt, w).duration_s;
    w.close();
  }
  eol::BatchOptions bo;
  bo.threads = threads;
  const eol::BatchOutcome b = eol::solve_batch(units, st, spec, camp, bo);
  const std::string report = (dir / "batch-report.html").string();
  eol::write_file_atomic(report, eol::render_batch_report(b, "Batch bench-batch: " + std::to_string(n) + " units, campaign-eol"));
  double cpu = 0;
  int solved = 0;
  for (const auto& u : b.units) {
    std::printf("%-7s %-8s %s  cpu %.2f s  %s%s\n", u.slot.c_str(), u.serial.c_str(), u.pass ? "PASS" : "FAIL", u.cpu_s,
                u.reasons.empty() ? "" : u.reasons[0].c_str(), u.outliers.empty() ? "" : ("  outlier: " + u.outliers[0]).c_str());
    if (u.solved) {
      cpu += u.cpu_s;
      ++solved;
    }
  }
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  std::printf("campaign-eol %.0f s simulated at %.0f Hz; %d of %d units pass; solve + fixture consider: %.2f s CPU per unit "
              "(mean of %d), %.1f s wall on %d threads; process peak RSS %.0f MB\nreport %s\n",
              sim_s, rate, b.passed, n, solved ? cpu / solved : 0.0, solved, b.wall_s, b.threads, ru.ru_maxrss / 1024.0,
              report.c_str());
  for (const auto& u : units) fs::remove(u.log_path);
  return 0;
}
