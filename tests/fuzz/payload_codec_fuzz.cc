// libFuzzer target: the cloud store's compressed payloads
// (core/cloud/payload_codec.h, docs/cloud-store.md "Compressed payloads").
//
// First byte, bit 0: positions on the grid (else floats); bit 1: ranges
// quantised (else floats); bit 2: which half of the target.
//   * Round trip (bit 2 clear): bytes 1-2 the point count (at most 2 100),
//     the rest the points' bits (any values, the input repeated as long as
//     needed). Encoded, they must decode bit for bit, whole, segment by
//     segment and block by block.
//   * Damaged (bit 2 set): the input is a compressed chunk as a reader
//     might find it: bytes 1-2 the point count (at most 5 000), then one
//     little-endian uint16 frame end a frame (each taken modulo the
//     remaining size plus 64, so some lie past the end), then the bytes.
//     Every read must refuse or decode to the size asked, never crash or
//     read outside the bytes (ASan).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "core/cloud/packed_chunk.h"
#include "core/cloud/payload_codec.h"

namespace {

using namespace sweepscan;

void Check(bool ok) {
  if (!ok) std::abort();
}

template <typename T>
bool Same(const std::vector<T>& a, const T* b, size_t count) {
  return a.size() == count && (count == 0 || std::memcmp(a.data(), b, count * sizeof(T)) == 0);
}

// Any bits from the input, cycled if it runs out.
template <typename T>
std::vector<T> Take(const uint8_t* data, size_t size, size_t count, size_t* at) {
  std::vector<T> v(count);
  uint8_t* out = reinterpret_cast<uint8_t*>(v.data());
  for (size_t i = 0; i < count * sizeof(T); ++i) out[i] = size == 0 ? 0 : data[(*at)++ % size];
  return v;
}

void RoundTrip(bool grid, bool quantised, const uint8_t* data, size_t size) {
  if (size < 2) return;
  const size_t n = (data[0] | data[1] << 8) % 2101;  // Up to three segments.
  data += 2;
  size -= 2;
  size_t at = 0;
  ChunkPayload p;
  if (grid) p.xyz_mm = Take<int16_t>(data, size, 3 * n, &at);
  if (!grid) p.xyz = Take<float>(data, size, 3 * n, &at);
  if (quantised) p.range_q = Take<uint16_t>(data, size, n, &at);
  if (!quantised) p.range_f = Take<float>(data, size, n, &at);
  p.dt_ns = Take<uint32_t>(data, size, n, &at);
  p.beam = Take<uint16_t>(data, size, n, &at);
  std::vector<uint8_t> bytes;
  std::vector<uint32_t> ends;
  EncodePayload(p, n, &bytes, &ends);
  const size_t segments = (n + kCodecSegmentPoints - 1) / kCodecSegmentPoints;
  ChunkPayload back;
  std::string error;
  Check(DecodeSegments(bytes, ends, n, grid, quantised, 0, segments, false, &back, &error));
  Check(Same(back.xyz_mm, p.xyz_mm.data(), p.xyz_mm.size()) && Same(back.xyz, p.xyz.data(), p.xyz.size()));
  Check(Same(back.range_q, p.range_q.data(), p.range_q.size()) &&
        Same(back.range_f, p.range_f.data(), p.range_f.size()));
  Check(Same(back.dt_ns, p.dt_ns.data(), n) && Same(back.beam, p.beam.data(), n));
  for (size_t s = 0; s < segments; ++s) {
    Check(DecodeSegments(bytes, ends, n, grid, quantised, s, s + 1, false, &back, &error));
    const size_t first = s * kCodecSegmentPoints, count = std::min(n - first, kCodecSegmentPoints);
    Check(Same(back.dt_ns, p.dt_ns.data() + first, count) && Same(back.beam, p.beam.data() + first, count));
  }
  for (size_t b = 0; b * kCodecBlockPoints < n; ++b) {
    Check(DecodeBlockPositions(bytes, ends, n, grid, b, &back, &error));
    const size_t first = b * kCodecBlockPoints, count = std::min(n - first, kCodecBlockPoints);
    Check(grid ? Same(back.xyz_mm, p.xyz_mm.data() + 3 * first, 3 * count)
               : Same(back.xyz, p.xyz.data() + 3 * first, 3 * count));
    // Its first points alone (whole groups of 8), as a pick decodes them.
    const size_t points = (b * 37 + n) % (kCodecBlockPoints + 1);
    Check(DecodeBlockPositions(bytes, ends, n, grid, b, &back, &error, points));
    const size_t head = std::min(count, (points + 7) / 8 * 8);
    Check(grid ? Same(back.xyz_mm, p.xyz_mm.data() + 3 * first, 3 * head)
               : Same(back.xyz, p.xyz.data() + 3 * first, 3 * head));
  }
}

void Damaged(bool grid, bool quantised, const uint8_t* data, size_t size) {
  if (size < 2) return;
  const size_t n = (data[0] | data[1] << 8) % 5001;
  data += 2;
  size -= 2;
  const size_t segments = (n + kCodecSegmentPoints - 1) / kCodecSegmentPoints;
  const size_t frames = segments > 0 ? segments + 1 : 0;
  std::vector<uint32_t> ends;
  for (size_t f = 0; f < frames && size >= 2; ++f) {
    ends.push_back(data[0] | data[1] << 8);
    data += 2;
    size -= 2;
  }
  for (uint32_t& e : ends) e %= static_cast<uint32_t>(size + 64);
  const std::vector<uint8_t> bytes(data, data + size);
  ChunkPayload back;
  std::string error;
  if (DecodeSegments(bytes, ends, n, grid, quantised, 0, segments, false, &back, &error)) {
    Check(back.dt_ns.size() == n && back.beam.size() == n);
    Check((grid ? back.xyz_mm.size() : back.xyz.size()) == 3 * n);
  } else {
    Check(!error.empty());
  }
  for (size_t b = 0; b * kCodecBlockPoints < n; ++b) {
    if (DecodeBlockPositions(bytes, ends, n, grid, b, &back, &error)) {
      const size_t count = std::min(n - b * kCodecBlockPoints, kCodecBlockPoints);
      Check((grid ? back.xyz_mm.size() : back.xyz.size()) == 3 * count);
    } else {
      Check(!error.empty());
    }
    const size_t points = (b * 37 + n) % (kCodecBlockPoints + 1);
    if (DecodeBlockPositions(bytes, ends, n, grid, b, &back, &error, points)) {
      const size_t count =
          std::min({n - b * kCodecBlockPoints, kCodecBlockPoints, (points + 7) / 8 * 8});
      Check((grid ? back.xyz_mm.size() : back.xyz.size()) == 3 * count);
    } else {
      Check(!error.empty());
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const bool grid = data[0] & 1, quantised = data[0] & 2, damaged = data[0] & 4;
  (damaged ? Damaged : RoundTrip)(grid, quantised, data + 1, size - 1);
  return 0;
}
