// Effect catalog, sensor/model JSON, and measure() == nominal + regressors·θ.
#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "host/model/catalog.h"
#include "host/model/measure.h"
#include "host/model/sensor_model.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace sim_model_test {

using namespace imuforge::model;
using nlohmann::json;

TEST(Catalog, NamesAreUniqueAndRoundTrip) {
  std::set<std::string> names;
  for (const auto& p : params()) {
    EXPECT_TRUE(names.insert(p.name).second) << p.name;
    EXPECT_EQ(find_param(p.name), p.id);
  }
  EXPECT_EQ(find_param("accel.bias.x"), effect_params(Sensor::kAccel, Effect::kBias)[0]);
  EXPECT_EQ(find_param("accel.g_sensitivity.xx"), -1);  // gyro only
  EXPECT_GE(find_param("gyro.g2_sensitivity.z.zx"), 0);
  EXPECT_GE(find_param("accel.size_effect.y.rz"), 0);
  EXPECT_EQ(effect_params(Sensor::kGyro, Effect::kMisalignTemp).size(), 18u);
  const auto& p = param_info(find_param("gyro.misalign_temp.zx.t2"));
  EXPECT_EQ(p.j, 2);
  EXPECT_EQ(p.k, 0);
  EXPECT_EQ(p.power, 2);
  try {
    param_id_or_throw("gyro.misalign.xx");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("valid components"), std::string::npos) << e.what();
  }
  EXPECT_THROW(param_id_or_throw("accel.g_sensitivity.xx"), std::invalid_argument);
  EXPECT_EQ(effects().size(), static_cast<std::size_t>(kNumEffects));
  for (int i = 0; i < kNumEffects; ++i) EXPECT_EQ(static_cast<int>(effects()[static_cast<std::size_t>(i)].effect), i);
}

// A sample with every input of the model away from zero (hysteresis direction d given).
MeasureInput random_input(std::mt19937_64& gen, double d) {
  std::normal_distribution<double> nd;
  MeasureInput in;
  in.f = Eigen::Vector3d(nd(gen), nd(gen), nd(gen)) * 5;
  in.w = Eigen::Vector3d(nd(gen), nd(gen), nd(gen));
  in.wdot = Eigen::Vector3d(nd(gen), nd(gen), nd(gen));
  in.fdot = Eigen::Vector3d(nd(gen), nd(gen), nd(gen));
  in.T_C = 25 + 20 * nd(gen);
  in.Tdot_C_s = 0.05 * nd(gen);
  in.d = d;
  in.t_s = 100 * std::fabs(nd(gen));
  return in;
}

// The central consistency test: the simulator's measure() and the solver's regressors agree exactly.
TEST(Measure, EqualsNominalPlusRegressorsTimesTheta) {
  std::mt19937_64 gen(7);
  std::normal_distribution<double> nd;
  for (int trial = 0; trial < 50; ++trial) {
    ParamSet th;
    for (const auto& p : params())
      if (p.deterministic) th[p.id] = 1e-3 * nd(gen);
    const MeasureInput in = random_input(gen, trial % 3 - 1);
    for (Sensor s : {Sensor::kAccel, Sensor::kGyro}) {
      std::vector<ParamId> ids;
      for (const auto& p : params())
        if (p.deterministic) ids.push_back(p.id);  // both sensors: the other's columns must be zero
      Eigen::Matrix<double, 3, Eigen::Dynamic> J(3, ids.size());
      regressors(s, ids, in, 21.5, J);
      Eigen::VectorXd theta(ids.size());
      for (std::size_t i = 0; i < ids.size(); ++i) theta[static_cast<Eigen::Index>(i)] = th[ids[i]];
      const Eigen::Vector3d y = measure(compile(th, s, 21.5), in);
      const Eigen::Vector3d y2 = nominal(s, in) + J * theta;
      EXPECT_LT((y - y2).norm(), 1e-12 * (1 + y.norm())) << sensor_name(s) << " trial " << trial;
      // And without timing: the timing columns vanish.
      MeasureOptions no_t{false};
      regressors(s, ids, in, 21.5, J, no_t);
      EXPECT_LT((measure(compile(th, s, 21.5), in, no_t) - nominal(s, in) - J * theta).norm(), 1e-12 * (1 + y.norm()));
    }
  }
}

// The diagnosis sums regressors over a block's samples through RegressorPlan (one compiled column list, only the
// non-zero entries touched): the sum must be the one regressors() gives, to the bit, with and without timing,
// over every deterministic parameter of both sensors (the other sensor's columns stay zero), on a matrix that
// already holds something (the block's running sum), written into a column slice of a wider matrix.
TEST(Measure, RegressorPlanAccumulatesExactlyWhatRegressorsGive) {
  std::mt19937_64 gen(11);
  std::vector<ParamId> ids;
  for (const auto& p : params())
    if (p.deterministic) ids.push_back(p.id);
  std::shuffle(ids.begin(), ids.end(), gen);  // any order: a column is found by its position
  const auto n = static_cast<Eigen::Index>(ids.size());
  for (Sensor s : {Sensor::kAccel, Sensor::kGyro})
    for (const bool timing : {true, false}) {
      const MeasureOptions opt{timing};
      const RegressorPlan plan(s, ids, opt);
      ASSERT_EQ(plan.size(), ids.size());
      Eigen::Matrix<double, 3, Eigen::Dynamic> sum_ref = Eigen::Matrix<double, 3, Eigen::Dynamic>::Constant(3, n, 0.25), J(3, n);
      Eigen::MatrixXd wide = Eigen::MatrixXd::Constant(3, n + 2, 0.25);
      for (int k = 0; k < 40; ++k) {
        const MeasureInput in = random_input(gen, k % 3 - 1);
        regressors(s, ids, in, 21.5, J, opt);
        sum_ref += J;
        plan.accumulate(in, 21.5, wide.middleCols(1, n));
      }
      for (Eigen::Index c = 0; c < n; ++c)
        for (int r = 0; r < 3; ++r)
          ASSERT_EQ(wide(r, c + 1), sum_ref(r, c)) << param_info(ids[static_cast<std::size_t>(c)]).name << " row " << r << (timing ? "" : " (no timing)");
      EXPECT_TRUE((wide.col(0).array() == 0.25).all() && (wide.col(n + 1).array() == 0.25).all());  // nothing outside the slice
      Eigen::Matrix<double, 3, Eigen::Dynamic> narrow(3, n - 1);
      EXPECT_THROW(plan.accumulate(MeasureInput{}, 21.5, narrow), std::invalid_argument);
    }
}

TEST(Measure, IndividualTermsMatchTheDocumentedEquation) {
  ParamSet th;
  th.set("gyro.scale.x", 1e-3);
  th.set("gyro.misalign.xy", 2e-3);
  th.set("gyro.g_sensitivity.xz", 1e-4);
  th.set("gyro.bias_temp.x.t2", 1e-6);
  th.set("gyro.scale_asymmetry.x", 5e-4);
  MeasureInput in;
  in.w = Eigen::Vector3d(-0.5, 0.2, 0.1);
  in.f = Eigen::Vector3d(0, 0, -9.8);
  in.T_C = 35;
  const double expect = -0.5 * (1 + 1e-3) + 2e-3 * 0.2 + 1e-4 * -9.8 + 1e-6 * 100 + 5e-4 * -0.5;
  EXPECT_NEAR(measure(compile(th, Sensor::kGyro, 25), in).x(), expect, 1e-15);
  // Size effect: axis x at lever arm r_x = (0, 0.1, 0) rotating about z at 2 rad/s reads [ω×(ω×r)]_x = 0.
  ParamSet a;
  a.set("accel.size_effect.y.ry", 0.1);
  in.w = Eigen::Vector3d(0, 0, 2);
  in.wdot.setZero();
  in.f.setZero();
  EXPECT_NEAR(measure(compile(a, Sensor::kAccel, 25), in).y(), -0.4, 1e-15);  // −ω² r
}

TEST(Thermal, HysteresisDirection) {
  HysteresisTracker h(0.5);
  EXPECT_EQ(h.update(25.0), 0);
  EXPECT_EQ(h.update(25.3), 0);
  EXPECT_EQ(h.update(25.6), 1);   // heated by > 0.5
  EXPECT_EQ(h.update(40.0), 1);
  EXPECT_EQ(h.update(39.7), 1);   // small dip is not a turn
  EXPECT_EQ(h.update(39.4), -1);  // 0.6 below the maximum
  EXPECT_EQ(h.update(std::nan("")), -1);
  EXPECT_EQ(h.update(10.0), -1);
  EXPECT_EQ(h.update(10.6), 1);
}

// A logged temperature is noisy; the estimators' tracker reads it through kLoggedTempSmoothing_s. A die that
// self-heating warms by 0.4 °C (below the threshold) over a 300 s soak, logged with 0.02 °C of white noise at
// 100 Hz: read raw, the extremes of the noise turn d; smoothed, d stays, and the real turn that follows (a ramp
// up at 0.05 °C/s) comes within a few seconds of the noise-free one, as does a V-shaped turn at 0.4 °C/s.
TEST(Thermal, HysteresisOfALoggedTemperatureIsReadThroughTheSmoothing) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01;
  const double fs = 100.0;
  // The first time d reads `to`.
  auto first_turn = [&](auto temp, double dur_s, double noise_C, double tau_s, double to) {
    HysteresisTracker h(0.5, tau_s);
    double turned = -1;
    for (int i = 0; i < static_cast<int>(dur_s * fs); ++i) {
      const double t = i / fs;
      const double d = h.update(temp(t) + noise_C * n01(rng), t);
      if (d == to && turned < 0) turned = t;
    }
    return turned;
  };
  // Cooled to 13 °C (d = −1 from 1.4 s), then 0.4 °C of slow warming, then a ramp up from 400 s.
  auto soak = [](double t) {
    const double cool = t < 20 ? 20.0 - 0.35 * t : 13.0;
    return cool + 0.4 * (1.0 - std::exp(-std::max(0.0, t - 20.0) / 100.0)) + (t > 400 ? 0.05 * (t - 400) : 0.0);
  };
  const double clean = first_turn(soak, 500, 0.0, 0.0, 1.0);
  const double raw = first_turn(soak, 500, 0.02, 0.0, 1.0);
  const double smooth = first_turn(soak, 500, 0.02, kLoggedTempSmoothing_s, 1.0);
  EXPECT_GT(clean, 400.0) << "the soak alone does not turn a noise-free die";
  EXPECT_LT(raw, 400.0) << "raw, the noise turns it during the soak (else this test exercises nothing)";
  EXPECT_GT(smooth, clean - 0.5);
  EXPECT_LT(smooth, clean + 3.0 * kLoggedTempSmoothing_s);  // measured 0.6 s late (raw: 56 s early)
  // A V: 0.4 °C/s up to 40 °C at 50 s, then down.
  auto vee = [](double t) { return t < 50 ? 20.0 + 0.4 * t : 40.0 - 0.4 * (t - 50); };
  const double v_clean = first_turn(vee, 100, 0.0, 0.0, -1.0), v_smooth = first_turn(vee, 100, 0.02, kLoggedTempSmoothing_s, -1.0);
  EXPECT_NEAR(v_clean, 51.25, 0.02);
  EXPECT_GT(v_smooth, v_clean - 0.1);
  EXPECT_LT(v_smooth, v_clean + 1.5);  // measured 0.8 s late
  // Repeated time stamps leave the smoothed value; a time going backwards (a new recording) restarts it.
  HysteresisTracker h(0.5, 1.0);
  EXPECT_EQ(h.update(20.0, 0.0), 0);
  EXPECT_EQ(h.update(30.0, 0.0), 0) << "no time has passed: the filter has not moved";
  EXPECT_EQ(h.update(30.0, 10.0), 1);
  EXPECT_EQ(h.update(10.0, 2.0), -1) << "time went back: the filter restarts at the new value";
  h.reset();
  EXPECT_EQ(h.update(30.0, 5.0), 0);
}

TEST(Thermal, CentredTemperatureRate) {
  std::vector<double> t, T;
  for (int i = 0; i <= 1000; ++i) {
    t.push_back(i * 0.1);
    T.push_back(20 + 0.05 * i * 0.1);
  }
  auto r = temp_rate_centered(t, T, 10.0);
  for (double v : r) EXPECT_NEAR(v, 0.05, 1e-12);
}

TEST(SensorModel, ExamplesLoadAndCarryEffectsBeyondBasic) {
  for (const char* f : {"sensor-consumer.json", "sensor-automotive.json", "sensor-tactical.json"}) {
    SensorModel m = load_sensor_model(std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/" + f);
    int beyond = 0;
    for (int s = 0; s < kNumSensors; ++s)
      for (int e = static_cast<int>(Effect::kBiasTemp); e < kNumEffects; ++e) beyond += m.enabled[s][e];
    EXPECT_GE(beyond, 8) << f;
    // Round trip through JSON.
    SensorModel m2 = sensor_model_from_json(sensor_model_to_json(m));
    EXPECT_EQ(m2.effective_params().values(), m.effective_params().values()) << f;
  }
}

TEST(SensorModel, ErrorsNameTheProblem) {
  json base = {{"accel", {{"lsb", 1e-3}, {"bits", 16}}}, {"gyro", {{"lsb", 1e-4}, {"bits", 16}}}};
  auto msg = [&](json j) {
    try {
      sensor_model_from_json(j);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  json j = base;
  j["effects"]["accel.bais"] = {{"x", 1}};
  EXPECT_NE(msg(j).find("unknown effect 'bais'"), std::string::npos) << msg(j);
  j = base;
  j["effects"]["accel.g_sensitivity"] = {{"xx", 1}};
  EXPECT_NE(msg(j).find("does not apply to the accel"), std::string::npos) << msg(j);
  j = base;
  j["effects"]["gyro.bias"] = {{"w", 1}};
  EXPECT_NE(msg(j).find("valid components"), std::string::npos) << msg(j);
  j = base;
  j["effects"]["gyro.bias"] = {{"x", "big"}};
  EXPECT_NE(msg(j).find("gyro.bias.x"), std::string::npos) << msg(j);
  j = base;
  j["accel"]["lsb"] = 0;
  EXPECT_NE(msg(j).find("lsb"), std::string::npos) << msg(j);
  j = base;
  j["effects"]["gyro.white_noise"] = {{"x", -1}};
  EXPECT_NE(msg(j).find(">= 0"), std::string::npos) << msg(j);
  j = base;
  j.erase("gyro");
  EXPECT_NE(msg(j).find("gyro"), std::string::npos);
  j = base;
  j["effects"]["bias"] = {{"x", 0.5}, {"enabled", false}};
  SensorModel m = sensor_model_from_json(j);  // plain effect name = both sensors
  EXPECT_EQ(m.params.get("gyro.bias.x"), 0.5);
  EXPECT_EQ(m.effective_params().get("gyro.bias.x"), 0.0);
}

TEST(ModelSpec, ExpandsOrdersAndOptions) {
  json j = {{"name", "t"},
            {"effects", {{"accel.bias", json::object()},
                         {"accel.bias_temp", {{"order", 2}}},
                         {"gyro.misalign", {{"components", {"xy", "zx"}}}},
                         {"gyro.bias", {{"per_plateau", true}}},
                         {"gyro.white_noise", json::object()}}},
            {"solver", {{"iterations", 5}}}};
  ModelSpec m = model_spec_from_json(j);
  auto ids = m.parameters();
  std::vector<std::string> names;
  for (auto id : ids) names.push_back(param_info(id).name);
  // nlohmann::json objects iterate in key order.
  std::vector<std::string> expect = {"accel.bias.x", "accel.bias.y", "accel.bias.z",
                                     "accel.bias_temp.x.t1", "accel.bias_temp.x.t2", "accel.bias_temp.y.t1",
                                     "accel.bias_temp.y.t2", "accel.bias_temp.z.t1", "accel.bias_temp.z.t2",
                                     "gyro.bias.x", "gyro.bias.y", "gyro.bias.z", "gyro.misalign.xy",
                                     "gyro.misalign.zx"};
  EXPECT_EQ(names, expect);
  EXPECT_TRUE(m.extra.contains("solver"));
  EXPECT_THROW(model_spec_from_json(json{{"effects", {{"accel.bias", {{"order", 2}}}}}}), std::invalid_argument);
  EXPECT_THROW(model_spec_from_json(json{{"effects", {{"accel.bias_temp", {{"order", 4}}}}}}), std::invalid_argument);
  // The hysteresis tracker's threshold: read, written back, and refused with its key unless positive.
  EXPECT_TRUE(std::isnan(m.hysteresis_threshold_C));
  EXPECT_FALSE(model_spec_to_json(m).contains("hysteresis_threshold_C"));
  const ModelSpec h = model_spec_from_json(json{{"hysteresis_threshold_C", 0.3}, {"effects", {{"accel.temp_hysteresis", json::object()}}}});
  EXPECT_DOUBLE_EQ(h.hysteresis_threshold_C, 0.3);
  EXPECT_FALSE(h.extra.contains("hysteresis_threshold_C")) << "a parsed key, not a verbatim solver option";
  EXPECT_DOUBLE_EQ(model_spec_to_json(h).at("hysteresis_threshold_C").get<double>(), 0.3);
  for (const json& bad : {json(0.0), json(-0.5), json("0.3")}) {
    try {
      model_spec_from_json(json{{"hysteresis_threshold_C", bad}, {"effects", {{"accel.bias", json::object()}}}});
      ADD_FAILURE() << bad.dump();
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("hysteresis_threshold_C"), std::string::npos) << e.what();
    }
  }
  for (const char* f : {"model-basic.json", "model-thermal.json"}) {
    ModelSpec s = load_model_spec(std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/" + f);
    EXPECT_GE(s.parameters().size(), 24u) << f;
  }
}
}  // namespace sim_model_test
