#include "firmware/common/crc32.h"

namespace imuforge::fw {

namespace {
// Nibble table for the reflected polynomial 0xEDB88320: kNibble[i] = CRC of the 4-bit value i.
constexpr std::uint32_t kNibble[16] = {
    0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u, 0x4DB26158u, 0x5005713Cu,
    0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu, 0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu,
};
}  // namespace

std::uint32_t crc32_update(std::uint32_t state, const void* data, std::size_t len) noexcept {
  const auto* p = static_cast<const std::uint8_t*>(data);
  std::uint32_t c = state;
  for (std::size_t i = 0; i < len; ++i) {
    c ^= p[i];
    c = (c >> 4) ^ kNibble[c & 0x0Fu];
    c = (c >> 4) ^ kNibble[c & 0x0Fu];
  }
  return c;
}

std::uint32_t crc32(const void* data, std::size_t len) noexcept {
  return crc32_final(crc32_update(crc32_init(), data, len));
}

}  // namespace imuforge::fw
