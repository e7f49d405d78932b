// Fixture drivers against bench-sim's real libmodbus servers (in-process): TCP loopback on a free port
// and RTU on a pty. Fault cases: exceptions, late answers, lost answers, lost requests, a server that
// dies and comes back. "Exactly once" is checked on the server side (commands applied).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "host/benchsim/bench.h"
#include "host/benchsim/modbus_server.h"
#include "host/fixture/fixture.h"

#include <unistd.h>

#include <cstdio>
#include <nlohmann/json.hpp>

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace modbus_test_driver {

using namespace imuforge;
using fixture::FixtureConfig;
using fixture::FixtureError;

namespace {

std::string map_path(const std::string& f) { return std::string(IMUFORGE_SOURCE_DIR) + "/host/fixture/maps/" + f; }

struct Lab {
  std::unique_ptr<benchsim::Bench> bench;
  std::unique_ptr<benchsim::ModbusServer> server;
  benchsim::ServerOptions opt;

  explicit Lab(double time_scale, const std::string& chamber_map = "imuforge-chamber.json", bool rtu = true) {
    benchsim::WorldConfig wc;
    wc.settle_s = 0.5;
    benchsim::RegisterBank bank(fixture::RegisterMap::load(map_path("imuforge-table.json")),
                                fixture::RegisterMap::load(map_path(chamber_map)));
    bench = std::make_unique<benchsim::Bench>(benchsim::make_sim_world(wc), std::move(bank), time_scale);
    opt.tcp_port = 0;
    opt.rtu_pty = rtu;
    server = std::make_unique<benchsim::ModbusServer>(*bench, opt);
    server->start();
    opt.tcp_port = server->tcp_port();
  }
  void kill() { server->stop(); }
  void revive() {
    opt.rtu_pty = false;
    server = std::make_unique<benchsim::ModbusServer>(*bench, opt);
    server->start();
  }
  FixtureConfig cfg(const std::string& name, const std::string& map, bool rtu = false) const {
    FixtureConfig c;
    c.name = name;
    c.map_path = map_path(map);
    if (rtu) {
      c.link.transport = "rtu";
      c.link.device = server->rtu_path();
    } else {
      c.link.port = server->tcp_port();
    }
    c.link.timeout_s = 0.3;
    c.link.retries = 3;
    c.link.backoff_s = 0.02;
    return c;
  }
  uint64_t applied() {
    std::lock_guard<std::mutex> l(bench->mutex());
    return bench->bank().commands_applied();
  }
};

std::string what_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const FixtureError& e) {
    return e.what();
  }
  return "(no FixtureError)";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST(ModbusDriver, TcpPositionRateAndStop) {
  Lab lab(200.0);
  auto t = fixture::open_rate_table(lab.cfg("table-1", "imuforge-table.json"));
  ASSERT_EQ(t->axes(), 3);
  t->command_position(0, 90.0);
  ASSERT_TRUE(t->wait_settled(0, 30.0));
  auto s = t->status(0);
  EXPECT_EQ(s.mode, fixture::AxisMode::kPosition);
  EXPECT_NEAR(s.angle_deg, 90.0, 1e-4);
  EXPECT_TRUE(s.in_position);
  EXPECT_TRUE(s.settled);
  EXPECT_EQ(s.seq_ack, t->last_seq(0));
  t->command_rate(1, -20.0);
  ASSERT_TRUE(t->wait_settled(1, 30.0));
  EXPECT_NEAR(t->status(1).rate_deg_s, -20.0, 1e-4);
  t->stop(1);
  ASSERT_TRUE(t->wait_settled(1, 30.0));
  EXPECT_NEAR(t->status(1).rate_deg_s, 0.0, 1e-9);
  // The fixture clock is the simulated one, and it runs.
  const double t0 = t->fixture_time_s();
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_GT(t->fixture_time_s(), t0);
  EXPECT_EQ(t->stats().resent, 0u);
  EXPECT_EQ(t->stats().confirmed_by_readback, 0u);
}

TEST(ModbusDriver, RtuOnPty) {
  Lab lab(200.0);
  ASSERT_FALSE(lab.server->rtu_path().empty());
  auto t = fixture::open_rate_table(lab.cfg("table-rtu", "imuforge-table.json", true));
  t->command_position(2, -30.0);
  ASSERT_TRUE(t->wait_settled(2, 30.0));
  EXPECT_NEAR(t->status(2).angle_deg, -30.0, 1e-4);
  auto c = fixture::open_chamber(lab.cfg("chamber-rtu", "imuforge-chamber.json", true));
  c->set_ramp(4.0);
  c->set_setpoint(31.25);
  const auto cs = c->status();
  EXPECT_NEAR(cs.setpoint_degC, 31.25, 1e-9);
  EXPECT_NEAR(cs.ramp_degC_min, 4.0, 1e-9);
  ASSERT_TRUE(cs.running.has_value());
  EXPECT_TRUE(*cs.running);
}

TEST(ModbusDriver, ChamberRampLimitFirstOrderAndDieLag) {
  Lab lab(1.0, "imuforge-chamber.json", false);
  std::atomic<double> t_sim{0.0};
  lab.bench->set_clock([&] { return t_sim.load(); });
  auto c = fixture::open_chamber(lab.cfg("chamber-1", "imuforge-chamber.json"));
  // The test owns the clock: it advances the world itself, so a long jump is not paid for inside a
  // Modbus request (which would time out, slow builds included).
  auto set_time = [&](double t) {
    t_sim = t;
    std::lock_guard<std::mutex> l(lab.bench->mutex());
    lab.bench->sync();
  };
  c->set_ramp(2.0);
  c->set_setpoint(45.0);
  set_time(300.0);
  const auto s1 = c->status();
  EXPECT_GT(s1.air_degC, 25.0);
  EXPECT_LE(s1.air_degC - 25.0, 2.0 * 300.0 / 60.0 + 1e-9);  // never faster than the ramp limit
  ASSERT_TRUE(s1.at_setpoint.has_value());
  EXPECT_FALSE(*s1.at_setpoint);
  double die_C, air_C;
  {
    std::lock_guard<std::mutex> l(lab.bench->mutex());
    die_C = lab.bench->world().imu_truth().die_C;
    air_C = lab.bench->world().chamber().air_C;
  }
  EXPECT_LT(die_C, air_C);  // the die lags the air while it heats
  set_time(4.0 * 3600.0);
  const auto s2 = c->status();
  EXPECT_NEAR(s2.air_degC, 45.0, 0.01);
  EXPECT_TRUE(*s2.at_setpoint);
}

TEST(ModbusDriver, SafetyLimitsRefuseBeforeAnythingIsSent) {
  Lab lab(50.0, "imuforge-chamber.json", false);
  auto tc = lab.cfg("table-1", "imuforge-table.json");
  tc.limits.max_rate_deg_s = 100.0;
  auto t = fixture::open_rate_table(tc);
  auto cc = lab.cfg("chamber-1", "imuforge-chamber.json");
  cc.limits.max_temp_degC = 85.0;
  cc.limits.max_ramp_degC_min = 2.0;
  auto c = fixture::open_chamber(cc);
  const uint64_t before = lab.server->requests();
  std::string m = what_of([&] { t->command_rate(0, 150.0); });
  EXPECT_TRUE(contains(m, "table-1")) << m;
  EXPECT_TRUE(contains(m, "nothing written")) << m;
  EXPECT_TRUE(contains(m, "max_rate_deg_s=100")) << m;
  m = what_of([&] { c->set_setpoint(120.0); });
  EXPECT_TRUE(contains(m, "chamber-1") && contains(m, "outside the station limits")) << m;
  m = what_of([&] { c->set_ramp(5.0); });
  EXPECT_TRUE(contains(m, "max_ramp_degC_min")) << m;
  m = what_of([&] { t->command_position(3, 0.0); });
  EXPECT_TRUE(contains(m, "axis 3 does not exist")) << m;
  m = what_of([&] { t->command_rate(0, NAN); });
  EXPECT_TRUE(contains(m, "nothing written")) << m;
  EXPECT_EQ(lab.server->requests(), before);  // not one request went out
  // The controller's own ramp (3 degC/min) is faster than the station allows: the driver lowers it
  // before handing over a setpoint.
  std::vector<std::string> notices;
  c->set_notice_handler([&](const std::string& s) { notices.push_back(s); });
  c->set_setpoint(30.0);
  EXPECT_NEAR(c->status().ramp_degC_min, 2.0, 1e-9);
  ASSERT_EQ(notices.size(), 1u);
  EXPECT_TRUE(contains(notices[0], "exceeds the station limit"));
}

TEST(ModbusDriver, WatlowF4Map) {
  Lab lab(50.0, "watlow-f4.json", false);
  auto c = fixture::open_chamber(lab.cfg("watlow", "watlow-f4.json"));
  EXPECT_FALSE(c->has_ramp());
  c->set_setpoint(35.5);
  fixture::ModbusLink raw("probe", lab.cfg("probe", "watlow-f4.json").link);
  EXPECT_EQ(raw.read(300, 1, "set point 1")[0], 355);
  const auto pv = raw.read(100, 1, "input 1 value")[0];
  const auto s = c->status();
  EXPECT_NEAR(s.air_degC, static_cast<int16_t>(pv) * 0.1, 0.2);
  EXPECT_NEAR(s.setpoint_degC, 35.5, 1e-9);
  EXPECT_TRUE(std::isnan(s.ramp_degC_min));
  EXPECT_FALSE(s.running.has_value());
  EXPECT_TRUE(contains(what_of([&] { c->set_ramp(1.0); }), "no ramp register"));
}

TEST(ModbusDriver, ExceptionsAreClearAndNotRetried) {
  Lab lab(50.0, "imuforge-chamber.json", false);
  auto t = fixture::open_rate_table(lab.cfg("table-1", "imuforge-table.json"));
  t->connect();
  lab.bench->faults().exception_code = 4;
  lab.bench->faults().exception_count = 1;
  const uint64_t before = lab.server->requests();
  std::string m = what_of([&] { t->status(0); });
  EXPECT_TRUE(contains(m, "fixture 'table-1'")) << m;
  EXPECT_TRUE(contains(m, "axis0 status block @1100..1115")) << m;
  EXPECT_TRUE(contains(m, "Modbus exception 4")) << m;
  EXPECT_EQ(lab.server->requests(), before + 1);  // a refusal is final: not retried
  // The server's own refusal of a write to a read-only register.
  fixture::ModbusLink raw("table-1", lab.cfg("table-1", "imuforge-table.json").link);
  m = what_of([&] { raw.write(1110, {5}, "axis0.angle @1110"); });
  EXPECT_TRUE(contains(m, "axis0.angle @1110")) << m;
  EXPECT_TRUE(contains(m, "exception 2 (Illegal data address)")) << m;
  // An out-of-range mode value.
  m = what_of([&] { raw.write(1100, {7, 0, 0, 9}, "axis0 command block"); });
  EXPECT_TRUE(contains(m, "exception 3")) << m;
  EXPECT_EQ(lab.applied(), 0u);
}

TEST(ModbusDriver, BusyIsRetried) {
  Lab lab(50.0, "imuforge-chamber.json", false);
  auto t = fixture::open_rate_table(lab.cfg("table-1", "imuforge-table.json"));
  t->command_position(0, 5.0);
  lab.bench->faults().exception_code = 6;  // slave device busy
  lab.bench->faults().exception_count = 2;
  t->command_position(0, 10.0);
  EXPECT_EQ(lab.applied(), 2u);
  EXPECT_GE(t->stats().retries, 2u);
}

TEST(ModbusDriver, LateAnswerIsConfirmedByReadBackNotSentTwice) {
  Lab lab(100.0, "imuforge-chamber.json", false);
  auto t = fixture::open_rate_table(lab.cfg("table-1", "imuforge-table.json"));
  std::vector<std::string> notices;
  t->set_notice_handler([&](const std::string& s) { notices.push_back(s); });
  t->command_position(0, 0.0);  // the driver learns the sequence number with its first command
  ASSERT_EQ(lab.applied(), 1u);
  lab.bench->faults().delay_ms = 700;  // > the 0.3 s response timeout
  lab.bench->faults().delay_count = 1;
  t->command_position(0, 10.0);
  EXPECT_EQ(lab.applied(), 2u);
  EXPECT_EQ(t->stats().confirmed_by_readback, 1u);
  EXPECT_EQ(t->stats().resent, 0u);
  EXPECT_GE(t->stats().timeouts, 1u);
  bool told = false;
  for (const auto& n : notices) told = told || contains(n, "NOT sent again");
  EXPECT_TRUE(told);
  ASSERT_TRUE(t->wait_settled(0, 30.0));
  EXPECT_NEAR(t->status(0).angle_deg, 10.0, 1e-4);
}

TEST(ModbusDriver, LostAnswerIsConfirmedByReadBack) {
  Lab lab(100.0, "imuforge-chamber.json", false);
  auto c = fixture::open_chamber(lab.cfg("chamber-1", "imuforge-chamber.json"));
  c->set_notice_handler([](const std::string&) {});
  c->connect();
  lab.bench->faults().drop_count = 1;
  c->set_ramp(1.5);
  EXPECT_EQ(c->stats().confirmed_by_readback, 1u);
  EXPECT_EQ(c->stats().resent, 0u);
  EXPECT_NEAR(c->status().ramp_degC_min, 1.5, 1e-9);
}

TEST(ModbusDriver, LostRequestIsResentWithNotice) {
  Lab lab(100.0, "imuforge-chamber.json", false);
  auto t = fixture::open_rate_table(lab.cfg("table-1", "imuforge-table.json"));
  std::vector<std::string> notices;
  t->set_notice_handler([&](const std::string& s) { notices.push_back(s); });
  t->command_rate(2, 1.0);
  ASSERT_EQ(lab.applied(), 1u);
  lab.bench->faults().ignore_count = 1;
  t->command_rate(2, 5.0);
  EXPECT_EQ(lab.applied(), 2u);
  EXPECT_EQ(t->stats().resent, 1u);
  EXPECT_EQ(t->stats().confirmed_by_readback, 0u);
  bool told = false;
  for (const auto& n : notices) told = told || contains(n, "NOT applied, sending it again");
  EXPECT_TRUE(told);
}

TEST(ModbusDriver, ServerDiesMidCampaignAndComesBack) {
  Lab lab(100.0, "imuforge-chamber.json", false);
  auto t = fixture::open_rate_table(lab.cfg("table-1", "imuforge-table.json"));
  std::vector<std::string> notices;
  t->set_notice_handler([&](const std::string& s) { notices.push_back(s); });
  t->command_position(0, 45.0);
  ASSERT_TRUE(t->wait_settled(0, 30.0));
  lab.kill();
  const std::string m = what_of([&] { t->status(0); });
  EXPECT_TRUE(contains(m, "fixture 'table-1'")) << m;
  EXPECT_TRUE(contains(m, "tcp 127.0.0.1:" + std::to_string(lab.opt.tcp_port))) << m;
  EXPECT_TRUE(contains(m, "axis0 status block")) << m;
  EXPECT_TRUE(contains(m, "after 4 attempts")) << m;
  lab.revive();
  const auto s = t->status(0);  // the driver reconnects by itself
  EXPECT_NEAR(s.angle_deg, 45.0, 1e-4);  // the lab kept its state
  EXPECT_GE(t->stats().reconnects, 1u);
  bool told = false;
  for (const auto& n : notices) told = told || contains(n, "reconnected");
  EXPECT_TRUE(told);
}

TEST(ModbusDriver, ServerDiesDuringACommandWhichLandsExactlyOnce) {
  Lab lab(100.0, "imuforge-chamber.json", false);
  auto cfg = lab.cfg("table-1", "imuforge-table.json");
  cfg.link.retries = 8;
  cfg.link.backoff_s = 0.05;
  auto t = fixture::open_rate_table(cfg);
  t->set_notice_handler([](const std::string&) {});
  t->command_position(1, 0.0);
  ASSERT_EQ(lab.applied(), 1u);
  lab.kill();
  std::thread reviver([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    lab.revive();
  });
  t->command_position(1, -60.0);
  reviver.join();
  EXPECT_EQ(lab.applied(), 2u);
  EXPECT_GE(t->stats().reconnects, 1u);
  ASSERT_TRUE(t->wait_settled(1, 30.0));
  EXPECT_NEAR(t->status(1).angle_deg, -60.0, 1e-4);
}

// A compressed end-of-line-like campaign through the drivers only: three temperature plateaus, a
// 12-position tumble and a CW/CCW rate pair at each, dwells timed on the fixture clock. Prints the
// simulated and wall durations (a figure, not an assertion on wall time).
TEST(ModbusDriver, AcceleratedCampaignOnTheFixtureClock) {
  Lab lab(1000.0, "imuforge-chamber.json", false);
  auto tc = lab.cfg("table-1", "imuforge-table.json");
  auto cc = lab.cfg("chamber-1", "imuforge-chamber.json");
  cc.limits.max_ramp_degC_min = 5.0;
  auto t = fixture::open_rate_table(tc);
  auto c = fixture::open_chamber(cc);
  const auto wall0 = std::chrono::steady_clock::now();
  const double sim0 = t->fixture_time_s();
  auto dwell = [&](double s) {
    const double until = t->fixture_time_s() + s;
    while (t->fixture_time_s() < until) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  };
  double dwelt_s = 0;
  c->set_ramp(5.0);
  for (double plateau : {45.0, 5.0, 25.0}) {
    c->set_setpoint(plateau);
    for (int i = 0; i < 2000; ++i) {  // bounded: 2000 polls of >= 2 ms
      const auto s = c->status();
      if (*s.at_setpoint && std::fabs(s.air_degC - plateau) < 0.05) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    ASSERT_NEAR(c->status().air_degC, plateau, 0.05);
    for (int k = 0; k < 12; ++k) {
      t->command_position(0, 90.0 * (k % 4));
      t->command_position(1, 90.0 * (k / 4));
      ASSERT_TRUE(t->wait_settled(0, 30.0, 0.002));
      ASSERT_TRUE(t->wait_settled(1, 30.0, 0.002));
      dwell(30.0);
      dwelt_s += 30.0;
    }
    for (double r : {100.0, -100.0}) {
      t->command_rate(2, r);
      ASSERT_TRUE(t->wait_settled(2, 30.0, 0.002));
      EXPECT_NEAR(t->status(2).rate_deg_s, r, 1e-4);
      dwell(60.0);
      dwelt_s += 60.0;
    }
    t->stop(2);
  }
  const double sim_s = t->fixture_time_s() - sim0;
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  EXPECT_GE(sim_s, dwelt_s);
  std::printf("[figure] accelerated campaign: %.0f s simulated (%.0f s of dwell) in %.1f s wall, time scale 1000, "
              "%llu Modbus requests\n",
              sim_s, dwelt_s, wall_s, static_cast<unsigned long long>(lab.server->requests()));
  EXPECT_EQ(t->stats().resent + c->stats().resent, 0u);
}

// A lab's own table map with an acceleration-limit register: the driver brings it within the station
// limit before the first command. The station example file parses as the runner will read it.
TEST(ModbusDriver, AccelLimitRegisterAndStationExample) {
  const std::string map = R"({"format":"imuforge-modbus-map","format_version":1,"model":"lab-2axis","kind":"rate_table",
    "axes":2,"axis_stride":20,"points":[
    {"name":"mode","address":100,"type":"u16","access":"rw","per_axis":true,"min":0,"max":2},
    {"name":"command","address":101,"type":"f32","unit":"deg","access":"rw","per_axis":true},
    {"name":"angle","address":105,"type":"f32","per_axis":true},
    {"name":"rate","address":107,"type":"f32","per_axis":true},
    {"name":"status","address":109,"type":"bits","per_axis":true,"bits":{"in_position":0,"settled":1,"fault":3}},
    {"name":"accel","address":110,"type":"u16","unit":"deg/s^2","access":"rw","per_axis":true}]})";
  const std::string path = "/tmp/imuforge-modbus-lab-map-" + std::to_string(getpid()) + ".json";
  {
    FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs(map.c_str(), f);
    std::fclose(f);
  }
  benchsim::WorldConfig wc;
  wc.axes = 2;
  wc.settle_s = 0.2;
  benchsim::RegisterBank bank(fixture::RegisterMap::load(path), fixture::RegisterMap::load(map_path("imuforge-chamber.json")));
  benchsim::Bench bench(benchsim::make_sim_world(wc), std::move(bank), 100.0);
  benchsim::ServerOptions so;
  so.tcp_port = 0;
  benchsim::ModbusServer server(bench, so);
  server.start();
  FixtureConfig c;
  c.name = "lab-table";
  c.map_path = path;
  c.link.port = server.tcp_port();
  c.limits.max_accel_deg_s2 = 200.0;
  auto t = fixture::open_rate_table(c);
  std::vector<std::string> notices;
  t->set_notice_handler([&](const std::string& s) { notices.push_back(s); });
  t->command_position(1, 33.0);  // no cmd_seq in this map: mode, then command
  ASSERT_TRUE(t->wait_settled(1, 30.0));
  EXPECT_NEAR(t->status(1).angle_deg, 33.0, 1e-4);
  fixture::ModbusLink raw("probe", c.link);
  EXPECT_EQ(raw.read(130, 1, "axis1.accel")[0], 200);
  ASSERT_FALSE(notices.empty());
  EXPECT_TRUE(contains(notices[0], "acceleration limit"));
  std::remove(path.c_str());

  // docs/examples/station.json (the runner's example) parses with the shipped maps.
  FILE* f = std::fopen((std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/station.json").c_str(), "r");
  if (f) {
    std::string text;
    char buf[4096];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
    std::fclose(f);
    const auto j = nlohmann::json::parse(text);
    const auto tc = fixture::fixture_config_from_json(j["fixtures"]["table"], IMUFORGE_SOURCE_DIR "/docs/examples");
    const auto cc = fixture::fixture_config_from_json(j["fixtures"]["chamber"], IMUFORGE_SOURCE_DIR "/docs/examples");
    EXPECT_EQ(tc.limits.max_accel_deg_s2, 1000.0);
    EXPECT_NE(cc.map_path.find("watlow-f4.json"), std::string::npos);
  }
}
}  // namespace modbus_test_driver
