#include "hardware/link/hmac_sha256.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <random>

#include "hardware/link/link_protocol.h"

namespace sweepscan {
namespace hardware {
namespace {

constexpr uint32_t kK[64] = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

inline uint32_t Rotr(uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }

}  // namespace

void Sha256::Reset() {
  state_ = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
            0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
  block_used_ = 0;
  total_bytes_ = 0;
}

// FIPS 180-4 section 6.2.2: message schedule W, then 64 rounds.
void Sha256::Compress(const uint8_t* block) {
  uint32_t w[64];
  for (int t = 0; t < 16; ++t) {
    w[t] = (static_cast<uint32_t>(block[4 * t]) << 24) |
           (static_cast<uint32_t>(block[4 * t + 1]) << 16) |
           (static_cast<uint32_t>(block[4 * t + 2]) << 8) | static_cast<uint32_t>(block[4 * t + 3]);
  }
  for (int t = 16; t < 64; ++t) {
    const uint32_t s0 = Rotr(w[t - 15], 7) ^ Rotr(w[t - 15], 18) ^ (w[t - 15] >> 3);
    const uint32_t s1 = Rotr(w[t - 2], 17) ^ Rotr(w[t - 2], 19) ^ (w[t - 2] >> 10);
    w[t] = w[t - 16] + s0 + w[t - 7] + s1;
  }
  uint32_t a = state_[0], b = state_[1], c = state_[2], d = state_[3];
  uint32_t e = state_[4], f = state_[5], g = state_[6], h = state_[7];
  for (int t = 0; t < 64; ++t) {
    const uint32_t big_s1 = Rotr(e, 6) ^ Rotr(e, 11) ^ Rotr(e, 25);
    const uint32_t ch = (e & f) ^ (~e & g);
    const uint32_t t1 = h + big_s1 + ch + kK[t] + w[t];
    const uint32_t big_s0 = Rotr(a, 2) ^ Rotr(a, 13) ^ Rotr(a, 22);
    const uint32_t maj = (a & b) ^ (a & c) ^ (b & c);
    const uint32_t t2 = big_s0 + maj;
    h = g;
    g = f;
    f = e;
    e = d + t1;
    d = c;
    c = b;
    b = a;
    a = t1 + t2;
  }
  state_[0] += a;
  state_[1] += b;
  state_[2] += c;
  state_[3] += d;
  state_[4] += e;
  state_[5] += f;
  state_[6] += g;
  state_[7] += h;
}

void Sha256::Update(const uint8_t* data, size_t n) {
  if (n == 0 || data == nullptr) return;
  total_bytes_ += n;
  while (n > 0) {
    if (block_used_ == 0 && n >= kSha256BlockSize) {
      Compress(data);
      data += kSha256BlockSize;
      n -= kSha256BlockSize;
      continue;
    }
    const size_t take = std::min(n, kSha256BlockSize - block_used_);
    std::memcpy(block_.data() + block_used_, data, take);
    block_used_ += take;
    data += take;
    n -= take;
    if (block_used_ == kSha256BlockSize) {
      Compress(block_.data());
      block_used_ = 0;
    }
  }
}

Sha256Digest Sha256::Final() {
  const uint64_t bit_length = total_bytes_ * 8;
  // Padding: 0x80, zeros up to 56 mod 64, then the 64-bit big-endian length.
  uint8_t pad[kSha256BlockSize * 2] = {0x80};
  const size_t pad_size =
      (block_used_ < 56 ? 56 - block_used_ : 56 + kSha256BlockSize - block_used_);
  uint8_t length[8];
  for (int i = 0; i < 8; ++i) length[i] = static_cast<uint8_t>(bit_length >> (56 - 8 * i));
  Update(pad, pad_size);
  Update(length, 8);
  Sha256Digest digest;
  for (int i = 0; i < 8; ++i) {
    digest[4 * i] = static_cast<uint8_t>(state_[i] >> 24);
    digest[4 * i + 1] = static_cast<uint8_t>(state_[i] >> 16);
    digest[4 * i + 2] = static_cast<uint8_t>(state_[i] >> 8);
    digest[4 * i + 3] = static_cast<uint8_t>(state_[i]);
  }
  Reset();
  return digest;
}

Sha256Digest Sha256Hash(const uint8_t* data, size_t n) {
  Sha256 sha;
  sha.Update(data, n);
  return sha.Final();
}

Sha256Digest HmacSha256(const uint8_t* key, size_t key_size, const uint8_t* message,
                        size_t message_size, const uint8_t* message2, size_t message2_size) {
  // K0: the key, hashed if longer than a block, zero-padded to a block.
  uint8_t k0[kSha256BlockSize] = {0};
  if (key_size > kSha256BlockSize) {
    const Sha256Digest hashed = Sha256Hash(key, key_size);
    std::memcpy(k0, hashed.data(), hashed.size());
  } else if (key_size > 0) {
    std::memcpy(k0, key, key_size);
  }
  uint8_t ipad[kSha256BlockSize];
  uint8_t opad[kSha256BlockSize];
  for (size_t i = 0; i < kSha256BlockSize; ++i) {
    ipad[i] = k0[i] ^ 0x36;
    opad[i] = k0[i] ^ 0x5c;
  }
  Sha256 inner;
  inner.Update(ipad, sizeof(ipad));
  inner.Update(message, message_size);
  inner.Update(message2, message2_size);
  const Sha256Digest inner_digest = inner.Final();
  Sha256 outer;
  outer.Update(opad, sizeof(opad));
  outer.Update(inner_digest.data(), inner_digest.size());
  // Key material should not linger on the stack longer than needed.
  volatile uint8_t* wipe = k0;
  for (size_t i = 0; i < kSha256BlockSize; ++i) wipe[i] = 0;
  return outer.Final();
}

Sha256Digest LinkAuthMac(const std::vector<uint8_t>& key, const uint8_t* nonce, size_t nonce_size) {
  const size_t context_size = sizeof(kLinkAuthContext) - 1;  // 17 bytes, no terminator.
  return HmacSha256(key.data(), key.size(), reinterpret_cast<const uint8_t*>(kLinkAuthContext),
                    context_size, nonce, nonce_size);
}

bool ConstantTimeEqual(const uint8_t* a, const uint8_t* b, size_t n) {
  // Accumulate every difference; no early exit. volatile keeps the compiler
  // from turning the loop back into a short-circuiting memcmp.
  volatile uint8_t diff = 0;
  for (size_t i = 0; i < n; ++i) diff = diff | static_cast<uint8_t>(a[i] ^ b[i]);
  return diff == 0;
}

bool FillRandomBytes(uint8_t* out, size_t n) {
  if (n == 0) return true;
  if (FILE* f = std::fopen("/dev/urandom", "rb")) {
    const size_t got = std::fread(out, 1, n, f);
    std::fclose(f);
    if (got == n) return true;
  }
  try {
    std::random_device device;
    for (size_t i = 0; i < n; i += 4) {
      const uint32_t r = device();
      for (size_t j = 0; j < 4 && i + j < n; ++j) out[i + j] = static_cast<uint8_t>(r >> (8 * j));
    }
    return true;
  } catch (...) {
    return false;
  }
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
