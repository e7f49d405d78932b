#include "host/physics/campaign.h"

#include <algorithm>
#include <cmath>

namespace imuforge::physics {

std::size_t Campaign::num_steps() const {
  std::size_t n = 0;
  for (const auto& p : phases) n += p.steps.size();
  return n;
}

double Campaign::nominal_duration_s() const {
  // Mirrors the simulator's timeline (host/physics/timeline.cpp) closely: trapezoidal moves to the nearest
  // equivalent angle, accel-limited rate changes, stops before static steps.
  const std::size_t n = axes.size();
  std::array<double, 3> ang{}, rate{};
  auto move_time = [&](std::size_t i, double d) {
    const double v = axes[i].max_rate_dps, a = axes[i].max_accel_dps2, ad = std::fabs(d);
    return ad >= v * v / a ? 2 * v / a + (ad - v * v / a) / v : 2 * std::sqrt(ad / a);
  };
  auto rate_to = [&](const std::array<double, 3>& r1) {
    double dur = 0;
    for (std::size_t i = 0; i < n; ++i) {
      dur = std::max(dur, std::fabs(r1[i] - rate[i]) / axes[i].max_accel_dps2);
      // The angle travelled while changing rate.
      ang[i] += (r1[i] + rate[i]) / 2 * std::fabs(r1[i] - rate[i]) / axes[i].max_accel_dps2;
      rate[i] = r1[i];
    }
    return dur;
  };
  double t = 0, T = initial_C;
  for (const auto& p : phases) {
    t += rate_to({0, 0, 0});
    if (p.kind == CampaignPhase::Kind::kRamp) {
      t += std::fabs(p.setpoint_C - T) / (p.rate_C_per_min / 60.0);
      T = p.setpoint_C;
      continue;
    }
    t += std::fabs(p.setpoint_C - T) / (ramp_limit_C_per_min / 60.0) + p.soak_s;
    T = p.setpoint_C;
    for (const auto& s : p.steps) {
      using K = CampaignStep::Kind;
      switch (s.kind) {
        case K::kPosition: {
          t += rate_to({0, 0, 0});
          double dur = 0;
          for (std::size_t i = 0; i < n; ++i) {
            double tgt = s.position_deg[i];
            tgt += 360.0 * std::round((ang[i] - tgt) / 360.0);
            dur = std::max(dur, move_time(i, tgt - ang[i]));
            ang[i] = tgt;
          }
          t += dur + (s.settle_s >= 0 ? s.settle_s : settle_s);
          break;
        }
        case K::kRate:
          t += rate_to(s.rate_dps);
          for (std::size_t i = 0; i < n; ++i) ang[i] += rate[i] * s.dwell_s;
          break;
        case K::kRampRate:
          t += rate_to(s.rate_from_dps);
          for (std::size_t i = 0; i < n; ++i) {
            ang[i] += (s.rate_from_dps[i] + s.rate_dps[i]) / 2 * s.dwell_s;
            rate[i] = s.rate_dps[i];
          }
          break;
        case K::kSine: {
          t += rate_to({0, 0, 0});
          double dur = 0;
          for (std::size_t i = 0; i < n; ++i) dur = std::max(dur, move_time(i, s.amplitude_deg[i]));
          t += dur;
          rate = {0, 0, 0};  // approximately: the oscillation ends near rest in the timeline's next stop
          break;
        }
        case K::kSoak:
          t += rate_to({0, 0, 0});
          break;
        case K::kPose:
          t += rate_to({0, 0, 0}) + s.move_s;
          break;
      }
      t += s.dwell_s;
    }
  }
  return t;
}

}  // namespace imuforge::physics
