// The navigator run shared by the Monte Carlo and the sensitivity: aligned to the truth at t = 0, reset to
// the truth (position and velocity; attitude too with Aiding::kPosVelAtt) after every update through
// sample i0, free from there through sample i1.
#pragma once

#include <cstddef>

#include "host/nav/strapdown.h"
#include "host/navigate/impact.h"
#include "host/sim/vehicle_sim.h"

namespace imuforge::navigate {

// sample(i, f, w): the compensated specific force and rate of sample i.
// observe(i, state): called after every free update (i > i0).
template <class Sample, class Observe>
void aided_run(const sim::VehicleTruth& truth, std::size_t i0, std::size_t i1, Aiding aiding, Sample&& sample,
               Observe&& observe) {
  const double dt = 1.0 / truth.rate_hz;
  nav::NavState s0;
  s0.q_nb = truth.states[0].q_nb;
  s0.v_ned = truth.states[0].v_ned;
  s0.pos = truth.states[0].pos;
  nav::Strapdown nav(s0);
  nav::SampleIntegrator integ;
  nav::Increment inc;
  Eigen::Vector3d f, w;
  for (std::size_t i = 0; i <= i1; ++i) {
    sample(i, f, w);
    if (!integ.push(f, w, dt, inc)) continue;
    nav.update(inc);
    const physics::VehicleState& t = truth.states[i];
    if (i <= i0) {
      nav.reset_position_velocity(t.pos, t.v_ned);
      if (aiding == Aiding::kPosVelAtt) nav.reset_attitude(t.q_nb);
    } else {
      observe(i, nav.state());
    }
  }
}

}  // namespace imuforge::navigate
