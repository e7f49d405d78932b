#include "hal/sim/sim_flash.h"

#include <cstring>

namespace imuforge::hal {

SimFlash::SimFlash(std::uint8_t* storage, std::uint32_t size_bytes, std::uint32_t sector_bytes) noexcept
    : mem_(storage), size_(size_bytes), sector_(sector_bytes == 0u ? 1u : sector_bytes) {}

void SimFlash::erase_all() noexcept { std::memset(mem_, 0xFF, size_); }

bool SimFlash::in_range(std::uint32_t addr, std::size_t len) const noexcept {
  return addr <= size_ && len <= static_cast<std::size_t>(size_ - addr);
}

bool SimFlash::tick() noexcept {
  ++ops_;
  return cut_at_ != 0u && ops_ == cut_at_;
}

int SimFlash::read(std::uint32_t addr, std::uint8_t* dst, std::size_t len) noexcept {
  if (!powered_) return kFlashErrPowerLost;
  if (!in_range(addr, len)) return kFlashErrRange;
  if (len > 0u) std::memcpy(dst, mem_ + addr, len);
  return kFlashOk;
}

int SimFlash::program(std::uint32_t addr, const std::uint8_t* src, std::size_t len) noexcept {
  if (!powered_) return kFlashErrPowerLost;
  if (!in_range(addr, len)) return kFlashErrRange;
  ++programs_;
  const bool torn = tick();
  const std::size_t n = torn ? len / 2u : len;
  for (std::size_t i = 0; i < n; ++i) mem_[addr + i] = static_cast<std::uint8_t>(mem_[addr + i] & src[i]);
  if (torn) {
    powered_ = false;
    return kFlashErrPowerLost;
  }
  return kFlashOk;
}

int SimFlash::erase_sector(std::uint32_t addr) noexcept {
  if (!powered_) return kFlashErrPowerLost;
  if (addr % sector_ != 0u) return kFlashErrAlign;
  if (!in_range(addr, sector_)) return kFlashErrRange;
  ++erases_;
  const bool torn = tick();
  std::memset(mem_ + addr, 0xFF, torn ? sector_ / 2u : sector_);
  if (torn) {
    powered_ = false;
    return kFlashErrPowerLost;
  }
  return kFlashOk;
}

}  // namespace imuforge::hal
