// CRC-32 (IEEE, reflected) and little-endian helpers: known answers and consistency.
#include <cstring>
#include <initializer_list>

#include "firmware/common/crc32.h"
#include "firmware/common/endian.h"
#include "firmware/common/error.h"
#include "tests/firmware/fwtest.h"

using namespace imuforge::fw;

// Bit-at-a-time reference (the textbook definition), to cross-check the nibble table.
static std::uint32_t crc32_bitwise(const std::uint8_t* p, std::size_t n) {
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (c >> 1) ^ 0xEDB88320u : c >> 1;
  }
  return ~c;
}

static void test_known_answers() {
  FW_EXPECT_EQ_INT(crc32("123456789", 9), 0xCBF43926u);
  FW_EXPECT_EQ_INT(crc32(nullptr, 0), 0u);
  FW_EXPECT_EQ_INT(crc32("a", 1), 0xE8B7BE43u);
  const char* fox = "The quick brown fox jumps over the lazy dog";
  FW_EXPECT_EQ_INT(crc32(fox, std::strlen(fox)), 0x414FA339u);
}

static void test_matches_bitwise_and_incremental() {
  fwtest::Rng rng(7);
  static std::uint8_t buf[777];
  for (auto& b : buf) b = static_cast<std::uint8_t>(rng.next());
  for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{3}, std::size_t{64}, sizeof buf}) {
    FW_EXPECT_EQ_INT(crc32(buf, n), crc32_bitwise(buf, n));
    for (std::size_t cut = 0; cut <= n; cut += (n / 5) + 1) {
      std::uint32_t c = crc32_init();
      c = crc32_update(c, buf, cut);
      c = crc32_update(c, buf + cut, n - cut);
      FW_EXPECT_EQ_INT(crc32_final(c), crc32(buf, n));
    }
  }
  // A single flipped bit changes the CRC.
  const std::uint32_t ref = crc32(buf, sizeof buf);
  buf[100] ^= 0x10;
  FW_EXPECT(crc32(buf, sizeof buf) != ref);
}

static void test_endian() {
  std::uint8_t b[8];
  store_le32(b, 0x11223344u);
  FW_EXPECT(b[0] == 0x44 && b[1] == 0x33 && b[2] == 0x22 && b[3] == 0x11);
  FW_EXPECT_EQ_INT(load_le32(b), 0x11223344u);
  store_le16(b, 0xBEEFu);
  FW_EXPECT(b[0] == 0xEF && b[1] == 0xBE);
  store_le64s(b, -2);
  FW_EXPECT(b[0] == 0xFE && b[7] == 0xFF);
  FW_EXPECT_EQ_INT(load_le64s(b), -2);
  store_lef32(b, 1.0f);  // 0x3F800000
  FW_EXPECT(b[0] == 0 && b[1] == 0 && b[2] == 0x80 && b[3] == 0x3F);
  FW_EXPECT(load_lef32(b) == 1.0f);
  FW_EXPECT_EQ_INT(load_le16s(b + 2), 0x3F80);
  FW_EXPECT(std::strcmp(fw_strerror(kErrTimeout), "timeout") == 0);
}

int main() {
  FW_RUN(test_known_answers);
  FW_RUN(test_matches_bitwise_and_incremental);
  FW_RUN(test_endian);
  return fwtest::summary("fw_crc32");
}
