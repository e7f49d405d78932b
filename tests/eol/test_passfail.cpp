// Pass/fail against station limits, limit matching, the station file, and settling detection.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "host/eol/passfail.h"
#include "host/eol/settle.h"
#include "host/eol/station.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace eol_test_passfail {

using namespace imuforge::eol;
using imuforge::records::ParameterRecord;
using imuforge::records::VerificationRecord;

namespace {
StationConfig station() {
  return station_from_json(nlohmann::json::parse(R"({
    "name": "s1", "model": "m.json",
    "limits": {
      "parameters": {
        "accel.bias": {"abs": 0.1, "sigma": 1e-3},
        "accel.bias.z": {"abs": 0.5},
        "gyro*": {"sigma": 1e-4}
      },
      "verification": {"accel_mps2": 0.01, "gyro_rad_s": 0.001}
    }})"),
                           "/tmp");
}
}  // namespace

TEST(PassFail, LimitMatching) {
  auto st = station();
  ASSERT_NE(st.limit_for("accel.bias.x"), nullptr);
  EXPECT_EQ(st.limit_for("accel.bias.x")->pattern, "accel.bias");
  EXPECT_EQ(st.limit_for("accel.bias.z")->pattern, "accel.bias.z") << "exact name wins";
  EXPECT_EQ(st.limit_for("accel.bias_temp.x.t1"), nullptr) << "prefix matches only at a '.' boundary";
  EXPECT_EQ(st.limit_for("gyro.scale.y")->pattern, "gyro*");
  EXPECT_EQ(st.limit_for("accel.scale.x"), nullptr);
}

TEST(PassFail, PassWhenEverythingIsWithinLimits) {
  auto st = station();
  std::vector<ParameterRecord> p = {{"accel.bias.x", 0.05, 5e-4}, {"accel.bias.z", 0.4, 1e-2}, {"gyro.scale.x", 1e-3, 5e-5}};
  std::vector<VerificationRecord> v = {{"ver0.accel.x", 0.005, 0.01}, {"ver0.gyro.x", -5e-4, 0.001}};
  Verdict r = evaluate(st, p, v);
  EXPECT_TRUE(r.pass);
  EXPECT_TRUE(r.reasons.empty());
  EXPECT_EQ(p[0].limit_abs, 0.1);
  EXPECT_EQ(p[0].sigma_spec, 1e-3);
  EXPECT_EQ(p[1].sigma_spec, 0.0);
  EXPECT_TRUE(p[2].pass);
}

TEST(PassFail, EachFailureNamesItsCause) {
  auto st = station();
  std::vector<ParameterRecord> p = {{"accel.bias.x", -0.2, 5e-4},            // |value| over limit
                                    {"accel.bias.y", 0.0, 2e-3},             // sigma over spec
                                    {"gyro.bias.x", NAN, 1e-5},              // not determined
                                    {"accel.scale.x", 123.0, 1.0}};          // no limit: passes
  std::vector<VerificationRecord> v = {{"ver0.accel.x", -0.02, 0.01}, {"ver0.gyro.x", 1e-4, 0.001}};
  Verdict r = evaluate(st, p, v, {"flash: read-back differs"});
  EXPECT_FALSE(r.pass);
  ASSERT_EQ(r.reasons.size(), 5u);
  EXPECT_EQ(r.reasons[0], "flash: read-back differs");
  EXPECT_NE(r.reasons[1].find("accel.bias.x: |value| 0.2 > limit 0.1"), std::string::npos) << r.reasons[1];
  EXPECT_NE(r.reasons[2].find("accel.bias.y: sigma"), std::string::npos) << r.reasons[2];
  EXPECT_NE(r.reasons[3].find("gyro.bias.x: not determined"), std::string::npos) << r.reasons[3];
  EXPECT_NE(r.reasons[4].find("verification ver0.accel.x"), std::string::npos) << r.reasons[4];
  EXPECT_FALSE(p[0].pass);
  EXPECT_FALSE(p[1].pass);
  EXPECT_FALSE(p[2].pass);
  EXPECT_TRUE(p[3].pass);
  EXPECT_FALSE(v[0].pass);
  EXPECT_TRUE(v[1].pass);
}

TEST(PassFail, UnverifiedNeverPasses) {
  auto st = station();
  std::vector<ParameterRecord> p = {{"accel.bias.x", 0.0, 1e-4}};
  std::vector<VerificationRecord> v;
  Verdict r = evaluate(st, p, v);
  EXPECT_FALSE(r.pass);
  ASSERT_EQ(r.reasons.size(), 1u);
  EXPECT_NE(r.reasons[0].find("no verification"), std::string::npos);
}

TEST(Station, BadFilesAreClearErrors) {
  EXPECT_THROW(station_from_json(nlohmann::json::array(), "/"), StationError);
  EXPECT_THROW(station_from_json(nlohmann::json::parse(R"({"limits":{"parameters":{"a":{"abs":-1}}}})"), "/"), StationError);
  EXPECT_THROW(station_from_json(nlohmann::json::parse(R"({"can":{"stream_rate_hz":"fast"}})"), "/"), StationError);
  EXPECT_THROW(station_from_json(nlohmann::json::parse(R"({"verification":[{"dwell_s":0}]})"), "/"), StationError);
  EXPECT_THROW(load_station("/nonexistent/station.json"), StationError);
}

TEST(Settle, ExponentialApproachSettlesOnlyWhenSlopeIsSmall) {
  // T(t) = 40 − 15 exp(−t/300): slope 15/300·exp(−t/300) °C/s. Threshold 0.05 °C/min over 120 s.
  SlopeSettleDetector det(120.0, 0.05 / 60.0);
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0, 0.01);
  double settled_at = -1;
  for (double t = 0; t < 4000; t += 0.1) {
    det.add(t, 40 - 15 * std::exp(-t / 300) + noise(rng));
    if (settled_at < 0 && det.settled()) settled_at = t;
  }
  ASSERT_GT(settled_at, 0);
  // The true slope falls below 0.05 °C/min (8.33e-4 °C/s) at t = 300·ln(0.05/8.33e-4) ≈ 1228 s; the
  // window's regression lags by about half a window.
  EXPECT_GT(settled_at, 1228 - 10);
  EXPECT_LT(settled_at, 1228 + 200);
}

TEST(Settle, NeedsAFullWindow) {
  SlopeSettleDetector det(60.0, 1e-3);
  for (double t = 0; t < 50; t += 1) det.add(t, 25.0);
  EXPECT_FALSE(det.settled()) << "flat but the window is not full yet";
  for (double t = 50; t < 61; t += 1) det.add(t, 25.0);
  EXPECT_TRUE(det.settled());
  det.add(61, 30.0);  // a jump: the slope over the window rises
  EXPECT_FALSE(det.settled());
}
}  // namespace eol_test_passfail
