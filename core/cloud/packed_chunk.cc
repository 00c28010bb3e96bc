#include "core/cloud/packed_chunk.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/cloud/cloud_pager.h"

namespace sweepscan {

bool QuantiseRange(float range_m, uint16_t* q) {
  if (!(range_m >= 0.0f)) return false;
  const double steps = std::round(range_m / PackedChunk::kRangeStepM);
  if (steps > std::numeric_limits<uint16_t>::max()) return false;
  *q = static_cast<uint16_t>(steps);
  return static_cast<float>(*q * PackedChunk::kRangeStepM) == range_m;
}

std::shared_ptr<const PackedChunk> PackedChunk::Pack(const CloudPoint* points, size_t n,
                                                     CloudPager* pager) {
  std::shared_ptr<PackedChunk> chunk(new PackedChunk());
  auto payload = std::make_shared<ChunkPayload>();
  chunk->size_ = n;
  chunk->last_time_ns_ = n > 0 ? points[0].time_ns : 0;
  payload->xyz.resize(3 * n);
  payload->dt_ns.resize(n);
  payload->beam.resize(n);
  payload->range_q.resize(n);
  bool quantised = true;
  auto& b = chunk->bounds_;
  b = EmptyBounds();
  for (size_t i = 0; i < n; ++i) {
    const CloudPoint& p = points[i];
    payload->xyz[3 * i] = p.x;
    payload->xyz[3 * i + 1] = p.y;
    payload->xyz[3 * i + 2] = p.z;
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
  chunk->runs_.shrink_to_fit();
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
  return pager_->PageIn(this);
}

bool PackedChunk::resident() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return payload_ != nullptr;
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
    p.x = payload.xyz[3 * i];
    p.y = payload.xyz[3 * i + 1];
    p.z = payload.xyz[3 * i + 2];
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
