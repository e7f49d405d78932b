#include "host/can/stream_decoder.h"

#include "firmware/can_node/protocol.h"
#include "firmware/common/endian.h"

namespace imuforge::can {

StreamDecoder::StreamDecoder(std::uint8_t node_id, bool extended, std::uint8_t channels, Callback cb)
    : node_(node_id), ext_(extended), channels_(channels), cb_(std::move(cb)) {
  nparts_ = ((channels & proto::kChAccel) ? 1u : 0u) + ((channels & proto::kChGyro) ? 1u : 0u) +
            ((channels & proto::kChTemp) ? 1u : 0u);
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

bool StreamDecoder::on_frame(const hal::CanFrame& f) {
  if (f.extended != ext_ || f.len != 8) return false;
  int part = -1;
  for (std::uint8_t p = 0; p < proto::kPartCount; ++p) {
    if (f.id == proto::stream_id(node_, p, ext_)) part = p;
  }
  if (part < 0) return false;
  const std::uint8_t bit = static_cast<std::uint8_t>(1u << part);
  if ((channels_ & bit) == 0u) return true;  // a channel we did not ask for
  ++k_.frames;
  const std::uint16_t s16 = fw::load_le16(f.data);
  std::int64_t seq;
  if (!started_) {
    started_ = true;
    seq = s16;
    highest_ = seq - 1;
  } else {
    const auto diff = static_cast<std::int16_t>(static_cast<std::uint16_t>(s16 - static_cast<std::uint16_t>(highest_)));
    seq = highest_ + diff;
  }
  if (seq > highest_) {
    // Samples skipped between the previous highest and this one: lost unless a frame shows up later.
    for (std::int64_t g = highest_ + 1; g < seq; ++g) {
      Slot& gs = win_[static_cast<std::size_t>(g) % kWindow];
      retire(gs);
      gs.seq = g;  // placeholder with no parts: "missing"
      gs.parts = 0;
      ++k_.lost;
      k_.frames_lost += nparts_;
    }
    Slot& ns = win_[static_cast<std::size_t>(seq) % kWindow];
    retire(ns);
    ns.seq = seq;
    highest_ = seq;
  } else if (seq < highest_) {
    ++k_.reordered;
    if (highest_ - seq >= static_cast<std::int64_t>(kWindow)) return true;  // too old to place
  }
  Slot& s = win_[static_cast<std::size_t>(seq) % kWindow];
  if (s.seq != seq) return true;  // evicted already
  if ((s.parts & bit) != 0u) {
    ++k_.duplicated;
    return true;
  }
  if (s.parts == 0u && seq < highest_) {
    // a sample counted lost turned out to be only late
    --k_.lost;
    k_.frames_lost -= nparts_;
  }
  s.parts = static_cast<std::uint8_t>(s.parts | bit);
  s.s.seq = static_cast<std::uint64_t>(seq);
  if (part == proto::kPartAccel) {
    for (int i = 0; i < 3; ++i) s.s.accel_counts[i] = fw::load_le16s(f.data + 2 + 2 * i);
  } else if (part == proto::kPartGyro) {
    for (int i = 0; i < 3; ++i) s.s.gyro_counts[i] = fw::load_le16s(f.data + 2 + 2 * i);
  } else {
    s.s.temp_cdegC = fw::load_le16s(f.data + 2);
    const std::uint32_t t32 = fw::load_le32(f.data + 4);
    if (t_started_ && t32 < t_last_ && t_last_ - t32 > 0x80000000u) t_hi_ += 1ull << 32;
    t_started_ = true;
    t_last_ = t32;
    s.s.t_us = t_hi_ | t32;
  }
  s.s.parts = s.parts;
  if (s.parts == channels_) {
    s.delivered = true;
    ++k_.received;
    if (cb_) cb_(s.s);
  }
  return true;
}

void StreamDecoder::flush() {
  for (Slot& s : win_) {
    if (s.seq >= 0 && s.parts != 0u) retire(s);
    s = Slot{};
  }
}

}  // namespace imuforge::can
