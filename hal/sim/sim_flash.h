// Simulated NOR flash with power-fail injection, for the table store's power-fail test and the virtual IMU.
//
// Semantics follow hal/flash.h: erase sets a sector to 0xFF, program ANDs bytes in (bits only clear).
// Power-fail injection: cut_power_at(n) makes the n-th program/erase operation from now be interrupted:
//   - an interrupted erase leaves the first half of the sector erased and the rest as it was
//     (erase proceeds in address order on the parts we model);
//   - an interrupted program leaves the first half of the bytes programmed and the rest untouched;
//   - afterwards every operation (read included) fails with kFlashErrPowerLost until power_on().
// So every "operation boundary" and a torn operation at each boundary are exercised.
// Storage is caller-owned (no heap). All operations are O(len) / O(sector).
#pragma once
#include <cstddef>
#include <cstdint>

#include "hal/flash.h"

namespace imuforge::hal {

class SimFlash final : public Flash {
 public:
  // `storage` must hold size_bytes; it is not cleared (call erase_all() for a factory-fresh part).
  SimFlash(std::uint8_t* storage, std::uint32_t size_bytes, std::uint32_t sector_bytes) noexcept;

  std::uint32_t size_bytes() const noexcept override { return size_; }
  std::uint32_t sector_bytes() const noexcept override { return sector_; }
  int read(std::uint32_t addr, std::uint8_t* dst, std::size_t len) noexcept override;
  int program(std::uint32_t addr, const std::uint8_t* src, std::size_t len) noexcept override;
  int erase_sector(std::uint32_t addr) noexcept override;

  void erase_all() noexcept;
  // 0 disables the cut. n >= 1: the n-th program/erase operation from now is torn.
  void cut_power_at(std::uint32_t n) noexcept { cut_at_ = n == 0u ? 0u : ops_ + n; }
  void power_on() noexcept { powered_ = true; cut_at_ = 0; }
  bool powered() const noexcept { return powered_; }
  // Program + erase operations attempted since construction.
  std::uint32_t op_count() const noexcept { return ops_; }
  std::uint32_t erase_count() const noexcept { return erases_; }
  std::uint32_t program_count() const noexcept { return programs_; }

 private:
  bool in_range(std::uint32_t addr, std::size_t len) const noexcept;
  // Counts one operation; returns true if this one is the torn one.
  bool tick() noexcept;

  std::uint8_t* mem_;
  std::uint32_t size_;
  std::uint32_t sector_;
  std::uint32_t ops_ = 0;
  std::uint32_t erases_ = 0;
  std::uint32_t programs_ = 0;
  std::uint32_t cut_at_ = 0;
  bool powered_ = true;
};

}  // namespace imuforge::hal
