// SHA-256 (FIPS 180-4) and HMAC-SHA256 (RFC 2104), for the robot link's
// challenge-response authentication (docs/protocol.md, "Connection,
// authentication"). Implemented here so the robot agent needs no crypto
// library on the robot computer; checked against the FIPS 180 examples and
// the RFC 4231 test cases (tests/hardware/link/hmac_sha256_test.cc).
//
// Pure C++17. Sha256 is used from one thread at a time; the free functions
// are pure and thread-safe.
#ifndef SWEEPSCAN_HARDWARE_LINK_HMAC_SHA256_H_
#define SWEEPSCAN_HARDWARE_LINK_HMAC_SHA256_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace sweepscan {
namespace hardware {

inline constexpr size_t kSha256DigestSize = 32;
inline constexpr size_t kSha256BlockSize = 64;
using Sha256Digest = std::array<uint8_t, kSha256DigestSize>;

// Incremental SHA-256: Update() any number of times, then Final() once.
class Sha256 {
 public:
  Sha256() { Reset(); }
  void Reset();
  void Update(const uint8_t* data, size_t n);
  void Update(const std::string& s) {
    Update(reinterpret_cast<const uint8_t*>(s.data()), s.size());
  }
  // Pads, returns the digest and leaves the object reset.
  Sha256Digest Final();

 private:
  void Compress(const uint8_t* block);

  std::array<uint32_t, 8> state_{};
  std::array<uint8_t, kSha256BlockSize> block_{};
  size_t block_used_ = 0;
  uint64_t total_bytes_ = 0;
};

Sha256Digest Sha256Hash(const uint8_t* data, size_t n);

// HMAC-SHA256(key, message); keys longer than the block size are hashed first
// (RFC 2104). `message` may be given in two parts (prefix || rest) so the link
// handshake needs no concatenation.
Sha256Digest HmacSha256(const uint8_t* key, size_t key_size, const uint8_t* message,
                        size_t message_size, const uint8_t* message2 = nullptr,
                        size_t message2_size = 0);

// The robot link's AuthResponse MAC: HMAC-SHA256(key, "sweepscan-link-v1" || nonce).
Sha256Digest LinkAuthMac(const std::vector<uint8_t>& key, const uint8_t* nonce, size_t nonce_size);

// Compares two byte strings in time that depends only on n, never on where
// they differ, so a remote client cannot find a valid MAC byte by byte.
bool ConstantTimeEqual(const uint8_t* a, const uint8_t* b, size_t n);

// Fills *out with bytes from the operating system's CSPRNG (/dev/urandom,
// std::random_device as a fallback). Returns false if neither worked; the
// caller must then refuse to authenticate rather than use a weak nonce.
bool FillRandomBytes(uint8_t* out, size_t n);

// Lower-case hex of bytes ("9f86d0..."), for tests and logs.
std::string ToHex(const uint8_t* data, size_t n);

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_LINK_HMAC_SHA256_H_
