#include "core/cloud/packed_chunk.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <limits>

#include "core/cloud/cloud_pager.h"
#include "core/cloud/payload_codec.h"
#include "core/common/rounding.h"

namespace sweepscan {

static_assert(PackedChunk::kBlockPoints == kCodecBlockPoints, "a pick decodes the blocks it tests");

namespace {

// Step q of the 255 across [lo, hi], the ends exact: a piece's side is
// lo + q (hi - lo) / 255, in double (the loops below check the rounding).
double PieceSide(float lo, float hi, uint8_t q) {
  if (q == 0) return lo;
  if (q == 255) return hi;
  return lo + (static_cast<double>(hi) - lo) * q / 255.0;
}

// A piece's extent [min, max] on one axis of its block's [lo, hi] as the
// steps at or outside it (q[0] the min's, q[1] the max's), checked against
// PieceSide so that rounding never puts a point outside its piece's box.
// No finite coordinate (min > max): q = {255, 0}, an empty box.
void QuantisePiece(float lo, float hi, float min, float max, uint8_t q[2]) {
  if (!(min <= max) || !(lo <= hi)) {
    q[0] = 255;
    q[1] = 0;
    return;
  }
  // An infinite coordinate (a chunk may hold one, as it may a NaN): no
  // step is finite; the piece keeps the block's side (q * inf would be
  // NaN at q = 0, and its conversion to int undefined).
  if (!std::isfinite(static_cast<double>(hi) - lo)) {
    q[0] = 0;
    q[1] = 255;
    return;
  }
  const double steps = hi > lo ? 255.0 / (static_cast<double>(hi) - lo) : 0.0;
  int q0 =
      std::clamp(static_cast<int>(std::floor((min - static_cast<double>(lo)) * steps)), 0, 255);
  int q1 = std::clamp(static_cast<int>(std::ceil((max - static_cast<double>(lo)) * steps)), 0, 255);
  while (q0 > 0 && PieceSide(lo, hi, static_cast<uint8_t>(q0)) > min) --q0;
  while (q1 < 255 && PieceSide(lo, hi, static_cast<uint8_t>(q1)) < max) ++q1;
  q[0] = static_cast<uint8_t>(q0);
  q[1] = static_cast<uint8_t>(q1);
}

}  // namespace

bool PackedChunk::PieceBox(size_t piece, double box[6]) const {
  const std::array<float, 6>& block = block_bounds_[piece / kPiecesPerBlock];
  const std::array<uint8_t, 6>& q = piece_boxes_[piece];
  for (int a = 0; a < 3; ++a) {
    if (q[2 * a] > q[2 * a + 1]) return false;
  }
  for (int k = 0; k < 6; ++k) box[k] = PieceSide(block[k & ~1], block[k | 1], q[k]);
  return true;
}

bool QuantiseRange(float range_m, uint16_t* q) {
  // 65 535 steps are 16.38 m: anything longer (or NaN) keeps its float.
  if (!(range_m >= 0.0f && range_m < 17.0f)) return false;
  const int64_t steps = RoundHalfAway(range_m / PackedChunk::kRangeStepM);
  if (steps > std::numeric_limits<uint16_t>::max()) return false;
  *q = static_cast<uint16_t>(steps);
  return static_cast<float>(*q * PackedChunk::kRangeStepM) == range_m;
}

// Positions as int16 grid steps after the chunk's origin (the middle of its
// bounds, in whole steps), if every point is on the grid (its float comes
// back bit for bit) and the chunk spans at most 65 534 steps an axis.
bool PackedChunk::PackOnGrid(const CloudPoint* points, size_t n, PackedChunk* chunk,
                             ChunkPayload* payload) {
  const auto& b = chunk->bounds_;
  for (int k = 0; k < 3; ++k) {
    if (!(std::abs(b[2 * k]) < 8e3 && std::abs(b[2 * k + 1]) < 8e3)) return false;
    const int64_t lo = GridIndex(static_cast<float>(b[2 * k]));
    const int64_t hi = GridIndex(static_cast<float>(b[2 * k + 1]));
    if (hi - lo > 2 * int64_t{std::numeric_limits<int16_t>::max()}) return false;
    chunk->origin_mm_[k] = lo + (hi - lo) / 2;
  }
  payload->xyz_mm.resize(3 * n);
  for (size_t i = 0; i < n; ++i) {
    const float v[3] = {points[i].x, points[i].y, points[i].z};
    for (int k = 0; k < 3; ++k) {
      const int64_t g = GridIndex(v[k]);
      const int64_t q = g - chunk->origin_mm_[k];
      if (GridPosition(g) != v[k] || q < std::numeric_limits<int16_t>::min() ||
          q > std::numeric_limits<int16_t>::max()) {
        payload->xyz_mm.clear();
        payload->xyz_mm.shrink_to_fit();
        return false;
      }
      payload->xyz_mm[3 * i + k] = static_cast<int16_t>(q);
    }
  }
  return true;
}

void PackedChunk::TakeCensus(const CloudPoint* points, size_t n, PackedChunk* chunk) {
  // Counted in a dense array over the chunk's bounds in cubes (a room's
  // slab: about 20 x 10 x 5), indexed x-major so that its cubes come out in
  // key order. Consecutive points change cube every two or so (measured on
  // the lab drive's chunks), so neither runs nor a hash table's probes beat
  // it; a chunk spanning more than 2^18 cubes is counted in a sorted copy.
  if (n == 0) return;
  const auto& b = chunk->bounds_;
  int32_t lo[3];
  size_t dim[3];
  size_t volume = 1;
  for (int a = 0; a < 3; ++a) {
    lo[a] = CellIndex(static_cast<float>(b[2 * a]));  // the bounds are points' floats
    dim[a] = static_cast<size_t>(CellIndex(static_cast<float>(b[2 * a + 1])) - lo[a]) + 1;
    volume *= dim[a];
  }
  // A NaN coordinate (which the bounds skip) falls outside them: then the
  // sorted copy, where it has a key like any other.
  std::vector<uint32_t> counts;
  bool dense = volume <= (size_t{1} << 18);
  if (dense) {
    counts.assign(volume, 0);
    for (size_t i = 0; i < n && dense; ++i) {
      const size_t x = static_cast<size_t>(CellIndex(points[i].x) - lo[0]);
      const size_t y = static_cast<size_t>(CellIndex(points[i].y) - lo[1]);
      const size_t z = static_cast<size_t>(CellIndex(points[i].z) - lo[2]);
      dense = x < dim[0] && y < dim[1] && z < dim[2];
      if (dense) ++counts[(x * dim[1] + y) * dim[2] + z];
    }
  }
  if (dense) {
    for (size_t k = 0; k < volume; ++k) {
      if (counts[k] == 0) continue;
      const size_t z = k % dim[2], y = k / dim[2] % dim[1], x = k / dim[2] / dim[1];
      chunk->cell_keys_.push_back(CellKeyOf(lo[0] + static_cast<int32_t>(x),
                                            lo[1] + static_cast<int32_t>(y),
                                            lo[2] + static_cast<int32_t>(z)));
      chunk->cell_counts_.push_back(counts[k]);
    }
  } else {
    std::vector<uint64_t> keys(n);
    for (size_t i = 0; i < n; ++i) {
      const float v[3] = {points[i].x, points[i].y, points[i].z};
      keys[i] = CellKey(v);
    }
    std::sort(keys.begin(), keys.end());
    for (size_t i = 0; i < n; ++i) {
      if (i == 0 || keys[i] != keys[i - 1]) {
        chunk->cell_keys_.push_back(keys[i]);
        chunk->cell_counts_.push_back(0);
      }
      ++chunk->cell_counts_.back();
    }
  }
  chunk->cell_keys_.shrink_to_fit();
  chunk->cell_counts_.shrink_to_fit();
}

std::shared_ptr<const PackedChunk> PackedChunk::Pack(const CloudPoint* points, size_t n,
                                                     CloudPager* pager) {
  std::shared_ptr<PackedChunk> chunk(new PackedChunk());
  auto payload = std::make_shared<ChunkPayload>();
  chunk->size_ = n;
  chunk->last_time_ns_ = n > 0 ? points[0].time_ns : 0;
  payload->dt_ns.resize(n);
  payload->beam.resize(n);
  payload->range_q.resize(n);
  bool quantised = true;
  auto& b = chunk->bounds_;
  b = EmptyBounds();
  for (size_t i = 0; i < n; ++i) {
    const CloudPoint& p = points[i];
    ExtendBounds(&b, p);
    payload->beam[i] = p.beam;
    chunk->max_range_m_ = std::max(chunk->max_range_m_, p.range_m);
    chunk->last_time_ns_ = std::max(chunk->last_time_ns_, p.time_ns);
    if (quantised && !QuantiseRange(p.range_m, &payload->range_q[i])) quantised = false;
    // A new run where the scan, the source or the flags change, or where the
    // time goes back or too far for 32 bits of nanoseconds.
    const ScanRun* run = chunk->runs_.empty() ? nullptr : &chunk->runs_.back();
    const bool same = run != nullptr && run->scan == p.scan && run->pose_source == p.pose_source &&
                      run->flags == p.flags && p.time_ns >= run->time0_ns &&
                      p.time_ns - run->time0_ns <= std::numeric_limits<uint32_t>::max();
    if (!same) {
      chunk->runs_.push_back({static_cast<uint32_t>(i), p.scan, p.time_ns, p.pose_source, p.flags});
      run = &chunk->runs_.back();
    }
    payload->dt_ns[i] = static_cast<uint32_t>(p.time_ns - run->time0_ns);
  }
  if (!quantised) {
    payload->range_q.clear();
    payload->range_q.shrink_to_fit();
    payload->range_f.resize(n);
    for (size_t i = 0; i < n; ++i) payload->range_f[i] = points[i].range_m;
  }
  chunk->ranges_quantised_ = quantised;
  chunk->positions_on_grid_ = n > 0 && PackOnGrid(points, n, chunk.get(), payload.get());
  if (!chunk->positions_on_grid_) {
    payload->xyz.resize(3 * n);
    for (size_t i = 0; i < n; ++i) {
      payload->xyz[3 * i] = points[i].x;
      payload->xyz[3 * i + 1] = points[i].y;
      payload->xyz[3 * i + 2] = points[i].z;
    }
  }
  chunk->runs_.shrink_to_fit();
  chunk->block_bounds_.resize((n + kBlockPoints - 1) / kBlockPoints);
  for (size_t k = 0; k < chunk->block_bounds_.size(); ++k) {
    constexpr float kInf = std::numeric_limits<float>::infinity();
    std::array<float, 6> box = {kInf, -kInf, kInf, -kInf, kInf, -kInf};
    for (size_t i = k * kBlockPoints; i < std::min(n, (k + 1) * kBlockPoints); ++i) {
      const float v[3] = {points[i].x, points[i].y, points[i].z};
      for (int a = 0; a < 3; ++a) {
        box[2 * a] = std::min(box[2 * a], v[a]);
        box[2 * a + 1] = std::max(box[2 * a + 1], v[a]);
      }
    }
    chunk->block_bounds_[k] = box;
  }
  chunk->piece_boxes_.resize((n + kPiecePoints - 1) / kPiecePoints);
  for (size_t p = 0; p < chunk->piece_boxes_.size(); ++p) {
    const std::array<float, 6>& block = chunk->block_bounds_[p / kPiecesPerBlock];
    for (int a = 0; a < 3; ++a) {
      float lo = std::numeric_limits<float>::infinity(), hi = -lo;
      for (size_t i = p * kPiecePoints; i < std::min(n, (p + 1) * kPiecePoints); ++i) {
        const float v = a == 0 ? points[i].x : a == 1 ? points[i].y : points[i].z;
        lo = std::min(lo, v);  // NaN is passed over, as in the block's box.
        hi = std::max(hi, v);
      }
      QuantisePiece(block[2 * a], block[2 * a + 1], lo, hi, &chunk->piece_boxes_[p][2 * a]);
    }
  }
  TakeCensus(points, n, chunk.get());
  chunk->first_time_ns_ = n > 0 ? points[0].time_ns : 0;
  if (n == 0) chunk->last_time_ns_ = 0;
  chunk->payload_bytes_ = payload->bytes();
  chunk->payload_ = std::move(payload);
  chunk->pager_ = pager;
  if (pager != nullptr) pager->Add(chunk.get());
  return chunk;
}

PackedChunk::~PackedChunk() {
  if (pager_ != nullptr) pager_->Remove(this);
}

std::shared_ptr<const ChunkPayload> PackedChunk::Pin() const {
  std::shared_ptr<const ChunkPayload> p;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    p = payload_;
  }
  if (p != nullptr) {
    // Outside the chunk's lock: the lock order is the pager's, then a chunk's.
    if (pager_ != nullptr) pager_->Touch(this);
    return p;
  }
  return pager_->Unpack(this);
}

std::shared_ptr<const ChunkPayload> PackedChunk::PinBlockPositions(size_t block, size_t* first) const {
  return BlockPositions(PinPositions(), block, first);
}

PackedChunk::PositionsPin PackedChunk::PinPositions() const {
  std::shared_ptr<const ChunkPayload> p;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    p = payload_;
  }
  if (p != nullptr) {  // Always so without a pager.
    if (pager_ != nullptr) pager_->Touch(this);
    return {std::move(p), nullptr};
  }
  auto bytes = pager_->PinPacked(this);
  if (bytes == nullptr) return {Pin(), nullptr};  // Unpacked meanwhile by another thread.
  return {nullptr, std::move(bytes)};
}

std::shared_ptr<const ChunkPayload> PackedChunk::BlockPositions(const PositionsPin& pin,
                                                                size_t block, size_t* first,
                                                                size_t points) const {
  if (pin.payload != nullptr) {
    *first = 0;
    return pin.payload;
  }
  *first = block * kBlockPoints;
  return Unpack(*pin.packed, block, points);
}

std::shared_ptr<ChunkPayload> PackedChunk::Unpack(const std::vector<uint8_t>& bytes, size_t block,
                                                  size_t points) const {
  auto p = std::make_shared<ChunkPayload>();
  std::string error;
  const bool ok =
      block == kWholeChunk
          ? DecodeSegments(bytes, segment_ends_, size_, positions_on_grid_, ranges_quantised_, 0,
                           (size_ + kCodecSegmentPoints - 1) / kCodecSegmentPoints, false, p.get(),
                           &error)
          : DecodeBlockPositions(bytes, segment_ends_, size_, positions_on_grid_, block, p.get(),
                                 &error, points);
  if (!ok) {
    // Bytes this process compressed (and maybe wrote to and read back from
    // its own unnamed file): a failure is a fault of the machine or ours,
    // and a cloud with holes would be worse than stopping.
    std::fprintf(stderr, "sweepscan: a compressed cloud chunk does not decode: %s\n", error.c_str());
    std::abort();
  }
  return p;
}

bool PackedChunk::resident() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return payload_ != nullptr || packed_ != nullptr;
}

bool PackedChunk::unpacked() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return payload_ != nullptr;
}

size_t PackedChunk::packed_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return packed_bytes_;
}

void PackedChunk::DecodeFrom(const PackedChunk& chunk, const ChunkPayload& payload, size_t begin,
                             size_t end, std::vector<CloudPoint>* out) {
  const auto& runs = chunk.runs_;
  // The run holding `begin`: the last one whose first point is <= begin.
  size_t r = std::upper_bound(runs.begin(), runs.end(), begin,
                              [](size_t i, const ScanRun& run) { return i < run.first; }) -
             runs.begin() - 1;
  for (size_t i = begin; i < end; ++i) {
    while (r + 1 < runs.size() && runs[r + 1].first <= i) ++r;
    CloudPoint p;
    float xyz[3];
    chunk.PositionOf(payload, i, xyz);
    p.x = xyz[0];
    p.y = xyz[1];
    p.z = xyz[2];
    p.range_m = chunk.RangeOf(payload, i);
    p.time_ns = chunk.TimeOf(payload, i, r);
    p.scan = runs[r].scan;
    p.beam = payload.beam[i];
    p.pose_source = runs[r].pose_source;
    p.flags = runs[r].flags;
    out->push_back(p);
  }
}

void PackedChunk::Decode(std::vector<CloudPoint>* out) const {
  const auto payload = Pin();
  out->reserve(out->size() + size_);
  DecodeFrom(*this, *payload, 0, size_, out);
}

}  // namespace sweepscan
