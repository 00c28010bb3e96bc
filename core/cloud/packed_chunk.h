// The compact cloud store's unit: a sealed chunk of up to 65 536 points in
// 14 bytes a point (an X4's; up to 22 for points off the 1 mm grid or a lidar
// whose ranges are not whole quarter millimetres), every CloudPoint attribute
// recoverable bit for bit.
//
// Why these bytes (docs/cloud-store.md has the layout):
//   x, y, z   int16 mm after the     6 B  exact for points on the cloud's 1 mm
//             chunk's origin              grid (cloud.h: every assembled point
//                                         is); a chunk with a point off it, or
//                                         wider than 65.5 m, keeps float32 (12 B)
//   range     uint16 quarter mm      2 B  the X4's own unit (raw / 4 mm), so
//                                         exact for it; a chunk whose ranges
//                                         are not whole steps keeps float32 (4 B)
//   time      uint32 ns after its    4 B  exact; a scan lasts ~0.14 s, far
//             scan run's start              inside 2^32 ns (4.29 s)
//   beam      uint16                 2 B  exact
// A scan run is a stretch of points with one scan index, pose source, flags
// and a time origin: ~700 points of an X4 share 24 bytes.
// CloudPoint is 32 bytes; the view's old per-point arrays were ~300.
//
// Three forms of the payload (docs/cloud-store.md, "Compressed payloads"
// and "Out of core"); the header (size, bounds, time span, runs) always
// stays in memory:
//   unpacked    the arrays below, what readers use; the pager keeps the
//               most recently sealed ones up to its unpacked budget;
//   compressed  payload_codec.h, under 3 bytes a point, made once, when the
//               unpacked payload is evicted; Pin() unpacks it for its caller;
//   paged out   the compressed bytes in the pager's cache file, when the
//               process is over its memory budget; read back on demand.
// A sealed chunk never changes, so it is compressed and written at most once.
//
// Threading: immutable after Pack(); Pin() may be called from any thread.
#ifndef SWEEPSCAN_CORE_CLOUD_PACKED_CHUNK_H_
#define SWEEPSCAN_CORE_CLOUD_PACKED_CHUNK_H_

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "core/cloud/cloud.h"

namespace sweepscan {

class CloudPager;

struct ScanRun {
  uint32_t first = 0;  // Index of the run's first point in the chunk.
  uint32_t scan = 0;
  int64_t time0_ns = 0;  // Times of the run's points are time0_ns + dt.
  uint8_t pose_source = 0;
  uint8_t flags = 0;
};

// The per-point arrays (structure of arrays, in the order points were given).
struct ChunkPayload {
  std::vector<int16_t> xyz_mm;     // 3 per point, grid steps after the chunk's origin, or empty ...
  std::vector<float> xyz;          // ... and these instead (3 per point)
  std::vector<uint16_t> range_q;   // quarter millimetres, or empty ...
  std::vector<float> range_f;      // ... and these instead
  std::vector<uint32_t> dt_ns;     // after the run's time0_ns
  std::vector<uint16_t> beam;
  size_t bytes() const {
    return xyz_mm.size() * 2 + xyz.size() * 4 + range_q.size() * 2 + range_f.size() * 4 + dt_ns.size() * 4 +
           beam.size() * 2;
  }
};

class PackedChunk {
 public:
  static constexpr double kRangeStepM = 0.00025;  // The X4's range unit.

  // `pager` (may be null: never paged) accounts the payload and may page it out.
  static std::shared_ptr<const PackedChunk> Pack(const CloudPoint* points, size_t n,
                                                 CloudPager* pager);
  ~PackedChunk();
  PackedChunk(const PackedChunk&) = delete;
  PackedChunk& operator=(const PackedChunk&) = delete;

  size_t size() const { return size_; }
  // Axis-aligned bounds: x min, x max, y min, y max, z min, z max (VTK's order).
  const std::array<double, 6>& bounds() const { return bounds_; }
  int64_t first_time_ns() const { return first_time_ns_; }
  int64_t last_time_ns() const { return last_time_ns_; }
  float max_range_m() const { return max_range_m_; }
  const std::vector<ScanRun>& runs() const { return runs_; }
  // The bounds (as bounds(), in floats, attained) of every kBlockPoints
  // consecutive points, about a third of an X4's turn: a pick tests only
  // the blocks its ray passes near, and reads (or pages in) no payload when
  // it passes near none. 0.09 bytes a point, kept with the header.
  static constexpr size_t kBlockPoints = 256;
  const std::vector<std::array<float, 6>>& block_bounds() const { return block_bounds_; }
  // The boxes of every kPiecePoints consecutive points (a block's eighth,
  // 16 degrees of an X4's turn: under a metre of wall), each side one of 255
  // steps across its block's box, rounded outwards, 6 bytes a piece (0.19
  // bytes a point). Why: a block is a slab across the room (the scan plane
  // is vertical), and a ray through the room crosses the boxes of most
  // blocks it passes while metres from their points; on 210 M points of
  // one room a pick tested 100 000 blocks, 25 M points. A piece's box is
  // met by the rays that pass near its points.
  static constexpr size_t kPiecePoints = 32;
  static constexpr size_t kPiecesPerBlock = kBlockPoints / kPiecePoints;
  size_t piece_count() const { return piece_boxes_.size(); }
  // Piece `piece`'s box (VTK's order), every point of it inside or on it;
  // false (box untouched) if the piece has no finite coordinate on an axis.
  bool PieceBox(size_t piece, double box[6]) const;
  // The chunk's points counted in the cubes of a kCellM grid of the world
  // frame (a census): the cubes' keys (CellKey) ascending, and their counts.
  // A chunk is 13 s of sweeps across the room and a block a third of a scan
  // line, so both boxes meet nearly any view from inside the room; the
  // census is what tells the view how many points lie in its frustum
  // (CloudView's rest plan; docs/cloud-store.md). About 0.1 bytes a point.
  static constexpr float kCellM = 0.5f;
  const std::vector<uint64_t>& cell_keys() const { return cell_keys_; }
  const std::vector<uint32_t>& cell_counts() const { return cell_counts_; }
  // A position's cube: floor(v / kCellM) an axis, each clamped to int16 and
  // offset by 2^15 into 16 bits, x in bits 32-47, y 16-31, z 0-15.
  static uint64_t CellKey(const float v[3]) {
    return CellKeyOf(CellIndex(v[0]), CellIndex(v[1]), CellIndex(v[2]));
  }
  // The key of the cube (cx, cy, cz), each in [-32768, 32767], and back.
  static uint64_t CellKeyOf(int32_t cx, int32_t cy, int32_t cz) {
    return static_cast<uint64_t>(cx + 32768) << 32 | static_cast<uint64_t>(cy + 32768) << 16 |
           static_cast<uint64_t>(cz + 32768);
  }
  static int32_t CellOfKey(uint64_t key, int axis) {
    return static_cast<int32_t>((key >> (32 - 16 * axis)) & 0xFFFF) - 32768;
  }
  // floor(v / kCellM) clamped to [-32768, 32767] (NaN to the low end), by
  // truncation and a step down for negative fractions: std::floor is a libm
  // call here, and this runs for every point a chunk seals.
  static int32_t CellIndex(float v) {
    float c = v * (1.0f / kCellM);  // exact: kCellM is a power of two
    c = c >= -32768.0f ? std::min(c, 32767.0f) : -32768.0f;
    const int32_t i = static_cast<int32_t>(c);
    return i - (static_cast<float>(i) > c ? 1 : 0);
  }
  // The cube of a key, as bounds() orders a box.
  static std::array<float, 6> CellBox(uint64_t key) {
    std::array<float, 6> box;
    for (int a = 0; a < 3; ++a) {
      const float lo = static_cast<float>(CellOfKey(key, a)) * kCellM;
      box[2 * a] = lo;
      box[2 * a + 1] = lo + kCellM;
    }
    return box;
  }
  // How the payload is stored: positions as grid steps after origin_mm()
  // (else float32), ranges as quarter millimetres (else float32).
  bool positions_on_grid() const { return positions_on_grid_; }
  bool ranges_quantised() const { return ranges_quantised_; }
  const std::array<int64_t, 3>& origin_mm() const { return origin_mm_; }

  // The payload, unpacked (decoded for this caller if the chunk is
  // compressed, read back from the cache file first if it was paged out).
  // Holding the pointer keeps it in memory. Never null (a
  // failed read is fatal: the cache file and the compressed bytes are ours;
  // see docs/cloud-store.md).
  std::shared_ptr<const ChunkPayload> Pin() const;
  // The positions of block `block`'s points (points [block * kBlockPoints,
  // ...)) without unpacking the chunk: a payload whose point j is the
  // chunk's point *first + j. The whole unpacked payload (*first = 0) when
  // it is in memory, else that block's positions alone, decoded for this
  // caller and not kept (a pick meets a few blocks of each of many chunks).
  std::shared_ptr<const ChunkPayload> PinBlockPositions(size_t block, size_t* first) const;
  // The same for a reader that tests many blocks of one chunk (a pick on a
  // floor driven over a hundred times meets a hundred blocks of each of a
  // thousand chunks): the chunk's positions held once, the unpacked payload
  // if it is in memory, else its compressed bytes (read back from the cache
  // file once, not for every block), and its blocks decoded from the pin
  // without the pager. PinBlockPositions(b) is BlockPositions(PinPositions(), b).
  struct PositionsPin {
    std::shared_ptr<const ChunkPayload> payload;         // unpacked, or
    std::shared_ptr<const std::vector<uint8_t>> packed;  // compressed
  };
  PositionsPin PinPositions() const;
  // With `points`, a compressed block decodes its first `points` only (a
  // multiple of 8; the pieces a pick tests end there).
  std::shared_ptr<const ChunkPayload> BlockPositions(const PositionsPin& pin, size_t block,
                                                     size_t* first,
                                                     size_t points = kBlockPoints) const;
  bool resident() const;  // In memory, unpacked or compressed (not only in the cache file).
  bool unpacked() const;  // Unpacked in memory.
  size_t payload_bytes() const { return payload_bytes_; }  // Unpacked.
  size_t packed_bytes() const;  // Compressed; 0 until it first was.

  // Appends the chunk's points, decoded exactly, to `out`.
  void Decode(std::vector<CloudPoint>* out) const;
  static void DecodeFrom(const PackedChunk& chunk, const ChunkPayload& payload, size_t begin,
                         size_t end, std::vector<CloudPoint>* out);
  // Position of point i, from a pinned payload.
  void PositionOf(const ChunkPayload& payload, size_t i, float out[3]) const {
    if (payload.xyz_mm.empty()) {
      std::copy_n(&payload.xyz[3 * i], 3, out);
      return;
    }
    for (int k = 0; k < 3; ++k) out[k] = GridPosition(origin_mm_[k] + payload.xyz_mm[3 * i + k]);
  }
  // Range and time of point i (the view's colours), from a pinned payload.
  float RangeOf(const ChunkPayload& payload, size_t i) const {
    return payload.range_q.empty() ? payload.range_f[i]
                                   : static_cast<float>(payload.range_q[i] * kRangeStepM);
  }
  int64_t TimeOf(const ChunkPayload& payload, size_t i, size_t run) const {
    return runs_[run].time0_ns + payload.dt_ns[i];
  }

 private:
  friend class CloudPager;
  PackedChunk() = default;
  static bool PackOnGrid(const CloudPoint* points, size_t n, PackedChunk* chunk,
                         ChunkPayload* payload);
  static void TakeCensus(const CloudPoint* points, size_t n, PackedChunk* chunk);
  // From the compressed bytes, the whole payload (kWholeChunk) or one
  // block's positions; fatal if they do not decode.
  static constexpr size_t kWholeChunk = ~size_t{0};
  std::shared_ptr<ChunkPayload> Unpack(const std::vector<uint8_t>& bytes, size_t block,
                                       size_t points = kBlockPoints) const;

  size_t size_ = 0;
  std::array<double, 6> bounds_{};
  int64_t first_time_ns_ = 0, last_time_ns_ = 0;
  float max_range_m_ = 0.0f;
  bool positions_on_grid_ = false, ranges_quantised_ = false;
  std::array<int64_t, 3> origin_mm_{};
  std::vector<ScanRun> runs_;
  std::vector<std::array<float, 6>> block_bounds_;
  std::vector<std::array<uint8_t, 6>> piece_boxes_;  // Steps of the block's box: min, max an axis.
  std::vector<uint64_t> cell_keys_;
  std::vector<uint32_t> cell_counts_;
  size_t payload_bytes_ = 0;
  CloudPager* pager_ = nullptr;
  // Paging state, under mutex_.
  mutable std::mutex mutex_;
  mutable std::shared_ptr<const ChunkPayload> payload_;         // Unpacked, or null.
  mutable std::shared_ptr<const std::vector<uint8_t>> packed_;  // Compressed, or null.
  mutable std::vector<uint32_t> segment_ends_;  // Of the compressed frames, set with the first packed_.
  mutable size_t packed_bytes_ = 0;             // Size of the compressed form, once made.
  mutable int64_t file_offset_ = -1;  // Where the compressed form is in the cache file, once written.
};

// Axis-aligned bounds in VTK's order (x min, x max, y min, y max, z min,
// z max): empty, and grown by a point.
inline std::array<double, 6> EmptyBounds() {
  constexpr double inf = std::numeric_limits<double>::infinity();
  return {inf, -inf, inf, -inf, inf, -inf};
}
inline void ExtendBounds(std::array<double, 6>* b, const CloudPoint& p) {
  const double v[3] = {p.x, p.y, p.z};
  for (int k = 0; k < 3; ++k) {
    (*b)[2 * k] = std::min((*b)[2 * k], v[k]);
    (*b)[2 * k + 1] = std::max((*b)[2 * k + 1], v[k]);
  }
}

// The range of a CloudPoint as a whole number of kRangeStepM, if it is one
// (the float that the step gives back is bit for bit the same).
bool QuantiseRange(float range_m, uint16_t* q);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_PACKED_CHUNK_H_
