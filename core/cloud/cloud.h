// The assembled 3D cloud: world points with their provenance, stored in
// fixed-size chunks. The processing thread appends to the open chunk; when
// it is full it is sealed (made immutable) and published. Readers (the
// viewer on the GUI thread, exporters) take a snapshot of the sealed chunks
// under a mutex and then read them without locks: a sealed chunk never
// changes, so a viewer uploads each one to the GPU exactly once.
#ifndef SWEEPSCAN_CORE_CLOUD_CLOUD_H_
#define SWEEPSCAN_CORE_CLOUD_CLOUD_H_

#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "core/common/rounding.h"
#include "core/common/time.h"

namespace sweepscan {

// The cloud's position grid. Assembled points lie on a 1 mm grid in the
// world frame, as a LAS file at scale 0.001 holds them: a coordinate is
// the float nearest to k / 1000 metres for a whole k. The X4's noise is
// about 10 mm, so rounding to 1 mm (uniform, 0.29 mm RMS an axis) loses
// nothing it measured, and a point on the grid packs into 16 bits against
// its chunk's origin (packed_chunk.h), exactly: the app's store, the CLI's
// PLY and LAS and the app's exports hold the same numbers.
// (A multiplication, not a division by 1000: the app decodes whole chunks
// with it. Both give the same float for every |k| <= 8 192 000, and
// GridIndex gives k back from it: checked for every one of them.)
constexpr double kGridStepM = 0.001;
// The grid step nearest to `v` (finite, |v| < 9e15 mm).
inline int64_t GridIndex(float v) { return RoundHalfAway(static_cast<double>(v) * 1000.0); }
// Grid step `k` in metres: (float)((double)k * 0.001).
inline float GridPosition(int64_t k) { return static_cast<float>(static_cast<double>(k) * kGridStepM); }
inline float SnapToGrid(float v) {
  return std::isfinite(v) && std::abs(v) < 1e9f ? GridPosition(GridIndex(v)) : v;
}

// 32 bytes. Position in float (metres) on the grid above: 1 mm steps, held
// distinctly as floats within +-8 km (a float's step there is 1 mm).
struct CloudPoint {
  float x = 0.0f, y = 0.0f, z = 0.0f;
  float range_m = 0.0f;
  int64_t time_ns = 0;   // robot time of the sample
  uint32_t scan = 0;     // scan (revolution) index
  uint16_t beam = 0;     // sample index within the scan
  uint8_t pose_source = 0;  // PoseSource of the pose that placed it
  uint8_t flags = 0;     // bit 0: placed without deskew
};
static_assert(sizeof(CloudPoint) == 32, "CloudPoint layout");

using CloudChunk = std::vector<CloudPoint>;

class PackedChunk;
class CloudPager;

// What a cloud holds at one moment, cheap to take (shared pointers to the
// sealed chunks and a copy of the open chunk's points, at most a chunk) and
// decoded later on any thread: a job exports or evaluates millions of points
// without the GUI waiting while they are unpacked or read back from disk.
struct CloudSnapshotRef {
  std::vector<std::shared_ptr<const PackedChunk>> sealed;
  std::vector<CloudPoint> open;
  size_t size() const;
  // Any thread: every point, sealed then open, decoded. 32 bytes a point:
  // readers of a whole cloud (export, evaluation, pass split, plan) use
  // ForEachChunk, which holds one chunk's points at a time.
  std::vector<CloudPoint> Flatten() const;
  // Any thread: every point in order, a chunk at a time (at most a chunk
  // decoded at once); `fn` returns false to stop. False if it stopped.
  bool ForEachChunk(const std::function<bool(const CloudPoint* points, size_t n)>& fn) const;
};

// Sealed chunks are packed (core/cloud/packed_chunk.h: 14 bytes a point
// instead of CloudPoint's 32, every attribute exact) and may be paged out
// to disk under the pager's memory budget (core/cloud/cloud_pager.h).
class PointChunks {
 public:
  // `pager`: null for CloudPager::Default().
  explicit PointChunks(size_t chunk_capacity = 65536, CloudPager* pager = nullptr);
  ~PointChunks();

  // Processing thread only.
  void Append(const CloudPoint& p) {
    open_.push_back(p);
    if (open_.size() >= chunk_capacity_) Seal();
  }
  // Publishes the open chunk even if not full (end of a recording, or a
  // viewer tick that wants the newest points).
  void Seal();

  // Any thread: the sealed chunks so far (cheap: copies shared pointers).
  std::vector<std::shared_ptr<const PackedChunk>> SealedChunks() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return sealed_;
  }
  size_t sealed_point_count() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return sealed_points_;
  }
  // Processing thread only: the open (growing) chunk. A reader that follows
  // the cloud incrementally copies the sealed chunks it has not seen and then
  // the open chunk's new tail; when the open chunk is sealed it becomes the
  // next sealed chunk with the same points in the same order.
  const CloudChunk& open_chunk() const { return open_; }
  // Processing thread only: everything, sealed and open, decoded.
  std::vector<CloudPoint> Flatten() const;
  // Processing thread only: the same, to be decoded later (CloudSnapshotRef).
  CloudSnapshotRef Snapshot() const;

 private:
  size_t chunk_capacity_;
  CloudPager* pager_;
  CloudChunk open_;
  mutable std::mutex mutex_;
  std::vector<std::shared_ptr<const PackedChunk>> sealed_;
  size_t sealed_points_ = 0;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_CLOUD_H_
