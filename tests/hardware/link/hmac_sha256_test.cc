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

TEST(HmacSha256Test, TwoPartMessageEqualsTheJoinedMessage) {
  const std::vector<uint8_t> key = Bytes("key");
  const std::vector<uint8_t> a = Bytes("first part, "), b = Repeat(0x42, 300);
  std::vector<uint8_t> joined = a;
  joined.insert(joined.end(), b.begin(), b.end());
  EXPECT_EQ(HmacSha256(key.data(), key.size(), a.data(), a.size(), b.data(), b.size()),
            HmacSha256(key.data(), key.size(), joined.data(), joined.size()));
}

TEST(HkdfSha256Test, Rfc5869TestCase1) {
  std::vector<uint8_t> salt, info;
  for (uint8_t i = 0; i <= 0x0c; ++i) salt.push_back(i);
  for (uint8_t i = 0xf0; i <= 0xf9; ++i) info.push_back(i);
  const std::vector<uint8_t> ikm = Repeat(0x0b, 22);
  std::vector<uint8_t> okm(42);
  ASSERT_TRUE(HkdfSha256(salt.data(), salt.size(), ikm.data(), ikm.size(), info.data(), info.size(),
                         okm.data(), okm.size()));
  EXPECT_EQ(ToHex(okm.data(), okm.size()),
            "3cb25f25faacd57a90434f64d0362f2a2d2d0a90cf1a5a4c5db02d56ecc4c5bf34007208d5b887185865");
}

LinkNonce Nonce(uint8_t first) {
  LinkNonce n{};
  for (size_t i = 0; i < n.size(); ++i) n[i] = static_cast<uint8_t>(first + i);
  return n;
}

TEST(LinkCryptoTest, AuthMacAndSessionKeyMatchAnIndependentReference) {
  // Python: hmac.new(b"secret", b"sweepscan-link-v2" + bytes(range(32)) + bytes(range(32, 64)),
  // sha256); the session key with an HKDF written from RFC 5869.
  const Sha256Digest mac = LinkAuthMac(Bytes("secret"), Nonce(0), Nonce(32));
  EXPECT_EQ(Hex(mac), "287cfae0a3c01409ad7108cdd2b61cbf260807916943bb0132c870ea51709f14");
  const LinkSessionKey key = LinkDeriveSessionKey(Bytes("secret"), Nonce(0), Nonce(32));
  EXPECT_EQ(ToHex(key.data(), key.size()),
            "84095b1cae8c83922340e811d9e6d42240909d56dfb2a6b80819b5c546a1ee8b");
}

TEST(LinkCryptoTest, SignedFramesVerifyAndAnyChangeBreaksTheTag) {
  const LinkSessionKey key = LinkDeriveSessionKey(Bytes("secret"), Nonce(0), Nonce(32));
  LinkEncoder encoder(LinkSender::kClient, 7);
  encoder.SetSigner(MakeLinkFrameSigner(key));
  const std::vector<uint8_t> frame = encoder.Encode(Time(), DriveCommand{0.5, -0.25});
  ASSERT_EQ(frame.size(), kLinkFrameOverhead + 16 + kLinkTagSize);
  LinkMessage m;
  ASSERT_TRUE(ParseLinkFrame(frame.data(), frame.size(), &m).ok());
  EXPECT_TRUE(m.header.signed_frame);
  // ParseLinkFrame does not keep the signed bytes; the streaming decoder does.
  LinkDecoder decoder;
  auto messages = decoder.Feed(frame);
  ASSERT_EQ(messages.size(), 1u);
  EXPECT_TRUE(LinkFrameTagValid(key, messages[0]));
  LinkSessionKey other = key;
  other[31] ^= 1;
  EXPECT_FALSE(LinkFrameTagValid(other, messages[0]));
  // A changed payload with recomputed CRCs (an attacker without the key).
  LinkMessage changed = messages[0];
  changed.signed_bytes[kLinkSignedHeaderSize] ^= 1;
  EXPECT_FALSE(LinkFrameTagValid(key, changed));
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
