// The robot link's cryptography, from OpenSSL's libcrypto (Debian
// libssl-dev), never written by hand: SHA-256, HMAC-SHA256 (RFC 2104),
// HKDF-SHA256 (RFC 5869), constant-time comparison (CRYPTO_memcmp) and the
// operating system's CSPRNG (RAND_bytes). On top of them, the link's own
// constructions (docs/protocol.md, "Connection, authentication" and
// "Frame authentication"):
//   AuthResponse mac = HMAC-SHA256(key, "sweepscan-link-v2" || agent_nonce || client_nonce)
//   session key      = HKDF-SHA256(ikm = key, salt = agent_nonce || client_nonce,
//                                  info = "sweepscan-link-v2 session", 32 bytes)
//   frame tag        = first 16 bytes of HMAC-SHA256(session key, header bytes 0..23 || payload)
// The RFC 4231 and RFC 5869 vectors test this wrapper
// (tests/hardware/link/hmac_sha256_test.cc).
//
// Sha256 is used from one thread at a time; the free functions are
// thread-safe.
#ifndef SWEEPSCAN_HARDWARE_LINK_HMAC_SHA256_H_
#define SWEEPSCAN_HARDWARE_LINK_HMAC_SHA256_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hardware/link/link_protocol.h"

namespace sweepscan {
namespace hardware {

inline constexpr size_t kSha256DigestSize = 32;
inline constexpr size_t kSha256BlockSize = 64;
using Sha256Digest = std::array<uint8_t, kSha256DigestSize>;

// Incremental SHA-256 (OpenSSL EVP): Update() any number of times, then Final() once.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void Reset();
  void Update(const uint8_t* data, size_t n);
  void Update(const std::string& s) {
    Update(reinterpret_cast<const uint8_t*>(s.data()), s.size());
  }
  // Returns the digest and leaves the object reset.
  Sha256Digest Final();

 private:
  struct Context;
  std::unique_ptr<Context> context_;
};

Sha256Digest Sha256Hash(const uint8_t* data, size_t n);

// HMAC-SHA256(key, message || message2) (message2 optional).
Sha256Digest HmacSha256(const uint8_t* key, size_t key_size, const uint8_t* message,
                        size_t message_size, const uint8_t* message2 = nullptr,
                        size_t message2_size = 0);

// HKDF-SHA256 (RFC 5869, extract then expand) into out[0..out_size).
// False if OpenSSL refused (out_size > 255 * 32).
bool HkdfSha256(const uint8_t* salt, size_t salt_size, const uint8_t* ikm, size_t ikm_size,
                const uint8_t* info, size_t info_size, uint8_t* out, size_t out_size);

// The AuthResponse MAC: HMAC-SHA256(key, "sweepscan-link-v2" || agent_nonce || client_nonce).
Sha256Digest LinkAuthMac(const std::vector<uint8_t>& key, const LinkNonce& agent_nonce,
                         const LinkNonce& client_nonce);
// The per-connection session key both ends derive after the handshake.
using LinkSessionKey = std::array<uint8_t, 32>;
LinkSessionKey LinkDeriveSessionKey(const std::vector<uint8_t>& key, const LinkNonce& agent_nonce,
                                    const LinkNonce& client_nonce);
// The tag of one frame: HMAC-SHA256(session key, header bytes 0..23 || payload), first 16 bytes.
LinkTag LinkFrameTag(const LinkSessionKey& session_key, const uint8_t* header24,
                     const uint8_t* payload, size_t payload_size);
// A LinkFrameSigner (link_protocol.h) for LinkEncoder::SetSigner.
LinkFrameSigner MakeLinkFrameSigner(const LinkSessionKey& session_key);
// True when the signed frame `message` (LinkMessage::signed_bytes, tag) carries
// a valid tag under `session_key` (constant-time comparison).
bool LinkFrameTagValid(const LinkSessionKey& session_key, const LinkMessage& message);

// The client's side of the handshake: a fresh client nonce, the response to
// `challenge` and the session key that goes with it. False if there is no
// random source.
bool MakeLinkAuthResponse(const std::vector<uint8_t>& key, const AuthChallenge& challenge,
                          AuthResponse* response, LinkSessionKey* session_key);

// Compares two byte strings in time that depends only on n (CRYPTO_memcmp).
bool ConstantTimeEqual(const uint8_t* a, const uint8_t* b, size_t n);

// Fills *out from the operating system's CSPRNG (RAND_bytes). False if it
// failed; the caller must then refuse to authenticate rather than use a weak nonce.
bool FillRandomBytes(uint8_t* out, size_t n);

// Lower-case hex of bytes ("9f86d0..."), for tests and logs.
std::string ToHex(const uint8_t* data, size_t n);

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_LINK_HMAC_SHA256_H_
