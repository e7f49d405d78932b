// Benchmark (prints, never asserts): diagnosing a 1-hour, 1 kHz campaign against the full catalog.
// The campaign is simulated once into a binary log (not timed), then `diagnose` streams it from disk.
#include <chrono>
#include <ctime>
#include <cstdio>
#include <filesystem>

#include "host/io/campaign_file.h"
#include "host/diagnosis/sources.h"
#include "host/io/log.h"
#include "host/diagnosis/table_errors.h"
#include "tests/diagnosis/sim_helpers.h"

using namespace diagtest;

// One case: simulate (once, not timed) into `log`, then time `diagnose` streaming it from disk.
// table: the diagnosis knows the campaign's table (`diagnose --campaign`) and estimates its axis errors.
void run_case(const char* title, const std::string& log, const json& camp, const json& sensor, bool table = false) {
  const auto c = imuforge::io::campaign_from_json(camp);
  const auto m = imuforge::model::sensor_model_from_json(sensor);
  imuforge::sim::SimOptions so;
  so.seed = 1;
  if (!std::filesystem::exists(log)) {
    imuforge::io::LogWriter w(log, imuforge::sim::make_log_meta(c, m, so));
    auto t0 = std::chrono::steady_clock::now();
    auto sum = imuforge::sim::simulate(c, m, so, w);
    w.close();
    std::printf("simulated %.0f s, %llu rows in %.1f s -> %s\n", sum.duration_s, static_cast<unsigned long long>(sum.rows),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), log.c_str());
  }
  imuforge::diagnosis::LogSource src(log);
  imuforge::diagnosis::Options o;
  if (table) o.table = imuforge::diagnosis::table_of_campaign(c, src.meta().table_axes, "bench campaign");
  auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  auto r = imuforge::diagnosis::diagnose(src, imuforge::diagnosis::basic_model(), o);
  const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  std::printf("%s\ndiagnose: %lld samples (%.0f s at %.0f Hz), %d blocks, %zu candidates, %zu selected, %d timing / %d mount "
              "re-runs: %.2f s wall, %.2f s CPU\n",
              title, r.n_samples, r.duration_s, r.sample_rate_hz, r.n_blocks, r.ranking.size(), r.selected.size(), r.timing_iterations,
              r.mount_iterations, dt, cpu);
  for (const auto& s : r.selected) std::printf("  selected %s.%s\n", s.sensor.c_str(), s.effect.c_str());
  if (r.mount_iterations > 0)
    std::printf("  mount rotation (%.3g, %.3g, %.3g) mrad\n", 1e3 * r.mount_rotation_rad[0], 1e3 * r.mount_rotation_rad[1],
                1e3 * r.mount_rotation_rad[2]);
  if (r.fixture_known) {
    std::printf("  table axis errors (%d re-runs), mrad:", r.fixture_iterations);
    for (int m = 0; m < r.fixture_est.n; ++m)
      std::printf(" %.3g+/-%.2g", 1e3 * r.fixture_error_rad[static_cast<std::size_t>(m)], 1e3 * r.fixture_est.sigma_rad[static_cast<std::size_t>(m)]);
    std::printf("\n");
  }
}

// Usage: diagnosis_bench [LOG [CASE]]. CASE (plain, mounted or table) runs that case alone, for profiling one path.
int main(int argc, char** argv) {
  const std::string log = argc > 1 ? argv[1] : (std::filesystem::temp_directory_path() / "imuforge-diag-bench.bin").string();
  const std::string only = argc > 2 ? argv[2] : "";
  if (!only.empty() && only != "plain" && only != "mounted" && only != "table") {
    std::fprintf(stderr, "diagnosis_bench: unknown case '%s' (plain, mounted or table)\n", only.c_str());
    return 2;
  }
  auto want = [&](const char* c) { return only.empty() || only == c; };
  const double fs_hz = 1000.0;
  // Repeat the rich campaign at several plateaus until it lasts an hour.
  const std::vector<double> plateaus = {25, 35, 15, 30, 20, 40, 10, 28, 33, 18, 38, 12, 26, 22, 36};
  json camp = rich_campaign(plateaus, fs_hz);
  if (want("plain")) run_case("1 h at 1 kHz, gyro g-sensitivity", log, camp, base_sensor(true, {{"gyro.g_sensitivity", {{"xz", 2e-4}}}}));
  // The costliest path: a gyro cross-coupling on a case mounted 0.1° off, which the diagnosis estimates and
  // re-runs at (docs/diagnosis.md, "Mount rotation"), each re-run a full pass over the log.
  camp["simulation"]["fixture_errors"] = {{"mount_error_deg", {0.0, 0.1, -0.06}}};
  if (want("mounted"))
    run_case("1 h at 1 kHz, gyro cross-coupling on a case mounted 0.1 deg off", log + ".mount.bin", camp,
           base_sensor(true, {{"gyro.g_sensitivity", {{"xz", 2e-4}}}, {"gyro.cross_coupling", {{"xz", 3e-3}, {"zx", -3e-3}}}}));
  // The table's axis tilted and its encoders' zeros offset (0.01–0.02°), diagnosed with the table known: the errors
  // are estimated in every run and the diagnosis re-runs on the re-evaluated reference (docs/diagnosis.md,
  // "Fixture errors").
  camp["simulation"]["fixture_errors"] = {{"axes", {{{"tilt_a_deg", 0.02}, {"tilt_b_deg", -0.01}, {"zero_deg", 0.01}},
                                                    {{"tilt_a_deg", -0.01}, {"tilt_b_deg", 0.015}, {"zero_deg", -0.02}},
                                                    {{"tilt_a_deg", 0.01}, {"tilt_b_deg", 0.02}, {"zero_deg", 0.01}}}}};
  if (want("table"))
    run_case("1 h at 1 kHz, gyro g-sensitivity, the table's axis errors estimated (--campaign)", log + ".table.bin", camp,
           base_sensor(true, {{"gyro.g_sensitivity", {{"xz", 2e-4}}}}), true);
  return 0;
}
