#include "firmware/store/table_store.h"

#include <cstring>

#include "firmware/common/crc32.h"
#include "firmware/common/endian.h"

namespace imuforge::fw {
namespace {

int flash_fail(TableStore& s, int rc) noexcept {
  s.last_flash_error = rc;
  return kStoreErrFlash;
}

// CRC-32 over `len` flash bytes at `addr`. Returns a StoreError.
int crc_of_flash(TableStore& s, std::uint32_t addr, std::uint32_t len, std::uint32_t& crc) noexcept {
  std::uint8_t buf[64];
  std::uint32_t c = crc32_init();
  std::uint32_t done = 0;
  while (done < len) {
    std::uint32_t n = len - done;
    if (n > sizeof buf) n = static_cast<std::uint32_t>(sizeof buf);
    const int rc = s.flash->read(addr + done, buf, n);
    if (rc != hal::kFlashOk) return flash_fail(s, rc);
    c = crc32_update(c, buf, n);
    done += n;
  }
  crc = crc32_final(c);
  return kStoreOk;
}

void encode_record(std::uint8_t rec[kStoreRecordBytes], std::uint32_t seq, std::uint32_t len,
                   std::uint32_t crc) noexcept {
  std::memset(rec, 0xFF, kStoreRecordBytes);
  store_le32(rec + 0, kStoreMagic);
  store_le32(rec + 4, seq);
  store_le32(rec + 8, len);
  store_le32(rec + 12, crc);
  store_le32(rec + 16, crc32(rec, 16));
}

int scan_slot(TableStore& s, int i) noexcept {
  StoreSlotInfo info;
  std::uint8_t rec[kStoreRecordBytes];
  const int rc = s.flash->read(s.cfg.slot_addr[i], rec, sizeof rec);
  if (rc != hal::kFlashOk) return flash_fail(s, rc);
  const std::uint32_t len = load_le32(rec + 8);
  if (load_le32(rec) == kStoreMagic && load_le32(rec + 16) == crc32(rec, 16) && len > 0u &&
      len <= s.cfg.slot_bytes - kStoreRecordBytes) {
    std::uint32_t crc = 0;
    const int e = crc_of_flash(s, s.cfg.slot_addr[i] + kStoreRecordBytes, len, crc);
    if (e != kStoreOk) return e;
    if (crc == load_le32(rec + 12)) {
      info.valid = true;
      info.seq = load_le32(rec + 4);
      info.len = len;
      info.crc = crc;
    }
  }
  s.slot[i] = info;
  return kStoreOk;
}

bool config_ok(const TableStore& s) noexcept {
  const std::uint32_t sec = s.flash->sector_bytes();
  const std::uint32_t size = s.flash->size_bytes();
  if (sec == 0u || s.cfg.slot_bytes <= kStoreRecordBytes || s.cfg.slot_bytes % sec != 0u) return false;
  for (int i = 0; i < 2; ++i) {
    const std::uint32_t a = s.cfg.slot_addr[i];
    if (a % sec != 0u || a > size || s.cfg.slot_bytes > size - a) return false;
  }
  const std::uint32_t a0 = s.cfg.slot_addr[0], a1 = s.cfg.slot_addr[1];
  return a0 < a1 ? a0 + s.cfg.slot_bytes <= a1 : a1 + s.cfg.slot_bytes <= a0;
}

}  // namespace

void store_init(TableStore& s, hal::Flash& flash, const TableStoreConfig& cfg) noexcept {
  s = TableStore{};
  s.flash = &flash;
  s.cfg = cfg;
}

int store_mount(TableStore& s) noexcept {
  s.active = -1;
  s.staged = -1;
  if (!config_ok(s)) return kStoreErrConfig;
  for (int i = 0; i < 2; ++i) {
    const int e = scan_slot(s, i);
    if (e != kStoreOk) return e;
  }
  if (s.slot[0].valid && s.slot[1].valid) {
    s.active = s.slot[1].seq > s.slot[0].seq ? 1 : 0;
  } else if (s.slot[0].valid) {
    s.active = 0;
  } else if (s.slot[1].valid) {
    s.active = 1;
  }
  return s.active >= 0 ? kStoreOk : kStoreErrNoTable;
}

int store_write(TableStore& s, const std::uint8_t* data, std::uint32_t len, std::uint32_t seq) noexcept {
  if (!config_ok(s)) return kStoreErrConfig;
  if (len == 0u || len > s.cfg.slot_bytes - kStoreRecordBytes) return kStoreErrTooLarge;
  const int target = s.active == 0 ? 1 : 0;
  const std::uint32_t base = s.cfg.slot_addr[target];
  s.staged = -1;
  s.slot[target] = StoreSlotInfo{};
  // 1. Erase, commit record sector first: from the first operation on, this slot can no longer look
  //    committed, whatever happens to its data sectors.
  const std::uint32_t sec = s.flash->sector_bytes();
  for (std::uint32_t off = 0; off < s.cfg.slot_bytes; off += sec) {
    const int rc = s.flash->erase_sector(base + off);
    if (rc != hal::kFlashOk) return flash_fail(s, rc);
  }
  // 2. Program the blob row by row, then verify it from flash.
  for (std::uint32_t off = 0; off < len; off += static_cast<std::uint32_t>(kStoreProgramChunk)) {
    std::uint32_t n = len - off;
    if (n > kStoreProgramChunk) n = static_cast<std::uint32_t>(kStoreProgramChunk);
    const int rc = s.flash->program(base + kStoreRecordBytes + off, data + off, n);
    if (rc != hal::kFlashOk) return flash_fail(s, rc);
  }
  const std::uint32_t want = crc32(data, len);
  std::uint32_t got = 0;
  const int e = crc_of_flash(s, base + kStoreRecordBytes, len, got);
  if (e != kStoreOk) return e;
  if (got != want) return kStoreErrVerify;
  s.slot[target].len = len;
  s.slot[target].crc = want;
  s.slot[target].seq = seq;
  s.staged = target;
  s.staged_seq = seq;
  return kStoreOk;
}

int store_commit(TableStore& s, std::uint32_t seq) noexcept {
  if (s.staged < 0 || s.staged_seq != seq) return kStoreErrNotStaged;
  const int target = s.staged;
  std::uint8_t rec[kStoreRecordBytes];
  encode_record(rec, seq, s.slot[target].len, s.slot[target].crc);
  const int rc = s.flash->program(s.cfg.slot_addr[target], rec, sizeof rec);
  if (rc != hal::kFlashOk) return flash_fail(s, rc);
  // Re-scan rather than trust our RAM copy: the slot becomes active only if flash says it is valid.
  const int e = scan_slot(s, target);
  if (e != kStoreOk) return e;
  s.staged = -1;
  if (!s.slot[target].valid) return kStoreErrVerify;
  s.active = target;
  return kStoreOk;
}

int store_read(TableStore& s, std::uint32_t offset, std::uint8_t* dst, std::size_t len) noexcept {
  const StoreSlotInfo* a = store_active(s);
  if (a == nullptr) return kStoreErrNoTable;
  if (offset > a->len || len > a->len - offset) return kStoreErrRange;
  const int rc = s.flash->read(s.cfg.slot_addr[s.active] + kStoreRecordBytes + offset, dst, len);
  return rc == hal::kFlashOk ? kStoreOk : flash_fail(s, rc);
}

}  // namespace imuforge::fw
