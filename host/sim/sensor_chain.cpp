#include "host/sim/sensor_chain.h"

#include <algorithm>
#include <cmath>

namespace imuforge::sim {

using model::Effect;
using model::Sensor;

SensorChain::OutStage SensorChain::make_out(const model::SensorModel& m, Sensor s) {
  OutStage o;
  const auto& t = m.triad(s);
  o.inv_lsb = 1.0 / t.lsb;
  const double word = std::ldexp(1.0, t.bits - 1);
  o.lo = -word;
  o.hi = word - 1;
  if (t.range > 0) {
    o.lo = std::max(o.lo, std::floor(-t.range / t.lsb));
    o.hi = std::min(o.hi, std::ceil(t.range / t.lsb));
  }
  const auto p = m.effective_params();
  const auto ids_q = model::effect_params(s, Effect::kQuantization);
  const auto ids_s = model::effect_params(s, Effect::kSaturation);
  for (std::size_t j = 0; j < 3; ++j) {
    o.q[j] = p[ids_q[j]];
    o.sat[j] = p[ids_s[j]];
  }
  return o;
}

SensorChain::SensorChain(const model::SensorModel& m, double dt_s, std::uint64_t seed)
    : tri_{model::compile(m, Sensor::kAccel), model::compile(m, Sensor::kGyro)},
      out_{make_out(m, Sensor::kAccel), make_out(m, Sensor::kGyro)},
      rng_axis_{Rng(seed * 0x9E3779B97F4A7C15ULL + 11), Rng(seed * 0x9E3779B97F4A7C15ULL + 12),
                Rng(seed * 0x9E3779B97F4A7C15ULL + 13), Rng(seed * 0x9E3779B97F4A7C15ULL + 14),
                Rng(seed * 0x9E3779B97F4A7C15ULL + 15), Rng(seed * 0x9E3779B97F4A7C15ULL + 16)} {
  // Independent streams so switching one process on does not change the others' realisations.
  Rng rng_turn_on(seed * 0x9E3779B97F4A7C15ULL + 1);
  const model::ParamSet P = m.effective_params();
  for (int s = 0; s < 2; ++s) {
    const Sensor sn = static_cast<Sensor>(s);
    const auto wn = model::effect_params(sn, Effect::kWhiteNoise);
    const auto bi = model::effect_params(sn, Effect::kBiasInstability);
    const auto rw = model::effect_params(sn, Effect::kRateRandomWalk);
    const auto tb = model::effect_params(sn, Effect::kTurnOnBias);
    const double tau = P[bi[3]];
    for (std::size_t j = 0; j < 3; ++j) {
      const int ch = 3 * s + static_cast<int>(j);
      noise_[ch].configure(P[wn[j]], P[bi[j]], tau, P[rw[j]], dt_s, rng_axis_[ch]);
      turn_on_[ch] = P[tb[j]] * rng_turn_on.normal();
      if (m.on(sn, Effect::kTurnOnBias)) realised_[model::param_info(tb[j]).name] = turn_on_[ch];
    }
  }
}

void SensorChain::counts(Sensor s, const Eigen::Vector3d& y, std::int32_t out[3]) {
  const int si = static_cast<int>(s);
  const OutStage& o = out_[si];
  for (int j = 0; j < 3; ++j) {
    const int ch = 3 * si + j;
    double v = y[j] + turn_on_[ch] + noise_[ch].step(rng_axis_[ch]);
    if (o.q[j] > 0) v = o.q[j] * std::nearbyint(v / o.q[j]);
    if (o.sat[j] > 0) v = std::clamp(v, -o.sat[j], o.sat[j]);
    double c = std::nearbyint(v * o.inv_lsb);
    if (!(c >= o.lo)) c = o.lo;  // NaN also lands here: never an undefined cast
    if (c > o.hi) c = o.hi;
    out[j] = static_cast<std::int32_t>(c);
  }
}

}  // namespace imuforge::sim
