#include "core/cloud/cloud.h"

#include "core/cloud/cloud_pager.h"
#include "core/cloud/packed_chunk.h"

namespace sweepscan {

PointChunks::PointChunks(size_t chunk_capacity, CloudPager* pager)
    : chunk_capacity_(chunk_capacity), pager_(pager != nullptr ? pager : &CloudPager::Default()) {
  open_.reserve(chunk_capacity_);
}

PointChunks::~PointChunks() = default;

void PointChunks::Seal() {
  if (open_.empty()) return;
  auto chunk = PackedChunk::Pack(open_.data(), open_.size(), pager_);
  open_.clear();  // Keeps its capacity: the next chunk fills the same buffer.
  std::lock_guard<std::mutex> lock(mutex_);
  sealed_points_ += chunk->size();
  sealed_.push_back(std::move(chunk));
}

std::vector<CloudPoint> PointChunks::Flatten() const { return Snapshot().Flatten(); }

CloudSnapshotRef PointChunks::Snapshot() const {
  CloudSnapshotRef s;
  s.sealed = SealedChunks();
  s.open.assign(open_.begin(), open_.end());
  return s;
}

size_t CloudSnapshotRef::size() const {
  size_t n = open.size();
  for (const auto& c : sealed) n += c->size();
  return n;
}

bool CloudSnapshotRef::ForEachChunk(
    const std::function<bool(const CloudPoint*, size_t)>& fn) const {
  std::vector<CloudPoint> points;
  for (const auto& c : sealed) {
    points.clear();
    c->Decode(&points);
    if (!fn(points.data(), points.size())) return false;
  }
  return open.empty() || fn(open.data(), open.size());
}

std::vector<CloudPoint> CloudSnapshotRef::Flatten() const {
  std::vector<CloudPoint> all;
  all.reserve(size());
  for (const auto& c : sealed) c->Decode(&all);
  all.insert(all.end(), open.begin(), open.end());
  return all;
}

}  // namespace sweepscan
