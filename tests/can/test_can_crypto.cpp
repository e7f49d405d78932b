// SHA-256 against FIPS 180-4 example vectors and HMAC-SHA256 against RFC 4231 test cases.
#include <cstring>

#include "firmware/crypto/sha256.h"
#include "tests/can/fwcheck.h"

using namespace imuforge::fw;

namespace {

int hexval(char c) { return c <= '9' ? c - '0' : (c | 0x20) - 'a' + 10; }
bool digest_is(const std::uint8_t* d, const char* hex) {
  for (std::size_t i = 0; i < 32; ++i) {
    if (d[i] != static_cast<std::uint8_t>(hexval(hex[2 * i]) << 4 | hexval(hex[2 * i + 1]))) return false;
  }
  return true;
}

void sha_vectors() {
  std::uint8_t d[32];
  sha256("abc", 3, d);
  CHECK(digest_is(d, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"));
  sha256("", 0, d);
  CHECK(digest_is(d, "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"));
  const char* m448 = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
  sha256(m448, std::strlen(m448), d);
  CHECK(digest_is(d, "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1"));
  const char* m896 =
      "abcdefghbcdefghicdefghijdefghijkefghijklfghijklmghijklmnhijklmnoijklmnopjklmnopqklmnopqrlmnopqrsmnopqrstnopqrstu";
  sha256(m896, std::strlen(m896), d);
  CHECK(digest_is(d, "cf5b16a778af8380036ce59e7b0492370b249b11e8f07a51afac45037afee9d1"));
  // One million 'a', fed in odd-sized chunks to exercise the block buffer.
  Sha256 s;
  sha256_init(s);
  std::uint8_t a[997];
  std::memset(a, 'a', sizeof a);
  std::size_t left = 1000000;
  while (left > 0) {
    const std::size_t n = left < sizeof a ? left : sizeof a;
    sha256_update(s, a, n);
    left -= n;
  }
  sha256_final(s, d);
  CHECK(digest_is(d, "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0"));
}

void hmac_case(const std::uint8_t* key, std::size_t kl, const void* msg, std::size_t ml, const char* hex) {
  HmacSha256 m;
  hmac_sha256_init(m, key, kl);
  hmac_sha256_update(m, msg, ml);
  std::uint8_t d[32];
  hmac_sha256_final(m, d);
  CHECK(digest_is(d, hex));
}

void hmac_vectors() {
  std::uint8_t k[131];
  std::memset(k, 0x0b, 20);
  hmac_case(k, 20, "Hi There", 8, "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7");
  hmac_case(reinterpret_cast<const std::uint8_t*>("Jefe"), 4, "what do ya want for nothing?", 28,
            "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
  std::uint8_t dd[50];
  std::memset(k, 0xaa, 20);
  std::memset(dd, 0xdd, sizeof dd);
  hmac_case(k, 20, dd, 50, "773ea91e36800e46854db8ebd09181a72959098b3ef8c122d9635514ced565fe");
  std::uint8_t k4[25];
  for (int i = 0; i < 25; ++i) k4[i] = static_cast<std::uint8_t>(i + 1);
  std::uint8_t cd[50];
  std::memset(cd, 0xcd, sizeof cd);
  hmac_case(k4, 25, cd, 50, "82558a389a443c0ea4cc819899f2083a85f0faa3e578f8077a2e3ff46729665b");
  std::memset(k, 0xaa, 131);
  const char* m6 = "Test Using Larger Than Block-Size Key - Hash Key First";
  hmac_case(k, 131, m6, std::strlen(m6), "60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54");
  const char* m7 =
      "This is a test using a larger than block-size key and a larger than block-size data. The key needs to be "
      "hashed before being used by the HMAC algorithm.";
  hmac_case(k, 131, m7, std::strlen(m7), "9b09ffa71b942fcb27635fbcd5b0e944bfdc63644f0713938a7f51535c3a35e2");
  // A wrong key must not verify: the comparison actually compares.
  std::uint8_t d1[32], d2[32];
  HmacSha256 m;
  hmac_sha256_init(m, k, 20);
  hmac_sha256_update(m, "x", 1);
  hmac_sha256_final(m, d1);
  k[0] ^= 1u;
  hmac_sha256_init(m, k, 20);
  hmac_sha256_update(m, "x", 1);
  hmac_sha256_final(m, d2);
  CHECK(!ct_equal(d1, d2, 32));
  CHECK(ct_equal(d1, d1, 32));
}

}  // namespace

int main() {
  sha_vectors();
  hmac_vectors();
  return FW_TEST_RESULT("test_can_crypto");
}
