// A/B table store: power-fail-safe storage of one coefficient table blob in two flash slots.
//
// Layout of each slot (slot_bytes, a whole number of sectors, slot-aligned):
//   [0 .. 32)        commit record, left erased (0xFF) while the data is written, programmed LAST
//   [32 .. 32+len)   the table blob
// Commit record (little endian): magic "IFTS" (0x53544649) u32, seq u32, len u32, data_crc32 u32,
//   record_crc32 u32 (CRC-32 of the 16 bytes before it), 12 bytes 0xFF.
//
// Update protocol (store_write then store_commit):
//   1. erase the INACTIVE slot (the active one is never touched),
//   2. program the blob in kStoreProgramChunk pieces, read back and check its CRC-32,
//   3. program the commit record, read it back and check it: from that instant the new slot is the
//      newest valid slot.
// Boot (store_mount): a slot is valid iff its record has the magic, a good record CRC, a sane length and
// the blob matches data_crc32; the valid slot with the highest seq is active. A cut at any point leaves
// the old slot intact, and the new slot is either fully valid or invalid; never a mix
// (tests/can/test_store_powerfail.cpp checks every program/erase boundary).
// No heap. Reads go through a 64-byte stack buffer. Complexity: mount/write/commit O(slot_bytes).
#pragma once
#include <cstddef>
#include <cstdint>

#include "hal/flash.h"

namespace imuforge::fw {

enum StoreError : int {
  kStoreOk = 0,
  kStoreErrNoTable = -1,     // no valid slot (factory-fresh device)
  kStoreErrTooLarge = -2,    // blob does not fit a slot
  kStoreErrFlash = -3,       // flash operation failed (incl. power loss)
  kStoreErrVerify = -4,      // read-back CRC mismatch after programming
  kStoreErrNotStaged = -5,   // commit without a matching successful write
  kStoreErrConfig = -6,      // slot layout does not fit the flash or is not sector aligned
  kStoreErrRange = -7,       // read outside the active blob
};

constexpr std::uint32_t kStoreRecordBytes = 32;
constexpr std::uint32_t kStoreMagic = 0x53544649u;  // "IFTS"
constexpr std::size_t kStoreProgramChunk = 64;      // bytes per program operation (a flash row)

struct TableStoreConfig {
  std::uint32_t slot_addr[2] = {0, 0};
  std::uint32_t slot_bytes = 0;
};

struct StoreSlotInfo {
  bool valid = false;
  std::uint32_t seq = 0;
  std::uint32_t len = 0;
  std::uint32_t crc = 0;  // CRC-32 of the blob
};

struct TableStore {
  hal::Flash* flash = nullptr;
  TableStoreConfig cfg;
  StoreSlotInfo slot[2];
  int active = -1;  // 0, 1 or -1 (none)
  int staged = -1;  // slot holding a verified, uncommitted blob, or -1
  std::uint32_t staged_seq = 0;
  int last_flash_error = 0;
};

// Cannot fail: checks happen in store_mount().
void store_init(TableStore& s, hal::Flash& flash, const TableStoreConfig& cfg) noexcept;
// Scans both slots and selects the newest valid one. Returns kStoreOk, kStoreErrNoTable, kStoreErrConfig
// or kStoreErrFlash.
int store_mount(TableStore& s) noexcept;
// Steps 1 and 2: erase the inactive slot, write `len` bytes, verify. On success the blob is staged.
int store_write(TableStore& s, const std::uint8_t* data, std::uint32_t len, std::uint32_t seq) noexcept;
// Step 3: program the commit record of the staged slot if its seq matches.
int store_commit(TableStore& s, std::uint32_t seq) noexcept;
// Reads `len` bytes of the active blob from `offset`.
int store_read(TableStore& s, std::uint32_t offset, std::uint8_t* dst, std::size_t len) noexcept;

inline const StoreSlotInfo* store_active(const TableStore& s) noexcept {
  return s.active >= 0 ? &s.slot[s.active] : nullptr;
}

}  // namespace imuforge::fw
