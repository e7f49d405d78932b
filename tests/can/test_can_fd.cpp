// CAN FD: the HAL frame check, and the firmware node's FD sample stream on the in-memory bus (frame
// layout byte by byte against the sensor, 4 samples per frame, the partial frame at stop / reboot /
// sensor error / FIFO overflow, refusals). Runs on the host and on the Cortex-M target (fwtest).
#include <cstring>

#include "tests/can/fwcheck.h"
#include "tests/can/node_harness.h"

using namespace imuforge;
using namespace imuforge::fw;

namespace {

cantest::NodeRig rig;

// The rig's node on a bus that carries FD (or not), with an FD-capable controller (or not).
void init_fd(bool bus_fd, bool node_fd) {
  rig.init();
  rig.bus.fd = bus_fd;
  rig.cfg.can_fd = node_fd;
  rig.node.counters = NodeCounters{};  // node_init keeps counters across a reboot; each case starts at 0
  rig.stream_frames = 0;
  node_init(rig.node, rig.cfg, rig.node_port, rig.flash, rig.sensor);
  (void)node_boot(rig.node, rig.t_us);
}

std::uint8_t start(std::uint16_t rate_hz, std::uint8_t channels, int flags) {
  std::uint8_t r[5] = {proto::kCmdStreamStart, 0, 0, channels, 0};
  store_le16(r + 1, rate_hz);
  std::size_t len = 4;
  if (flags >= 0) {
    r[4] = static_cast<std::uint8_t>(flags);
    len = 5;
  }
  return rig.exchange(r, len) >= 2 ? rig.host_rx[1] : 0xFF;
}

std::uint8_t cmd1(std::uint8_t cmd) {
  std::uint8_t r[1] = {cmd};
  return rig.exchange(r, 1) >= 2 ? rig.host_rx[1] : 0xFF;
}

// What RampSensor returns at t_us (tests/can/node_harness.h), as the node would pack it.
std::int16_t ramp(std::uint64_t t_us) { return static_cast<std::int16_t>(t_us / 1000u); }
std::int16_t ramp_temp(std::uint64_t t_us) { return static_cast<std::int16_t>(2500 + static_cast<int>(t_us / 1000u % 100u)); }

struct FdLog {
  unsigned frames = 0, samples = 0, partial = 0, bad_layout = 0, bad_values = 0, seq_breaks = 0;
  long next_seq = -1;
};

// Checks every FD frame queued at the host port against the layout and the sensor.
void drain(FdLog& log, std::uint8_t channels, std::uint32_t period_us) {
  hal::CanFdFrame f;
  while (rig.host_port.take_fd(f)) {
    ++log.frames;
    if (f.id != proto::stream_id(5, proto::kPartFd, false) || f.extended || !f.fd || !f.brs ||
        f.len != proto::kFdFrameBytes) {
      ++log.bad_layout;
      continue;
    }
    const unsigned count = f.data[2];
    if (count == 0u || count > proto::kFdSamplesPerFrame || f.data[3] != channels) {
      ++log.bad_layout;
      continue;
    }
    if (count < proto::kFdSamplesPerFrame) ++log.partial;
    const long seq = load_le16(f.data);
    if (log.next_seq >= 0 && seq != log.next_seq) ++log.seq_breaks;
    log.next_seq = (seq + static_cast<long>(count)) % 65536;
    const std::uint32_t t0 = load_le32(f.data + 4);
    if (load_le16s(f.data + 8) != ramp_temp(t0)) ++log.bad_values;
    for (unsigned i = 0; i < count; ++i) {
      const std::uint8_t* p = f.data + proto::kFdHeaderBytes + proto::kFdSampleBytes * i;
      const std::int16_t v = ramp(t0 + i * period_us);
      for (int a = 0; a < 3; ++a) {
        const std::int16_t ax = (channels & proto::kChAccel) ? static_cast<std::int16_t>(v + a) : 0;
        const std::int16_t gx = (channels & proto::kChGyro) ? static_cast<std::int16_t>(-v - a) : 0;
        if (load_le16s(p + 2 * a) != ax || load_le16s(p + 6 + 2 * a) != gx) ++log.bad_values;
      }
    }
    for (unsigned i = 1; i < count; ++i) {
      if (load_le16s(f.data + proto::kFdTempTailOffset + 2 * (i - 1)) != ramp_temp(t0 + i * period_us)) ++log.bad_values;
    }
    // Bytes of samples the frame does not hold: padding.
    for (unsigned b = proto::kFdHeaderBytes + proto::kFdSampleBytes * count; b < proto::kFdTempTailOffset; ++b) {
      if (f.data[b] != proto::kFdPadByte) ++log.bad_layout;
    }
    for (unsigned b = proto::kFdTempTailOffset + 2 * (count - 1); b < proto::kFdFrameBytes; ++b) {
      if (f.data[b] != proto::kFdPadByte) ++log.bad_layout;
    }
    log.samples += count;
  }
}

void frame_check() {
  hal::CanFdFrame f;
  f.id = 0x10F;
  const unsigned ok_len[] = {0, 1, 7, 8, 12, 16, 20, 24, 32, 48, 64};
  for (unsigned n : ok_len) {
    f.len = static_cast<std::uint8_t>(n);
    CHECK_EQ(hal::can_fd_frame_check(f), hal::kCanOk);
  }
  const unsigned bad_len[] = {9, 10, 11, 13, 33, 63, 65, 255};
  for (unsigned n : bad_len) {
    f.len = static_cast<std::uint8_t>(n);
    CHECK_EQ(hal::can_fd_frame_check(f), hal::kCanErrFdLength);
    CHECK(!hal::can_fd_frame_valid(f));
  }
  CHECK_EQ(hal::kCanErrFdLength, -6);  // stable: part of the HAL's error codes
  CHECK_EQ(hal::kCanErrNoFd, -7);
  // A classic frame in the FD type: 0..8 only.
  f.fd = false;
  f.len = 8;
  CHECK_EQ(hal::can_fd_frame_check(f), hal::kCanOk);
  f.len = 12;
  CHECK_EQ(hal::can_fd_frame_check(f), hal::kCanErrFdLength);
  // Identifier out of range: the same code as a classic frame's; the length is checked first.
  f.fd = true;
  f.len = 64;
  f.id = 0x800;
  CHECK_EQ(hal::can_fd_frame_check(f), hal::kCanErrArg);
  f.extended = true;
  CHECK_EQ(hal::can_fd_frame_check(f), hal::kCanOk);
  f.id = 0x20000000u;
  CHECK_EQ(hal::can_fd_frame_check(f), hal::kCanErrArg);
  f.len = 9;
  CHECK_EQ(hal::can_fd_frame_check(f), hal::kCanErrFdLength);
  // The loop bus rejects a bad length with the same code, and a classic bus refuses FD altogether.
  init_fd(true, true);
  f.id = 0x10F;
  f.extended = false;
  CHECK_EQ(rig.node_port.send_fd(f), hal::kCanErrFdLength);
  rig.bus.fd = false;
  f.len = 64;
  CHECK_EQ(rig.node_port.send_fd(f), hal::kCanErrNoFd);
}

void refusals() {
  // A classic-only node: identify says so, an FD stream start is refused with its own status.
  init_fd(false, false);
  std::uint8_t q[1] = {proto::kCmdIdentify};
  CHECK_EQ(rig.exchange(q, 1), 2 + proto::kIdentifyBytes);
  CHECK_EQ(rig.host_rx[2 + 38] & proto::kIdCanFd, 0);
  CHECK_EQ(start(1000, proto::kChAll, proto::kStreamFlagFd), proto::kStFdUnsupported);
  CHECK(!rig.node.streaming);
  // Unknown flag bits and a 6-byte request.
  init_fd(true, true);
  CHECK_EQ(rig.exchange(q, 1), 2 + proto::kIdentifyBytes);
  CHECK_EQ(rig.host_rx[2 + 38] & proto::kIdCanFd, proto::kIdCanFd);
  CHECK_EQ(start(1000, proto::kChAll, 0x02), proto::kStBadArgument);
  std::uint8_t r6[6] = {proto::kCmdStreamStart, 0xE8, 0x03, proto::kChAll, 1, 0};
  CHECK_EQ(rig.exchange(r6, 6) >= 2 ? rig.host_rx[1] : 0xFF, proto::kStBadLength);
  // flags 0 in a 5-byte request is the classic stream.
  CHECK_EQ(start(1000, proto::kChAll, 0), proto::kStOk);
  for (int i = 0; i < 100; ++i) rig.step(100);
  CHECK(rig.stream_frames >= 27);
  CHECK_EQ(rig.host_port.fd_count, 0);
  CHECK_EQ(cmd1(proto::kCmdStreamStop), proto::kStOk);
}

void fd_stream() {
  init_fd(true, true);
  CHECK_EQ(start(1000, proto::kChAll, proto::kStreamFlagFd), proto::kStOk);
  std::uint8_t q[1] = {proto::kCmdStatus};
  CHECK_EQ(rig.exchange(q, 1), 2 + proto::kStatusBytes);
  CHECK_EQ(rig.host_rx[2 + 46], 2);  // streaming: 2 = CAN FD
  FdLog log;
  const std::uint32_t s0 = 0, tx0 = 0;  // counters start at 0 (init_fd); the FD queue holds every frame since
  for (int i = 0; i < 1000; ++i) {
    rig.step(100);  // 100 ms at 1 kHz
    drain(log, proto::kChAll, 1000);
  }
  CHECK_EQ(rig.stream_frames, 0);  // no classic stream frame
  const std::uint32_t before_stop = rig.node.counters.samples_sent - s0;
  CHECK(before_stop >= 99 && before_stop <= 101);
  CHECK_EQ(cmd1(proto::kCmdStreamStop), proto::kStOk);  // samples go on while the request travels
  drain(log, proto::kChAll, 1000);
  const std::uint32_t sent = rig.node.counters.samples_sent - s0;
  CHECK_EQ(log.samples, sent);  // every sample, the partial frame at stop included
  CHECK_EQ(log.frames, (sent + 3u) / 4u);
  CHECK_EQ(log.frames, rig.node.counters.stream_frames_tx - tx0);
  CHECK_EQ(log.partial, sent % 4u == 0u ? 0u : 1u);
  CHECK_EQ(log.bad_layout, 0);
  CHECK_EQ(log.bad_values, 0);
  CHECK_EQ(log.seq_breaks, 0);
  CHECK_EQ(rig.node.fd_count, 0);

  // Exactly 6 samples, then stop: one full frame and a partial one of count 2, sent before the answer.
  init_fd(true, true);
  CHECK_EQ(start(200, proto::kChAccel | proto::kChTemp, proto::kStreamFlagFd), proto::kStOk);
  FdLog six;
  const std::uint64_t t_start = rig.node.next_sample_us;
  while (rig.node.counters.samples_sent < 6u) rig.step(100);
  CHECK(rig.t_us > t_start);
  CHECK_EQ(cmd1(proto::kCmdStreamStop), proto::kStOk);
  drain(six, proto::kChAccel | proto::kChTemp, 5000);
  CHECK_EQ(six.frames, 2);
  CHECK_EQ(six.samples, 6);
  CHECK_EQ(six.partial, 1);
  CHECK_EQ(six.bad_layout, 0);
  CHECK_EQ(six.bad_values, 0);  // gyro zero: not asked for
}

void fd_breaks() {
  // A sensor error in the middle of a frame: the frame so far leaves with the samples it has, the
  // failed sample's seq is skipped, the next frame starts at the following seq.
  init_fd(true, true);
  CHECK_EQ(start(1000, proto::kChAll, proto::kStreamFlagFd), proto::kStOk);
  while (rig.node.counters.samples_sent < 6u) rig.step(100);
  rig.sensor.fail = true;
  const std::uint32_t err0 = rig.node.counters.sensor_errors;
  while (rig.node.counters.sensor_errors == err0) rig.step(100);
  rig.sensor.fail = false;
  while (rig.node.counters.samples_sent < 12u) rig.step(100);
  CHECK_EQ(cmd1(proto::kCmdStreamStop), proto::kStOk);
  hal::CanFdFrame f;
  unsigned samples = 0, frames = 0;
  long expect = 0;
  int breaks = 0;
  while (rig.host_port.take_fd(f)) {
    ++frames;
    const long seq = load_le16(f.data);
    if (seq != expect) ++breaks;
    expect = seq + f.data[2];
    samples += f.data[2];
  }
  CHECK_EQ(samples, rig.node.counters.samples_sent);
  CHECK_EQ(breaks, static_cast<int>(rig.node.counters.sensor_errors));
  CHECK(frames >= 4);

  // FIFO overflow: the frame under construction leaves before the seq jumps.
  init_fd(true, true);
  CHECK_EQ(start(1000, proto::kChAll, proto::kStreamFlagFd), proto::kStOk);
  while (rig.node.counters.samples_sent < 2u) rig.step(100);
  rig.t_us += 500000;  // 500 ms stall: 128 kept, the rest dropped
  for (int i = 0; i < 200; ++i) rig.step(100);
  CHECK(rig.node.counters.samples_fifo_overflow > 300u);
  CHECK_EQ(cmd1(proto::kCmdStreamStop), proto::kStOk);
  FdLog log;
  drain(log, proto::kChAll, 1000);
  CHECK_EQ(log.seq_breaks, 1);
  CHECK_EQ(log.samples, rig.node.counters.samples_sent);
  CHECK_EQ(log.bad_values, 0);
  CHECK_EQ(log.bad_layout, 0);
  CHECK(rig.host_port.fd_overruns == 0u);

  // Reboot while streaming FD: the partial frame leaves, the stream ends.
  init_fd(true, true);
  CHECK_EQ(start(1000, proto::kChAll, proto::kStreamFlagFd), proto::kStOk);
  while (rig.node.counters.samples_sent < 3u) rig.step(100);
  const std::uint32_t sent = rig.node.counters.samples_sent;
  CHECK_EQ(cmd1(proto::kCmdReboot), proto::kStOk);
  FdLog rb;
  drain(rb, proto::kChAll, 1000);
  CHECK_EQ(rb.samples, sent);
  CHECK_EQ(rb.partial, 1);

  // Bus-off: FD frames are refused and counted like classic ones.
  init_fd(true, true);
  CHECK_EQ(start(1000, proto::kChAll, proto::kStreamFlagFd), proto::kStOk);
  rig.node_port.bus_off = true;
  for (int i = 0; i < 200; ++i) rig.step(100);
  CHECK_EQ(rig.node.counters.bus_off_events, 1);
  CHECK(rig.node.counters.stream_frames_dropped >= 4u);
  rig.node_port.bus_off = false;
  CHECK_EQ(cmd1(proto::kCmdStreamStop), proto::kStOk);
}

}  // namespace

int main() {
  frame_check();
  refusals();
  fd_stream();
  fd_breaks();
  return FW_TEST_RESULT("test_can_fd");
}
