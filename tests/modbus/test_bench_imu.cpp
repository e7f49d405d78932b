// One world: the rate the fixture driver commands over Modbus is the rate the virtual IMU streams over
// the (virtual) CAN bus, and the IMU's temperature is the world's die temperature.
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "host/benchsim/bench.h"
#include "host/benchsim/imu_link.h"
#include "host/benchsim/modbus_server.h"
#include "host/can/client.h"
#include "host/fixture/fixture.h"
#include "host/physics/earth.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace modbus_test_bench_imu {

using namespace imuforge;

namespace {
std::string map_path(const std::string& f) { return std::string(IMUFORGE_SOURCE_DIR) + "/host/fixture/maps/" + f; }

struct Mean {
  std::mutex mu;
  double gz = 0, az = 0, temp = 0;
  long n = 0;
  void add(const can::StreamSample& s) {
    std::lock_guard<std::mutex> l(mu);
    gz += s.gyro_counts[2];
    az += s.accel_counts[2];
    temp += s.temp_cdegC;
    ++n;
  }
  void reset() {
    std::lock_guard<std::mutex> l(mu);
    gz = az = temp = 0;
    n = 0;
  }
};
}  // namespace

TEST(ModbusBenchImu, ImuSeesTheCommandedRateAndTheWorldTemperature) {
  benchsim::WorldConfig wc;
  wc.settle_s = 0.2;
  wc.latitude_deg = 45.0;
  benchsim::RegisterBank bank(fixture::RegisterMap::load(map_path("imuforge-table.json")),
                              fixture::RegisterMap::load(map_path("imuforge-chamber.json")));
  benchsim::Bench bench(benchsim::make_sim_world(wc), std::move(bank), 1.0);
  benchsim::ServerOptions so;
  so.tcp_port = 0;
  benchsim::ModbusServer server(bench, so);
  server.start();
  benchsim::ImuOptions io;
  io.bus = "virtual:modbus-imu-" + std::to_string(getpid());
  io.serial = 4242;
  auto imu = benchsim::start_imu(bench, io);
  benchsim::ImuSampler probe(bench, "", 1);  // same default LSBs as the IMU

  fixture::FixtureConfig tc;
  tc.name = "table-1";
  tc.map_path = map_path("imuforge-table.json");
  tc.link.port = server.tcp_port();
  auto table = fixture::open_rate_table(tc);
  table->command_rate(0, 30.0);  // inner axis = NED down: +30 deg/s about z
  ASSERT_TRUE(table->wait_settled(0, 20.0));

  auto client = can::Client::connect(io.bus, 1);
  EXPECT_EQ(client->identify().serial, 4242u);
  Mean m;
  client->start_stream(200, proto::kChAll, [&](const can::StreamSample& s) { m.add(s); });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  m.reset();
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  client->stop_stream();
  imu->stop();
  ASSERT_GT(m.n, 50);
  physics::Site site;
  site.latitude_deg = 45.0;
  const double wz_expected = 30.0 * M_PI / 180.0 + physics::earth_rate_ned(site).z();
  EXPECT_NEAR(m.gz / m.n * probe.gyro_lsb(), wz_expected, 2.0 * probe.gyro_lsb());
  EXPECT_NEAR(m.az / m.n * probe.accel_lsb(), -physics::normal_gravity_mps2(site), 2.0 * probe.accel_lsb());
  double die_C;
  {
    std::lock_guard<std::mutex> l(bench.mutex());
    die_C = bench.world().imu_truth().die_C;
  }
  EXPECT_NEAR(m.temp / m.n / 100.0, die_C, 0.02);
}

// With a sensor model, the bench's IMU carries the model's errors and noise (host/model + host/sim
// noise processes): repeated static samples scatter, and the same seed gives the same samples.
TEST(ModbusBenchImu, SensorModelErrorsAndNoiseAreApplied) {
  const std::string sensor = std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/sensor-consumer.json";
  auto make = [&] {
    benchsim::WorldConfig wc;
    benchsim::RegisterBank bank(fixture::RegisterMap::load(map_path("imuforge-table.json")),
                                fixture::RegisterMap::load(map_path("imuforge-chamber.json")));
    return std::make_unique<benchsim::Bench>(benchsim::make_sim_world(wc), std::move(bank), 1.0);
  };
  auto b1 = make(), b2 = make();
  benchsim::ImuSampler ideal(*b1, "", 7), real1(*b1, sensor, 7), real2(*b2, sensor, 7);
  double sum = 0, sum2 = 0, ideal_first = 0;
  bool ideal_constant = true, same_seed_same = true;
  const int n = 2000;
  for (int i = 0; i < n; ++i) {
    const double t = 1.0 + i * 0.001;
    const auto si = ideal.sample(t);
    if (i == 0) ideal_first = si.accel_counts[2];
    ideal_constant = ideal_constant && si.accel_counts[2] == ideal_first;
    const auto s1 = real1.sample(t), s2 = real2.sample(t);
    same_seed_same = same_seed_same && s1.gyro_counts[0] == s2.gyro_counts[0] && s1.accel_counts[2] == s2.accel_counts[2];
    const double gx = s1.gyro_counts[0] * real1.gyro_lsb();
    sum += gx;
    sum2 += gx * gx;
  }
  EXPECT_TRUE(ideal_constant);
  EXPECT_TRUE(same_seed_same);
  const double mean = sum / n, sd = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
  EXPECT_GT(sd, 0.0);  // the consumer part is noisy at 1 kHz
}

// Several virtual IMUs on one bench (issue 14 item 5): each slot its own node, serial and sensor
// realisation; a slot's nest rotation tilts what it senses; a dead slot never answers.
TEST(ModbusBenchImu, SlotsAreSeparateUnitsWithTheirOwnNestAndNoise) {
  benchsim::SlotPlan plan;
  plan.slots = 4;
  plan.buses = {"virtual:bench-slots-a-" + std::to_string(getpid()), "virtual:bench-slots-b-" + std::to_string(getpid())};
  plan.first_serial = 500;
  plan.first_node = 3;
  plan.seed = 9;
  plan.nest_sigma_rad = 0.5 * M_PI / 180;
  plan.dead = {2};
  const auto opts = benchsim::slot_imus(plan);
  ASSERT_EQ(opts.size(), 3u);
  EXPECT_EQ(opts[0].node_id, 3);
  EXPECT_EQ(opts[1].node_id, 5);  // slot 3; slot 2 (node 4) is dead
  EXPECT_EQ(opts[1].serial, 502u);
  EXPECT_EQ(opts[1].bus, plan.buses[0]);
  EXPECT_EQ(opts[2].bus, plan.buses[1]);
  EXPECT_NE(opts[0].seed, opts[1].seed);
  EXPECT_GT((opts[0].nest_error_rad - opts[1].nest_error_rad).norm(), 0.0);
  EXPECT_EQ(benchsim::slot_imus(plan)[2].nest_error_rad, opts[2].nest_error_rad) << "seeded per slot";
  benchsim::SlotPlan bad = plan;
  bad.first_node = 126;
  EXPECT_THROW(benchsim::slot_imus(bad), std::invalid_argument);

  benchsim::WorldConfig wc;
  wc.latitude_deg = 45.0;
  benchsim::RegisterBank bank(fixture::RegisterMap::load(map_path("imuforge-table.json")),
                              fixture::RegisterMap::load(map_path("imuforge-chamber.json")));
  benchsim::Bench bench(benchsim::make_sim_world(wc), std::move(bank), 1.0);
  std::vector<std::unique_ptr<benchsim::ImuLink>> imus;
  for (const auto& o : opts) imus.push_back(benchsim::start_imu(bench, o));
  benchsim::ImuSampler probe(bench, "", 1);
  const double g = physics::normal_gravity_mps2(physics::Site{45.0, 0.0});
  for (const auto& o : opts) {
    auto client = can::Client::connect(o.bus, static_cast<std::uint8_t>(o.node_id));
    EXPECT_EQ(client->identify().serial, o.serial);
    Mean m;
    double ax = 0, ay = 0;
    std::mutex mu;
    client->start_stream(200, proto::kChAll, [&](const can::StreamSample& s) {
      std::lock_guard<std::mutex> l(mu);
      ax += s.accel_counts[0];
      ay += s.accel_counts[1];
      m.add(s);
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    client->stop_stream();
    std::lock_guard<std::mutex> l(mu);
    ASSERT_GT(m.n, 20);
    // Static, z down: the nest rotation e puts Exp([e×])·(0, 0, −g) on x and y: (−g e_y, +g e_x).
    EXPECT_NEAR(ax / m.n * probe.accel_lsb(), -g * o.nest_error_rad.y(), 1.5 * probe.accel_lsb()) << o.node_id;
    EXPECT_NEAR(ay / m.n * probe.accel_lsb(), g * o.nest_error_rad.x(), 1.5 * probe.accel_lsb()) << o.node_id;
  }
  // The dead slot's node (4) never answers.
  can::Client::Options co;
  co.timeout_ms = 200;
  co.retries = 0;
  auto dead = can::Client::connect(plan.buses[1], 4, co);
  EXPECT_THROW(dead->identify(), can::Error);
  for (auto& i : imus) i->stop();
}
}  // namespace modbus_test_bench_imu
