// hal::Clock on the Cortex-M SysTick timer (core clock source). The SysTick interrupt fires every
// millisecond and counts milliseconds; now_us() combines that count with the current down-counter.
// One instance per part (SysTick is a single core peripheral); define it statically and call init()
// once before enabling interrupts globally. now_us() is O(1) (one 32-bit division).
#pragma once
#include <cstdint>

#include "hal/clock.h"

namespace imuforge::hal {

class SysTickClock final : public Clock {
 public:
  // core_hz: the SysTick input clock (mps2-an385/an386 under QEMU: 25 MHz). Starts at 0 µs. core_hz is
  // clamped to [1 MHz, 2^24 kHz] so that one millisecond fits the 24-bit reload register.
  void init(std::uint32_t core_hz) noexcept;
  std::uint64_t now_us() noexcept override;
  // Called by SysTick_Handler (hal/mcu/systick_clock.cpp); not for applications.
  void on_tick() noexcept { ++ms_; }

 private:
  volatile std::uint64_t ms_ = 0;
  std::uint32_t reload_ = 0;
  std::uint32_t cycles_per_us_ = 1;
};

// The instance SysTick_Handler advances (null until SysTickClock::init runs).
SysTickClock* systick_clock_instance() noexcept;

// Raw SysTick access for cycle measurements (benchmarks): free-running 24-bit down-counter at core clock,
// no interrupt. Do not mix with SysTickClock. O(1).
void systick_free_run_start() noexcept;
std::uint32_t systick_value() noexcept;

}  // namespace imuforge::hal
