// Flash seam: NOR-flash semantics as on a Cortex-M part's internal flash.
//
//   - erase works on whole sectors and sets every byte of the sector to 0xFF;
//   - program can only clear bits (new = old & data); programming a byte twice without erase ANDs;
//   - read is random access.
// The table store (firmware/store/) relies on exactly these semantics and on nothing else: it never
// assumes an operation is atomic, which is what the power-fail test in tests/can/ checks with the
// simulated flash in hal/sim/ (an operation cut by power loss leaves a partial result).
#pragma once
#include <cstddef>
#include <cstdint>

namespace imuforge::hal {

enum FlashError : int {
  kFlashOk = 0,
  kFlashErrRange = -1,      // address/length outside the device
  kFlashErrAlign = -2,      // erase address not at a sector boundary
  kFlashErrPowerLost = -3,  // the (simulated) supply failed during or before the operation
  kFlashErrHw = -4,         // controller reported a failure (verify, lock)
};

class Flash {
 public:
  virtual std::uint32_t size_bytes() const noexcept = 0;
  virtual std::uint32_t sector_bytes() const noexcept = 0;
  // Copies `len` bytes at `addr` into dst. O(len).
  virtual int read(std::uint32_t addr, std::uint8_t* dst, std::size_t len) noexcept = 0;
  // ANDs `len` bytes into flash at `addr` (NOR: bits go 1 -> 0 only). O(len).
  virtual int program(std::uint32_t addr, const std::uint8_t* src, std::size_t len) noexcept = 0;
  // Sets the sector starting at `addr` (must be sector aligned) to 0xFF. O(sector).
  virtual int erase_sector(std::uint32_t addr) noexcept = 0;

 protected:
  ~Flash() = default;
};

}  // namespace imuforge::hal
