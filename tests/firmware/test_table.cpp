// Coefficient table v1: round trip, every parser error code, never a usable table on failure.
#include <cstring>

#include "firmware/common/crc32.h"
#include "firmware/common/endian.h"
#include "firmware/table/table.h"
#include "tests/firmware/fwtest.h"
#include "tests/firmware/test_tables.h"

using namespace imuforge::fw;

static Table g_src, g_dst;
static std::uint8_t g_buf[kTableMaxSize + 8];
static std::uint8_t g_mut[kTableMaxSize + 8];

static bool tables_equal(const Table& a, const Table& b) {
  if (a.device_serial != b.device_serial || a.table_sequence != b.table_sequence ||
      a.created_unix_s != b.created_unix_s || a.model_flags != b.model_flags ||
      a.accel_lsb_mps2 != b.accel_lsb_mps2 || a.gyro_lsb_rad_s != b.gyro_lsb_rad_s ||
      a.accel_raw_bits != b.accel_raw_bits || a.gyro_raw_bits != b.gyro_raw_bits ||
      a.n_breakpoints != b.n_breakpoints)
    return false;
  for (int i = 0; i < a.n_breakpoints; ++i)
    if (a.breakpoints_degC[i] != b.breakpoints_degC[i] ||
        std::memcmp(&a.coeffs[i], &b.coeffs[i], sizeof(BreakpointCoeffs)) != 0)
      return false;
  return true;
}

static void test_round_trip() {
  fwtest::Rng rng(11);
  for (int n = 1; n <= 16; ++n) {
    fwtest::make_random_table(&g_src, rng, n, 16.0f, 2000.0f);
    const int len = table_serialize(&g_src, g_buf, sizeof g_buf);
    FW_EXPECT_EQ_INT(len, table_serialized_size(static_cast<std::size_t>(n)));
    FW_EXPECT(table_is_valid(&g_src));
    FW_EXPECT_EQ_INT(table_parse(g_buf, static_cast<std::size_t>(len), &g_dst), kTableOk);
    FW_EXPECT(table_is_valid(&g_dst));
    FW_EXPECT(tables_equal(g_src, g_dst));
    FW_EXPECT_EQ_INT(g_dst.crc32, load_le32(g_buf + len - 4));
  }
  FW_EXPECT_EQ_INT(kTableMaxSize, 2244);
  // Header fields land at their documented offsets (docs/table-format.md).
  FW_EXPECT(std::memcmp(g_buf, "IFCT", 4) == 0);
  FW_EXPECT_EQ_INT(load_le16(g_buf + 4), 1);
  FW_EXPECT_EQ_INT(load_le16(g_buf + 6), 64);
  FW_EXPECT_EQ_INT(load_le32(g_buf + 8), 2244);
  FW_EXPECT_EQ_INT(load_le64(g_buf + 16), 0x1234567890ull);
  FW_EXPECT_EQ_INT(load_le32(g_buf + 24), 7);
  FW_EXPECT_EQ_INT(load_le64s(g_buf + 32), 1790000000);
  FW_EXPECT(g_buf[50] == 16 && g_buf[48] == 16 && g_buf[49] == 16);
  FW_EXPECT_EQ_INT(load_le32(g_buf + 52), 132);
  FW_EXPECT(load_lef32(g_buf + 64) == g_src.breakpoints_degC[0]);
  FW_EXPECT(load_lef32(g_buf + 64 + 16 * 4) == g_src.coeffs[0].accel.C[0]);
  FW_EXPECT(load_lef32(g_buf + 64 + 16 * 4 + 132 + 9 * 4) == g_src.coeffs[1].accel.b[0]);
}

// Serialises g_src into g_mut, applies `mutate` to the bytes, optionally re-seals the CRC, parses.
template <typename F>
static int parse_mutated(F mutate, bool fix_crc, std::size_t* len_io = nullptr) {
  int len = table_serialize(&g_src, g_mut, sizeof g_mut);
  if (len < 0) return len;
  std::size_t n = static_cast<std::size_t>(len);
  mutate(g_mut, &n);
  if (fix_crc && n >= 4) store_le32(g_mut + n - 4, crc32(g_mut, n - 4));
  if (len_io) *len_io = n;
  std::memset(&g_dst, 0x5A, sizeof g_dst);  // garbage: the parser must clear it
  const int rc = table_parse(g_mut, n, &g_dst);
  if (rc != kTableOk) {
    FW_EXPECT(!table_is_valid(&g_dst));
    FW_EXPECT_EQ_INT(g_dst.n_breakpoints, 0);
  }
  return rc;
}

static void set_f32(std::uint8_t* b, std::size_t off, float v) { store_lef32(b + off, v); }
static float nan_f() {
  std::uint8_t b[4];
  store_le32(b, 0x7FC00000u);
  return load_lef32(b);
}
static float inf_f() {
  std::uint8_t b[4];
  store_le32(b, 0x7F800000u);
  return load_lef32(b);
}

static void test_every_error_code() {
  fwtest::Rng rng(5);
  fwtest::make_random_table(&g_src, rng, 4, 8.0f, 500.0f);
  const std::size_t bp0 = 64, rec0 = 64 + 4 * 4;  // 4 breakpoints
  auto none = [](std::uint8_t*, std::size_t*) {};
  FW_EXPECT_EQ_INT(parse_mutated(none, false), kTableOk);
  FW_EXPECT_EQ_INT(table_parse(nullptr, 10, &g_dst), kTableNullArgument);
  FW_EXPECT_EQ_INT(table_parse(g_buf, 10, nullptr), kTableNullArgument);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t*, std::size_t* n) { *n = 67; }, false), kTableTooShort);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[0] = 'X'; }, true), kTableBadMagic);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { store_le16(b + 4, 2); }, true),
                   kTableUnsupportedVersion);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { store_le16(b + 6, 60); }, true),
                   kTableBadHeaderLength);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t*, std::size_t* n) { *n -= 1; }, false), kTableLengthMismatch);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[100] ^= 1; }, false), kTableCrcMismatch);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t* n) { b[*n - 1] ^= 0x80; }, false),
                   kTableCrcMismatch);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[30] = 1; }, true), kTableReservedNonZero);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[51] = 1; }, true), kTableReservedNonZero);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[63] = 1; }, true), kTableReservedNonZero);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[50] = 0; }, true), kTableZeroBreakpoints);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[50] = 17; }, true),
                   kTableTooManyBreakpoints);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { store_le32(b + 52, 128); }, true),
                   kTableBadRecordLength);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[50] = 3; }, true), kTableSizeMismatch);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { set_f32(b, 40, 0.0f); }, true), kTableBadLsb);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { set_f32(b, 44, -1e-3f); }, true),
                   kTableBadLsb);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { set_f32(b, 44, inf_f()); }, true),
                   kTableBadLsb);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[48] = 7; }, true), kTableBadRawBits);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[49] = 25; }, true), kTableBadRawBits);
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[12] |= 0x40; }, true),
                   kTableUnknownModelFlags);
  FW_EXPECT_EQ_INT(parse_mutated([=](std::uint8_t* b, std::size_t*) { set_f32(b, bp0 + 8, nan_f()); }, true),
                   kTableBreakpointNotFinite);
  FW_EXPECT_EQ_INT(parse_mutated([=](std::uint8_t* b, std::size_t*) { set_f32(b, bp0 + 12, 300.0f); }, true),
                   kTableBreakpointOutOfRange);
  FW_EXPECT_EQ_INT(parse_mutated([=](std::uint8_t* b, std::size_t*) { set_f32(b, bp0, -101.0f); }, true),
                   kTableBreakpointOutOfRange);
  FW_EXPECT_EQ_INT(parse_mutated(
                       [=](std::uint8_t* b, std::size_t*) { set_f32(b, bp0 + 8, load_lef32(b + bp0 + 4)); }, true),
                   kTableBreakpointsNotIncreasing);
  FW_EXPECT_EQ_INT(parse_mutated(
                       [=](std::uint8_t* b, std::size_t*) { set_f32(b, bp0 + 4, load_lef32(b + bp0) - 1.0f); },
                       true),
                   kTableBreakpointsNotIncreasing);
  FW_EXPECT_EQ_INT(parse_mutated([=](std::uint8_t* b, std::size_t*) { set_f32(b, rec0 + 132 + 20, nan_f()); },
                                 true),
                   kTableCoefficientNotFinite);
  FW_EXPECT_EQ_INT(parse_mutated([=](std::uint8_t* b, std::size_t*) { set_f32(b, rec0 + 128, inf_f()); }, true),
                   kTableCoefficientNotFinite);
  FW_EXPECT_EQ_INT(parse_mutated([=](std::uint8_t* b, std::size_t*) { set_f32(b, rec0 + 4, 5.0f); }, true),
                   kTableCoefficientOutOfRange);
  FW_EXPECT_EQ_INT(parse_mutated([=](std::uint8_t* b, std::size_t*) { set_f32(b, rec0 + 100, 1.5f); }, true),
                   kTableCoefficientOutOfRange);  // G
  FW_EXPECT_EQ_INT(parse_mutated([=](std::uint8_t* b, std::size_t*) { set_f32(b, rec0 + 36, 1e3f); }, true),
                   kTableCoefficientOutOfRange);  // accel bias beyond full scale
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[12] &= static_cast<std::uint8_t>(~0x10); },
                                 true),
                   kTableFlagsMismatch);  // G flagged absent but present
  FW_EXPECT_EQ_INT(parse_mutated([](std::uint8_t* b, std::size_t*) { b[12] &= static_cast<std::uint8_t>(~0x20); },
                                 true),
                   kTableFlagsMismatch);  // 4 breakpoints without the temperature flag

  // The writer refuses what the parser would refuse.
  Table bad = g_src;
  bad.breakpoints_degC[2] = bad.breakpoints_degC[1];
  FW_EXPECT_EQ_INT(table_serialize(&bad, g_buf, sizeof g_buf), kTableBreakpointsNotIncreasing);
  FW_EXPECT(!table_is_valid(&bad));
  FW_EXPECT_EQ_INT(table_serialize(&g_src, g_buf, 100), kTableBufferTooSmall);
  bad = g_src;
  bad.n_breakpoints = 17;
  FW_EXPECT_EQ_INT(table_validate(&bad), kTableTooManyBreakpoints);
  // Every code has a distinct name.
  for (int a = -100; a >= -122; --a)
    for (int b = a - 1; b >= -122; --b) FW_EXPECT(std::strcmp(table_strerror(a), table_strerror(b)) != 0);
}

static void test_identity_table() {
  Table t;
  table_init_identity(&t, 1e-3f, 1e-4f, 16, 16);
  FW_EXPECT(!table_is_valid(&t));
  FW_EXPECT_EQ_INT(table_validate(&t), kTableOk);
  FW_EXPECT(table_is_valid(&t));
  t.coeffs[0].gyro.b[1] = 0.01f;  // bias without its flag
  FW_EXPECT_EQ_INT(table_validate(&t), kTableFlagsMismatch);
  t.model_flags = kModelGyroBias;
  FW_EXPECT_EQ_INT(table_validate(&t), kTableOk);
}

int main() {
  FW_RUN(test_round_trip);
  FW_RUN(test_every_error_code);
  FW_RUN(test_identity_table);
  return fwtest::summary("fw_table");
}
