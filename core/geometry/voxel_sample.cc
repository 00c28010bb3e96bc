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
  cell_.fill(first_cell_);
  inv_cell_.fill(1.0 / first_cell_);
  next_axis_ = 0;
  ++generation_;
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
  for (size_t k = 0; k < n; ++k) {
    const float* p = xyz + 3 * k;
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
    const auto [it, inserted] = reps_.try_emplace(Key(p), Rep{source, index[k], {p[0], p[1], p[2]}});
    if (inserted && taken != nullptr) taken->push_back(static_cast<uint32_t>(k));
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
  std::unordered_map<uint64_t, Rep> merged;
  merged.reserve(reps_.size());
  for (const auto& [old_key, rep] : reps_) {
    const auto [it, inserted] = merged.try_emplace(Key(rep.xyz), rep);
    // Of two representatives, the one offered first stays, whatever order
    // the hash map visits them in.
    if (!inserted && (rep.source < it->second.source ||
                      (rep.source == it->second.source && rep.index < it->second.index))) {
      it->second = rep;
    }
  }
  reps_.swap(merged);
  ++generation_;
}

bool VoxelSample::Holds(uint32_t source, uint32_t index, const float* xyz) const {
  const auto it = reps_.find(Key(xyz));
  return it != reps_.end() && it->second.source == source && it->second.index == index;
}

}  // namespace sweepscan
