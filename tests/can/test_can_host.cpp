// Host CAN client against the virtual IMU on the embedded virtual bus (in-process VirtualImu, the same
// firmware node sources): commands, table flashing, streaming with loss accounting, and bus faults.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <mutex>
#include <thread>

#include "firmware/table/table.h"
#include "host/can/client.h"
#include "host/vimu/virtual_imu.h"
#include "hal/linux/linux_can.h"
#include "tests/can/vcan_dir.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace can_test_can_host {

using namespace imuforge;
using namespace std::chrono_literals;

namespace {

constexpr std::uint64_t kSerial = 4242;

// The virtual buses live in a directory of this program's own, removed when it exits.
using imuforge::testing::virtual_test_bus;

std::vector<std::uint8_t> table_for(std::uint64_t serial, std::uint32_t seq, float bias = 0.0f) {
  fw::Table t;
  fw::table_init_identity(&t, 0.0024f, 0.0005f, 16, 16);
  t.device_serial = serial;
  t.table_sequence = seq;
  if (bias != 0.0f) {
    t.model_flags |= fw::kModelAccelBias;
    t.coeffs[0].accel.b[1] = bias;
  }
  std::vector<std::uint8_t> b(fw::kTableMaxSize);
  const int n = fw::table_serialize(&t, b.data(), b.size());
  EXPECT_GT(n, 0);
  b.resize(static_cast<std::size_t>(n > 0 ? n : 0));
  return b;
}

vimu::VirtualImuConfig imu_config(const std::string& bus) {
  vimu::VirtualImuConfig c;
  c.bus = bus;
  c.node_id = 3;
  c.serial = kSerial;
  return c;
}

can::Client::Options fast_opts() {
  can::Client::Options o;
  o.timeout_ms = 1500;
  o.retries = 2;
  return o;
}

TEST(CanHost, IdentifyFlashReadReboot) {
  const std::string bus = virtual_test_bus("flash");
  vimu::VirtualImu imu(imu_config(bus));
  imu.start();
  auto c = can::Client::connect(bus, 3, fast_opts());
  can::Identity id = c->identify();
  EXPECT_EQ(id.serial, kSerial);
  EXPECT_EQ(id.fw_version, IMUFORGE_VERSION);
  EXPECT_FALSE(id.table_present);
  EXPECT_TRUE(id.key_provisioned);
  EXPECT_THROW(c->read_table(), can::Error);

  const auto key = vimu::dev_key_for_serial(kSerial);
  const auto t1 = table_for(kSerial, 10, 0.05f);
  c->flash_table(t1, 10, key, kSerial);
  id = c->identify();
  EXPECT_TRUE(id.table_present);
  EXPECT_EQ(id.table_seq, 10u);
  EXPECT_EQ(id.table_len, t1.size());
  std::uint32_t seq = 0;
  EXPECT_EQ(c->read_table(&seq), t1);
  EXPECT_EQ(seq, 10u);

  // wrong key: refused with the documented code, table stays
  auto bad = key;
  bad[0] ^= 1u;
  const auto t2 = table_for(kSerial, 11);
  try {
    c->flash_table(t2, 11, bad, kSerial);
    ADD_FAILURE() << "a table with a wrong tag was accepted";
  } catch (const can::Error& e) {
    EXPECT_EQ(e.code(), proto::kStAuthFailed) << e.what();
  }
  // replay of the active sequence number
  try {
    c->write_table(t1, 10, key, kSerial);
    ADD_FAILURE() << "a replayed table was accepted";
  } catch (const can::Error& e) {
    EXPECT_EQ(e.code(), proto::kStReplay) << e.what();
  }
  EXPECT_EQ(c->read_table(), t1);

  c->reboot();
  std::this_thread::sleep_for(50ms);
  const can::NodeStatus st = c->status();
  EXPECT_EQ(st.boots, 2u);
  EXPECT_EQ(c->identify().table_seq, 10u);
  EXPECT_EQ(c->read_table(), t1);
  imu.stop();
}

TEST(CanHost, StreamCarriesTruthWithoutLoss) {
  const std::string bus = virtual_test_bus("stream");
  auto cfg = imu_config(bus);
  cfg.truth = [](double t_s) {
    hal::ImuRawSample s;
    const auto ms = static_cast<std::int16_t>(std::llround(t_s * 1000.0) % 30000);
    s.accel_counts[0] = ms;
    s.accel_counts[2] = 4096;
    s.gyro_counts[1] = static_cast<std::int16_t>(-ms);
    s.temp_cdegC = 3125;
    return s;
  };
  vimu::VirtualImu imu(cfg);
  imu.start();
  auto c = can::Client::connect(bus, 3, fast_opts());
  std::mutex mu;
  std::vector<can::StreamSample> got;
  c->start_stream(1000, proto::kChAll, [&](const can::StreamSample& s) {
    std::lock_guard<std::mutex> lk(mu);
    got.push_back(s);
  });
  std::this_thread::sleep_for(1500ms);
  const std::uint32_t sent = c->stop_stream(100);
  const can::StreamCounters k = c->stream_counters();
  std::lock_guard<std::mutex> lk(mu);
  ASSERT_GT(got.size(), 1200u);
  EXPECT_EQ(k.received, got.size());
  EXPECT_EQ(k.lost, 0u);
  EXPECT_EQ(k.incomplete, 0u);
  EXPECT_EQ(k.duplicated, 0u);
  EXPECT_EQ(got.size(), sent);
  for (std::size_t i = 1; i < got.size(); ++i) {
    ASSERT_EQ(got[i].seq, got[i - 1].seq + 1);
    ASSERT_EQ(got[i].t_us - got[i - 1].t_us, 1000u);  // sensor timestamps at the 1 kHz grid
  }
  for (const auto& s : got) {
    ASSERT_EQ(s.accel_counts[0], static_cast<std::int16_t>((s.t_us + 500) / 1000 % 30000));
    ASSERT_EQ(s.gyro_counts[1], -s.accel_counts[0]);
    ASSERT_EQ(s.accel_counts[2], 4096);
    ASSERT_EQ(s.temp_cdegC, 3125);
  }
  imu.stop();
}

TEST(CanHost, DecoderCountsLossDuplicatesReorder) {
  std::vector<std::uint64_t> seqs;
  can::StreamDecoder d(2, false, proto::kChAll, [&](const can::StreamSample& s) { seqs.push_back(s.seq); });
  auto frame = [](std::uint16_t seq, std::uint8_t part) {
    hal::CanFrame f;
    f.id = proto::stream_id(2, part, false);
    f.len = 8;
    f.data[0] = static_cast<std::uint8_t>(seq);
    f.data[1] = static_cast<std::uint8_t>(seq >> 8);
    return f;
  };
  auto sample = [&](std::uint16_t seq) {
    for (std::uint8_t p = 0; p < 3; ++p) d.on_frame(frame(seq, p));
  };
  sample(65534);
  sample(65535);
  sample(0);      // wrap
  sample(3);      // 1 and 2 lost...
  sample(1);      // ...but 1 was only late: reordered, not lost
  d.on_frame(frame(3, 1));  // duplicate part
  d.on_frame(frame(4, 0));  // 4 incomplete
  d.on_frame(frame(4, 2));
  sample(5);
  d.on_frame(frame(0, 0));  // stale duplicate of a delivered sample
  hal::CanFrame other = frame(9, 0);
  other.id = proto::stream_id(7, 0, false);
  EXPECT_FALSE(d.on_frame(other));
  d.flush();
  const auto& k = d.counters();
  EXPECT_EQ(k.received, 6u);
  EXPECT_EQ(k.lost, 1u);        // seq 2
  EXPECT_EQ(k.reordered, 4u);   // 3 frames of seq 1 + the late frame of seq 0 above
  EXPECT_EQ(k.duplicated, 2u);  // part 1 of seq 3, and seq 0 part 0 again
  EXPECT_EQ(k.incomplete, 1u);  // seq 4
  EXPECT_EQ(k.frames_lost, 3u + 1u);
  ASSERT_EQ(seqs.size(), 6u);
  EXPECT_EQ(seqs[2], 65536u);   // extended across the wrap
}

TEST(CanHost, BusFaultsAreReportedAndTableStays) {
  const std::string bus = virtual_test_bus("faults");
  vimu::VirtualImu imu(imu_config(bus));
  imu.start();
  auto c = can::Client::connect(bus, 3, fast_opts());
  const auto key = vimu::dev_key_for_serial(kSerial);
  const auto t1 = table_for(kSerial, 1);
  c->flash_table(t1, 1, key, kSerial);

  // Lost frames on the wire: the stream reports them, nothing crashes.
  imu.set_tx_drop_every(50);
  c->start_stream(1000, proto::kChAll, nullptr);
  std::this_thread::sleep_for(500ms);
  c->stop_stream(100);
  imu.set_tx_drop_every(0);
  const auto k = c->stream_counters();
  EXPECT_GT(k.frames_lost, 0u);
  EXPECT_GT(k.incomplete, 0u);

  // Bus-off: the node counts it; the host's commands time out and say so.
  imu.set_bus_off(true);
  can::Client::Options o = fast_opts();
  o.timeout_ms = 200;
  o.retries = 1;
  auto c2 = can::Client::connect(bus, 3, o);
  try {
    c2->identify();
    ADD_FAILURE() << "identify succeeded on a bus-off node";
  } catch (const can::Error& e) {
    EXPECT_EQ(e.code(), can::kErrTimeout) << e.what();
    EXPECT_NE(std::string(e.what()).find("did not answer"), std::string::npos);
  }
  imu.set_bus_off(false);
  EXPECT_EQ(c2->identify().table_seq, 1u);

  // Node reset in the middle of table transfers: every flash either completes (retry) or throws;
  // afterwards the node holds a complete table that is the old or the new one.
  std::atomic<bool> stop{false};
  std::thread resetter([&] {
    while (!stop) {
      std::this_thread::sleep_for(7ms);
      imu.reset();
    }
  });
  int ok = 0, failed = 0;
  for (std::uint32_t seq = 2; seq < 8; ++seq) {
    try {
      c->flash_table(table_for(kSerial, seq, 0.001f * static_cast<float>(seq)), seq, key, kSerial);
      ++ok;
    } catch (const can::Error&) {
      ++failed;
    }
  }
  stop = true;
  resetter.join();
  std::this_thread::sleep_for(50ms);
  const can::Identity id = c->identify();
  ASSERT_TRUE(id.table_present);
  std::uint32_t seq = 0;
  const auto now = c->read_table(&seq);
  EXPECT_EQ(seq, id.table_seq);
  EXPECT_EQ(now, seq == 1 ? t1 : table_for(kSerial, seq, 0.001f * static_cast<float>(seq)));
  std::printf("reset storm: %d flashes ok, %d reported failed, active seq %u, client retries %llu\n", ok, failed,
              seq, static_cast<unsigned long long>(c->transfer_stats().retries));
  imu.stop();
}

TEST(CanHost, DeadPeerAndBadSpecsAreClearErrors) {
  can::Client::Options o;
  o.timeout_ms = 100;
  o.retries = 1;
  auto c = can::Client::connect(virtual_test_bus("nobody"), 9, o);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_THROW(c->identify(), can::Error);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 5s);
  EXPECT_THROW(can::Client::connect("bogus", 1), can::Error);
  EXPECT_THROW(can::Client::connect("virtual:a/b", 1), can::Error);
  EXPECT_THROW(can::Client::connect("socketcan:nonexistent0", 1), can::Error);
  EXPECT_THROW(can::Client::connect(virtual_test_bus("x"), 64), can::Error);
  EXPECT_THROW(can::key_from_hex("zz"), std::invalid_argument);
}

// The virtual bus's acceptance filter (issue 14: 16 units on one bus): a sender skips an endpoint whose
// announced filter does not take the id, an endpoint without a filter gets every frame, and the same id
// in 11 and 29 bits are different frames.
TEST(CanHost, VirtualBusAcceptanceFilterIsAppliedBySenders) {
  const std::string bus = virtual_test_bus("filter");
  std::string err;
  auto filtered = hal::open_can_port(bus, &err);
  auto open_all = hal::open_can_port(bus, &err);
  ASSERT_TRUE(filtered && open_all) << err;
  ASSERT_TRUE(hal::set_can_filter(*filtered, {0x123, 0x124}, false, &err)) << err;
  auto sender = hal::open_can_port(bus, &err);  // opened after the filter: reads the announced list
  ASSERT_TRUE(sender) << err;
  auto frame = [](std::uint32_t id, bool ext, std::uint8_t tag) {
    hal::CanFrame f;
    f.id = id;
    f.extended = ext;
    f.len = 1;
    f.data[0] = tag;
    return f;
  };
  ASSERT_EQ(sender->send(frame(0x456, false, 1)), hal::kCanOk);
  ASSERT_EQ(sender->send(frame(0x123, true, 2)), hal::kCanOk);
  ASSERT_EQ(sender->send(frame(0x124, false, 3)), hal::kCanOk);
  // Loopback datagrams are queued when sendto returns; the long wait only covers a descheduled
  // receiver, the short one looks for frames that should not be there.
  auto drain = [](hal::LinuxCanPort& p, std::size_t expected) {
    std::vector<int> tags;
    hal::CanFrame f;
    while (p.receive_wait(f, tags.size() < expected ? 2000 : 50) == hal::kCanOk) tags.push_back(f.data[0]);
    return tags;
  };
  EXPECT_EQ(drain(*open_all, 3), (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(drain(*filtered, 1), (std::vector<int>{3}));
}

}  // namespace
}  // namespace can_test_can_host
