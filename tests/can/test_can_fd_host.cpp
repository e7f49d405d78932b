// CAN FD stream on the host: the decoder against the firmware node (the same samples as the classic
// stream, exactly), lost and malformed FD frames, the virtual bus's FD datagrams, and the client with the
// virtual IMU end to end (FD stream, classic-only node refusing it).
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <random>
#include <mutex>
#include <thread>
#include <vector>

#include "hal/linux/linux_can.h"
#include "host/can/client.h"
#include "host/can/stream_decoder.h"
#include "host/vimu/virtual_imu.h"
#include "tests/can/node_harness.h"
#include "tests/can/vcan_dir.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace can_test_can_fd_host {

using namespace imuforge;
using namespace std::chrono_literals;

namespace {

// The virtual buses live in a directory of this program's own, removed when it exits.
using imuforge::testing::virtual_test_bus;

struct NodeRun {
  std::vector<can::StreamSample> samples;
  can::StreamCounters k;
  std::uint32_t node_sent = 0, bus_dropped = 0;
};

// The firmware node (RampSensor, loop bus) streams `polls` x 250 µs from the same start time in either
// format; its frames go straight into a host StreamDecoder. Deterministic: no threads, no clock.
NodeRun node_stream(bool fd, std::uint16_t rate_hz, unsigned polls, std::uint32_t drop_every = 0) {
  static cantest::NodeRig rig;  // 40 KB: not on the stack
  rig.t_us = 1000;
  rig.init();
  rig.bus.fd = true;
  rig.bus.drop_every = drop_every;
  rig.cfg.can_fd = true;
  rig.node.counters = fw::NodeCounters{};
  fw::node_init(rig.node, rig.cfg, rig.node_port, rig.flash, rig.sensor);
  (void)fw::node_boot(rig.node, rig.t_us);
  NodeRun r;
  can::StreamDecoder dec(5, false, proto::kChAll, [&](const can::StreamSample& s) { r.samples.push_back(s); }, fd,
                         rate_hz);
  auto drain = [&] {
    hal::CanFrame f;
    while (rig.host_port.receive(f) == hal::kCanOk) dec.on_frame(f);
    hal::CanFdFrame g;
    while (rig.host_port.take_fd(g)) dec.on_frame(g);
  };
  std::uint8_t req[5] = {proto::kCmdStreamStart, 0, 0, proto::kChAll, proto::kStreamFlagFd};
  fw::store_le16(req + 1, rate_hz);
  std::uint8_t resp[proto::kMaxMessageBytes];
  fw::node_handle_command(rig.node, req, fd ? 5 : 4, resp, sizeof resp, rig.t_us);
  EXPECT_EQ(resp[1], proto::kStOk);
  for (unsigned i = 0; i < polls; ++i) {
    fw::node_poll(rig.node, rig.t_us);
    drain();
    rig.t_us += 250;
  }
  const std::uint8_t stop[1] = {proto::kCmdStreamStop};
  fw::node_handle_command(rig.node, stop, 1, resp, sizeof resp, rig.t_us);
  drain();
  dec.flush();
  r.k = dec.counters();
  r.node_sent = rig.node.counters.samples_sent;
  r.bus_dropped = rig.bus.dropped;
  return r;
}

hal::CanFdFrame fd_frame(std::uint16_t seq, std::uint8_t count, std::uint32_t t_us, std::uint8_t node = 2) {
  hal::CanFdFrame f;
  f.id = proto::stream_id(node, proto::kPartFd, false);
  f.len = 64;
  std::memset(f.data, proto::kFdPadByte, sizeof f.data);
  fw::store_le16(f.data, seq);
  f.data[2] = count;
  f.data[3] = proto::kChAll;
  fw::store_le32(f.data + 4, t_us);
  fw::store_le16s(f.data + 8, 2000);
  for (unsigned i = 0; i < count && i < 4; ++i) {
    std::uint8_t* p = f.data + proto::kFdHeaderBytes + proto::kFdSampleBytes * i;
    for (int a = 0; a < 6; ++a) fw::store_le16s(p + 2 * a, static_cast<std::int16_t>(seq + i + a));
    if (i > 0) fw::store_le16s(f.data + proto::kFdTempTailOffset + 2 * (i - 1), static_cast<std::int16_t>(2000 + i));
  }
  return f;
}

}  // namespace

TEST(CanFd, NodeFdStreamDecodesToTheClassicSamplesExactly) {
  for (std::uint16_t rate : {std::uint16_t{1000}, std::uint16_t{200}, std::uint16_t{333}}) {
    const NodeRun c = node_stream(false, rate, 4000);  // 1 s
    const NodeRun f = node_stream(true, rate, 4000);
    ASSERT_GT(c.samples.size(), static_cast<std::size_t>(rate) - 2) << rate;
    EXPECT_EQ(c.samples.size(), c.node_sent);
    EXPECT_EQ(f.samples.size(), f.node_sent);  // the partial frame at stop included
    ASSERT_EQ(f.samples.size(), c.samples.size()) << rate;
    for (const NodeRun* r : {&c, &f}) {
      EXPECT_EQ(r->k.lost, 0u);
      EXPECT_EQ(r->k.incomplete, 0u);
      EXPECT_EQ(r->k.malformed, 0u);
    }
    EXPECT_EQ(f.k.frames, (f.node_sent + 3) / 4);
    EXPECT_EQ(c.k.frames, 3u * c.node_sent);
    for (std::size_t i = 0; i < c.samples.size(); ++i) {
      const auto& a = c.samples[i];
      const auto& b = f.samples[i];
      ASSERT_EQ(a.seq, b.seq) << i;
      ASSERT_EQ(a.t_us, b.t_us) << i;  // FD: first sample's t_us + i * period, the classic one per sample
      ASSERT_EQ(a.temp_cdegC, b.temp_cdegC) << i;
      for (int j = 0; j < 3; ++j) {
        ASSERT_EQ(a.accel_counts[j], b.accel_counts[j]) << i;
        ASSERT_EQ(a.gyro_counts[j], b.gyro_counts[j]) << i;
      }
    }
  }
}

TEST(CanFd, LostFdFrameIsAGapOfItsCount) {
  const NodeRun f = node_stream(true, 1000, 4000, /*drop_every=*/7);
  ASSERT_GT(f.bus_dropped, 10u);
  // Every dropped frame but possibly the last one (no later frame shows its gap) held 4 samples.
  EXPECT_GE(f.k.frames_lost, f.bus_dropped - 1);
  EXPECT_LE(f.k.frames_lost, f.bus_dropped);
  EXPECT_EQ(f.k.lost, 4u * f.k.frames_lost);
  // What the decoder cannot see: the last frame, if it was the one dropped (1..4 samples).
  const std::uint64_t unseen = f.node_sent - (f.k.received + f.k.lost);
  if (f.bus_dropped == f.k.frames_lost) {
    EXPECT_EQ(unseen, 0u);
  } else {
    EXPECT_GE(unseen, 1u);
    EXPECT_LE(unseen, 4u);
  }
  EXPECT_EQ(f.k.received, f.samples.size());
  EXPECT_EQ(f.k.malformed, 0u);
  EXPECT_EQ(f.k.incomplete, 0u);
  // Delivered samples are still consecutive inside each frame, with their own timestamps.
  for (std::size_t i = 1; i < f.samples.size(); ++i) {
    ASSERT_EQ(f.samples[i].t_us - f.samples[i - 1].t_us, 1000u * (f.samples[i].seq - f.samples[i - 1].seq));
  }
}

TEST(CanFd, DecoderGapsLateDuplicatesWrapAndTimestamps) {
  std::vector<can::StreamSample> got;
  can::StreamDecoder d(2, false, proto::kChAll, [&](const can::StreamSample& s) { got.push_back(s); }, true, 1000);
  // Starts just before both wraps: seq 65534 and t_us 2^32 - 2000.
  d.on_frame(fd_frame(65534, 4, 0xFFFFF830u));  // 65534..65537
  d.on_frame(fd_frame(6, 4, 0xFFFFF830u + 8000u));  // seq 2..5 (one frame) lost
  EXPECT_EQ(d.counters().lost, 4u);
  EXPECT_EQ(d.counters().frames_lost, 1u);
  d.on_frame(fd_frame(2, 4, 0xFFFFF830u + 4000u));  // ...only late
  EXPECT_EQ(d.counters().lost, 0u);
  EXPECT_EQ(d.counters().frames_lost, 0u);
  EXPECT_EQ(d.counters().reordered, 1u);  // once per frame
  d.on_frame(fd_frame(2, 4, 0xFFFFF830u + 4000u));
  EXPECT_EQ(d.counters().duplicated, 1u);
  d.on_frame(fd_frame(10, 2, 0xFFFFF830u + 12000u));  // a partial frame (stop)
  d.on_frame(fd_frame(17, 1, 0xFFFFF830u + 19000u));  // 12..16: 5 samples, 2 frames' worth
  EXPECT_EQ(d.counters().lost, 5u);
  EXPECT_EQ(d.counters().frames_lost, 2u);
  d.flush();
  ASSERT_EQ(got.size(), 4u + 4u + 4u + 2u + 1u);
  EXPECT_EQ(got[2].seq, 65536u);                          // extended across the wrap
  EXPECT_EQ(got[2].t_us, (1ull << 32) + 0u);              // 2^32 - 2000 + 2 * 1000
  EXPECT_EQ(got[3].t_us, (1ull << 32) + 1000u);
  EXPECT_EQ(got[1].temp_cdegC, 2001);                     // each sample's own temperature
  EXPECT_EQ(got[0].temp_cdegC, 2000);
  EXPECT_EQ(got[1].gyro_counts[2], static_cast<std::int16_t>(65535 + 5));
  EXPECT_EQ(d.counters().received, got.size());
  EXPECT_EQ(d.counters().malformed, 0u);
  EXPECT_THROW(can::StreamDecoder(2, false, proto::kChAll, nullptr, true, 0), std::invalid_argument);
}

TEST(CanFd, MalformedFdFramesAreRejectedWithAReason) {
  std::vector<can::StreamSample> got;
  can::StreamDecoder d(2, false, proto::kChAll, [&](const can::StreamSample& s) { got.push_back(s); }, true, 1000);
  EXPECT_STREQ(d.last_reject_reason(), "");
  auto f = fd_frame(0, 0, 0);
  EXPECT_TRUE(d.on_frame(f));
  EXPECT_EQ(d.counters().malformed_count, 1u);
  EXPECT_NE(std::string(d.last_reject_reason()).find("count 0 or above 4"), std::string::npos);
  f = fd_frame(0, 5, 0);
  d.on_frame(f);
  f = fd_frame(0, 255, 0);
  d.on_frame(f);
  EXPECT_EQ(d.counters().malformed_count, 3u);
  f = fd_frame(0, 4, 0);
  f.len = 48;  // 4 samples need all 64 bytes
  d.on_frame(f);
  f.len = 8;  // not even the header
  f.fd = true;
  d.on_frame(f);
  EXPECT_EQ(d.counters().malformed_short, 2u);
  EXPECT_NE(std::string(d.last_reject_reason()).find("shorter"), std::string::npos);
  f = fd_frame(0, 1, 0);
  f.len = 24;  // one sample in 22 bytes: enough
  d.on_frame(f);
  EXPECT_EQ(got.size(), 1u);
  f = fd_frame(1, 4, 1000);
  f.data[3] = proto::kChAccel;  // other channels than asked for
  d.on_frame(f);
  hal::CanFrame classic;
  classic.id = proto::stream_id(2, proto::kPartFd, false);
  classic.len = 8;
  EXPECT_TRUE(d.on_frame(classic));  // a classic frame on the FD id
  EXPECT_EQ(d.counters().malformed_format, 2u);
  EXPECT_EQ(d.counters().malformed, 7u);
  EXPECT_EQ(d.counters().lost, 0u);  // rejected frames leave no trace in the sequence accounting
  EXPECT_EQ(got.size(), 1u);
  // Another node's FD frame is not ours; a classic decoder ignores FD frames.
  EXPECT_FALSE(d.on_frame(fd_frame(0, 4, 0, 7)));
  can::StreamDecoder classic_dec(2, false, proto::kChAll, nullptr);
  EXPECT_TRUE(classic_dec.on_frame(fd_frame(0, 4, 0)));
  EXPECT_EQ(classic_dec.counters().frames, 0u);
  // Arbitrary bytes never crash it.
  std::mt19937_64 rng(7);
  for (int i = 0; i < 20000; ++i) {
    hal::CanFdFrame x;
    x.id = proto::stream_id(2, proto::kPartFd, false);
    x.len = static_cast<std::uint8_t>(rng() % 65);
    for (auto& b : x.data) b = static_cast<std::uint8_t>(rng());
    if (rng() % 2) x.data[3] = proto::kChAll;
    d.on_frame(x);
  }
  EXPECT_EQ(d.counters().received, got.size());
}

// Found by fuzz_stream_decoder: a late frame of an earlier run whose seq is just below this stream's first
// one (seq -1 after extension) matched an empty slot and un-counted a loss never counted (lost wrapped).
TEST(CanFd, FrameFromBeforeTheStreamStartIsIgnored) {
  // The stream starts at seq 3 (extended: 3); a stale frame with seq 65535 extends to -1, one with
  // 65533 (FD, 4 samples) to -3..0.
  for (bool fd : {false, true}) {
    can::StreamDecoder d(2, false, proto::kChAll, nullptr, fd, 1000);
    if (fd) {
      d.on_frame(fd_frame(3, 4, 0));
      d.on_frame(fd_frame(65533, 4, 0));
      d.on_frame(fd_frame(65535, 1, 0));
    } else {
      for (std::uint8_t p = 0; p < 3; ++p) {
        hal::CanFrame f;
        f.id = proto::stream_id(2, p, false);
        f.len = 8;
        f.data[0] = 3;
        d.on_frame(f);
        f.data[0] = 0xFF;
        f.data[1] = 0xFF;
        d.on_frame(f);
      }
    }
    d.flush();
    EXPECT_EQ(d.counters().lost, 0u) << fd;
    EXPECT_EQ(d.counters().frames_lost, 0u) << fd;
    EXPECT_EQ(d.counters().incomplete, 0u) << fd;
    EXPECT_EQ(d.counters().received, fd ? 4u : 1u) << fd;
  }
}

TEST(CanFd, VirtualBusCarriesFdDatagramsBesideClassicOnes) {
  const std::string bus = virtual_test_bus("fdbus");
  std::string err;
  auto rx = hal::open_can_port(bus, &err);
  ASSERT_TRUE(rx) << err;
  auto tx = hal::open_can_port(bus, &err);
  ASSERT_TRUE(tx) << err;
  EXPECT_TRUE(tx->fd_enabled());
  hal::CanFdFrame f = fd_frame(9, 4, 123);
  f.brs = false;
  EXPECT_EQ(tx->send_fd(f), hal::kCanOk);
  hal::CanFrame c;
  c.id = 0x601;
  c.len = 3;
  c.data[0] = 0xAB;
  EXPECT_EQ(tx->send(c), hal::kCanOk);
  hal::CanFdFrame bad = f;
  bad.len = 33;
  EXPECT_EQ(tx->send_fd(bad), hal::kCanErrFdLength);
  hal::CanFdFrame got[4];
  int n = 0;
  for (int tries = 0; tries < 100 && n < 2; ++tries) {
    const int k = rx->receive_many_any_wait(got + n, 4 - n, 20);
    ASSERT_GE(k, 0);
    n += k;
  }
  ASSERT_EQ(n, 2);
  EXPECT_TRUE(got[0].fd);
  EXPECT_FALSE(got[0].brs);
  EXPECT_EQ(got[0].len, 64);
  EXPECT_EQ(got[0].id, f.id);
  EXPECT_EQ(std::memcmp(got[0].data, f.data, 64), 0);
  EXPECT_FALSE(got[1].fd);
  EXPECT_EQ(got[1].len, 3);
  EXPECT_EQ(got[1].data[0], 0xAB);
  // A classic reader on the same bus gets the classic frame only.
  EXPECT_EQ(tx->send_fd(f), hal::kCanOk);
  EXPECT_EQ(tx->send(c), hal::kCanOk);
  hal::CanFrame r;
  int rc = hal::kCanErrWouldBlock;
  for (int tries = 0; tries < 100 && rc == hal::kCanErrWouldBlock; ++tries) rc = rx->receive_wait(r, 20);
  ASSERT_EQ(rc, hal::kCanOk);
  EXPECT_EQ(r.id, 0x601u);
}

TEST(CanFd, ClientStreamsFdFromTheVirtualImu) {
  const std::string bus = virtual_test_bus("fdclient");
  vimu::VirtualImuConfig cfg;
  cfg.bus = bus;
  cfg.node_id = 3;
  cfg.serial = 77;
  cfg.truth = [](double t_s) {
    hal::ImuRawSample s;
    const auto ms = static_cast<std::int16_t>(std::llround(t_s * 1000.0) % 30000);
    s.accel_counts[0] = ms;
    s.gyro_counts[1] = static_cast<std::int16_t>(-ms);
    s.temp_cdegC = static_cast<std::int16_t>(2000 + ms % 7);
    return s;
  };
  vimu::VirtualImu imu(cfg);
  imu.start();
  can::Client::Options o;
  o.timeout_ms = 500;
  auto c = can::Client::connect(bus, 3, o);
  EXPECT_TRUE(c->identify().can_fd);
  for (bool fd : {false, true}) {
    std::mutex mu;
    std::vector<can::StreamSample> got;
    const std::uint32_t sent_before = c->status().samples_sent;
    c->start_stream(1000, proto::kChAll, [&](const can::StreamSample& s) {
      std::lock_guard<std::mutex> lk(mu);
      got.push_back(s);
    }, fd);
    EXPECT_EQ(c->status().stream_fd, fd);
    std::this_thread::sleep_for(1000ms);
    const std::uint32_t sent_total = c->stop_stream(100);
    const auto k = c->stream_counters();
    std::lock_guard<std::mutex> lk(mu);
    ASSERT_GT(got.size(), 700u) << (fd ? "fd" : "classic");
    EXPECT_EQ(k.lost, 0u);
    EXPECT_EQ(k.malformed, 0u);
    EXPECT_EQ(k.received, got.size());
    EXPECT_EQ(k.frames, fd ? (got.size() + 3) / 4 : 3 * got.size());
    EXPECT_EQ(got.size(), sent_total - sent_before);  // same count as the node sent, either format
    for (std::size_t i = 1; i < got.size(); ++i) {
      ASSERT_EQ(got[i].seq, got[i - 1].seq + 1);
      ASSERT_EQ(got[i].t_us - got[i - 1].t_us, 1000u);
    }
    for (const auto& s : got) {
      const auto ms = static_cast<std::int16_t>((s.t_us + 500) / 1000 % 30000);
      ASSERT_EQ(s.accel_counts[0], ms);
      ASSERT_EQ(s.gyro_counts[1], -ms);
      ASSERT_EQ(s.temp_cdegC, 2000 + ms % 7);
    }
  }

  // Frames lost on the wire (every 9th frame the node sends, responses included): each lost FD frame is
  // a gap of its count, 4 but for a partial one; every delivered sample is still the truth.
  const std::uint32_t sent_before = c->status().samples_sent;
  imu.set_tx_drop_every(9);
  std::vector<can::StreamSample> got;
  std::mutex mu;
  c->start_stream(1000, proto::kChAll, [&](const can::StreamSample& s) {
    std::lock_guard<std::mutex> lk(mu);
    got.push_back(s);
  }, true);
  std::this_thread::sleep_for(600ms);
  const std::uint32_t sent = c->stop_stream(100) - sent_before;
  imu.set_tx_drop_every(0);
  const auto k = c->stream_counters();
  std::lock_guard<std::mutex> lk(mu);
  EXPECT_GT(k.frames_lost, 5u);
  EXPECT_LE(k.lost, 4 * k.frames_lost);
  EXPECT_LE(4 * k.frames_lost - k.lost, 3u);  // at most one partial frame among the lost ones
  EXPECT_GE(k.received + k.lost, sent - 4u);  // the last frame's loss (if dropped) shows no gap
  EXPECT_LE(k.received + k.lost, sent);
  EXPECT_EQ(k.received, got.size());
  for (const auto& s : got) {
    const auto ms = static_cast<std::int16_t>((s.t_us + 500) / 1000 % 30000);
    ASSERT_EQ(s.accel_counts[0], ms);
  }
  imu.stop();

  // A classic-only part refuses an FD stream with its own status, and says so in identify.
  cfg.can_fd = false;
  cfg.bus = virtual_test_bus("fdclassic");
  vimu::VirtualImu old(cfg);
  old.start();
  auto c2 = can::Client::connect(cfg.bus, 3, o);
  EXPECT_FALSE(c2->identify().can_fd);
  try {
    c2->start_stream(1000, proto::kChAll, nullptr, true);
    ADD_FAILURE() << "a classic-only node accepted an FD stream";
  } catch (const can::Error& e) {
    EXPECT_EQ(e.code(), proto::kStFdUnsupported) << e.what();
    EXPECT_NE(std::string(e.what()).find("CAN FD"), std::string::npos) << e.what();
  }
  old.stop();
}
}  // namespace can_test_can_fd_host
