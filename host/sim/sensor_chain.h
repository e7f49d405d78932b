// The sensor from its deterministic output to raw counts: turn-on bias, noise processes (white, bias
// instability, rate random walk), quantization, saturation, LSB and word width. One implementation for the
// bench-campaign simulator and the vehicle simulator, so a sensor file means the same part in both.
#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "host/model/measure.h"
#include "host/model/sensor_model.h"
#include "host/sim/noise.h"

namespace imuforge::sim {

class SensorChain {
 public:
  // dt_s: sample interval. The random streams are derived from seed as the campaign simulator always has
  // (turn-on bias: seed·K + 1, axis noise: seed·K + 11..16), so a seed gives the same realisation in both.
  SensorChain(const model::SensorModel& m, double dt_s, std::uint64_t seed);

  const model::CompiledTriad& triad(model::Sensor s) const { return tri_[static_cast<int>(s)]; }
  // Timing of a triad: the simulator evaluates the motion at t − latency − ppm·1e-6·t.
  double shifted_time(model::Sensor s, double t_s) const {
    const auto& c = tri_[static_cast<int>(s)];
    return t_s - c.latency_s - c.ppm * 1e-6 * t_s;
  }
  bool has_timing(model::Sensor s) const {
    const auto& c = tri_[static_cast<int>(s)];
    return c.latency_s != 0 || c.ppm != 0;
  }
  // Raw counts of triad s for one sample, from the deterministic output y (SI, model::measure()).
  // Advances that triad's noise processes by one sample. O(1).
  void counts(model::Sensor s, const Eigen::Vector3d& y, std::int32_t out[3]);
  // Realised turn-on biases {param name: value} of the enabled turn-on effects.
  const nlohmann::json& realised() const { return realised_; }

 private:
  struct OutStage {
    double q[3] = {0, 0, 0};
    double sat[3] = {0, 0, 0};
    double inv_lsb = 1, lo = 0, hi = 0;
  };
  static OutStage make_out(const model::SensorModel& m, model::Sensor s);
  model::CompiledTriad tri_[2];
  OutStage out_[2];
  AxisNoise noise_[6];
  Rng rng_axis_[6];
  double turn_on_[6] = {};
  nlohmann::json realised_ = nlohmann::json::object();
};

}  // namespace imuforge::sim
