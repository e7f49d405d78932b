// Vehicle trajectories (host/physics/vehicle.h, host/sim/trajectory_file.h) against closed forms, and the
// navigator on the simulator's ideal samples (the two are written independently: analytic derivatives and
// Euler rates on one side, the integrated mechanisation on the other).
#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "host/nav/strapdown.h"
#include "host/physics/vehicle.h"
#include "host/sim/trajectory_file.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace nav_vehicle_test {

using namespace imuforge;
using physics::VehicleSegment;
using Eigen::Vector3d;

namespace {

constexpr double kDeg = M_PI / 180.0;

VehicleSegment seg(VehicleSegment::Kind k, double dur, double a = 0, double b = 0, double tr = 0) {
  VehicleSegment s;
  s.kind = k;
  s.duration_s = dur;
  if (k == VehicleSegment::Kind::kAccelerate) s.speed_to_mps = a;
  if (k == VehicleSegment::Kind::kTurn) {
    s.radius_m = a;
    s.angle_rad = b;
    s.transition_s = tr;
  }
  if (k == VehicleSegment::Kind::kClimb) s.height_change_m = a;
  return s;
}

Eigen::Vector2d ne(const physics::VehicleState& a, const physics::VehicleState& b) {
  return nav::horizontal_offset_m(a.pos, b.pos);
}

}  // namespace

TEST(Vehicle, AccelerateTurnClimbMatchClosedForms) {
  using K = VehicleSegment::Kind;
  physics::VehicleStart st;
  st.latitude_deg = 40;
  st.heading_deg = 0;
  // 0 → 10 m/s in 10 s covers s·T/2 = 50 m; a 90° right turn of radius 50 m without transitions ends 50 m
  // north and 50 m east of its start; a climb gains its height exactly. (R = 160/π m makes the turn last
  // exactly 8 s, so it ends on a sample.)
  const double R = 160 / M_PI;
  physics::VehicleTrajectory tr(st, {seg(K::kAccelerate, 10, 10), seg(K::kTurn, 0, R, M_PI / 2, 0), seg(K::kClimb, 20, 12),
                                     seg(K::kCruise, 5)});
  const double T_turn = M_PI / 2 * R / 10;
  EXPECT_NEAR(tr.segment_end_s(1) - tr.segment_start_s(1), T_turn, 1e-12);
  const auto s = physics::sample_vehicle(tr, 100);
  const std::size_t i_acc = 1000, i_turn = static_cast<std::size_t>(std::lround((10 + T_turn) * 100));
  EXPECT_NEAR(ne(s[i_acc], s[0]).x(), 50.0, 2e-3);
  EXPECT_NEAR(ne(s[i_acc], s[0]).y(), 0.0, 1e-6);
  const Eigen::Vector2d d = ne(s[i_turn], s[i_acc]);
  EXPECT_NEAR(d.x(), R, 5e-3);
  EXPECT_NEAR(d.y(), R, 5e-3);
  EXPECT_NEAR(nav::heading_rad(s[i_turn].q_nb), M_PI / 2, 1e-9);
  const std::size_t i_climb = i_turn + 2000;
  EXPECT_NEAR(s[i_climb].pos.h_m - s[i_turn].pos.h_m, 12.0, 1e-3);

  // Mid-turn: specific force is the centripetal s²/R to the right (body y), −g down, and the yaw rate is
  // s/R, each up to the Earth terms (2Ω v ≈ 1e-3 m/s², Ω ≈ 7e-5 rad/s).
  const physics::VehicleState& m = s[static_cast<std::size_t>(std::lround((10 + T_turn / 2) * 100))];
  EXPECT_NEAR(m.f_b.y(), 100.0 / R, 2e-3);
  EXPECT_NEAR(m.f_b.x(), 0.0, 2e-3);
  EXPECT_NEAR(m.f_b.z(), -physics::normal_gravity_mps2(physics::Site{40, 0}), 2e-3);
  EXPECT_NEAR(m.w_b.z(), 10.0 / R, 1e-4);
  // Mid-acceleration: the raised-cosine peak 2·Δs/T forward.
  EXPECT_NEAR(s[500].f_b.x(), 2.0, 2e-3);
}

TEST(Vehicle, RejectsImpossibleChainsNamingTheSegment) {
  using K = VehicleSegment::Kind;
  physics::VehicleStart st;
  try {
    physics::VehicleTrajectory tr(st, {seg(K::kStand, 5), seg(K::kTurn, 0, 20, 1.0, 1)});
    FAIL() << "a turn at zero speed was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("segments[1]"), std::string::npos) << e.what();
  }
  EXPECT_THROW(physics::VehicleTrajectory(st, {seg(K::kAccelerate, 5, 10), seg(K::kStand, 5)}), std::invalid_argument);
  EXPECT_THROW(physics::VehicleTrajectory(st, {seg(K::kAccelerate, 5, 2), seg(K::kClimb, 2, 10)}), std::invalid_argument);
}

TEST(TrajectoryFile, ErrorsNameTheKey) {
  auto msg = [](const std::string& text) {
    try {
      sim::trajectory_from_json(nlohmann::json::parse(text));
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::string start = R"("start": {"latitude_deg": 48, "longitude_deg": 11})";
  EXPECT_NE(msg("{" + start + R"(, "segments": [{"type": "stand", "duration": 3}]})").find("segments[0]: unknown key 'duration'"),
            std::string::npos);
  EXPECT_NE(msg("{" + start + R"(, "segments": [{"type": "jump", "duration_s": 3}]})").find("segments[0].type"), std::string::npos);
  EXPECT_NE(msg(R"({"segments": [{"type": "stand", "duration_s": 3}]})").find("start"), std::string::npos);
  EXPECT_NE(msg("{" + start + R"(, "segments": [{"type": "turn", "radius_m": -1, "angle_deg": 90}]})").find("segments[0]"),
            std::string::npos);
}

// The shipped example: about 10 minutes, stops, four turns, a 60 s tunnel.
TEST(TrajectoryFile, UrbanExampleHasStopsTurnsAndA60sTunnel) {
  const sim::TrajectoryFile tf = sim::load_trajectory(std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/trajectory-urban.json");
  EXPECT_NEAR(tf.trajectory.duration_s(), 600, 30);
  double t0 = 0, dur = 0;
  sim::labelled_span(tf.trajectory, "tunnel", t0, dur);
  EXPECT_NEAR(dur, 60.0, 1e-3);
  int stands = 0, turns = 0;
  for (const auto& s : tf.trajectory.segments()) {
    stands += s.kind == VehicleSegment::Kind::kStand;
    turns += s.kind == VehicleSegment::Kind::kTurn;
  }
  EXPECT_GE(stands, 3);
  EXPECT_GE(turns, 4);
}

// Ideal samples of the urban trajectory through the navigator, free from the start for the full 10 min:
// the error stays at the level of the trapezoid/coning truncation, millimetres, where a sign or frame
// mistake in either the simulator or the mechanisation would give hundreds of metres. A 60 s free run from
// the tunnel entrance with attitude, position and velocity from the truth stays below a millimetre.
TEST(Vehicle, NavigatorFollowsTheSimulatedUrbanTrajectory) {
  const sim::TrajectoryFile tf = sim::load_trajectory(std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/trajectory-urban.json");
  const auto s = physics::sample_vehicle(tf.trajectory, tf.sample_rate_hz);
  auto run = [&](std::size_t from, std::size_t to) {
    nav::NavState s0;
    s0.q_nb = s[from].q_nb;
    s0.v_ned = s[from].v_ned;
    s0.pos = s[from].pos;
    nav::Strapdown n(s0);
    nav::SampleIntegrator integ;
    nav::Increment inc;
    double worst = 0;
    for (std::size_t i = from; i <= to; ++i) {
      if (integ.push(s[i].f_b, s[i].w_b, 1.0 / tf.sample_rate_hz, inc)) n.update(inc);
      if (i == from) continue;
      n.hold_height(s[i].pos.h_m, s[i].v_ned.z());  // the free vertical channel diverges by nature
      worst = std::max(worst, nav::horizontal_offset_m(n.state().pos, s[i].pos).norm());
    }
    return worst;
  };
  const double full = run(0, s.size() - 1);
  double t0 = 0, dur = 0;
  sim::labelled_span(tf.trajectory, "tunnel", t0, dur);
  const std::size_t i0 = static_cast<std::size_t>(std::lround(t0 * tf.sample_rate_hz));
  const double tunnel = run(i0, i0 + static_cast<std::size_t>(std::lround(60 * tf.sample_rate_hz)));
  EXPECT_LT(full, 0.05) << "10 min free";
  EXPECT_LT(tunnel, 2e-3) << "60 s free from the tunnel entrance";
  RecordProperty("free_10min_m", std::to_string(full));
  std::printf("ideal samples: worst horizontal error %.3g m over 10 min free, %.3g m over the 60 s tunnel\n", full, tunnel);
}
}  // namespace nav_vehicle_test
