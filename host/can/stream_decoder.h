// Reassembles stream samples from the three stream frames and detects lost, duplicated and reordered
// frames by the 16-bit sample sequence counter (docs/can-protocol.md, "Sample stream").
// Pure logic, no I/O: fed by the client's receive thread and by the tests directly.
#pragma once
#include <array>
#include <cstdint>
#include <functional>

#include "hal/can.h"

namespace imuforge::can {

struct StreamSample {
  std::uint64_t seq = 0;    // sequence counter, extended to 64 bits (first sample of a run: its 16-bit value)
  std::uint64_t t_us = 0;   // sensor timestamp, extended from 32 bits
  std::int16_t accel_counts[3] = {0, 0, 0};
  std::int16_t gyro_counts[3] = {0, 0, 0};
  std::int16_t temp_cdegC = 0;
  std::uint8_t parts = 0;   // channels present (proto::Channel bits)
};

struct StreamCounters {
  std::uint64_t frames = 0;        // stream frames received for this node
  std::uint64_t received = 0;      // complete samples delivered
  std::uint64_t lost = 0;          // samples of which no frame arrived (gaps in the counter)
  std::uint64_t incomplete = 0;    // samples of which only some frames arrived
  std::uint64_t duplicated = 0;    // frames received twice (same sample, same part)
  std::uint64_t reordered = 0;     // frames that arrived after a frame of a later sample
  std::uint64_t frames_lost = 0;   // frames missing: 3*lost-ish + missing parts of incomplete samples
};

class StreamDecoder {
 public:
  using Callback = std::function<void(const StreamSample&)>;
  StreamDecoder(std::uint8_t node_id, bool extended, std::uint8_t channels, Callback cb);
  // Returns true if the frame was one of this node's stream frames.
  bool on_frame(const hal::CanFrame& f);
  // Settles every pending sample (end of a stream): incomplete ones are counted.
  void flush();
  const StreamCounters& counters() const { return k_; }

 private:
  static constexpr std::size_t kWindow = 256;
  struct Slot {
    std::int64_t seq = -1;
    std::uint8_t parts = 0;
    bool delivered = false;
    StreamSample s;
  };
  void retire(Slot& s);
  std::uint8_t node_;
  bool ext_;
  std::uint8_t channels_;
  unsigned nparts_;
  Callback cb_;
  bool started_ = false;
  std::int64_t highest_ = -1;
  std::uint64_t t_hi_ = 0;   // timestamp extension state
  std::uint32_t t_last_ = 0;
  bool t_started_ = false;
  std::array<Slot, kWindow> win_{};
  StreamCounters k_;
};

}  // namespace imuforge::can
