#include "host/can/stream_decoder.h"

#include "firmware/can_node/protocol.h"
#include "firmware/common/endian.h"

#include <stdexcept>

namespace imuforge::can {

StreamDecoder::StreamDecoder(std::uint8_t node_id, bool extended, std::uint8_t channels, Callback cb)
    : StreamDecoder(node_id, extended, channels, std::move(cb), false, 0) {}

StreamDecoder::StreamDecoder(std::uint8_t node_id, bool extended, std::uint8_t channels, Callback cb, bool fd,
                             std::uint16_t rate_hz)
    : node_(node_id), ext_(extended), channels_(channels), cb_(std::move(cb)), fd_(fd) {
  nparts_ = ((channels & proto::kChAccel) ? 1u : 0u) + ((channels & proto::kChGyro) ? 1u : 0u) +
            ((channels & proto::kChTemp) ? 1u : 0u);
  if (fd) {
    if (rate_hz == 0) throw std::invalid_argument("stream decoder: a CAN FD stream needs its rate (> 0 Hz)");
    period_us_ = 1000000u / rate_hz;  // the node's own integer period (firmware/can_node/node.cpp)
  }
}

void StreamDecoder::retire(Slot& s) {
  if (s.seq >= 0 && !s.delivered && s.parts != 0u) {
    ++k_.incomplete;
    unsigned have = 0;
    for (unsigned b = 0; b < 3; ++b) have += (s.parts >> b) & 1u;
    k_.frames_lost += nparts_ - have;
  }
  s = Slot{};
}

StreamDecoder::Slot* StreamDecoder::place(std::uint16_t s16, std::uint8_t bits, bool* late) {
  *late = false;
  std::int64_t seq;
  if (!started_) {
    started_ = true;
    seq = s16;
    highest_ = seq - 1;
  } else {
    const auto diff = static_cast<std::int16_t>(static_cast<std::uint16_t>(s16 - static_cast<std::uint16_t>(highest_)));
    seq = highest_ + diff;
  }
  // Before the first sample of this stream (a late frame of an earlier run): nothing to place. Without
  // this, seq -1 matched an empty slot's sentinel and un-counted a loss that was never counted.
  if (seq < 0) return nullptr;
  if (seq > highest_) {
    // Samples skipped between the previous highest and this one: lost unless a frame shows up later.
    const std::int64_t gap = seq - highest_ - 1;
    for (std::int64_t g = highest_ + 1; g < seq; ++g) {
      Slot& gs = win_[static_cast<std::size_t>(g) % kWindow];
      retire(gs);
      gs.seq = g;  // placeholder with no parts: "missing"
      gs.parts = 0;
      ++k_.lost;
      if (!fd_) k_.frames_lost += nparts_;
    }
    if (fd_ && gap > 0) k_.frames_lost += static_cast<std::uint64_t>((gap + proto::kFdSamplesPerFrame - 1) / proto::kFdSamplesPerFrame);
    Slot& ns = win_[static_cast<std::size_t>(seq) % kWindow];
    retire(ns);
    ns.seq = seq;
    highest_ = seq;
  } else if (seq < highest_) {
    ++k_.reordered;
    if (highest_ - seq >= static_cast<std::int64_t>(kWindow)) return nullptr;  // too old to place
  }
  Slot& s = win_[static_cast<std::size_t>(seq) % kWindow];
  if (s.seq != seq) return nullptr;  // evicted already
  if ((s.parts & bits) != 0u) {
    ++k_.duplicated;
    return nullptr;
  }
  if (s.parts == 0u && seq < highest_) {
    // a sample counted lost turned out to be only late
    --k_.lost;
    if (!fd_) k_.frames_lost -= nparts_;
    *late = true;
  }
  s.parts = static_cast<std::uint8_t>(s.parts | bits);
  s.s.seq = static_cast<std::uint64_t>(seq);
  s.s.parts = s.parts;
  return &s;
}

void StreamDecoder::deliver(Slot& s) {
  if (s.parts != channels_) return;
  s.delivered = true;
  ++k_.received;
  if (cb_) cb_(s.s);
}

std::uint64_t StreamDecoder::extend_t(std::uint32_t t32) {
  if (t_started_ && t32 < t_last_ && t_last_ - t32 > 0x80000000u) t_hi_ += 1ull << 32;
  t_started_ = true;
  t_last_ = t32;
  return t_hi_ | t32;
}

void StreamDecoder::reject(std::uint64_t& counter, const char* why) {
  ++counter;
  ++k_.malformed;
  reject_ = why;
}

bool StreamDecoder::on_frame(const hal::CanFrame& f) {
  if (f.extended != ext_ || f.len != 8) return false;
  int part = -1;
  for (std::uint8_t p = 0; p < proto::kPartCount; ++p) {
    if (f.id == proto::stream_id(node_, p, ext_)) part = p;
  }
  if (part < 0) {
    if (f.id != proto::stream_id(node_, proto::kPartFd, ext_)) return false;
    if (fd_) reject(k_.malformed_format, "classic frame on the CAN FD stream id");
    return true;
  }
  if (fd_) return true;  // a classic stream frame during an FD stream (stale or another host's)
  const std::uint8_t bit = static_cast<std::uint8_t>(1u << part);
  if ((channels_ & bit) == 0u) return true;  // a channel we did not ask for
  ++k_.frames;
  bool late = false;
  Slot* sp = place(fw::load_le16(f.data), bit, &late);
  if (sp == nullptr) return true;
  Slot& s = *sp;
  if (part == proto::kPartAccel) {
    for (int i = 0; i < 3; ++i) s.s.accel_counts[i] = fw::load_le16s(f.data + 2 + 2 * i);
  } else if (part == proto::kPartGyro) {
    for (int i = 0; i < 3; ++i) s.s.gyro_counts[i] = fw::load_le16s(f.data + 2 + 2 * i);
  } else {
    s.s.temp_cdegC = fw::load_le16s(f.data + 2);
    s.s.t_us = extend_t(fw::load_le32(f.data + 4));
  }
  deliver(s);
  return true;
}

bool StreamDecoder::on_frame(const hal::CanFdFrame& f) {
  if (f.extended != ext_) return false;
  if (!f.fd) return f.len <= 8 && on_frame(hal::can_frame_from_fd(f));
  if (f.id != proto::stream_id(node_, proto::kPartFd, ext_)) return false;
  if (!fd_) return true;  // an FD frame during a classic stream
  return on_fd(f);
}

bool StreamDecoder::on_fd(const hal::CanFdFrame& f) {
  ++k_.frames;
  if (f.len < proto::kFdHeaderBytes) {
    reject(k_.malformed_short, "CAN FD stream frame shorter than its 10-byte header");
    return true;
  }
  const unsigned count = f.data[2];
  if (count == 0u || count > proto::kFdSamplesPerFrame) {
    reject(k_.malformed_count, "CAN FD stream frame with count 0 or above 4");
    return true;
  }
  if (f.len < proto::fd_frame_min_len(count)) {
    reject(k_.malformed_short, "CAN FD stream frame shorter than its header + count samples");
    return true;
  }
  if (f.data[3] != channels_) {
    reject(k_.malformed_format, "CAN FD stream frame with other channels than the stream asked for");
    return true;
  }
  const std::uint16_t seq0 = fw::load_le16(f.data);
  const std::uint64_t t0 = extend_t(fw::load_le32(f.data + 4));
  const std::int16_t temp = fw::load_le16s(f.data + 8);
  bool any_late = false;
  for (unsigned i = 0; i < count; ++i) {
    bool late = false;
    const std::uint64_t reordered = k_.reordered, duplicated = k_.duplicated;
    Slot* sp = place(static_cast<std::uint16_t>(seq0 + i), channels_, &late);
    if (i > 0) {  // a late or repeated frame counts once, not once per sample
      k_.reordered = reordered;
      k_.duplicated = duplicated;
    }
    any_late = any_late || late;
    if (sp == nullptr) continue;
    Slot& s = *sp;
    const std::uint8_t* p = f.data + proto::kFdHeaderBytes + proto::kFdSampleBytes * i;
    for (int j = 0; j < 3; ++j) {
      s.s.accel_counts[j] = fw::load_le16s(p + 2 * j);
      s.s.gyro_counts[j] = fw::load_le16s(p + 6 + 2 * j);
    }
    s.s.temp_cdegC = i == 0 ? temp : fw::load_le16s(f.data + proto::kFdTempTailOffset + 2 * (i - 1));
    s.s.t_us = t0 + static_cast<std::uint64_t>(i) * period_us_;
    deliver(s);
  }
  if (any_late && k_.frames_lost > 0) --k_.frames_lost;
  return true;
}

void StreamDecoder::flush() {
  for (Slot& s : win_) {
    if (s.seq >= 0 && s.parts != 0u) retire(s);
    s = Slot{};
  }
}

}  // namespace imuforge::can
