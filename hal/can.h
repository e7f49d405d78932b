// CAN seam: one classic CAN 2.0 frame type and a non-blocking port interface.
//
// The firmware node (firmware/can_node/) and the firmware ISO-TP (firmware/isotp/) only see CanPort.
// Backends: hal/linux/ (SocketCAN raw, the virtual bus over Unix datagrams), an MCU driver on target.
// Frames are classic CAN (0..8 data bytes); CAN FD is optional and only ever used by hal/linux after an
// MTU check. No heap; every call is O(1) in the frame size.
#pragma once
#include <cstdint>

namespace imuforge::hal {

// Error codes shared by every CAN backend (stable; negative; 0 = success).
enum CanError : int {
  kCanOk = 0,
  kCanErrWouldBlock = -1,  // TX queue full (send) or nothing pending (receive): try again later
  kCanErrBusOff = -2,      // controller is bus-off; frames are not sent until recovery
  kCanErrIo = -3,          // backend I/O failure (socket error, driver fault)
  kCanErrArg = -4,         // bad frame (dlc > 8, id out of range for its format)
  kCanErrClosed = -5,      // port not open
};

constexpr std::uint32_t kCanStdIdMask = 0x7FFu;       // 11-bit identifier
constexpr std::uint32_t kCanExtIdMask = 0x1FFFFFFFu;  // 29-bit identifier

struct CanFrame {
  std::uint32_t id = 0;     // 11 or 29 bits, without flag bits
  bool extended = false;    // true: 29-bit identifier
  std::uint8_t len = 0;     // 0..8
  std::uint8_t data[8] = {0, 0, 0, 0, 0, 0, 0, 0};
};

// True if the frame is well formed (len <= 8, id fits its format).
constexpr bool can_frame_valid(const CanFrame& f) noexcept {
  return f.len <= 8u && (f.extended ? (f.id & ~kCanExtIdMask) == 0u : (f.id & ~kCanStdIdMask) == 0u);
}

// A CAN port. Implementations never block: send() queues or fails with kCanErrWouldBlock, receive()
// returns kCanErrWouldBlock when no frame is pending.
class CanPort {
 public:
  // Queues one frame for transmission. Returns kCanOk or a negative CanError.
  virtual int send(const CanFrame& frame) noexcept = 0;
  // Takes one received frame. Returns kCanOk (frame filled) or a negative CanError.
  virtual int receive(CanFrame& frame) noexcept = 0;

 protected:
  ~CanPort() = default;  // not deleted through the interface (no heap in firmware)
};

}  // namespace imuforge::hal
