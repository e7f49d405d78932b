// CRC-32 (IEEE 802.3 / zlib / PNG): reflected, polynomial 0xEDB88320, init 0xFFFFFFFF, final XOR
// 0xFFFFFFFF. Check value: crc32("123456789") == 0xCBF43926.
//
// Used by the coefficient table v1 (firmware/table/) and by the CAN node. No heap, no state beyond the
// running value, safe to call from any context. Table-driven with a 16-entry nibble table (64 bytes of
// flash) so it fits small parts; cost: O(n), two table lookups per byte.
#pragma once
#include <cstddef>
#include <cstdint>

namespace imuforge::fw {

// One-shot CRC over `len` bytes. `data` may be null only if len == 0.
std::uint32_t crc32(const void* data, std::size_t len) noexcept;

// Incremental form: start with crc32_init(), feed chunks with crc32_update(), finish with crc32_final().
//   std::uint32_t c = crc32_init(); c = crc32_update(c, a, na); c = crc32_update(c, b, nb);
//   std::uint32_t crc = crc32_final(c);   // == crc32(a ++ b)
constexpr std::uint32_t crc32_init() noexcept { return 0xFFFFFFFFu; }
std::uint32_t crc32_update(std::uint32_t state, const void* data, std::size_t len) noexcept;
constexpr std::uint32_t crc32_final(std::uint32_t state) noexcept { return state ^ 0xFFFFFFFFu; }

}  // namespace imuforge::fw
