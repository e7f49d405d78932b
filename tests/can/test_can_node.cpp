// The firmware CAN node end to end on an in-memory bus: every command, every refusal path of a table
// write (tag, replay, parser, device, sequence), streaming, reboot, bus-off and a reset mid-transfer.
#include <cstring>

#include "firmware/common/crc32.h"
#include "tests/can/fwcheck.h"
#include "tests/can/node_harness.h"

using namespace imuforge;
using namespace imuforge::fw;
using cantest::kSerial;

namespace {

cantest::NodeRig rig;
std::uint8_t req[proto::kMaxMessageBytes + 64];
std::uint8_t table1[kTableMaxSize], table2[kTableMaxSize];

std::uint8_t cmd1(std::uint8_t cmd) {
  req[0] = cmd;
  const std::size_t n = rig.exchange(req, 1);
  if (n < 2 || rig.host_rx[0] != (cmd | proto::kResponseFlag)) return 0xFF;
  return rig.host_rx[1];
}

std::uint8_t write(const std::uint8_t* key, std::uint64_t serial, std::uint32_t seq, const std::uint8_t* t,
                   std::size_t len) {
  const std::size_t n = cantest::make_write(req, key, serial, seq, t, len);
  const std::size_t r = rig.exchange(req, n);
  return r >= 2 ? rig.host_rx[1] : 0xFF;
}

std::uint8_t commit(std::uint32_t seq) {
  req[0] = proto::kCmdCommit;
  store_le32(req + 1, seq);
  const std::size_t r = rig.exchange(req, 5);
  return r >= 2 ? rig.host_rx[1] : 0xFF;
}

std::uint32_t active_seq() {
  req[0] = proto::kCmdIdentify;
  const std::size_t n = rig.exchange(req, 1);
  CHECK_EQ(n, 2 + proto::kIdentifyBytes);
  if (n != 2 + proto::kIdentifyBytes || rig.host_rx[2 + 24] == 0) return 0;
  return load_le32(rig.host_rx + 2 + 25);
}

void commands() {
  rig.init();
  req[0] = proto::kCmdIdentify;
  std::size_t n = rig.exchange(req, 1);
  CHECK_EQ(n, 2 + proto::kIdentifyBytes);
  CHECK_EQ(rig.host_rx[0], proto::kCmdIdentify | proto::kResponseFlag);
  CHECK_EQ(rig.host_rx[1], proto::kStOk);
  CHECK(load_le64(rig.host_rx + 2) == kSerial);
  CHECK_EQ(rig.host_rx[2 + 24], 0);  // no table yet
  CHECK_EQ(cmd1(proto::kCmdReadTable), proto::kStNoTable);
  CHECK_EQ(cmd1(0x55), proto::kStUnknownCommand);
  req[1] = 0;
  CHECK_EQ(rig.exchange(req, 2) >= 2 ? rig.host_rx[1] : 0xFF, proto::kStUnknownCommand);
  req[0] = proto::kCmdIdentify;
  CHECK_EQ(rig.exchange(req, 2) >= 2 ? rig.host_rx[1] : 0xFF, proto::kStBadLength);
  CHECK_EQ(commit(1), proto::kStNotStaged);

  const std::size_t len1 = cantest::make_table(table1, sizeof table1, kSerial, 1, 0.01f);
  CHECK(len1 > 0);
  std::uint8_t wrong_key[32];
  std::memcpy(wrong_key, rig.cfg.key, 32);
  wrong_key[7] ^= 0x40u;
  CHECK_EQ(write(wrong_key, kSerial, 1, table1, len1), proto::kStAuthFailed);
  CHECK_EQ(write(rig.cfg.key, kSerial + 1, 1, table1, len1), proto::kStAuthFailed);  // tag binds the serial
  CHECK_EQ(write(rig.cfg.key, kSerial, 2, table1, len1), proto::kStSeqMismatch);
  std::uint8_t other[kTableMaxSize];
  const std::size_t lo = cantest::make_table(other, sizeof other, kSerial + 9, 1);
  CHECK_EQ(write(rig.cfg.key, kSerial, 1, other, lo), proto::kStWrongDevice);
  std::memcpy(other, table1, len1);
  other[70] ^= 1u;  // properly signed, but the table's own CRC fails
  CHECK_EQ(write(rig.cfg.key, kSerial, 1, other, len1), proto::kStTableInvalid);
  CHECK_EQ(rig.node.counters.auth_failures, 2);
  CHECK_EQ(active_seq(), 0);

  CHECK_EQ(write(rig.cfg.key, kSerial, 1, table1, len1), proto::kStOk);
  CHECK_EQ(load_le32(rig.host_rx + 2), crc32(table1, len1));
  CHECK_EQ(commit(1), proto::kStOk);
  CHECK_EQ(active_seq(), 1);
  req[0] = proto::kCmdReadTable;
  n = rig.exchange(req, 1);
  CHECK_EQ(n, 6 + len1);
  CHECK_EQ(load_le32(rig.host_rx + 2), 1);
  CHECK(std::memcmp(rig.host_rx + 6, table1, len1) == 0);

  // replays: same and older sequence numbers are refused, the active table stays
  CHECK_EQ(write(rig.cfg.key, kSerial, 1, table1, len1), proto::kStReplay);
  const std::size_t l0 = cantest::make_table(table2, sizeof table2, kSerial, 0);
  CHECK_EQ(write(rig.cfg.key, kSerial, 0, table2, l0), proto::kStReplay);
  CHECK_EQ(commit(1), proto::kStReplay);
  CHECK_EQ(active_seq(), 1);

  // a newer table replaces it; an older one still cannot come back
  const std::size_t len2 = cantest::make_table(table2, sizeof table2, kSerial, 7, -0.02f);
  CHECK_EQ(write(rig.cfg.key, kSerial, 7, table2, len2), proto::kStOk);
  CHECK_EQ(commit(7), proto::kStOk);
  CHECK_EQ(active_seq(), 7);
  CHECK_EQ(write(rig.cfg.key, kSerial, 1, table1, len1), proto::kStReplay);

  // the committed table survives a reboot
  CHECK_EQ(cmd1(proto::kCmdReboot), proto::kStOk);
  rig.step();
  CHECK(node_reboot_requested(rig.node));
  node_init(rig.node, rig.cfg, rig.node_port, rig.flash, rig.sensor);
  CHECK_EQ(node_boot(rig.node, rig.t_us), kStoreOk);
  CHECK_EQ(active_seq(), 7);
  CHECK_EQ(rig.node.counters.boots, 2);

  // status block
  req[0] = proto::kCmdStatus;
  n = rig.exchange(req, 1);
  CHECK_EQ(n, 2 + proto::kStatusBytes);
  CHECK_EQ(load_le32(rig.host_rx + 2 + 40), 2);  // boots
}

void streaming() {
  rig.init();
  std::uint8_t r[4] = {proto::kCmdStreamStart, 0, 0, 0};
  store_le16(r + 1, 1000);
  r[3] = 8;
  CHECK_EQ(rig.exchange(r, 4) >= 2 ? rig.host_rx[1] : 0xFF, proto::kStBadArgument);
  r[3] = 0;
  CHECK_EQ(rig.exchange(r, 4) >= 2 ? rig.host_rx[1] : 0xFF, proto::kStBadArgument);
  store_le16(r + 1, 2001);
  r[3] = proto::kChAll;
  CHECK_EQ(rig.exchange(r, 4) >= 2 ? rig.host_rx[1] : 0xFF, proto::kStBadArgument);
  store_le16(r + 1, 1000);
  CHECK_EQ(rig.exchange(r, 4) >= 2 ? rig.host_rx[1] : 0xFF, proto::kStOk);
  const std::uint32_t f0 = rig.stream_frames;
  const std::uint32_t s0 = rig.node.counters.samples_sent;
  for (int i = 0; i < 1000; ++i) rig.step(100);  // 100 ms
  const std::uint32_t samples = rig.node.counters.samples_sent - s0;
  CHECK(samples >= 99 && samples <= 101);
  CHECK_EQ(rig.stream_frames - f0, 3 * samples);
  // bus-off: frames are refused and counted once per episode, the stream resumes afterwards
  rig.node_port.bus_off = true;
  for (int i = 0; i < 100; ++i) rig.step(100);
  CHECK_EQ(rig.node.counters.bus_off_events, 1);
  CHECK(rig.node.counters.stream_frames_dropped >= 27);
  rig.node_port.bus_off = false;
  const std::uint32_t f1 = rig.stream_frames;
  for (int i = 0; i < 100; ++i) rig.step(100);
  CHECK(rig.stream_frames - f1 >= 27);
  req[0] = proto::kCmdStreamStop;
  CHECK_EQ(rig.exchange(req, 1), 6);
  CHECK(!rig.node.streaming);
  // only the temperature channel: one frame per sample
  store_le16(r + 1, 2000);
  r[3] = proto::kChTemp;
  CHECK_EQ(rig.exchange(r, 4) >= 2 ? rig.host_rx[1] : 0xFF, proto::kStOk);
  const std::uint32_t f2 = rig.stream_frames, s2 = rig.node.counters.samples_sent;
  for (int i = 0; i < 100; ++i) rig.step(100);
  CHECK_EQ(rig.stream_frames - f2, rig.node.counters.samples_sent - s2);
  CHECK(rig.node.counters.samples_sent - s2 >= 19);
}

void reset_mid_transfer() {
  rig.init();
  const std::size_t len1 = cantest::make_table(table1, sizeof table1, kSerial, 3);
  CHECK_EQ(write(rig.cfg.key, kSerial, 3, table1, len1), proto::kStOk);
  CHECK_EQ(commit(3), proto::kStOk);
  // Start a second write, then reset the node after a few rounds (part of the blob transferred).
  const std::size_t len2 = cantest::make_table(table2, sizeof table2, kSerial, 4, 0.5f);
  const std::size_t n = cantest::make_write(req, rig.cfg.key, kSerial, 4, table2, len2);
  CHECK_EQ(isotp_send(rig.host, req, n, rig.t_us), kIsotpOk);
  for (int i = 0; i < 5; ++i) rig.step();
  node_init(rig.node, rig.cfg, rig.node_port, rig.flash, rig.sensor);
  (void)node_boot(rig.node, rig.t_us);
  for (int i = 0; i < 30000 && isotp_tx_busy(rig.host); ++i) rig.step();
  // The host's transfer must end with an error (N_Bs: the fresh node sends no FC for the old FF),
  // never with a response.
  CHECK(!isotp_tx_busy(rig.host));
  CHECK(!isotp_rx_ready(rig.host));
  CHECK_EQ(rig.host.counters.tx_errors, 1);
  CHECK_EQ(active_seq(), 3);
  // Staged-but-uncommitted data is lost by a reset: commit is refused, the table stays.
  CHECK_EQ(write(rig.cfg.key, kSerial, 4, table2, len2), proto::kStOk);
  node_init(rig.node, rig.cfg, rig.node_port, rig.flash, rig.sensor);
  (void)node_boot(rig.node, rig.t_us);
  CHECK_EQ(commit(4), proto::kStNotStaged);
  CHECK_EQ(active_seq(), 3);
  // Lost frames during a write: the transfer fails (timeout or wrong SN) and the table stays.
  rig.bus.drop_every = 7;
  (void)write(rig.cfg.key, kSerial, 4, table2, len2);
  rig.bus.drop_every = 0;
  for (int i = 0; i < 30000; ++i) rig.step();  // let every timer expire
  CHECK_EQ(active_seq(), 3);
  CHECK(rig.node.link.counters.rx_errors + rig.host.counters.tx_errors + rig.host.counters.rx_errors >= 1);
}

void extended_ids() {
  rig.init(true, true);
  CHECK_EQ(cmd1(proto::kCmdIdentify), proto::kStOk);
  CHECK_EQ(rig.host_rx[2 + 38] & 1, 1);
}

// The sample FIFO (NodeConfig::fifo_depth_samples): a late loop still sends every sample due, each with
// its own timestamp; only beyond the depth are samples dropped, counted exactly, and seen as a seq gap.
struct TempFrames {
  std::uint32_t n = 0, seq_gaps = 0, bad_dt = 0;
  long last_seq = -1;
  std::uint64_t last_t_us = 0;
  std::uint32_t gap_samples = 0;
};

void poll_collect(TempFrames& tf, unsigned polls, std::uint32_t dt_us) {
  for (unsigned i = 0; i < polls; ++i) {
    node_poll(rig.node, rig.t_us);
    imuforge::hal::CanFrame f;
    while (rig.host_port.receive(f) == imuforge::hal::kCanOk) {
      if (f.id != proto::stream_id(5, proto::kPartTemp, false)) continue;
      const long seq = load_le16(f.data);
      const std::uint64_t t = load_le32(f.data + 4);
      if (tf.last_seq >= 0) {
        const long step = (seq - tf.last_seq + 65536) % 65536;
        if (step != 1) {
          ++tf.seq_gaps;
          tf.gap_samples += static_cast<std::uint32_t>(step - 1);
        }
        // the timestamp is the sample's own (its due time), also for samples sent late
        if (t - tf.last_t_us != static_cast<std::uint64_t>(step) * 1000u) ++tf.bad_dt;
      }
      tf.last_seq = seq;
      tf.last_t_us = t;
      ++tf.n;
    }
    rig.t_us += dt_us;
  }
}

void sample_fifo() {
  rig.init();
  CHECK_EQ(rig.cfg.fifo_depth_samples, 128);
  std::uint8_t r[4] = {proto::kCmdStreamStart, 0, 0, proto::kChTemp};
  store_le16(r + 1, 1000);
  CHECK_EQ(rig.exchange(r, 4) >= 2 ? rig.host_rx[1] : 0xFF, proto::kStOk);
  TempFrames tf;
  poll_collect(tf, 100, 100);  // 10 ms on time
  // A 100 ms stall (100 samples due, within the depth): all of them arrive, in order, own timestamps.
  const std::uint32_t before = tf.n;
  rig.t_us += 100000;
  poll_collect(tf, 50, 100);
  CHECK(tf.n - before >= 100 + 4);
  CHECK_EQ(tf.seq_gaps, 0);
  CHECK_EQ(tf.bad_dt, 0);
  CHECK_EQ(rig.node.counters.samples_fifo_overflow, 0);
  // Drained over several polls (max_samples_per_poll), not in one burst.
  CHECK_EQ(rig.cfg.max_samples_per_poll, 16);
  // A 500 ms stall: 128 kept, the older ones dropped, counted, and visible as exactly that gap.
  const std::uint32_t sent0 = rig.node.counters.samples_sent;
  const std::uint64_t due_from = rig.node.next_sample_us;
  rig.t_us += 500000;
  const std::uint64_t due = (rig.t_us - due_from) / 1000u + 1u;
  poll_collect(tf, 200, 100);
  CHECK_EQ(rig.node.counters.samples_fifo_overflow, static_cast<std::uint32_t>(due - 128u));
  CHECK_EQ(tf.seq_gaps, 1);
  CHECK_EQ(tf.gap_samples, rig.node.counters.samples_fifo_overflow);
  CHECK_EQ(tf.bad_dt, 0);
  CHECK(rig.node.counters.samples_sent - sent0 >= 128);
  // The status block carries the overflow count.
  std::uint8_t q[1] = {proto::kCmdStatus};
  CHECK_EQ(rig.exchange(q, 1), 2 + proto::kStatusBytes);
  CHECK_EQ(load_le32(rig.host_rx + 2 + 50), rig.node.counters.samples_fifo_overflow);
}

}  // namespace

int main() {
  commands();
  streaming();
  reset_mid_transfer();
  extended_ids();
  sample_fifo();
  return FW_TEST_RESULT("test_can_node");
}
