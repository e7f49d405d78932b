// An in-memory CAN bus for firmware tests: N ports, every frame sent by one port is queued at all
// others. Fixed-size queues (no heap). Fault injection: drop every n-th frame, bus-off, a frame filter.
// CAN FD frames (send_fd) go to a separate queue per port (take_fd), only on a bus with fd = true; a
// classic bus answers send_fd like a classic controller's driver: kCanErrNoFd.
#pragma once
#include <cstdint>

#include "hal/can.h"

namespace cantest {

constexpr unsigned kQueue = 512;
constexpr unsigned kFdQueue = 64;

struct LoopBus;

class LoopPort final : public imuforge::hal::CanPort {
 public:
  LoopBus* bus = nullptr;
  imuforge::hal::CanFrame q[kQueue];
  unsigned head = 0, count = 0;
  std::uint32_t overruns = 0;
  bool bus_off = false;

  imuforge::hal::CanFdFrame fdq[kFdQueue];
  unsigned fd_head = 0, fd_count = 0;
  std::uint32_t fd_overruns = 0;

  int send(const imuforge::hal::CanFrame& f) noexcept override;
  int send_fd(const imuforge::hal::CanFdFrame& f) noexcept override;
  // Takes one received FD frame; false when none is queued.
  bool take_fd(imuforge::hal::CanFdFrame& f) {
    if (fd_count == 0u) return false;
    f = fdq[fd_head];
    fd_head = (fd_head + 1u) % kFdQueue;
    --fd_count;
    return true;
  }
  void push_fd(const imuforge::hal::CanFdFrame& f) {
    if (fd_count == kFdQueue) {
      ++fd_overruns;
      return;
    }
    fdq[(fd_head + fd_count) % kFdQueue] = f;
    ++fd_count;
  }
  int receive(imuforge::hal::CanFrame& f) noexcept override {
    if (count == 0u) return imuforge::hal::kCanErrWouldBlock;
    f = q[head];
    head = (head + 1u) % kQueue;
    --count;
    return imuforge::hal::kCanOk;
  }
  void push(const imuforge::hal::CanFrame& f) {
    if (count == kQueue) {
      ++overruns;
      return;
    }
    q[(head + count) % kQueue] = f;
    ++count;
  }
};

struct LoopBus {
  LoopPort* ports[4] = {nullptr, nullptr, nullptr, nullptr};
  unsigned n = 0;
  std::uint32_t drop_every = 0;  // 0: never
  std::uint32_t sent = 0;
  std::uint32_t dropped = 0;
  bool fd = false;  // the bus carries CAN FD
  void attach(LoopPort& p) {
    p.bus = this;
    ports[n++] = &p;
  }
};

inline int LoopPort::send(const imuforge::hal::CanFrame& f) noexcept {
  if (bus_off) return imuforge::hal::kCanErrBusOff;
  if (!imuforge::hal::can_frame_valid(f)) return imuforge::hal::kCanErrArg;
  ++bus->sent;
  if (bus->drop_every != 0u && bus->sent % bus->drop_every == 0u) {
    ++bus->dropped;
    return imuforge::hal::kCanOk;
  }
  for (unsigned i = 0; i < bus->n; ++i) {
    if (bus->ports[i] != this) bus->ports[i]->push(f);
  }
  return imuforge::hal::kCanOk;
}

inline int LoopPort::send_fd(const imuforge::hal::CanFdFrame& f) noexcept {
  if (!bus->fd) return imuforge::hal::kCanErrNoFd;
  if (bus_off) return imuforge::hal::kCanErrBusOff;
  const int chk = imuforge::hal::can_fd_frame_check(f);
  if (chk != imuforge::hal::kCanOk) return chk;
  ++bus->sent;
  if (bus->drop_every != 0u && bus->sent % bus->drop_every == 0u) {
    ++bus->dropped;
    return imuforge::hal::kCanOk;
  }
  for (unsigned i = 0; i < bus->n; ++i) {
    if (bus->ports[i] != this) bus->ports[i]->push_fd(f);
  }
  return imuforge::hal::kCanOk;
}

}  // namespace cantest
