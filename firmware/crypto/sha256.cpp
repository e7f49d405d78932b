#include "firmware/crypto/sha256.h"

#include <cstring>

namespace imuforge::fw {
namespace {

constexpr std::uint32_t kK[64] = {
    0x428a2f98u, 0x71374491u, 0xb5c0fbcfu, 0xe9b5dba5u, 0x3956c25bu, 0x59f111f1u, 0x923f82a4u, 0xab1c5ed5u,
    0xd807aa98u, 0x12835b01u, 0x243185beu, 0x550c7dc3u, 0x72be5d74u, 0x80deb1feu, 0x9bdc06a7u, 0xc19bf174u,
    0xe49b69c1u, 0xefbe4786u, 0x0fc19dc6u, 0x240ca1ccu, 0x2de92c6fu, 0x4a7484aau, 0x5cb0a9dcu, 0x76f988dau,
    0x983e5152u, 0xa831c66du, 0xb00327c8u, 0xbf597fc7u, 0xc6e00bf3u, 0xd5a79147u, 0x06ca6351u, 0x14292967u,
    0x27b70a85u, 0x2e1b2138u, 0x4d2c6dfcu, 0x53380d13u, 0x650a7354u, 0x766a0abbu, 0x81c2c92eu, 0x92722c85u,
    0xa2bfe8a1u, 0xa81a664bu, 0xc24b8b70u, 0xc76c51a3u, 0xd192e819u, 0xd6990624u, 0xf40e3585u, 0x106aa070u,
    0x19a4c116u, 0x1e376c08u, 0x2748774cu, 0x34b0bcb5u, 0x391c0cb3u, 0x4ed8aa4au, 0x5b9cca4fu, 0x682e6ff3u,
    0x748f82eeu, 0x78a5636fu, 0x84c87814u, 0x8cc70208u, 0x90befffau, 0xa4506cebu, 0xbef9a3f7u, 0xc67178f2u};

inline std::uint32_t rotr(std::uint32_t x, unsigned n) noexcept { return (x >> n) | (x << (32u - n)); }

void compress(std::uint32_t h[8], const std::uint8_t* p) noexcept {
  std::uint32_t w[64];
  for (unsigned i = 0; i < 16; ++i) {
    w[i] = (static_cast<std::uint32_t>(p[4 * i]) << 24) | (static_cast<std::uint32_t>(p[4 * i + 1]) << 16) |
           (static_cast<std::uint32_t>(p[4 * i + 2]) << 8) | static_cast<std::uint32_t>(p[4 * i + 3]);
  }
  for (unsigned i = 16; i < 64; ++i) {
    const std::uint32_t s0 = rotr(w[i - 15], 7) ^ rotr(w[i - 15], 18) ^ (w[i - 15] >> 3);
    const std::uint32_t s1 = rotr(w[i - 2], 17) ^ rotr(w[i - 2], 19) ^ (w[i - 2] >> 10);
    w[i] = w[i - 16] + s0 + w[i - 7] + s1;
  }
  std::uint32_t a = h[0], b = h[1], c = h[2], d = h[3], e = h[4], f = h[5], g = h[6], hh = h[7];
  for (unsigned i = 0; i < 64; ++i) {
    const std::uint32_t S1 = rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25);
    const std::uint32_t ch = (e & f) ^ (~e & g);
    const std::uint32_t t1 = hh + S1 + ch + kK[i] + w[i];
    const std::uint32_t S0 = rotr(a, 2) ^ rotr(a, 13) ^ rotr(a, 22);
    const std::uint32_t maj = (a & b) ^ (a & c) ^ (b & c);
    const std::uint32_t t2 = S0 + maj;
    hh = g; g = f; f = e; e = d + t1; d = c; c = b; b = a; a = t1 + t2;
  }
  h[0] += a; h[1] += b; h[2] += c; h[3] += d; h[4] += e; h[5] += f; h[6] += g; h[7] += hh;
}

}  // namespace

void sha256_init(Sha256& s) noexcept {
  static constexpr std::uint32_t kH0[8] = {0x6a09e667u, 0xbb67ae85u, 0x3c6ef372u, 0xa54ff53au,
                                           0x510e527fu, 0x9b05688cu, 0x1f83d9abu, 0x5be0cd19u};
  std::memcpy(s.h, kH0, sizeof kH0);
  s.total_bytes = 0;
  s.block_len = 0;
  std::memset(s.block, 0, sizeof s.block);
}

void sha256_update(Sha256& s, const void* data, std::size_t len) noexcept {
  const auto* p = static_cast<const std::uint8_t*>(data);
  s.total_bytes += len;
  while (len > 0) {
    if (s.block_len == 0 && len >= kSha256BlockBytes) {
      compress(s.h, p);
      p += kSha256BlockBytes;
      len -= kSha256BlockBytes;
      continue;
    }
    std::size_t take = kSha256BlockBytes - s.block_len;
    if (take > len) take = len;
    std::memcpy(s.block + s.block_len, p, take);
    s.block_len += static_cast<std::uint32_t>(take);
    p += take;
    len -= take;
    if (s.block_len == kSha256BlockBytes) {
      compress(s.h, s.block);
      s.block_len = 0;
    }
  }
}

void sha256_final(Sha256& s, std::uint8_t out[kSha256DigestBytes]) noexcept {
  const std::uint64_t bits = s.total_bytes * 8u;
  s.block[s.block_len++] = 0x80u;
  if (s.block_len > 56u) {
    std::memset(s.block + s.block_len, 0, kSha256BlockBytes - s.block_len);
    compress(s.h, s.block);
    s.block_len = 0;
  }
  std::memset(s.block + s.block_len, 0, 56u - s.block_len);
  for (unsigned i = 0; i < 8; ++i) s.block[56 + i] = static_cast<std::uint8_t>(bits >> (56u - 8u * i));
  compress(s.h, s.block);
  for (unsigned i = 0; i < 8; ++i) {
    out[4 * i] = static_cast<std::uint8_t>(s.h[i] >> 24);
    out[4 * i + 1] = static_cast<std::uint8_t>(s.h[i] >> 16);
    out[4 * i + 2] = static_cast<std::uint8_t>(s.h[i] >> 8);
    out[4 * i + 3] = static_cast<std::uint8_t>(s.h[i]);
  }
}

void sha256(const void* data, std::size_t len, std::uint8_t out[kSha256DigestBytes]) noexcept {
  Sha256 s;
  sha256_init(s);
  sha256_update(s, data, len);
  sha256_final(s, out);
}

void hmac_sha256_init(HmacSha256& m, const std::uint8_t* key, std::size_t key_len) noexcept {
  std::uint8_t k[kSha256BlockBytes] = {};
  if (key_len > kSha256BlockBytes) {
    sha256(key, key_len, k);
  } else if (key_len > 0) {
    std::memcpy(k, key, key_len);
  }
  std::uint8_t ikey[kSha256BlockBytes];
  for (std::size_t i = 0; i < kSha256BlockBytes; ++i) {
    ikey[i] = static_cast<std::uint8_t>(k[i] ^ 0x36u);
    m.okey[i] = static_cast<std::uint8_t>(k[i] ^ 0x5cu);
  }
  sha256_init(m.inner);
  sha256_update(m.inner, ikey, sizeof ikey);
}

void hmac_sha256_update(HmacSha256& m, const void* data, std::size_t len) noexcept {
  sha256_update(m.inner, data, len);
}

void hmac_sha256_final(HmacSha256& m, std::uint8_t out[kSha256DigestBytes]) noexcept {
  std::uint8_t ih[kSha256DigestBytes];
  sha256_final(m.inner, ih);
  Sha256 o;
  sha256_init(o);
  sha256_update(o, m.okey, sizeof m.okey);
  sha256_update(o, ih, sizeof ih);
  sha256_final(o, out);
}

bool ct_equal(const std::uint8_t* a, const std::uint8_t* b, std::size_t len) noexcept {
  std::uint8_t diff = 0;
  for (std::size_t i = 0; i < len; ++i) diff = static_cast<std::uint8_t>(diff | (a[i] ^ b[i]));
  return diff == 0;
}

}  // namespace imuforge::fw
