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
// [k w, k w + w), little-endian). First, for each block of
// kCodecBlockPoints after the first, the value before it (uint16,
// little-endian): where that block's differences start, so that a pick
// decodes the one block its ray meets (a quarter of the segment) and not
// the blocks before it; 0.02 bytes a point. Then every group's width as a
// 4-bit code (0-14: that many bits, 15: 16 bits), two a byte, low nibble
// first; then the groups. On the lab's drives 1.7 bytes a point for x, y
// and z together, as small as zstd makes them, and a segment decodes in a
// few microseconds instead of zstd's ten.
constexpr size_t kGroup = 8;
constexpr size_t kBlockGroups = kCodecBlockPoints / kGroup;
static_assert(kCodecSegmentPoints % kCodecBlockPoints == 0 && kCodecBlockPoints % kGroup == 0);

size_t Blocks(size_t m) { return (m + kCodecBlockPoints - 1) / kCodecBlockPoints; }

// The most bytes PackAxis writes for m values, with the 16 it may write
// past its end.
size_t PackAxisBound(size_t m) { return 2 * Blocks(m) + (m + kGroup) / kGroup / 2 + 1 + 2 * m + 16 + 16; }

// Writes one axis at `out` (PackAxisBound(m) bytes there), returns its end.
uint8_t* PackAxis(const uint16_t* v, size_t m, size_t stride, uint8_t* out) {
  for (size_t b = 1; b < Blocks(m); ++b) {
    const uint16_t start = v[(b * kCodecBlockPoints - 1) * stride];
    *out++ = static_cast<uint8_t>(start);
    *out++ = static_cast<uint8_t>(start >> 8);
  }
  const size_t groups = (m + kGroup - 1) / kGroup;
  uint8_t* codes = out;
  std::memset(codes, 0, (groups + 1) / 2);
  out += (groups + 1) / 2;
  uint16_t prev = 0;
  for (size_t g = 0; g < groups; ++g) {
    uint16_t z[kGroup] = {};
    unsigned all = 0;
    const size_t count = std::min(kGroup, m - g * kGroup);
    for (size_t k = 0; k < count; ++k) {
      const uint16_t x = v[(g * kGroup + k) * stride];
      z[k] = Zig(static_cast<uint16_t>(x - prev));
      prev = x;
      all |= z[k];
    }
    const int width = all == 0 ? 0 : 32 - __builtin_clz(all);
    const int code = std::min(width, 15);
    const int bits = code == 15 ? 16 : code;
    codes[g / 2] |= static_cast<uint8_t>(code << (4 * (g % 2)));
    // Values 0-3 in the low 4 w bits, 4-7 above them: 8 w bits, w bytes
    // (16 bytes stored, the group's w kept).
    uint64_t lo = 0, hi = 0;
    for (size_t k = 0; k < 4; ++k) {
      lo |= uint64_t{z[k]} << (k * bits);
      hi |= uint64_t{z[k + 4]} << (k * bits);
    }
    const unsigned __int128 group = lo | static_cast<unsigned __int128>(hi) << (4 * bits);
    std::memcpy(out, &group, 16);  // Little-endian, as UnpackGroup reads it.
    out += bits;
  }
  return out;
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

// Bytes of a group by its width code, and of the two groups whose codes
// share a byte.
constexpr size_t CodeBytes(int code) { return code == 15 ? 16 : static_cast<size_t>(code); }
constexpr auto kPairBytes = [] {
  std::array<uint8_t, 256> t{};
  for (int b = 0; b < 256; ++b) t[b] = static_cast<uint8_t>(CodeBytes(b & 15) + CodeBytes(b >> 4));
  return t;
}();

// Bytes of the groups [0, g) (a byte of codes at a time: this runs for
// every block a pick decodes).
size_t GroupBytes(const uint8_t* codes, size_t g) {
  size_t sum = 0;
  for (size_t i = 0; i < g / 2; ++i) sum += kPairBytes[codes[i]];
  if (g % 2 != 0) sum += CodeBytes(codes[g / 2] & 15);
  return sum;
}

// The inverse of PackAxis for the points of blocks [b0, b1) of the
// segment's m, at most `points` of them (a multiple of kGroup), into v (the
// block b0's first point at v[0]); returns where the axis ends, or null if
// its bytes run past `end` (a damaged segment).
const uint8_t* UnpackAxis(const uint8_t* in, const uint8_t* end, size_t m, size_t b0, size_t b1,
                          size_t points, size_t stride, uint16_t* v) {
  const size_t groups = (m + kGroup - 1) / kGroup;
  const size_t head = 2 * (Blocks(m) - 1) + (groups + 1) / 2;  // Block starts and width codes.
  if (static_cast<size_t>(end - in) < head) return nullptr;
  const uint8_t* starts = in;
  const uint8_t* codes = starts + 2 * (Blocks(m) - 1);
  const uint8_t* data = in + head;
  const size_t g0 = b0 * kBlockGroups,
               g1 = std::min({groups, b1 * kBlockGroups, g0 + points / kGroup});
  const size_t total = GroupBytes(codes, groups);
  if (static_cast<size_t>(end - data) < total) return nullptr;
  in = data + GroupBytes(codes, g0);
  uint16_t prev = b0 == 0 ? 0 : static_cast<uint16_t>(starts[2 * (b0 - 1)] | starts[2 * (b0 - 1) + 1] << 8);
  for (size_t g = g0; g < g1; ++g, v += kGroup * stride) {
    const int code = (codes[g / 2] >> (4 * (g % 2))) & 15;
    const int bits = code == 15 ? 16 : code;
    const size_t count = std::min(kGroup, m - g * kGroup);
    if (end - in >= 16 && count == kGroup) {
      UnpackGroup(in, bits, &prev, v, stride);
    } else {  // The last groups: from a copy padded to 16 bytes, into a full group.
      uint8_t padded[16] = {};
      uint16_t group[kGroup];
      std::memcpy(padded, in, static_cast<size_t>(bits));
      UnpackGroup(padded, bits, &prev, group, 1);
      for (size_t k = 0; k < count; ++k) v[k * stride] = group[k];
    }
    in += bits;
  }
  return data + total;
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
      bytes->resize(from + 3 * PackAxisBound(m));
      uint8_t* out = bytes->data() + from;
      for (int a = 0; a < 3; ++a) {
        out = PackAxis(reinterpret_cast<const uint16_t*>(p.xyz_mm.data()) + 3 * s0 + a, m, 3, out);
      }
      bytes->resize(static_cast<size_t>(out - bytes->data()));
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

namespace {

// Reads the frames of one compressed chunk of n points; every refusal says
// which frame and why.
class FrameReader {
 public:
  FrameReader(const std::vector<uint8_t>& bytes, const std::vector<uint32_t>& ends, size_t n,
              std::string* error)
      : bytes_(bytes), ends_(ends), n_(n), segments_((n + kCodecSegmentPoints - 1) / kCodecSegmentPoints),
        error_(error) {}

  size_t segments() const { return segments_; }

  bool CheckFrames() {
    const size_t expected = segments_ > 0 ? segments_ + 1 : 0;
    if (ends_.size() == expected) return true;
    *error_ = std::to_string(ends_.size()) + " frames for " + std::to_string(n_) + " points, expected " +
              std::to_string(expected);
    return false;
  }

  // Blocks [b0, b1) of segment s's positions (b1 clipped to the segment's
  // blocks), at most `points` of them (a multiple of kGroup), the block
  // b0's first point at out[0] (3 int16 or 3 floats a point, by `grid`).
  bool Positions(size_t s, bool grid, size_t b0, size_t b1, void* out,
                 size_t points = kCodecSegmentPoints) {
    const size_t m = std::min(kCodecSegmentPoints, n_ - s * kCodecSegmentPoints);
    b1 = std::min(b1, Blocks(m));
    size_t begin = 0, end = 0;
    if (grid) {  // Bit-packed, then the CRC-32C of the bytes before it.
      if (!Span(s, 4, &begin, &end)) return false;
      const uint8_t* in = bytes_.data() + begin;
      const uint8_t* crc_at = bytes_.data() + end - 4;
      uint32_t crc = 0;
      for (int b = 0; b < 4; ++b) crc |= uint32_t{crc_at[b]} << (8 * b);
      if (Crc32c(in, static_cast<size_t>(crc_at - in)) != crc) return Refuse(s, "CRC-32C mismatch");
      for (int a = 0; a < 3 && in != nullptr; ++a) {
        in = UnpackAxis(in, crc_at, m, b0, b1, points, 3, static_cast<uint16_t*>(out) + a);
      }
      if (in != crc_at) return Refuse(s, "its groups do not fill its bytes");
      return true;
    }
    if (!Decompress(s, 12 * m)) return false;  // Floats: the whole segment, the blocks kept.
    scratch_.resize(3 * m);
    const uint8_t* in = plain_.data();
    for (int a = 0; a < 3; ++a) in = GetPlanes(in, m, 3, false, scratch_.data() + a);
    const size_t first = b0 * kCodecBlockPoints;
    const size_t count = std::min(std::min(m, b1 * kCodecBlockPoints) - first, points);
    if (count > 0) std::memcpy(out, scratch_.data() + 3 * first, 3 * count * sizeof(float));
    return true;
  }

  // The ranges, times and beams of every point into `plain()`.
  bool Attributes(bool quantised) { return Decompress(segments_, ((quantised ? 2 : 4) + 4 + 2) * n_); }
  const uint8_t* plain() const { return plain_.data(); }

 private:
  // Frame f's bytes [*begin, *end) within the bytes, at least min_size long.
  bool Span(size_t f, size_t min_size, size_t* begin, size_t* end) {
    *begin = f == 0 ? 0 : ends_[f - 1];
    *end = ends_[f];
    if (*end >= *begin + min_size && *end <= bytes_.size()) return true;
    return Refuse(f, "its frame [" + std::to_string(*begin) + ", " + std::to_string(*end) +
                         ") is not within the " + std::to_string(bytes_.size()) + " bytes");
  }
  bool Refuse(size_t f, const std::string& why) {
    *error_ = (f < segments_ ? "segment " + std::to_string(f) + "'s positions"
                             : std::string("the ranges, times and beams")) +
              " in the compressed chunk: " + why;
    return false;
  }
  // Frame f (zstd) into plain_, expecting `size` bytes.
  bool Decompress(size_t f, size_t size) {
    size_t begin = 0, end = 0;
    if (plain_.size() < size) plain_.resize(size);
    if (!Span(f, 0, &begin, &end)) return false;
    const size_t got = ZSTD_decompressDCtx(DecompressContext(), plain_.data(), size, bytes_.data() + begin,
                                           end - begin);
    if (ZSTD_isError(got)) return Refuse(f, ZSTD_getErrorName(got));
    if (got != size) return Refuse(f, std::to_string(got) + " bytes, expected " + std::to_string(size));
    return true;
  }

  const std::vector<uint8_t>& bytes_;
  const std::vector<uint32_t>& ends_;
  const size_t n_, segments_;
  std::string* error_;
  // Reused by the thread's next chunk.
  static thread_local std::vector<uint8_t> plain_;
  static thread_local std::vector<uint32_t> scratch_;
};
thread_local std::vector<uint8_t> FrameReader::plain_;
thread_local std::vector<uint32_t> FrameReader::scratch_;

}  // namespace

bool DecodeSegments(const std::vector<uint8_t>& bytes, const std::vector<uint32_t>& ends, size_t n,
                    bool grid, bool quantised, size_t s0, size_t s1, bool positions_only,
                    ChunkPayload* p, std::string* error) {
  FrameReader reader(bytes, ends, n, error);
  if (!reader.CheckFrames()) return false;
  s1 = std::min(s1, reader.segments());
  const size_t first = s0 * kCodecSegmentPoints;
  const size_t count = s1 > s0 ? std::min(n, s1 * kCodecSegmentPoints) - first : 0;
  *p = ChunkPayload();
  (grid ? p->xyz_mm.resize(3 * count) : p->xyz.resize(3 * count));
  for (size_t s = s0; s < s1; ++s) {
    const size_t at = 3 * (s * kCodecSegmentPoints - first);  // The segment's first value in `p`.
    void* out = grid ? static_cast<void*>(p->xyz_mm.data() + at) : static_cast<void*>(p->xyz.data() + at);
    if (!reader.Positions(s, grid, 0, kCodecSegmentPoints / kCodecBlockPoints, out)) return false;
  }
  if (positions_only || count == 0) return true;
  // The attributes' frame holds every point of the chunk: decoded whole,
  // the segments' part kept.
  if (!reader.Attributes(quantised)) return false;
  const uint8_t* in = reader.plain();
  const bool whole = first == 0 && count == n;  // Straight into place.
  std::vector<uint16_t> range_q(quantised && !whole ? n : 0);
  std::vector<uint32_t> dt(whole ? 0 : n), bits(quantised ? 0 : n);
  std::vector<uint16_t> beam(whole ? 0 : n);
  uint16_t* range_q_at = whole && quantised ? (p->range_q.resize(n), p->range_q.data()) : range_q.data();
  uint32_t* dt_at = whole ? (p->dt_ns.resize(n), p->dt_ns.data()) : dt.data();
  uint16_t* beam_at = whole ? (p->beam.resize(n), p->beam.data()) : beam.data();
  in = quantised ? GetPlanes(in, n, 1, false, range_q_at) : GetPlanes(in, n, 1, false, bits.data());
  in = GetPlanes(in, n, 1, true, dt_at);
  GetPlanes(in, n, 1, false, beam_at);
  if (!quantised) {
    p->range_f.resize(count);
    std::memcpy(p->range_f.data(), bits.data() + first, count * sizeof(float));
  }
  if (whole) return true;
  const auto from = static_cast<std::ptrdiff_t>(first), to = static_cast<std::ptrdiff_t>(first + count);
  if (quantised) p->range_q.assign(range_q.begin() + from, range_q.begin() + to);
  p->dt_ns.assign(dt.begin() + from, dt.begin() + to);
  p->beam.assign(beam.begin() + from, beam.begin() + to);
  return true;
}

bool DecodeBlockPositions(const std::vector<uint8_t>& bytes, const std::vector<uint32_t>& ends,
                          size_t n, bool grid, size_t block, ChunkPayload* p, std::string* error,
                          size_t points) {
  FrameReader reader(bytes, ends, n, error);
  if (!reader.CheckFrames()) return false;
  const size_t first = block * kCodecBlockPoints;
  *p = ChunkPayload();
  if (first >= n) return true;
  // Whole groups: a group's eight values are written together.
  points = std::min(kCodecBlockPoints, (points + kGroup - 1) / kGroup * kGroup);
  const size_t count = std::min({n - first, kCodecBlockPoints, points});
  if (count == 0) return true;  // No point asked for: none read.
  (grid ? p->xyz_mm.resize(3 * count) : p->xyz.resize(3 * count));
  void* out = grid ? static_cast<void*>(p->xyz_mm.data()) : static_cast<void*>(p->xyz.data());
  constexpr size_t kBlocksASegment = kCodecSegmentPoints / kCodecBlockPoints;
  return reader.Positions(block / kBlocksASegment, grid, block % kBlocksASegment,
                          block % kBlocksASegment + 1, out, points);
}

}  // namespace sweepscan
