#include "hardware/link/hmac_sha256.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/kdf.h>
#include <openssl/rand.h>

#include <cstring>

namespace sweepscan {
namespace hardware {

struct Sha256::Context {
  EVP_MD_CTX* ctx = nullptr;
};

Sha256::Sha256() : context_(std::make_unique<Context>()) {
  context_->ctx = EVP_MD_CTX_new();
  Reset();
}

Sha256::~Sha256() { EVP_MD_CTX_free(context_->ctx); }

void Sha256::Reset() { EVP_DigestInit_ex(context_->ctx, EVP_sha256(), nullptr); }

void Sha256::Update(const uint8_t* data, size_t n) {
  if (n > 0) EVP_DigestUpdate(context_->ctx, data, n);
}

Sha256Digest Sha256::Final() {
  Sha256Digest digest{};
  unsigned int size = 0;
  EVP_DigestFinal_ex(context_->ctx, digest.data(), &size);
  Reset();
  return digest;
}

Sha256Digest Sha256Hash(const uint8_t* data, size_t n) {
  Sha256Digest digest{};
  unsigned int size = 0;
  EVP_Digest(data, n, digest.data(), &size, EVP_sha256(), nullptr);
  return digest;
}

Sha256Digest HmacSha256(const uint8_t* key, size_t key_size, const uint8_t* message,
                        size_t message_size, const uint8_t* message2, size_t message2_size) {
  Sha256Digest digest{};
  static const uint8_t kEmpty = 0;
  if (message2_size == 0) {
    unsigned int size = 0;
    HMAC(EVP_sha256(), key_size > 0 ? key : &kEmpty, static_cast<int>(key_size),
         message_size > 0 ? message : &kEmpty, message_size, digest.data(), &size);
    return digest;
  }
  // Two parts: the EVP_MAC interface (OpenSSL 3) streams them without a copy.
  EVP_MAC* mac = EVP_MAC_fetch(nullptr, "HMAC", nullptr);
  EVP_MAC_CTX* ctx = mac != nullptr ? EVP_MAC_CTX_new(mac) : nullptr;
  char digest_name[] = "SHA256";
  OSSL_PARAM params[] = {OSSL_PARAM_construct_utf8_string("digest", digest_name, 0),
                         OSSL_PARAM_construct_end()};
  size_t size = 0;
  if (ctx != nullptr && EVP_MAC_init(ctx, key_size > 0 ? key : &kEmpty, key_size, params) == 1) {
    EVP_MAC_update(ctx, message, message_size);
    EVP_MAC_update(ctx, message2, message2_size);
    EVP_MAC_final(ctx, digest.data(), &size, digest.size());
  }
  EVP_MAC_CTX_free(ctx);
  EVP_MAC_free(mac);
  return digest;
}

bool HkdfSha256(const uint8_t* salt, size_t salt_size, const uint8_t* ikm, size_t ikm_size,
                const uint8_t* info, size_t info_size, uint8_t* out, size_t out_size) {
  EVP_PKEY_CTX* ctx = EVP_PKEY_CTX_new_id(EVP_PKEY_HKDF, nullptr);
  if (ctx == nullptr) return false;
  static const uint8_t kEmpty = 0;
  size_t size = out_size;
  const bool ok =
      EVP_PKEY_derive_init(ctx) == 1 && EVP_PKEY_CTX_set_hkdf_md(ctx, EVP_sha256()) == 1 &&
      EVP_PKEY_CTX_set1_hkdf_salt(ctx, salt_size > 0 ? salt : &kEmpty,
                                  static_cast<int>(salt_size)) == 1 &&
      EVP_PKEY_CTX_set1_hkdf_key(ctx, ikm_size > 0 ? ikm : &kEmpty, static_cast<int>(ikm_size)) ==
          1 &&
      (info_size == 0 ||
       EVP_PKEY_CTX_add1_hkdf_info(ctx, info, static_cast<int>(info_size)) == 1) &&
      EVP_PKEY_derive(ctx, out, &size) == 1 && size == out_size;
  EVP_PKEY_CTX_free(ctx);
  return ok;
}

Sha256Digest LinkAuthMac(const std::vector<uint8_t>& key, const LinkNonce& agent_nonce,
                         const LinkNonce& client_nonce) {
  std::vector<uint8_t> message(kLinkAuthContext, kLinkAuthContext + sizeof(kLinkAuthContext) - 1);
  message.insert(message.end(), agent_nonce.begin(), agent_nonce.end());
  message.insert(message.end(), client_nonce.begin(), client_nonce.end());
  return HmacSha256(key.data(), key.size(), message.data(), message.size());
}

LinkSessionKey LinkDeriveSessionKey(const std::vector<uint8_t>& key, const LinkNonce& agent_nonce,
                                    const LinkNonce& client_nonce) {
  uint8_t salt[2 * kLinkNonceSize];
  std::memcpy(salt, agent_nonce.data(), kLinkNonceSize);
  std::memcpy(salt + kLinkNonceSize, client_nonce.data(), kLinkNonceSize);
  LinkSessionKey session{};
  HkdfSha256(salt, sizeof(salt), key.data(), key.size(),
             reinterpret_cast<const uint8_t*>(kLinkSessionKeyInfo), sizeof(kLinkSessionKeyInfo) - 1,
             session.data(), session.size());
  return session;
}

LinkTag LinkFrameTag(const LinkSessionKey& session_key, const uint8_t* header24,
                     const uint8_t* payload, size_t payload_size) {
  const Sha256Digest full = HmacSha256(session_key.data(), session_key.size(), header24,
                                       kLinkSignedHeaderSize, payload, payload_size);
  LinkTag tag{};
  std::memcpy(tag.data(), full.data(), tag.size());
  return tag;
}

LinkFrameSigner MakeLinkFrameSigner(const LinkSessionKey& session_key) {
  return [session_key](const uint8_t* header24, const uint8_t* payload, size_t n) {
    return LinkFrameTag(session_key, header24, payload, n);
  };
}

bool LinkFrameTagValid(const LinkSessionKey& session_key, const LinkMessage& message) {
  if (!message.header.signed_frame || message.signed_bytes.size() < kLinkSignedHeaderSize) {
    return false;
  }
  const LinkTag expected =
      LinkFrameTag(session_key, message.signed_bytes.data(),
                   message.signed_bytes.data() + kLinkSignedHeaderSize,
                   message.signed_bytes.size() - kLinkSignedHeaderSize);
  return ConstantTimeEqual(expected.data(), message.tag.data(), expected.size());
}

bool MakeLinkAuthResponse(const std::vector<uint8_t>& key, const AuthChallenge& challenge,
                          AuthResponse* response, LinkSessionKey* session_key) {
  if (!FillRandomBytes(response->client_nonce.data(), response->client_nonce.size())) return false;
  const Sha256Digest mac = LinkAuthMac(key, challenge.nonce, response->client_nonce);
  std::memcpy(response->mac.data(), mac.data(), mac.size());
  *session_key = LinkDeriveSessionKey(key, challenge.nonce, response->client_nonce);
  return true;
}

bool ConstantTimeEqual(const uint8_t* a, const uint8_t* b, size_t n) {
  return n == 0 || CRYPTO_memcmp(a, b, n) == 0;
}

bool FillRandomBytes(uint8_t* out, size_t n) {
  if (n == 0) return true;
  return RAND_bytes(out, static_cast<int>(n)) == 1;
}

std::string ToHex(const uint8_t* data, size_t n) {
  static const char kDigits[] = "0123456789abcdef";
  std::string s;
  s.reserve(2 * n);
  for (size_t i = 0; i < n; ++i) {
    s.push_back(kDigits[data[i] >> 4]);
    s.push_back(kDigits[data[i] & 15]);
  }
  return s;
}

}  // namespace hardware
}  // namespace sweepscan
