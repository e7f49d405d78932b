// Little-endian load/store helpers. Every on-wire and in-flash format of imuforge is little endian and
// is (de)serialised byte by byte through these helpers, never by memcpy of a struct, so the result is
// the same on any host (endianness, padding, alignment). All functions are O(1), constexpr-friendly
// where the language allows, and never touch more than the stated number of bytes.
#pragma once
#include <cstdint>
#include <cstring>

namespace imuforge::fw {

inline std::uint16_t load_le16(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
inline std::uint32_t load_le32(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}
inline std::uint64_t load_le64(const std::uint8_t* p) noexcept {
  return static_cast<std::uint64_t>(load_le32(p)) | (static_cast<std::uint64_t>(load_le32(p + 4)) << 32);
}
inline std::int16_t load_le16s(const std::uint8_t* p) noexcept { return static_cast<std::int16_t>(load_le16(p)); }
inline std::int32_t load_le32s(const std::uint8_t* p) noexcept { return static_cast<std::int32_t>(load_le32(p)); }
inline std::int64_t load_le64s(const std::uint8_t* p) noexcept { return static_cast<std::int64_t>(load_le64(p)); }
// IEEE 754 binary32, stored as its bit pattern in little-endian order.
inline float load_lef32(const std::uint8_t* p) noexcept {
  const std::uint32_t bits = load_le32(p);
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

inline void store_le16(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
inline void store_le32(std::uint8_t* p, std::uint32_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
  p[2] = static_cast<std::uint8_t>(v >> 16);
  p[3] = static_cast<std::uint8_t>(v >> 24);
}
inline void store_le64(std::uint8_t* p, std::uint64_t v) noexcept {
  store_le32(p, static_cast<std::uint32_t>(v));
  store_le32(p + 4, static_cast<std::uint32_t>(v >> 32));
}
inline void store_le16s(std::uint8_t* p, std::int16_t v) noexcept { store_le16(p, static_cast<std::uint16_t>(v)); }
inline void store_le32s(std::uint8_t* p, std::int32_t v) noexcept { store_le32(p, static_cast<std::uint32_t>(v)); }
inline void store_le64s(std::uint8_t* p, std::int64_t v) noexcept { store_le64(p, static_cast<std::uint64_t>(v)); }
inline void store_lef32(std::uint8_t* p, float f) noexcept {
  std::uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  store_le32(p, bits);
}

}  // namespace imuforge::fw
