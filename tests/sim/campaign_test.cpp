// Campaign parsing, timeline, thermal, and the simulator end to end.
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "host/io/campaign_file.h"
#include "host/io/log.h"
#include "host/model/measure.h"
#include "host/physics/campaign.h"
#include "host/physics/earth.h"
#include "host/sim/simulator.h"
#include "host/physics/timeline.h"
#include "host/sim/noise.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace sim_campaign_test {

using namespace imuforge;
using nlohmann::json;

namespace {

std::string ex(const char* f) { return std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/" + f; }

model::SensorModel ideal_sensor() {
  json j = {{"name", "ideal"},
            {"accel", {{"lsb", 1e-7}, {"bits", 32}}},
            {"gyro", {{"lsb", 1e-8}, {"bits", 32}}}};  // ±21 rad/s: above every table rate
  return model::sensor_model_from_json(j);
}

std::vector<io::LogRow> run(const physics::Campaign& c, const model::SensorModel& m, std::uint64_t seed) {
  std::vector<io::LogRow> out;
  sim::SimOptions o;
  o.seed = seed;
  sim::simulate(c, m, o, [&](const io::LogRow& r) { out.push_back(r); });
  return out;
}

std::string parse_error(const json& j) {
  try {
    io::campaign_from_json(j);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(Campaign, ExamplesParseAndRoundTrip) {
  for (const char* f : {"campaign-small.json", "campaign-eol.json"}) {
    physics::Campaign c = io::load_campaign(ex(f));
    EXPECT_EQ(c.axes.size(), 3u);
    physics::Campaign c2 = io::campaign_from_json(io::campaign_to_json(c));
    EXPECT_EQ(c2.num_steps(), c.num_steps());
    EXPECT_EQ(io::campaign_to_json(c2), io::campaign_to_json(c));
  }
  physics::Campaign eol = io::load_campaign(ex("campaign-eol.json"));
  EXPECT_GE(eol.phases.size(), 4u);
  EXPECT_GE(eol.num_steps(), 4 * 24u);
  physics::Timeline tl = physics::build_timeline(eol);
  EXPECT_GT(tl.duration_s, 3600.0);  // realistic: hours, dominated by chamber soaks
  EXPECT_NEAR(tl.duration_s, eol.nominal_duration_s(), 0.01 * tl.duration_s);
  physics::Campaign small = io::load_campaign(ex("campaign-small.json"));
  EXPECT_NEAR(physics::build_timeline(small).duration_s, small.nominal_duration_s(), 0.01 * small.nominal_duration_s());
}

TEST(Campaign, ErrorsNameTheJsonPath) {
  json c = json::parse(std::ifstream(ex("campaign-small.json")));
  json b = c;
  b["phases"][1]["steps"][0] = {{"type", "position"}, {"position_deg", {0, 0}}, {"dwell_s", 1}};
  EXPECT_NE(parse_error(b).find("phases[1].steps[0].position_deg"), std::string::npos) << parse_error(b);
  b = c;
  b["phases"][0]["steps"][1] = {{"type", "rate"}, {"rate_dps", {0, 0, 5000}}, {"dwell_s", 1}};
  EXPECT_NE(parse_error(b).find("exceeds its max_rate_dps"), std::string::npos);
  b = c;
  b["phases"][0]["steps"][0] = {{"use", "nope"}};
  EXPECT_NE(parse_error(b).find("no sequence named 'nope'"), std::string::npos);
  b = c;
  b["phases"][0]["steps"][0] = {{"type", "soak"}, {"dwell_s", 0}};
  EXPECT_NE(parse_error(b).find("dwell_s"), std::string::npos);
  b = c;
  b["phases"][0]["colour"] = 1;
  EXPECT_NE(parse_error(b).find("unknown key 'colour'"), std::string::npos);
  b = c;
  b["sequences"]["loop"] = json::array({{{"use", "loop"}}});
  b["phases"][0]["steps"][0] = {{"use", "loop"}};
  EXPECT_NE(parse_error(b).find("nest"), std::string::npos);
}

TEST(Timeline, SegmentsAndMotionAreContinuous) {
  physics::Campaign c = io::load_campaign(ex("campaign-small.json"));
  physics::Timeline tl = physics::build_timeline(c);
  std::size_t cur = 0;
  double prev_ang[3] = {0, 0, 0};
  const double dt = 1e-3;
  for (double t = 0; t < tl.duration_s; t += dt) {
    auto m = physics::sample_motion(tl, t, cur);
    for (int a = 0; a < 3; ++a) {
      // Angles continuous: step bounded by max rate · dt.
      EXPECT_LE(std::fabs(m.table.angle_rad[a] - prev_ang[a]), c.axes[a].max_rate_dps * M_PI / 180 * dt * 1.0001 + 1e-12)
          << "t " << t << " axis " << a;
      EXPECT_LE(std::fabs(m.table.accel_rad_s2[a]), c.axes[a].max_accel_dps2 * M_PI / 180 * 1.0001);
      prev_ang[a] = m.table.angle_rad[a];
    }
    if (m.entry->segment >= 0 && tl.segments[static_cast<std::size_t>(m.entry->segment)].kind == "position")
      for (int a = 0; a < 3; ++a) EXPECT_EQ(m.table.rate_rad_s[a], 0.0);
  }
  // 2 plateaus × (soak + 6 faces + 3 × (1 position + 2 rates)) segments.
  EXPECT_EQ(tl.segments.size(), 2u * (1 + 6 + 9));
}

TEST(Simulate, SameSeedBitIdenticalDifferentSeedDiffers) {
  physics::Campaign c = io::load_campaign(ex("campaign-small.json"));
  model::SensorModel m = model::load_sensor_model(ex("sensor-automotive.json"));
  auto a = run(c, m, 5), b = run(c, m, 5), d = run(c, m, 6);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 10000u);
  bool differ = false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(std::memcmp(a[i].raw, b[i].raw, sizeof a[i].raw), 0) << i;
    ASSERT_EQ(a[i].t_s, b[i].t_s);
    ASSERT_EQ(std::memcmp(a[i].f_ref, b[i].f_ref, sizeof a[i].f_ref), 0);
    ASSERT_EQ(a[i].temp_C, b[i].temp_C);
    differ = differ || std::memcmp(a[i].raw, d[i].raw, sizeof a[i].raw) != 0;
  }
  EXPECT_TRUE(differ);
}

// An ideal sensor (tiny LSB, no effects) on a perfect fixture reads exactly the reference; a sensor with
// only deterministic effects reads measure(reference) to within half an LSB.
TEST(Simulate, IdealAndDeterministicSensorsReadTheModel) {
  physics::Campaign c = io::load_campaign(ex("campaign-small.json"));
  c.simulation_json.clear();  // no fixture errors, no encoder/temperature noise
  model::SensorModel ideal = ideal_sensor();
  const double g = physics::normal_gravity_mps2(physics::Site{c.latitude_deg, c.height_m});
  std::size_t static_rows = 0;
  for (const auto& r : run(c, ideal, 1)) {
    ASSERT_TRUE(r.has_ref);
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(r.raw[j] * 1e-7, r.f_ref[j], 0.51e-7);
      EXPECT_NEAR(r.raw[3 + j] * 1e-8, r.w_ref[j], 0.51e-8);
    }
    const bool still = r.table_rate_rad_s[0] == 0 && r.table_rate_rad_s[1] == 0 && r.table_rate_rad_s[2] == 0;
    if (still && r.segment >= 0) {
      ++static_rows;
      EXPECT_NEAR(std::sqrt(r.f_ref[0] * r.f_ref[0] + r.f_ref[1] * r.f_ref[1] + r.f_ref[2] * r.f_ref[2]), g, 1e-10 * g);  // lever arm sees Ω_ie²·r ≈ 2e-10 m/s²
    }
  }
  EXPECT_GT(static_rows, 1000u);

  json sj = model::sensor_model_to_json(ideal);
  sj["effects"] = {{"accel.bias", {{"x", 0.1}, {"z", -0.05}}},
                   {"accel.scale", {{"y", 0.01}}},
                   {"accel.size_effect", {{"x.rx", 0.01}}},
                   {"gyro.g_sensitivity", {{"xz", 1e-4}}},
                   {"gyro.bias_temp", {{"z.t1", 1e-5}}},
                   {"gyro.misalign", {{"yx", 2e-3}}}};
  model::SensorModel det = model::sensor_model_from_json(sj);
  const auto ca = model::compile(det, model::Sensor::kAccel), cg = model::compile(det, model::Sensor::kGyro);
  model::HysteresisTracker h;
  std::size_t i = 0;
  for (const auto& r : run(c, det, 1)) {
    model::MeasureInput in;
    in.f = Eigen::Vector3d(r.f_ref[0], r.f_ref[1], r.f_ref[2]);
    in.w = Eigen::Vector3d(r.w_ref[0], r.w_ref[1], r.w_ref[2]);
    in.T_C = r.temp_C;
    const Eigen::Vector3d ya = model::measure(ca, in), yg = model::measure(cg, in);
    // ω̇ is not logged: skip rate transitions (size effect's ω̇×r term) for the accelerometer.
    if (r.segment >= 0)
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(r.raw[j] * 1e-7, ya[j], 0.51e-7) << "row " << i;
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(r.raw[3 + j] * 1e-8, yg[j], 0.51e-8) << "row " << i;
    ++i;
  }
}

TEST(Simulate, ThermalLagsAndSelfHeats) {
  physics::Campaign c = io::load_campaign(ex("campaign-small.json"));
  c.simulation_json.clear();
  model::SensorModel m = ideal_sensor();
  m.thermal.die_tau_s = 30;
  m.thermal.self_heating_C = 2.0;
  m.thermal.self_heating_tau_s = 10;
  auto rows = run(c, m, 1);
  // Plateau 1 at 25 °C: after a while the die sits 2 °C above the air.
  const auto& r0 = rows[static_cast<std::size_t>(5 * c.sample_rate_hz)];
  const auto& r1 = rows[static_cast<std::size_t>(80 * c.sample_rate_hz)];
  EXPECT_NEAR(r1.chamber_C, 25.0, 1e-9);
  // die − air → self_heating·(1 − e^(−t/τ_sh)) through the die lag: small early, ≈ 2 °C later.
  EXPECT_LT(r0.temp_C - r0.chamber_C, 0.5);
  // Closed form for a first-order lag (τd = 30 s) driven by 2·(1 − e^(−t/τs)), τs = 10 s.
  const double t1 = 80, expect = 2.0 * (1 - (30 * std::exp(-t1 / 30) - 10 * std::exp(-t1 / 10)) / 20);
  EXPECT_NEAR(r1.temp_C - r1.chamber_C, expect, 2e-3);
  // The air never slews faster than the chamber's limit, the die lags the air while heating.
  double max_rate = 0;
  for (std::size_t i = 1; i < rows.size(); ++i)
    max_rate = std::max(max_rate, (rows[i].chamber_C - rows[i - 1].chamber_C) * c.sample_rate_hz);
  EXPECT_LE(max_rate, c.ramp_limit_C_per_min / 60.0 * 1.0001);
  EXPECT_GT(max_rate, 0.05);
  EXPECT_NEAR(rows.back().chamber_C, 35.0, 0.2);  // first-order tail (τ = 20 s)
}

TEST(Simulate, WhiteNoiseHasTheSpecifiedDensity) {
  physics::Campaign c = io::load_campaign(ex("campaign-small.json"));
  c.simulation_json.clear();
  json sj = model::sensor_model_to_json(ideal_sensor());
  sj["effects"] = {{"gyro.white_noise", {{"x", 1e-4}, {"y", 2e-4}, {"z", 3e-4}}}};
  model::SensorModel m = model::sensor_model_from_json(sj);
  auto rows = run(c, m, 9);
  for (int j = 0; j < 3; ++j) {
    double s = 0, s2 = 0;
    for (const auto& r : rows) {
      double e = r.raw[3 + j] * 1e-8 - r.w_ref[j];
      s += e, s2 += e * e;
    }
    const double n = static_cast<double>(rows.size());
    const double sd = std::sqrt(s2 / n - (s / n) * (s / n));
    const double expect = (j + 1) * 1e-4 * std::sqrt(c.sample_rate_hz);
    EXPECT_NEAR(sd, expect, 0.03 * expect);
  }
}

TEST(Simulate, TruthHoldsEveryParameterAndTheRealisedTurnOnBias) {
  physics::Campaign c = io::load_campaign(ex("campaign-small.json"));
  model::SensorModel m = model::load_sensor_model(ex("sensor-consumer.json"));
  sim::SimOptions o;
  o.seed = 3;
  auto sum = sim::simulate(c, m, o, [](const io::LogRow&) {});
  EXPECT_EQ(sum.truth["parameters"].size(), static_cast<std::size_t>(model::num_params()));
  EXPECT_DOUBLE_EQ(sum.truth["parameters"]["accel.bias.x"].get<double>(), m.params.get("accel.bias.x"));
  EXPECT_TRUE(sum.truth["realised"].contains("gyro.turn_on_bias.z"));
  EXPECT_EQ(sum.truth["segments"].size(), static_cast<std::size_t>(sum.segments));
}


namespace {
double adev(const std::vector<double>& x, std::size_t m) {
  const std::size_t K = x.size() / m;
  std::vector<double> a(K);
  for (std::size_t k = 0; k < K; ++k) {
    double s = 0;
    for (std::size_t i = 0; i < m; ++i) s += x[k * m + i];
    a[k] = s / static_cast<double>(m);
  }
  double s2 = 0;
  for (std::size_t k = 0; k + 1 < K; ++k) s2 += (a[k + 1] - a[k]) * (a[k + 1] - a[k]);
  return std::sqrt(s2 / (2.0 * static_cast<double>(K - 1)));
}
}  // namespace

TEST(Noise, BiasInstabilityAllanFloor) {
  sim::Rng rng(11);
  sim::AxisNoise n;
  const double dt = 0.01, B = 2.0;
  n.configure(0, B, 1.0, 0, dt, rng);
  std::vector<double> x(1000000);
  for (auto& v : x) v = n.step(rng);
  for (double tau : {0.2, 1.0, 5.0}) EXPECT_NEAR(adev(x, static_cast<std::size_t>(tau / dt)), 0.664 * B, 0.12 * 0.664 * B) << tau;
}

TEST(Noise, RateRandomWalkAllanSlope) {
  sim::Rng rng(12);
  sim::AxisNoise n;
  const double dt = 0.01, K = 0.5;
  n.configure(0, 0, 0, K, dt, rng);
  std::vector<double> x(1000000);
  for (auto& v : x) v = n.step(rng);
  // Allan deviation of a rate random walk: K·√(τ/3).
  for (double tau : {1.0, 10.0}) EXPECT_NEAR(adev(x, static_cast<std::size_t>(tau / dt)), K * std::sqrt(tau / 3), 0.15 * K * std::sqrt(tau / 3)) << tau;
}

TEST(Simulate, FacesOfTheExampleTumbleAreWhatTheDocsSay) {
  physics::Campaign c = io::load_campaign(ex("campaign-small.json"));
  c.simulation_json.clear();
  physics::Timeline tl = physics::build_timeline(c);
  std::vector<io::LogRow> rows = run(c, ideal_sensor(), 1);
  const double g = physics::normal_gravity_mps2(physics::Site{c.latitude_deg, c.height_m});
  int checked = 0;
  for (const auto& s : tl.segments) {
    if (s.kind != "position" || s.label.find(" az ") == std::string::npos) continue;
    const auto& r = rows[static_cast<std::size_t>((s.t0 + s.t1) / 2 * c.sample_rate_hz)];
    const int axis = s.label[1] - 'x';
    const double sign = s.label.find("down") != std::string::npos ? -1.0 : 1.0;  // axis down: f points up = −axis
    EXPECT_NEAR(r.f_ref[axis], sign * g, 1e-6) << s.label;
    ++checked;
  }
  EXPECT_EQ(checked, 12);
}

TEST(Simulate, HandHeldPosesHaveNoReferenceAndRestAtTheAttitude) {
  json j = {{"name", "poses"},
            {"sample_rate_hz", 50},
            {"site", {{"latitude_deg", 35.0}, {"height_m", 0.0}}},
            {"phases",
             {{{"type", "plateau"},
               {"setpoint_C", 25},
               {"soak_s", 0},
               {"steps",
                {{{"type", "pose"}, {"attitude_deg", {30, 0, 0}}, {"move_s", 2}, {"dwell_s", 4}, {"label", "roll 30"}},
                 {{"type", "pose"}, {"attitude_deg", {0, -90, 45}}, {"move_s", 3}, {"dwell_s", 4}, {"label", "nose down"}}}}}}}};
  physics::Campaign c = io::campaign_from_json(j);
  json sj = model::sensor_model_to_json(ideal_sensor());
  model::SensorModel m = model::sensor_model_from_json(sj);
  auto rows = run(c, m, 1);
  physics::Timeline tl = physics::build_timeline(c);
  ASSERT_EQ(tl.segments.size(), 2u);
  const double g = physics::normal_gravity_mps2(physics::Site{35.0, 0.0});
  for (const auto& r : rows) {
    EXPECT_FALSE(r.has_ref);
    EXPECT_TRUE(std::isnan(r.table_angle_rad[0]));
  }
  // Resting at roll 30°: |f| = g and the roll recovered from f is 30°.
  const auto& a = rows[static_cast<std::size_t>((tl.segments[0].t0 + tl.segments[0].t1) / 2 * 50)];
  const double fy = a.raw[1] * 1e-7, fz = a.raw[2] * 1e-7, fx = a.raw[0] * 1e-7;
  EXPECT_NEAR(std::sqrt(fx * fx + fy * fy + fz * fz), g, 1e-5);
  EXPECT_NEAR(std::atan2(-fy, -fz) * 180 / M_PI, 30.0, 1e-5);
  const auto& b = rows[static_cast<std::size_t>((tl.segments[1].t0 + tl.segments[1].t1) / 2 * 50)];
  EXPECT_NEAR(b.raw[0] * 1e-7, -g, 1e-5);  // pitch −90° (NED): nose (x) down, f_x = −g
  // The gyro at rest reads only the Earth rate.
  const double wn = std::sqrt(std::pow(b.raw[3] * 1e-8, 2) + std::pow(b.raw[4] * 1e-8, 2) + std::pow(b.raw[5] * 1e-8, 2));
  EXPECT_NEAR(wn, physics::wgs84::kOmegaE_rad_s, 2e-8);
}
}  // namespace sim_campaign_test
