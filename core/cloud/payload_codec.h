// The store's compressed form of a sealed chunk's payload: what keeps a
// cloud of 100 M points in under 3 bytes a point instead of 14
// (docs/cloud-store.md, "Compressed payloads", has the byte layout).
//
// Why it compresses: the payload's points are in the order the lidar gave
// them, so each field changes little from one point to the next. Positions
// along a scan line move a few millimetres a beam, a range likewise, a
// beam index by one and a time by a nearly constant step. Each field is
// written as its differences from the point before (the time's as the
// differences of those: a constant step becomes zero), zigzagged so that a
// small negative difference is a small number.
//   * Positions on the 1 mm grid: bit-packed in groups of 8 values at the
//     width of the group's largest, so a depth edge's jump costs only its
//     group; a CRC-32C a segment. Decoded in microseconds, no tables.
//   * Positions off the grid (floats), and every point's range, time and
//     beam: the differences split into byte planes (every low byte, then
//     every high byte: the high planes are nearly all zero), then zstd
//     (level 1, with its checksum).
// Every step is exact modulo 2^16 or 2^32, so any payload, even one that
// does not compress, comes back bit for bit.
//
// Positions in independently decodable segments of kCodecSegmentPoints
// points (four of the chunk's 256-point blocks, each decodable alone on the
// grid), the other fields in one frame: a pick decodes only the positions of
// the blocks its ray meets, not the chunk.
#ifndef SWEEPSCAN_CORE_CLOUD_PAYLOAD_CODEC_H_
#define SWEEPSCAN_CORE_CLOUD_PAYLOAD_CODEC_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace sweepscan {

struct ChunkPayload;

constexpr size_t kCodecSegmentPoints = 1024;
// A segment's grid positions decode a block at a time (a pick's unit: the
// store's PackedChunk::kBlockPoints).
constexpr size_t kCodecBlockPoints = 256;

// Bytes a point before compression, by layout: positions on the grid
// (int16 x 3) or floats, ranges quantised (uint16) or floats, then dt
// (uint32) and beam (uint16).
inline size_t CodecPointBytes(bool grid, bool quantised) {
  return (grid ? 6 : 12) + (quantised ? 2 : 4) + 4 + 2;
}

// Compresses the n points of `payload` (its layout: the arrays that are not
// empty). Frames back to back in `bytes`: frame s (s < S, the number of
// segments) segment s's positions, what a pick reads; frame S every point's
// range, time and beam, read only when the whole chunk is unpacked.
// `ends[f]` is where frame f ends; it starts where frame f - 1 ends (0 for
// the first). No frame for no points.
void EncodePayload(const ChunkPayload& payload, size_t n, std::vector<uint8_t>* bytes,
                   std::vector<uint32_t>* ends);

// The points of segments [s0, s1) of a chunk of n points, as a payload of
// min(n, s1 * kCodecSegmentPoints) - s0 * kCodecSegmentPoints points in the
// given layout; with `positions_only`, only its position arrays. False,
// with `error` (which frame and why), if a frame lies outside `bytes`,
// fails its checksum or does not decode to its segment's size.
bool DecodeSegments(const std::vector<uint8_t>& bytes, const std::vector<uint32_t>& ends, size_t n,
                    bool grid, bool quantised, size_t s0, size_t s1, bool positions_only,
                    ChunkPayload* out, std::string* error);

// The positions of block `block` of a chunk of n points (points
// [block * kCodecBlockPoints, ...), at most kCodecBlockPoints of them) as a
// payload of those points' positions alone; with `points`, of its first
// `points` only (rounded up to a multiple of 8: a pick that needs the
// block's first pieces decodes no further). Grid positions decode that
// block only (its segment's CRC is checked whole); floats decode its
// segment. False, with `error`, as DecodeSegments.
bool DecodeBlockPositions(const std::vector<uint8_t>& bytes, const std::vector<uint32_t>& ends,
                          size_t n, bool grid, size_t block, ChunkPayload* out, std::string* error,
                          size_t points = kCodecBlockPoints);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_PAYLOAD_CODEC_H_
