// Clock seam: a monotonic microsecond clock, the time base of the CAN node (stream timestamps, ISO-TP
// timers) and of anything else that waits on the MCU side.
//
//   - now_us() never goes backwards and starts near 0 at init; it does not wrap for 584 000 years;
//   - resolution is backend-defined (SysTick: 1 µs or better; Linux: 1 µs);
//   - it is callable from thread context and, on the MCU, from interrupts of lower priority than SysTick.
// Backends: mcu/systick_clock.h (Cortex-M SysTick), the Linux steady clock, a settable clock in sim/.
#pragma once
#include <cstdint>

namespace imuforge::hal {

class Clock {
 public:
  // Microseconds since the clock was started. O(1).
  virtual std::uint64_t now_us() noexcept = 0;

 protected:
  ~Clock() = default;
};

}  // namespace imuforge::hal
