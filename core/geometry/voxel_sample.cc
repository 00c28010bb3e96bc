#include "core/geometry/voxel_sample.h"

#include <algorithm>
#include <cmath>

namespace sweepscan {
namespace {

constexpr int64_t kHalfRange = int64_t{1} << 20;  // 21 bits an axis
constexpr int kMaxDoublings = 60;                  // a cell wider than any cloud

}  // namespace

VoxelSample::VoxelSample(size_t budget, double first_cell)
    : budget_(std::max<size_t>(budget, 1)), first_cell_(first_cell) {
  Clear();
}

void VoxelSample::Clear() {
  reps_.clear();
  Rehash(1024);
  cell_.fill(first_cell_);
  inv_cell_.fill(1.0 / first_cell_);
  next_axis_ = 0;
  ++generation_;
}

size_t VoxelSample::Slot(uint64_t key) const {
  // Fibonacci hashing (the product's top bits): the key's bits are three
  // packed cell indices, whose low bits alone would cluster.
  size_t slot = static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
  while (keys_[slot] != kEmpty && keys_[slot] != key) slot = (slot + 1) & mask_;
  return slot;
}

void VoxelSample::Rehash(size_t capacity) {
  size_t n = 1024;
  int bits = 10;
  for (; n < capacity; n *= 2) ++bits;
  keys_.assign(n, kEmpty);
  slots_.assign(n, 0);
  mask_ = n - 1;
  shift_ = 64 - bits;
  for (size_t r = 0; r < reps_.size(); ++r) {
    const uint64_t key = Key(reps_[r].xyz);
    const size_t slot = Slot(key);
    keys_[slot] = key;
    slots_[slot] = static_cast<uint32_t>(r);
  }
}

void VoxelSample::SetBudget(size_t budget) {
  budget_ = std::max<size_t>(budget, 1);
  Fit();
}

uint64_t VoxelSample::Key(const float* xyz) const {
  uint64_t key = 0;
  for (int a = 0; a < 3; ++a) {
    const double c = std::floor(static_cast<double>(xyz[a]) * inv_cell_[a]);
    const int64_t i = static_cast<int64_t>(std::clamp(c, -static_cast<double>(kHalfRange),
                                                      static_cast<double>(kHalfRange - 1)));
    key = (key << 21) | static_cast<uint64_t>(i + kHalfRange);
  }
  return key;
}

void VoxelSample::Offer(uint32_t source, const float* xyz, const uint32_t* index, size_t n,
                        std::vector<uint32_t>* taken) {
  // Consecutive points of a scan line mostly share a cell once cells are
  // wider than their spacing: the second of two in one cell cannot take it
  // (the first did, or found it taken), so it costs no lookup.
  uint64_t last = ~uint64_t{0};
  for (size_t k = 0; k < n; ++k) {
    const float* p = xyz + 3 * k;
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
    const uint64_t key = Key(p);
    if (key == last) continue;
    last = key;
    const size_t slot = Slot(key);
    if (keys_[slot] == key) continue;
    keys_[slot] = key;
    slots_[slot] = static_cast<uint32_t>(reps_.size());
    reps_.push_back(Rep{source, index[k], {p[0], p[1], p[2]}});
    if (taken != nullptr) taken->push_back(static_cast<uint32_t>(k));
    if (2 * reps_.size() > keys_.size()) Rehash(2 * keys_.size());
  }
}

bool VoxelSample::Fit() {
  bool merged = false;
  for (int guard = 0; reps_.size() > budget_ && guard < 3 * kMaxDoublings; ++guard) {
    Merge();
    merged = true;
  }
  return merged;
}

void VoxelSample::Merge() {
  const int a = next_axis_;
  next_axis_ = (next_axis_ + 1) % 3;
  cell_[a] *= 2.0;
  inv_cell_[a] = 1.0 / cell_[a];
  // Of two representatives in one merged cell, the one offered first stays
  // (smallest (source, index)). reps_ is in the order they were taken,
  // which is offer order when every source is offered in order; compared
  // anyway, so that the rule does not rest on it.
  std::vector<Rep> old;
  old.swap(reps_);
  keys_.assign(keys_.size(), kEmpty);
  for (const Rep& rep : old) {
    const uint64_t key = Key(rep.xyz);
    const size_t slot = Slot(key);
    if (keys_[slot] != key) {
      keys_[slot] = key;
      slots_[slot] = static_cast<uint32_t>(reps_.size());
      reps_.push_back(rep);
    } else {
      Rep& kept = reps_[slots_[slot]];
      if (rep.source < kept.source || (rep.source == kept.source && rep.index < kept.index)) kept = rep;
    }
  }
  ++generation_;
}

bool VoxelSample::Holds(uint32_t source, uint32_t index, const float* xyz) const {
  const uint64_t key = Key(xyz);
  const size_t slot = Slot(key);
  if (keys_[slot] != key) return false;
  const Rep& rep = reps_[slots_[slot]];
  return rep.source == source && rep.index == index;
}

}  // namespace sweepscan
