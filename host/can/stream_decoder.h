// Reassembles stream samples from the three classic stream frames, or unpacks the CAN FD stream frame
// (4 samples per 64-byte frame), and detects lost, duplicated and reordered samples by the 16-bit sample
// sequence counter (docs/can-protocol.md, "Sample stream", "CAN FD stream frame"). Both formats feed
// the same window and counters, so a lost FD frame shows as a gap of its `count` samples.
// Pure logic, no I/O: fed by the client's receive thread, the tests and the fuzzer directly.
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
  std::uint64_t frames_lost = 0;   // frames missing: classic 3*lost-ish + missing parts of incomplete
                                   // samples; FD: ceil(gap / 4) per gap in the counter
  // Stream frames of this node rejected as malformed (never decoded, never delivered). FD only: the
  // classic frames have no field that can be inconsistent.
  std::uint64_t malformed = 0;           // sum of the three below
  std::uint64_t malformed_count = 0;     // FD count 0 or above 4
  std::uint64_t malformed_short = 0;     // FD frame shorter than its header + count samples
  std::uint64_t malformed_format = 0;    // classic frame on the FD id, or channels other than asked
};

class StreamDecoder {
 public:
  using Callback = std::function<void(const StreamSample&)>;
  // Classic stream: three frames per sample.
  StreamDecoder(std::uint8_t node_id, bool extended, std::uint8_t channels, Callback cb);
  // fd: the CAN FD stream frame, whose later samples' t_us follow from the node's sample period
  // 1000000 / rate_hz (throws std::invalid_argument if fd and rate_hz is 0).
  StreamDecoder(std::uint8_t node_id, bool extended, std::uint8_t channels, Callback cb, bool fd,
                std::uint16_t rate_hz);
  // Returns true if the frame was one of this node's stream frames (also a rejected or ignored one:
  // classic frames during an FD stream and FD frames during a classic one are ignored).
  bool on_frame(const hal::CanFrame& f);
  bool on_frame(const hal::CanFdFrame& f);
  // Why the last malformed frame was rejected ("" if none was).
  const char* last_reject_reason() const { return reject_; }
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
  // Claims sample s16 for part bits `bits`: extends the counter, marks gaps lost, un-counts a sample
  // that was only late. Returns its slot, or nullptr (duplicate, too old, evicted). *late: it filled a
  // sample counted lost.
  Slot* place(std::uint16_t s16, std::uint8_t bits, bool* late);
  void deliver(Slot& s);
  std::uint64_t extend_t(std::uint32_t t32);
  bool on_fd(const hal::CanFdFrame& f);
  void reject(std::uint64_t& counter, const char* why);
  std::uint8_t node_;
  bool ext_;
  std::uint8_t channels_;
  unsigned nparts_;
  Callback cb_;
  bool fd_ = false;
  std::uint32_t period_us_ = 0;
  const char* reject_ = "";
  bool started_ = false;
  std::int64_t highest_ = -1;
  std::uint64_t t_hi_ = 0;   // timestamp extension state
  std::uint32_t t_last_ = 0;
  bool t_started_ = false;
  std::array<Slot, kWindow> win_{};
  StreamCounters k_;
};

}  // namespace imuforge::can
