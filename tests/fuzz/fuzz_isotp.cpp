// libFuzzer: the firmware ISO-TP receiver (and its flow-control sender side). The input is a script of
// frames: [dt_ms u8][flags u8: bit0 other-id, bit1 extended][len u8][8 data bytes] repeated.
// Invariants: buffers never overrun, a ready message has rx_len <= capacity, no crash/UB.
#include <cstdlib>
#include <cstring>

#include "firmware/isotp/isotp.h"

using namespace imuforge;
using namespace imuforge::fw;

namespace {
class SinkPort final : public hal::CanPort {
 public:
  int send(const hal::CanFrame& f) noexcept override {
    if (!hal::can_frame_valid(f)) std::abort();
    return (++n % 5u) == 0u ? hal::kCanErrWouldBlock : hal::kCanOk;  // sometimes a full TX queue
  }
  int receive(hal::CanFrame&) noexcept override { return hal::kCanErrWouldBlock; }
  unsigned n = 0;
};
std::uint8_t rx[300], tx[300];
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  SinkPort port;
  IsotpLink l;
  IsotpConfig c;
  c.rx_id = 0x601;
  c.tx_id = 0x681;
  c.block_size = size > 0 ? static_cast<std::uint8_t>(data[0] & 3u) : 0;
  isotp_init(l, c, port, rx, sizeof rx, tx, sizeof tx);
  std::uint64_t t = 0;
  std::size_t i = 1;
  // Also run a transmission so FC handling is fuzzed: 200 bytes from us.
  std::uint8_t msg[200];
  std::memset(msg, 0x5A, sizeof msg);
  (void)isotp_send(l, msg, sizeof msg, t);
  while (i + 11 <= size) {
    t += static_cast<std::uint64_t>(data[i]) * 1000u;
    hal::CanFrame f;
    f.id = (data[i + 1] & 1u) ? 0x123u : 0x601u;
    f.extended = (data[i + 1] & 2u) != 0u;
    f.len = data[i + 2] % 9u;
    std::memcpy(f.data, data + i + 3, 8);
    (void)isotp_on_frame(l, f, t);
    (void)isotp_poll(l, t);
    if (l.rx_pos > sizeof rx || l.rx_len > sizeof rx && l.rx_state != IsotpRxState::kIdle) std::abort();
    if (isotp_rx_ready(l)) {
      if (l.rx_len == 0 || l.rx_len > sizeof rx) std::abort();
      isotp_rx_release(l);
    }
    if (!isotp_tx_busy(l) && (data[i + 1] & 4u)) (void)isotp_send(l, msg, 1u + data[i + 3] % sizeof msg, t);
    i += 11;
  }
  return 0;
}
