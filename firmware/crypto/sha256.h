// SHA-256 (FIPS 180-4) and HMAC-SHA256 (RFC 2104), no heap, no tables beyond the 64 round constants.
//
// Used by the CAN node to authorise coefficient tables (docs/can-protocol.md, "Authorisation").
// Streaming API: init, update any number of times, final. Cost: O(n), one 64-round compression per
// 64 bytes. Instance size: 104 bytes (Sha256) / 200 bytes (HmacSha256).
#pragma once
#include <cstddef>
#include <cstdint>

namespace imuforge::fw {

constexpr std::size_t kSha256DigestBytes = 32;
constexpr std::size_t kSha256BlockBytes = 64;

struct Sha256 {
  std::uint32_t h[8];
  std::uint64_t total_bytes;
  std::uint8_t block[kSha256BlockBytes];
  std::uint32_t block_len;
};

void sha256_init(Sha256& s) noexcept;
// `data` may be null only if len == 0.
void sha256_update(Sha256& s, const void* data, std::size_t len) noexcept;
// Writes 32 bytes; the instance must be re-initialised before reuse.
void sha256_final(Sha256& s, std::uint8_t out[kSha256DigestBytes]) noexcept;
void sha256(const void* data, std::size_t len, std::uint8_t out[kSha256DigestBytes]) noexcept;

struct HmacSha256 {
  Sha256 inner;
  std::uint8_t okey[kSha256BlockBytes];  // key XOR opad, kept for the outer hash
};

// Any key length is allowed (keys longer than 64 bytes are hashed first, per RFC 2104).
void hmac_sha256_init(HmacSha256& m, const std::uint8_t* key, std::size_t key_len) noexcept;
void hmac_sha256_update(HmacSha256& m, const void* data, std::size_t len) noexcept;
void hmac_sha256_final(HmacSha256& m, std::uint8_t out[kSha256DigestBytes]) noexcept;

// Constant-time comparison (no early exit), so a tag check leaks no timing about where it differs.
bool ct_equal(const std::uint8_t* a, const std::uint8_t* b, std::size_t len) noexcept;

}  // namespace imuforge::fw
