// A/B table store: normal operation, and the power-fail sweep: for a write+commit of a new table, cut
// the power at EVERY program/erase operation (torn: half done), reboot, and require the old table or
// the new table, complete and byte-exact. Never a mix, never none when there was one. Repeated from
// each starting state (empty device, table in slot A, table in slot B) and for a table that spans
// several sectors.
#include <cstring>

#include "firmware/store/table_store.h"
#include "hal/sim/sim_flash.h"
#include "tests/can/fwcheck.h"

using namespace imuforge;
using namespace imuforge::fw;

namespace {

constexpr std::uint32_t kFlash = 8192;
constexpr std::uint32_t kSector = 1024;
constexpr std::uint32_t kSlot = 3072;  // 3 sectors: record + up to 3040 bytes of blob
std::uint8_t mem[kFlash];
std::uint8_t old_blob[2300], new_blob[2300], readback[3072];

TableStoreConfig cfg() {
  TableStoreConfig c;
  c.slot_addr[0] = 1024;  // not at 0: layout offsets are exercised
  c.slot_addr[1] = 1024 + kSlot;
  c.slot_bytes = kSlot;
  return c;
}

void fill(std::uint8_t* b, std::size_t n, std::uint8_t salt) {
  for (std::size_t i = 0; i < n; ++i) b[i] = static_cast<std::uint8_t>((i * 31u) ^ salt ^ (i >> 3));
}

bool active_is(TableStore& s, const std::uint8_t* blob, std::uint32_t len, std::uint32_t seq) {
  const StoreSlotInfo* a = store_active(s);
  if (a == nullptr || a->len != len || a->seq != seq) return false;
  if (store_read(s, 0, readback, len) != kStoreOk) return false;
  return std::memcmp(readback, blob, len) == 0;
}

void basics() {
  hal::SimFlash f(mem, kFlash, kSector);
  f.erase_all();
  TableStore s;
  store_init(s, f, cfg());
  CHECK_EQ(store_mount(s), kStoreErrNoTable);
  CHECK_EQ(store_commit(s, 1), kStoreErrNotStaged);
  fill(old_blob, 100, 1);
  CHECK_EQ(store_write(s, old_blob, 100, 5), kStoreOk);
  CHECK(store_active(s) == nullptr);  // written but not committed: not active
  CHECK_EQ(store_commit(s, 6), kStoreErrNotStaged);
  CHECK_EQ(store_commit(s, 5), kStoreOk);
  CHECK(active_is(s, old_blob, 100, 5));
  // uncommitted write does not survive a reboot
  fill(new_blob, 200, 2);
  CHECK_EQ(store_write(s, new_blob, 200, 6), kStoreOk);
  TableStore s2;
  store_init(s2, f, cfg());
  CHECK_EQ(store_mount(s2), kStoreOk);
  CHECK(active_is(s2, old_blob, 100, 5));
  CHECK_EQ(store_write(s2, old_blob, kSlot, 7), kStoreErrTooLarge);
  CHECK_EQ(store_read(s2, 90, readback, 11), kStoreErrRange);
  // a bit flip in the active blob invalidates that slot at the next mount
  std::uint8_t zero = 0;
  CHECK_EQ(f.program(1024 + kStoreRecordBytes + 10, &zero, 1), hal::kFlashOk);
  TableStore s3;
  store_init(s3, f, cfg());
  CHECK_EQ(store_mount(s3), kStoreErrNoTable);
  // overlapping slots are a config error
  TableStoreConfig bad = cfg();
  bad.slot_addr[1] = bad.slot_addr[0] + kSector;
  store_init(s3, f, bad);
  CHECK_EQ(store_mount(s3), kStoreErrConfig);
}

// Prepares the flash: `prior` committed tables written in sequence (0: empty device).
std::uint32_t prepare(hal::SimFlash& f, int prior, std::uint32_t old_len) {
  f.power_on();
  f.erase_all();
  TableStore s;
  store_init(s, f, cfg());
  (void)store_mount(s);
  std::uint32_t seq = 0;
  for (int i = 0; i < prior; ++i) {
    seq = 10u + static_cast<std::uint32_t>(i);
    CHECK_EQ(store_write(s, old_blob, old_len, seq), kStoreOk);
    CHECK_EQ(store_commit(s, seq), kStoreOk);
  }
  return seq;
}

void sweep(int prior, std::uint32_t old_len, std::uint32_t new_len) {
  hal::SimFlash f(mem, kFlash, kSector);
  fill(old_blob, old_len, 0x11);
  fill(new_blob, new_len, 0x77);
  // Count the operations of an uninterrupted update first.
  const std::uint32_t old_seq = prepare(f, prior, old_len);
  const std::uint32_t before = f.op_count();
  {
    TableStore s;
    store_init(s, f, cfg());
    (void)store_mount(s);
    CHECK_EQ(store_write(s, new_blob, new_len, old_seq + 1), kStoreOk);
    CHECK_EQ(store_commit(s, old_seq + 1), kStoreOk);
  }
  const std::uint32_t total_ops = f.op_count() - before;
  CHECK(total_ops >= 4u);
  unsigned saw_old = 0, saw_new = 0;
  for (std::uint32_t n = 1; n <= total_ops + 1; ++n) {
    (void)prepare(f, prior, old_len);
    f.cut_power_at(n);
    {
      TableStore s;
      store_init(s, f, cfg());
      (void)store_mount(s);
      if (store_write(s, new_blob, new_len, old_seq + 1) == kStoreOk) (void)store_commit(s, old_seq + 1);
    }
    CHECK(n > total_ops ? f.powered() : !f.powered());
    f.power_on();  // reboot
    TableStore s;
    store_init(s, f, cfg());
    const int m = store_mount(s);
    const bool is_new = m == kStoreOk && active_is(s, new_blob, new_len, old_seq + 1);
    const bool is_old = prior > 0 && m == kStoreOk && active_is(s, old_blob, old_len, old_seq);
    if (!(is_new || is_old || (prior == 0 && m == kStoreErrNoTable))) {
      std::printf("power cut at op %u of %u (prior %d): mount %d, neither old nor new table\n",
                  static_cast<unsigned>(n), static_cast<unsigned>(total_ops), prior, m);
      CHECK(false);
    }
    saw_new += is_new ? 1u : 0u;
    saw_old += is_old ? 1u : 0u;
    // Once a cut leaves the new table valid, every later cut must too (the commit point is one op).
    if (n == total_ops + 1) CHECK(is_new);
    // And the device must still accept a further update after any cut.
    const std::uint8_t* again = prior > 0 ? old_blob : new_blob;
    const std::uint32_t again_len = prior > 0 ? old_len : new_len;
    CHECK_EQ(store_write(s, again, again_len, old_seq + 2), kStoreOk);
    CHECK_EQ(store_commit(s, old_seq + 2), kStoreOk);
    CHECK(active_is(s, again, again_len, old_seq + 2));
  }
  // The sweep must have covered both outcomes: cuts before the commit record and after it.
  CHECK(saw_new >= 1u);
  if (prior > 0) CHECK(saw_old >= total_ops - 1u);
  std::printf("sweep prior=%d old=%u new=%u: %u cut points, old kept %u, new taken %u\n", prior,
              static_cast<unsigned>(old_len), static_cast<unsigned>(new_len), static_cast<unsigned>(total_ops + 1),
              saw_old, saw_new);
}

}  // namespace

int main() {
  basics();
  sweep(0, 0, 2244);
  sweep(1, 2244, 2244);   // old in slot A, new goes to B
  sweep(2, 700, 2244);    // old in slot B, new goes to A
  sweep(3, 2244, 130);
  return FW_TEST_RESULT("test_can_store");
}
