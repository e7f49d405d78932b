// libFuzzer: coefficient table v1 parser. Pass = no crash, no sanitizer report, and every accepted
// table really is valid: CRC matches, counts in range, and it re-serialises to the same bytes.
#include <cstdlib>
#include <cstring>

#include "firmware/common/crc32.h"
#include "firmware/common/endian.h"
#include "firmware/table/table.h"

using namespace imuforge::fw;

static Table g_t;
static std::uint8_t g_out[kTableMaxSize + 16];

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const int rc = table_parse(data, size, &g_t);
  if (rc != 0) {
    if (table_is_valid(&g_t)) std::abort();  // a rejected table must not look valid
    return 0;
  }
  if (!table_is_valid(&g_t)) std::abort();
  if (size < kTableHeaderLen + kTableCrcLen || size > kTableMaxSize) std::abort();
  if (crc32(data, size - 4) != load_le32(data + size - 4)) std::abort();
  if (g_t.n_breakpoints < 1 || g_t.n_breakpoints > kTableMaxBreakpoints) std::abort();
  for (unsigned i = 1; i < g_t.n_breakpoints; ++i) {
    if (!(g_t.breakpoints_degC[i] > g_t.breakpoints_degC[i - 1])) std::abort();
  }
  const int n = table_serialize(&g_t, g_out, sizeof g_out);
  if (n != static_cast<int>(size) || std::memcmp(g_out, data, size) != 0) std::abort();
  return 0;
}
