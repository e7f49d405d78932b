// libFuzzer: the CAN stream decoder (host/can/stream_decoder.cpp), classic and CAN FD, on any frame
// sequence. Input: [mode u8: bit0 FD stream, bit1 29-bit ids][rate u8: Hz = 1 + 8·rate] then frames
// [kind u8: bit0 FD frame, bit1 this node's id (else another node's), bits 2-3 stream part][len u8][bytes].
// Invariants (abort): a delivered sample holds every channel asked for; the callback count equals
// `received`; `malformed` is the sum of its reasons and never comes without a reason; `lost` and
// `frames_lost` never wrap below zero (late frames un-count only what was counted).
#include <cstdlib>
#include <cstring>

#include "firmware/can_node/protocol.h"
#include "host/can/stream_decoder.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imuforge;
  if (size < 2) return 0;
  const bool fd = (data[0] & 1u) != 0, ext = (data[0] & 2u) != 0;
  const auto rate = static_cast<std::uint16_t>(1u + 8u * data[1]);
  const std::uint8_t node = 9;
  std::uint64_t delivered = 0;
  can::StreamDecoder d(node, ext, proto::kChAll, [&](const can::StreamSample& s) {
    if (s.parts != proto::kChAll) std::abort();
    ++delivered;
  }, fd, rate);
  std::size_t i = 2;
  while (i + 2 <= size) {
    const std::uint8_t kind = data[i], len = data[i + 1];
    i += 2;
    const std::size_t n = len < size - i ? len : size - i;
    const std::uint8_t part = static_cast<std::uint8_t>((kind >> 2) & 3u);
    const std::uint8_t who = (kind & 2u) != 0 ? node : static_cast<std::uint8_t>(node + 1);
    auto feed = [&](auto f, std::size_t cap) {
      f.id = proto::stream_id(who, part, ext);
      f.extended = ext;
      f.len = static_cast<std::uint8_t>(n > cap ? cap : n);
      std::memcpy(f.data, data + i, f.len);
      (void)d.on_frame(f);
    };
    if ((kind & 1u) != 0) {
      feed(hal::CanFdFrame{}, 64);
    } else {
      feed(hal::CanFrame{}, 8);
    }
    i += n;
    const auto& k = d.counters();
    if (k.received != delivered) std::abort();
    if (k.malformed != k.malformed_count + k.malformed_short + k.malformed_format) std::abort();
    if (k.malformed > 0 && d.last_reject_reason()[0] == '\0') std::abort();
    if (k.lost > (1ull << 62) || k.frames_lost > (1ull << 62)) std::abort();  // an underflow
  }
  d.flush();
  if (d.counters().received != delivered) std::abort();
  return 0;
}
