// Benchmark: the urban trajectory (10 min at 200 Hz) x 100 sensor realisations, the automotive example with
// one calibration (its oracle table), navigated over the whole 10 min (the outage is the last 60 s).
// Prints CPU seconds: sensor simulation + firmware kernel + navigator, one thread and all threads.
#include <cstdio>
#include <cstdlib>
#include <ctime>

#include "host/model/sensor_model.h"
#include "host/navigate/candidates.h"
#include "host/navigate/impact.h"
#include "host/sim/trajectory_file.h"
#include "host/sim/vehicle_sim.h"

using namespace imuforge;

int main(int argc, char** argv) {
  const int runs = argc > 1 ? std::atoi(argv[1]) : 100;
  const std::string src = IMUFORGE_SOURCE_DIR;
  const sim::TrajectoryFile tf = sim::load_trajectory(src + "/docs/examples/trajectory-urban.json");
  const model::SensorModel sensor = model::load_sensor_model(src + "/docs/examples/sensor-automotive.json");
  std::clock_t c0 = std::clock();
  const sim::VehicleTruth truth = sim::vehicle_truth(tf, sensor);
  const double truth_cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  const navigate::RawFormat fmt = navigate::raw_format(sensor);
  navigate::ImpactOptions opt;
  const double dur = static_cast<double>(truth.states.size() - 1) / truth.rate_hz;
  opt.outage_start_s = std::floor(dur) - 60;
  opt.outage_s = 60;
  opt.runs = runs;
  opt.accel_shift = fmt.accel_shift;
  opt.gyro_shift = fmt.gyro_shift;
  opt.threads = 1;
  const std::vector<navigate::Candidate> one = {navigate::oracle_candidate(sensor, fmt, truth.temp_C)};
  const navigate::ImpactResult r = navigate::run_impact(truth, sensor, one, opt);
  std::printf("navigate bench: %.0f s at %.0f Hz x %d runs, 1 calibration, 1 thread: %.2f s CPU (%.1f ns per sample: "
              "sensor simulation + kernel + navigator), truth %.2f s CPU once\n",
              opt.outage_start_s + opt.outage_s, truth.rate_hz, runs, r.cpu_s,
              1e9 * r.cpu_s / static_cast<double>(r.nav_steps), truth_cpu);
  opt.threads = 0;
  const navigate::ImpactResult r2 = navigate::run_impact(truth, sensor, one, opt);
  std::printf("navigate bench: all threads: %.2f s CPU, %.2f s wall\n", r2.cpu_s, r2.wall_s);
  std::printf("oracle horizontal error after 60 s: median %.3g m\n", r.candidates[0].hpos.back().median);
  return 0;
}
