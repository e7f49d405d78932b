// Benchmark (not a test): simulate 1 h of 6-axis data at 1 kHz with EVERY catalog effect on and write
// the binary log. Target: ≤ 10 s on one core. Usage: sim_bench [out.bin] [hours]
#include <algorithm>
#include <chrono>
#include <ctime>
#include <fstream>
#include <cstdio>
#include <string>

#include "host/io/campaign_file.h"
#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"
#include "host/sim/simulator.h"

using namespace imuforge;
using nlohmann::json;

int main(int argc, char** argv) {
  const std::string out = argc > 1 ? argv[1] : "/tmp/imuforge-sim-bench.bin";
  const double hours = argc > 2 ? std::stod(argv[2]) : 1.0;
  const std::string ex = std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/";
  model::SensorModel m = model::load_sensor_model(ex + "sensor-tactical.json");
  // Switch on every effect: a small value for any parameter the example leaves at zero.
  for (const auto& p : model::params()) {
    m.enabled[static_cast<int>(p.sensor)][static_cast<int>(p.effect)] = true;
    if (m.params[p.id] == 0.0) {
      double v = 1e-6;
      if (p.effect == model::Effect::kSaturation) v = 1e3;
      if (p.effect == model::Effect::kQuantization) v = 1e-7;
      if (p.effect == model::Effect::kBiasInstability && p.component == "tau_s") v = 100;
      m.params[p.id] = v;
    }
  }
  // A campaign of tumbles and rate runs filling the requested time at 1 kHz, with a thermal ramp.
  json c = json::parse(std::ifstream(ex + "campaign-eol.json"));
  c["sample_rate_hz"] = 1000;
  json steps = json::array();
  steps.push_back({{"use", "tumble24"}});
  steps.push_back({{"use", "rates"}});
  c["phases"] = json::array();
  c["phases"].push_back({{"type", "plateau"}, {"setpoint_C", 25}, {"soak_s", 0}, {"steps", steps}});
  physics::Campaign base = io::campaign_from_json(c);
  const double one = physics::Campaign(base).nominal_duration_s();
  int reps = std::max(1, static_cast<int>(hours * 3600 / one) + 1);
  c["phases"] = json::array();
  for (int i = 0; i < reps; ++i)
    c["phases"].push_back({{"type", "plateau"}, {"setpoint_C", 25 + (i % 2) * 10}, {"soak_s", 0}, {"steps", steps}});
  double done = 0;
  {
    physics::Campaign tmp = io::campaign_from_json(c);
    done = tmp.nominal_duration_s();
  }
  if (done < hours * 3600)
    c["phases"].push_back({{"type", "plateau"}, {"setpoint_C", 25}, {"soak_s", hours * 3600 - done},
                           {"steps", json::array({{{"type", "soak"}, {"dwell_s", 1}}})}});
  physics::Campaign camp = io::campaign_from_json(c);
  sim::SimOptions opt;
  opt.seed = 1;
  opt.max_duration_s = hours * 3600;
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  io::LogWriter w(out, sim::make_log_meta(camp, m, opt), io::LogEncoding::kBinary);
  auto sum = sim::simulate(camp, m, opt, w);
  w.close();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  std::printf("sim_bench: %.0f s simulated at 1 kHz (%llu rows, every effect on, %d segments), binary log %s\n",
              sum.duration_s, static_cast<unsigned long long>(sum.rows), sum.segments, out.c_str());
  std::printf("sim_bench: wall %.2f s, CPU %.2f s (%.2f M rows/s of CPU, %.0f x real time)\n", wall, cpu,
              static_cast<double>(sum.rows) / cpu * 1e-6, sum.duration_s / cpu);
  return 0;
}
