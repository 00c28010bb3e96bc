// SHA-256 against the FIPS 180-4 examples (and the long-message vector of
// the NIST CAVP / FIPS 180-2 appendix), HMAC-SHA256 against RFC 4231.
#include "hardware/link/hmac_sha256.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace sweepscan {
namespace hardware {
namespace {

std::vector<uint8_t> Bytes(const std::string& s) {
  return std::vector<uint8_t>(s.begin(), s.end());
}
std::vector<uint8_t> Repeat(uint8_t b, size_t n) { return std::vector<uint8_t>(n, b); }
std::string Hex(const Sha256Digest& d) { return ToHex(d.data(), d.size()); }
std::string ShaHex(const std::vector<uint8_t>& m) { return Hex(Sha256Hash(m.data(), m.size())); }
std::string HmacHex(const std::vector<uint8_t>& key, const std::vector<uint8_t>& m) {
  return Hex(HmacSha256(key.data(), key.size(), m.data(), m.size()));
}

TEST(Sha256Test, Fips180Examples) {
  EXPECT_EQ(ShaHex(Bytes("abc")),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(ShaHex(Bytes("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq")),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(ShaHex({}), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(ShaHex(Repeat('a', 1000000)),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Sha256Test, AnyChunkingGivesTheSameDigest) {
  std::vector<uint8_t> message;
  for (int i = 0; i < 300; ++i) message.push_back(static_cast<uint8_t>(i * 7 + 3));
  const Sha256Digest whole = Sha256Hash(message.data(), message.size());
  for (size_t split = 0; split <= message.size(); ++split) {
    Sha256 sha;
    sha.Update(message.data(), split);
    sha.Update(message.data() + split, message.size() - split);
    ASSERT_EQ(sha.Final(), whole) << "split at " << split;
  }
  // Lengths around the padding boundary (55, 56, 63, 64 bytes).
  for (size_t n : {55u, 56u, 63u, 64u, 65u, 119u, 120u}) {
    Sha256 sha;
    for (size_t i = 0; i < n; ++i) sha.Update(message.data() + i, 1);
    EXPECT_EQ(sha.Final(), Sha256Hash(message.data(), n)) << n;
  }
}

TEST(HmacSha256Test, Rfc4231TestCases) {
  EXPECT_EQ(HmacHex(Repeat(0x0b, 20), Bytes("Hi There")),
            "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7");
  EXPECT_EQ(HmacHex(Bytes("Jefe"), Bytes("what do ya want for nothing?")),
            "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
  EXPECT_EQ(HmacHex(Repeat(0xaa, 20), Repeat(0xdd, 50)),
            "773ea91e36800e46854db8ebd09181a72959098b3ef8c122d9635514ced565fe");
  std::vector<uint8_t> key4;
  for (uint8_t b = 1; b <= 25; ++b) key4.push_back(b);
  EXPECT_EQ(HmacHex(key4, Repeat(0xcd, 50)),
            "82558a389a443c0ea4cc819899f2083a85f0faa3e578f8077a2e3ff46729665b");
  // Test case 5 specifies only the first 128 bits.
  EXPECT_EQ(HmacHex(Repeat(0x0c, 20), Bytes("Test With Truncation")).substr(0, 32),
            "a3b6167473100ee06e0c796c2955552b");
  EXPECT_EQ(
      HmacHex(Repeat(0xaa, 131), Bytes("Test Using Larger Than Block-Size Key - Hash Key First")),
      "60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54");
  EXPECT_EQ(HmacHex(Repeat(0xaa, 131),
                    Bytes("This is a test using a larger than block-size key and a larger than "
                          "block-size data. The key needs to be hashed before being used by the "
                          "HMAC algorithm.")),
            "9b09ffa71b942fcb27635fbcd5b0e944bfdc63644f0713938a7f51535c3a35e2");
}

TEST(HmacSha256Test, LinkAuthMacIsHmacOfContextAndNonce) {
  std::vector<uint8_t> nonce;
  for (uint8_t i = 0; i < 32; ++i) nonce.push_back(i);
  const Sha256Digest mac = LinkAuthMac(Bytes("secret"), nonce.data(), nonce.size());
  // Independent reference: Python hmac.new(b"secret", b"sweepscan-link-v1" + bytes(range(32)),
  // sha256).
  EXPECT_EQ(Hex(mac), "28f38d5f211907eaae55dfda88f84116f747c1f7f395415502d85444fb54226d");
  std::vector<uint8_t> joined = Bytes("sweepscan-link-v1");
  joined.insert(joined.end(), nonce.begin(), nonce.end());
  EXPECT_EQ(Hex(mac), HmacHex(Bytes("secret"), joined));
}

TEST(HmacSha256Test, ConstantTimeEqual) {
  const std::vector<uint8_t> a = Repeat(7, 32);
  std::vector<uint8_t> b = a;
  EXPECT_TRUE(ConstantTimeEqual(a.data(), b.data(), 32));
  for (size_t i = 0; i < 32; ++i) {
    b = a;
    b[i] ^= 0x80;
    EXPECT_FALSE(ConstantTimeEqual(a.data(), b.data(), 32)) << i;
  }
  EXPECT_TRUE(ConstantTimeEqual(a.data(), b.data(), 0));
}

TEST(HmacSha256Test, RandomBytesDiffer) {
  std::array<uint8_t, 32> x{}, y{};
  ASSERT_TRUE(FillRandomBytes(x.data(), x.size()));
  ASSERT_TRUE(FillRandomBytes(y.data(), y.size()));
  EXPECT_NE(x, y);  // 2^-256 chance of a false failure.
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan
