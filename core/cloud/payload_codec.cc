#include "core/cloud/payload_codec.h"

#include <zstd.h>

#include <algorithm>
#include <array>
#include <utility>
#include <cstring>
#include <memory>
#include <new>
#include <type_traits>

#include "core/cloud/packed_chunk.h"
#include "core/common/crc32c.h"

namespace sweepscan {
namespace {

// Level 1: the store compresses a chunk as it is evicted from the unpacked
// cache, on the thread that seals (docs/cloud-store.md has the figures).
constexpr int kZstdLevel = 1;

// Each frame carries zstd's content checksum (4 bytes, 0.004 bytes a
// point): a flipped bit in memory or in the cache file is refused, not drawn.
ZSTD_CCtx* CompressContext() {
  thread_local std::unique_ptr<ZSTD_CCtx, size_t (*)(ZSTD_CCtx*)> context(
      [] {
        ZSTD_CCtx* c = ZSTD_createCCtx();
        ZSTD_CCtx_setParameter(c, ZSTD_c_compressionLevel, kZstdLevel);
        ZSTD_CCtx_setParameter(c, ZSTD_c_checksumFlag, 1);
        return c;
      }(),
      ZSTD_freeCCtx);
  return context.get();
}

ZSTD_DCtx* DecompressContext() {
  thread_local std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> context(ZSTD_createDCtx(),
                                                                          ZSTD_freeDCtx);
  return context.get();
}

// Zigzag: 0, -1, 1, -2, ... -> 0, 1, 2, 3, ... on the wrapped difference.
template <typename U>
U Zig(U d) {
  using S = std::make_signed_t<U>;
  const S s = static_cast<S>(d);
  return static_cast<U>(static_cast<U>(static_cast<U>(s) << 1) ^ static_cast<U>(s >> (8 * sizeof(U) - 1)));
}
template <typename U>
U Unzig(U z) {
  return static_cast<U>(static_cast<U>(z >> 1) ^ static_cast<U>(0 - static_cast<U>(z & 1)));
}

// n values v[0], v[stride], ... as sizeof(U) byte planes of n bytes each:
// the zigzagged first differences (second differences with `order2`),
// differences modulo 2^(8 sizeof U), the first against 0.
template <typename U>
uint8_t* PutPlanes(const U* v, size_t n, size_t stride, bool order2, uint8_t* out) {
  U prev = 0, prev_d = 0;
  for (size_t i = 0; i < n; ++i) {
    const U x = v[i * stride];
    const U d = static_cast<U>(x - prev);
    prev = x;
    U e = d;
    if (order2) {
      e = static_cast<U>(d - prev_d);
      prev_d = d;
    }
    const U z = Zig(e);
    for (size_t b = 0; b < sizeof(U); ++b) out[b * n + i] = static_cast<uint8_t>(z >> (8 * b));
  }
  return out + sizeof(U) * n;
}

template <typename U>
const uint8_t* GetPlanes(const uint8_t* in, size_t n, size_t stride, bool order2, U* v) {
  U prev = 0, prev_d = 0;
  for (size_t i = 0; i < n; ++i) {
    U z = 0;
    for (size_t b = 0; b < sizeof(U); ++b) z = static_cast<U>(z | static_cast<U>(U{in[b * n + i]} << (8 * b)));
    U d = Unzig(z);
    if (order2) {
      d = static_cast<U>(d + prev_d);
      prev_d = d;
    }
    prev = static_cast<U>(prev + d);
    v[i * stride] = prev;
  }
  return in + sizeof(U) * n;
}

// Grid positions (int16 steps) of one segment, one axis: the zigzagged
// first differences in groups of 8 values, each group at the width of its
// largest, so that one long jump (a depth edge) costs only its group. A
// group of 8 values at w bits is exactly w bytes (value k at bits
// [k w, k w + w), little-endian). First every group's width as a 4-bit
// code (0-14: that many bits, 15: 16 bits), two a byte, low nibble first;
// then the groups. On the lab's drives 1.7 bytes a point for x, y and z
// together, as small as zstd makes them, and a pick decodes a segment in a
// few microseconds instead of zstd's ten.
constexpr size_t kGroup = 8;

void PackAxis(const uint16_t* v, size_t m, size_t stride, std::vector<uint8_t>* out) {
  const size_t groups = (m + kGroup - 1) / kGroup;
  const size_t codes = out->size();
  out->resize(out->size() + (groups + 1) / 2, 0);
  uint16_t prev = 0;
  for (size_t g = 0; g < groups; ++g) {
    uint16_t z[kGroup] = {};
    unsigned all = 0;
    for (size_t k = 0; k < kGroup && g * kGroup + k < m; ++k) {
      const uint16_t x = v[(g * kGroup + k) * stride];
      z[k] = Zig(static_cast<uint16_t>(x - prev));
      prev = x;
      all |= z[k];
    }
    const int width = all == 0 ? 0 : 32 - __builtin_clz(all);
    const int code = std::min(width, 15);
    const int bits = code == 15 ? 16 : code;
    (*out)[codes + g / 2] |= static_cast<uint8_t>(code << (4 * (g % 2)));
    unsigned __int128 acc = 0;
    for (size_t k = 0; k < kGroup; ++k) acc |= static_cast<unsigned __int128>(z[k]) << (k * bits);
    for (int b = 0; b < bits; ++b) out->push_back(static_cast<uint8_t>(acc >> (8 * b)));
  }
}

// One group of 8 values at `bits` bits, added to `prev` in turn: values
// 0-3 from the group's first 8 bytes, 4-7 from the 8 bytes at bit 4 bits.
// The width is a run-time shift, not a branch: widths change from group to
// group, and a branch or a call a width mispredicted about every other
// group (half the decoding time). Reads 16 bytes from `in`, so the caller
// gives a group near the end of its bytes through a padded copy.
inline void UnpackGroup(const uint8_t* in, int bits, uint16_t* prev, uint16_t* out, size_t stride) {
  uint64_t lo, hi;
  std::memcpy(&lo, in, 8);  // Little-endian, as written (x86-64 and arm64 alike).
  std::memcpy(&hi, in + (4 * bits) / 8, 8);
  hi >>= (4 * bits) % 8;
  const uint64_t mask = (uint64_t{1} << bits) - 1u;
  uint16_t p = *prev;
  for (int k = 0; k < 4; ++k) {
    p = static_cast<uint16_t>(p + Unzig(static_cast<uint16_t>((lo >> (k * bits)) & mask)));
    out[k * stride] = p;
  }
  for (int k = 0; k < 4; ++k) {
    p = static_cast<uint16_t>(p + Unzig(static_cast<uint16_t>((hi >> (k * bits)) & mask)));
    out[(k + 4) * stride] = p;
  }
  *prev = p;
}

// The inverse of PackAxis; null if the groups run past `end` (a damaged
// segment).
const uint8_t* UnpackAxis(const uint8_t* in, const uint8_t* end, size_t m, size_t stride, uint16_t* v) {
  const size_t groups = (m + kGroup - 1) / kGroup;
  const uint8_t* codes = in;
  if (static_cast<size_t>(end - in) < (groups + 1) / 2) return nullptr;
  in += (groups + 1) / 2;
  uint16_t prev = 0;
  for (size_t g = 0; g < groups; ++g) {
    const int code = (codes[g / 2] >> (4 * (g % 2))) & 15;
    const int bits = code == 15 ? 16 : code;
    if (end - in < bits) return nullptr;
    const size_t count = std::min(kGroup, m - g * kGroup);
    if (end - in >= 16 && count == kGroup) {
      UnpackGroup(in, bits, &prev, v + g * kGroup * stride, stride);
    } else {  // The last groups: from a copy padded to 16 bytes, into a full group.
      uint8_t padded[16] = {};
      uint16_t group[kGroup];
      std::memcpy(padded, in, static_cast<size_t>(bits));
      UnpackGroup(padded, bits, &prev, group, 1);
      // The padding decodes as zero differences: prev is the count-th value.
      for (size_t k = 0; k < count; ++k) v[(g * kGroup + k) * stride] = group[k];
    }
    in += bits;
  }
  return in;
}

void PutCrc(std::vector<uint8_t>* out, size_t from) {
  const uint32_t crc = Crc32c(out->data() + from, out->size() - from);
  for (int b = 0; b < 4; ++b) out->push_back(static_cast<uint8_t>(crc >> (8 * b)));
}

}  // namespace

void EncodePayload(const ChunkPayload& p, size_t n, std::vector<uint8_t>* bytes,
                   std::vector<uint32_t>* ends) {
  const bool grid = !p.xyz_mm.empty() || (p.xyz.empty() && n == 0);
  const bool quantised = !p.range_q.empty() || (p.range_f.empty() && n == 0);
  bytes->clear();
  ends->clear();
  const size_t segments = (n + kCodecSegmentPoints - 1) / kCodecSegmentPoints;
  thread_local std::vector<uint8_t> plain, frame;
  thread_local std::vector<uint32_t> scratch;
  plain.resize(std::max(CodecPointBytes(grid, quantised) * n, size_t{1}));
  scratch.resize(std::max(3 * n, size_t{1}));
  frame.resize(ZSTD_compressBound(plain.size()));
  auto compress = [&](const uint8_t* end) {
    const size_t size = ZSTD_compress2(CompressContext(), frame.data(), frame.size(), plain.data(),
                                       static_cast<size_t>(end - plain.data()));
    // Compressing into a buffer of ZSTD_compressBound cannot fail but for
    // memory, which the store treats as the allocator does.
    if (ZSTD_isError(size)) throw std::bad_alloc();
    bytes->insert(bytes->end(), frame.begin(), frame.begin() + static_cast<std::ptrdiff_t>(size));
    ends->push_back(static_cast<uint32_t>(bytes->size()));
  };
  // Frames 0 .. segments - 1: each segment's positions.
  if (!grid) std::memcpy(scratch.data(), p.xyz.data(), 3 * n * sizeof(float));
  for (size_t s0 = 0; s0 < n; s0 += kCodecSegmentPoints) {
    const size_t m = std::min(kCodecSegmentPoints, n - s0);
    if (grid) {  // Bit-packed (above), with a CRC-32C of the segment's bytes.
      const size_t from = bytes->size();
      for (int a = 0; a < 3; ++a) {
        PackAxis(reinterpret_cast<const uint16_t*>(p.xyz_mm.data()) + 3 * s0 + a, m, 3, bytes);
      }
      PutCrc(bytes, from);
      ends->push_back(static_cast<uint32_t>(bytes->size()));
      continue;
    }
    uint8_t* out = plain.data();  // Floats: their bits' differences, zstd.
    for (int a = 0; a < 3; ++a) out = PutPlanes(scratch.data() + 3 * s0 + a, m, 3, false, out);
    compress(out);
  }
  // Frame `segments`: every point's range, time and beam (read together,
  // only when the whole chunk is unpacked).
  if (segments > 0) {
    uint8_t* out = plain.data();
    if (quantised) {
      out = PutPlanes(p.range_q.data(), n, 1, false, out);
    } else {
      std::memcpy(scratch.data(), p.range_f.data(), n * sizeof(float));
      out = PutPlanes(scratch.data(), n, 1, false, out);
    }
    out = PutPlanes(p.dt_ns.data(), n, 1, true, out);
    out = PutPlanes(p.beam.data(), n, 1, false, out);
    compress(out);
  }
  bytes->shrink_to_fit();
  ends->shrink_to_fit();
}

bool DecodeSegments(const std::vector<uint8_t>& bytes, const std::vector<uint32_t>& ends, size_t n,
                    bool grid, bool quantised, size_t s0, size_t s1, bool positions_only,
                    ChunkPayload* p, std::string* error) {
  const size_t segments = (n + kCodecSegmentPoints - 1) / kCodecSegmentPoints;
  if (ends.size() != (segments > 0 ? segments + 1 : 0)) {
    *error = std::to_string(ends.size()) + " frames for " + std::to_string(n) + " points, expected " +
             std::to_string(segments > 0 ? segments + 1 : 0);
    return false;
  }
  s1 = std::min(s1, segments);
  const size_t first = s0 * kCodecSegmentPoints;
  const size_t count = s1 > s0 ? std::min(n, s1 * kCodecSegmentPoints) - first : 0;
  *p = ChunkPayload();
  (grid ? p->xyz_mm.resize(3 * count) : p->xyz.resize(3 * count));
  thread_local std::vector<uint8_t> plain;
  thread_local std::vector<uint32_t> scratch;
  // Frame f's bytes [*begin, *end) within `bytes`, or why not.
  auto span = [&](size_t f, size_t min_size, size_t* begin, size_t* end, std::string* why) {
    *begin = f == 0 ? 0 : ends[f - 1];
    *end = ends[f];
    if (*end >= *begin + min_size && *end <= bytes.size()) return true;
    *why = "its frame [" + std::to_string(*begin) + ", " + std::to_string(*end) +
           ") is not within the " + std::to_string(bytes.size()) + " bytes";
    return false;
  };
  // False, with `error` saying which frame and why.
  auto refuse = [&](size_t f, const std::string& why) {
    *error = (f < segments ? "segment " + std::to_string(f) + "'s positions"
                           : std::string("the ranges, times and beams")) +
             " in the compressed chunk: " + why;
    return false;
  };
  // Frame f (zstd) into `plain`, expecting `size` bytes.
  auto decompress = [&](size_t f, size_t size) {
    size_t begin = 0, end = 0;
    std::string why;
    if (plain.size() < size) plain.resize(size);
    if (!span(f, 0, &begin, &end, &why)) return refuse(f, why);
    const size_t got =
        ZSTD_decompressDCtx(DecompressContext(), plain.data(), size, bytes.data() + begin, end - begin);
    if (ZSTD_isError(got)) return refuse(f, ZSTD_getErrorName(got));
    if (got != size) return refuse(f, std::to_string(got) + " bytes, expected " + std::to_string(size));
    return true;
  };
  if (!grid) scratch.resize(3 * kCodecSegmentPoints);
  for (size_t s = s0; s < s1; ++s) {
    const size_t m = std::min(kCodecSegmentPoints, n - s * kCodecSegmentPoints);
    const size_t at = s * kCodecSegmentPoints - first;  // First point of the segment in `p`.
    if (grid) {  // Bit-packed, then the CRC-32C of the bytes before it.
      size_t begin = 0, end = 0;
      std::string why;
      if (!span(s, 4, &begin, &end, &why)) return refuse(s, why);
      const uint8_t* in = bytes.data() + begin;
      const uint8_t* crc_at = bytes.data() + end - 4;
      uint32_t crc = 0;
      for (int b = 0; b < 4; ++b) crc |= uint32_t{crc_at[b]} << (8 * b);
      if (Crc32c(in, static_cast<size_t>(crc_at - in)) != crc) return refuse(s, "CRC-32C mismatch");
      for (int a = 0; a < 3 && in != nullptr; ++a) {
        in = UnpackAxis(in, crc_at, m, 3, reinterpret_cast<uint16_t*>(p->xyz_mm.data()) + 3 * at + a);
      }
      if (in != crc_at) return refuse(s, "its groups do not fill its bytes");
      continue;
    }
    if (!decompress(s, 12 * m)) return false;
    const uint8_t* in = plain.data();
    for (int a = 0; a < 3; ++a) in = GetPlanes(in, m, 3, false, scratch.data() + a);
    std::memcpy(p->xyz.data() + 3 * at, scratch.data(), 3 * m * sizeof(float));
  }
  if (positions_only || count == 0) return true;
  // The attributes' frame holds every point of the chunk: decoded whole,
  // the segments' part kept.
  if (!decompress(segments, ((quantised ? 2 : 4) + 4 + 2) * n)) return false;
  const uint8_t* in = plain.data();
  if (first == 0 && count == n) {  // The whole chunk: straight into place.
    if (quantised) {
      p->range_q.resize(n);
      in = GetPlanes(in, n, 1, false, p->range_q.data());
    } else {
      scratch.resize(n);
      in = GetPlanes(in, n, 1, false, scratch.data());
      p->range_f.resize(n);
      std::memcpy(p->range_f.data(), scratch.data(), n * sizeof(float));
    }
    p->dt_ns.resize(n);
    in = GetPlanes(in, n, 1, true, p->dt_ns.data());
    p->beam.resize(n);
    GetPlanes(in, n, 1, false, p->beam.data());
    return true;
  }
  std::vector<uint16_t> range_q;
  std::vector<uint32_t> dt(n), bits;
  std::vector<uint16_t> beam(n);
  if (quantised) {
    range_q.resize(n);
    in = GetPlanes(in, n, 1, false, range_q.data());
  } else {
    bits.resize(n);
    in = GetPlanes(in, n, 1, false, bits.data());
  }
  in = GetPlanes(in, n, 1, true, dt.data());
  GetPlanes(in, n, 1, false, beam.data());
  const auto from = static_cast<std::ptrdiff_t>(first), to = static_cast<std::ptrdiff_t>(first + count);
  if (quantised) {
    p->range_q.assign(range_q.begin() + from, range_q.begin() + to);
  } else {
    p->range_f.resize(count);
    std::memcpy(p->range_f.data(), bits.data() + first, count * sizeof(float));
  }
  p->dt_ns.assign(dt.begin() + from, dt.begin() + to);
  p->beam.assign(beam.begin() + from, beam.begin() + to);
  return true;
}

}  // namespace sweepscan
