// Firmware ISO-TP: transfers of every size class between two links, flow control (BS, STmin), the
// 32-bit FF_DL escape, and the N_Bs / N_Cr timeouts, wrong sequence numbers and receiver overflow.
#include <cstring>

#include "firmware/isotp/isotp.h"
#include "tests/can/fwcheck.h"
#include "tests/can/loop_bus.h"

using namespace imuforge;
using namespace imuforge::fw;

namespace {

std::uint8_t a_rx[6000], a_tx[6000], b_rx[6000], b_tx[6000], msg[6000];

struct Pair {
  cantest::LoopBus bus;
  cantest::LoopPort pa, pb;
  IsotpLink a, b;
  std::uint64_t t_us = 0;
  Pair(std::uint8_t bs_b, std::uint8_t stmin_b, std::size_t b_rx_cap) {
    bus.attach(pa);
    bus.attach(pb);
    IsotpConfig ca;
    ca.tx_id = 0x601;
    ca.rx_id = 0x681;
    IsotpConfig cb;
    cb.tx_id = 0x681;
    cb.rx_id = 0x601;
    cb.block_size = bs_b;
    cb.st_min_raw = stmin_b;
    isotp_init(a, ca, pa, a_rx, sizeof a_rx, a_tx, sizeof a_tx);
    isotp_init(b, cb, pb, b_rx, b_rx_cap, b_tx, sizeof b_tx);
  }
  // Advances time by step_us per round, delivering frames both ways.
  void run(unsigned rounds, std::uint32_t step_us, bool deliver_to_b = true) {
    for (unsigned r = 0; r < rounds; ++r) {
      hal::CanFrame f;
      while (pb.receive(f) == hal::kCanOk) {
        if (deliver_to_b) (void)isotp_on_frame(b, f, t_us);
      }
      while (pa.receive(f) == hal::kCanOk) (void)isotp_on_frame(a, f, t_us);
      (void)isotp_poll(a, t_us);
      (void)isotp_poll(b, t_us);
      t_us += step_us;
    }
  }
};

void transfer(std::size_t len, std::uint8_t bs, std::uint8_t stmin) {
  Pair p(bs, stmin, sizeof b_rx);
  for (std::size_t i = 0; i < len; ++i) msg[i] = static_cast<std::uint8_t>(i * 7u + len);
  CHECK_EQ(isotp_send(p.a, msg, len, 0), kIsotpOk);
  CHECK_EQ(isotp_send(p.a, msg, len, 0), len <= 7 ? kIsotpOk : kIsotpErrBusy);
  if (len <= 7) {
    // second SF went out too; the receiver refuses it while the first is unreleased
  }
  p.run(8000, 100);
  CHECK(isotp_rx_ready(p.b));
  CHECK_EQ(p.b.rx_len, len);
  CHECK(std::memcmp(b_rx, msg, len) == 0);
  CHECK(!isotp_tx_busy(p.a));
  CHECK_EQ(p.a.counters.tx_errors, 0);
  // If STmin was requested, the transfer cannot be faster than (CFs-1) * STmin.
  if (len > 7 && stmin > 0 && stmin <= 0x7F) {
    const std::size_t cfs = (len - 6 + 6) / 7;
    CHECK(p.t_us >= (cfs - 1) * stmin * 1000u);
  }
}

void sizes() {
  const std::size_t lens[] = {1, 6, 7, 8, 13, 14, 62, 63, 100, 2244, 2281, 4095, 4096, 5000};
  for (std::size_t len : lens) {
    transfer(len, 0, 0);
    transfer(len, 4, 0);
    transfer(len, 1, 0xF5);
  }
  transfer(200, 8, 2);
}

void n_bs_timeout() {
  Pair p(0, 0, sizeof b_rx);
  CHECK_EQ(isotp_send(p.a, msg, 100, 0), kIsotpOk);
  p.run(30, 100000, /*deliver_to_b=*/false);  // receiver deaf: no FC ever
  CHECK(!isotp_tx_busy(p.a));
  CHECK_EQ(p.a.last_error, kIsotpErrTimeoutBs);
  CHECK_EQ(p.a.counters.tx_errors, 1);
}

void n_cr_timeout() {
  Pair p(0, 0, sizeof b_rx);
  hal::CanFrame ff;
  ff.id = 0x601;
  ff.len = 8;
  ff.data[0] = 0x10;
  ff.data[1] = 50;  // announces 50 bytes, then nothing
  CHECK_EQ(isotp_on_frame(p.b, ff, 0), kIsotpOk);
  CHECK(p.b.rx_state == IsotpRxState::kReceiving);
  CHECK_EQ(isotp_poll(p.b, 999999), kIsotpOk);
  CHECK_EQ(isotp_poll(p.b, 1000000), kIsotpErrTimeoutCr);
  CHECK(p.b.rx_state == IsotpRxState::kIdle);
}

void wrong_sn_and_overflow() {
  Pair p(0, 0, 64);
  hal::CanFrame ff;
  ff.id = 0x601;
  ff.len = 8;
  ff.data[0] = 0x10;
  ff.data[1] = 20;
  CHECK_EQ(isotp_on_frame(p.b, ff, 0), kIsotpOk);
  hal::CanFrame cf;
  cf.id = 0x601;
  cf.len = 8;
  cf.data[0] = 0x22;  // SN 2, expected 1
  CHECK_EQ(isotp_on_frame(p.b, cf, 10), kIsotpErrWrongSn);
  CHECK(p.b.rx_state == IsotpRxState::kIdle);
  hal::CanFrame stale;
  while (p.pa.receive(stale) == hal::kCanOk) {  // the CTS b sent for the injected FF
  }
  // 100 bytes announced to a 64-byte receiver: FC OVFLW, and the sender aborts.
  CHECK_EQ(isotp_send(p.a, msg, 100, 0), kIsotpOk);
  p.run(10, 100);
  CHECK_EQ(p.a.last_error, kIsotpErrOverflow);
  CHECK(!isotp_tx_busy(p.a));
  CHECK(!isotp_rx_ready(p.b));
  // malformed frames are rejected, not crashed on: SF length 0 and SF longer than the frame
  hal::CanFrame sf;
  sf.id = 0x601;
  sf.len = 3;
  sf.data[0] = 0x00;
  CHECK_EQ(isotp_on_frame(p.b, sf, 0), kIsotpErrBadFrame);
  sf.data[0] = 0x05;
  CHECK_EQ(isotp_on_frame(p.b, sf, 0), kIsotpErrBadFrame);
  // FF escape for a length that fits 12 bits is malformed
  hal::CanFrame fe;
  fe.id = 0x601;
  fe.len = 8;
  fe.data[0] = 0x10;
  fe.data[1] = 0;
  fe.data[5] = 20;
  CHECK_EQ(isotp_on_frame(p.b, fe, 0), kIsotpErrBadFrame);
  // frames for other ids are ignored
  sf.id = 0x123;
  CHECK_EQ(isotp_on_frame(p.b, sf, 0), kIsotpOk);
}

void wait_frames() {
  Pair p(0, 0, sizeof b_rx);
  CHECK_EQ(isotp_send(p.a, msg, 30, 0), kIsotpOk);
  hal::CanFrame f;
  while (p.pb.receive(f) == hal::kCanOk) {
  }
  hal::CanFrame wait;
  wait.id = 0x681;
  wait.len = 3;
  wait.data[0] = 0x31;
  std::uint64_t t = 0;
  for (int i = 0; i < 10; ++i) {  // wft_max = 10 WAITs are tolerated, each restarting N_Bs
    t += 900000;
    CHECK_EQ(isotp_on_frame(p.a, wait, t), kIsotpOk);
    CHECK_EQ(isotp_poll(p.a, t), kIsotpOk);
  }
  CHECK_EQ(isotp_on_frame(p.a, wait, t), kIsotpErrWftMax);
  CHECK(!isotp_tx_busy(p.a));
}

void tx_queue_full() {
  Pair p(0, 0, sizeof b_rx);
  p.pa.bus_off = true;  // port refuses every frame: N_As must fire
  CHECK_EQ(isotp_send(p.a, msg, 5, 0), kIsotpOk);
  CHECK(isotp_tx_busy(p.a));
  CHECK_EQ(isotp_poll(p.a, 500000), kIsotpOk);
  CHECK_EQ(isotp_poll(p.a, 1000000), kIsotpErrTimeoutAs);
  CHECK(!isotp_tx_busy(p.a));
}

}  // namespace

int main() {
  sizes();
  n_bs_timeout();
  n_cr_timeout();
  wrong_sn_and_overflow();
  wait_frames();
  tx_queue_full();
  CHECK_EQ(isotp_st_min_to_us(0x7F), 127000);
  CHECK_EQ(isotp_st_min_to_us(0xF3), 300);
  CHECK_EQ(isotp_st_min_to_us(0x80), 127000);
  return FW_TEST_RESULT("test_can_isotp");
}
