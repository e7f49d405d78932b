#include "hal/mcu/systick_clock.h"

namespace imuforge::hal {

namespace {
// SysTick registers (ARMv7-M architecture reference, B3.3).
volatile std::uint32_t& kCsr = *reinterpret_cast<volatile std::uint32_t*>(0xE000E010u);
volatile std::uint32_t& kRvr = *reinterpret_cast<volatile std::uint32_t*>(0xE000E014u);
volatile std::uint32_t& kCvr = *reinterpret_cast<volatile std::uint32_t*>(0xE000E018u);
constexpr std::uint32_t kCsrEnable = 1u << 0, kCsrTickInt = 1u << 1, kCsrClkSource = 1u << 2;
SysTickClock* g_clock = nullptr;
}  // namespace

void SysTickClock::init(std::uint32_t core_hz) noexcept {
  if (core_hz < 1000000u) core_hz = 1000000u;
  if (core_hz / 1000u > 0x1000000u) core_hz = 0x1000000u * 1000u;
  cycles_per_us_ = core_hz / 1000000u;
  reload_ = core_hz / 1000u - 1u;
  ms_ = 0;
  g_clock = this;
  kCsr = 0;
  kRvr = reload_;
  kCvr = 0;
  kCsr = kCsrEnable | kCsrTickInt | kCsrClkSource;
}

std::uint64_t SysTickClock::now_us() noexcept {
  // Read ms, counter, ms again: if a tick happened in between, the counter may belong to either
  // millisecond; re-read until both ms reads agree.
  std::uint64_t ms0, ms1;
  std::uint32_t cvr;
  do {
    ms0 = ms_;
    cvr = kCvr;
    ms1 = ms_;
  } while (ms0 != ms1);
  const std::uint32_t elapsed = reload_ - cvr;
  return ms0 * 1000u + elapsed / cycles_per_us_;
}

SysTickClock* systick_clock_instance() noexcept { return g_clock; }

void systick_free_run_start() noexcept {
  kCsr = 0;
  kRvr = 0x00FFFFFFu;
  kCvr = 0;
  kCsr = kCsrEnable | kCsrClkSource;
}

std::uint32_t systick_value() noexcept { return kCvr; }

}  // namespace imuforge::hal

extern "C" void SysTick_Handler(void) {
  if (auto* c = imuforge::hal::systick_clock_instance()) c->on_tick();
}
