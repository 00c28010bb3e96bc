// One neighbour structure per evaluation: k nearest neighbours of the
// points of a cloud, built once and shared by outlier removal and density.
//
// Build() copies the points in a spatial order (a 30-bit Morton code of the
// bounding box, radix-sorted), so that neighbours are near in memory and
// queries in that order walk the structure coherently. Three backends, by
// measurement on scanner clouds (docs/performance.md, "Evaluation"):
//   kBatched    a kd-tree over the Morton codes whose range queries answer a
//               group of neighbouring points at once (batched_tree.h; the
//               default);
//   kKdTree     nanoflann's KDTreeSingleIndexAdaptor;
//   kVoxelGrid  a hash grid with cells sized from the data, searched in
//               rings of cells until the k-th neighbour is provably found;
//   kPclKdTree  PCL's KdTreeFLANN (what the evaluation used before).
// All four are exact: the same k distances for every query.
//
// Queries are const and may run on many threads at once.
#ifndef SWEEPSCAN_CORE_EVALUATION_NEIGHBOURS_H_
#define SWEEPSCAN_CORE_EVALUATION_NEIGHBOURS_H_

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace sweepscan {

enum class NeighbourBackend { kKdTree, kVoxelGrid, kPclKdTree, kBatched };
const char* NeighbourBackendName(NeighbourBackend backend);

class NeighbourIndex {
 public:
  NeighbourIndex();
  ~NeighbourIndex();
  NeighbourIndex(const NeighbourIndex&) = delete;
  NeighbourIndex& operator=(const NeighbourIndex&) = delete;

  // Runs body(block, begin, end) over the blocks of [0, n); false if
  // cancelled. Build() uses it to copy and to build the kd-tree's pieces
  // on several threads; null runs everything here.
  using ParallelFor =
      std::function<bool(size_t n, size_t block, const std::function<void(size_t, size_t, size_t)>&)>;

  // At most 2^32 - 1 points, all finite. The kd-tree is a forest: one tree
  // per run of 2^18 Morton-sorted points (spatially compact), built in
  // parallel, a query searching its own piece first and then every piece
  // whose bounding box is nearer than its k-th neighbour so far. Returns
  // false if cancelled (the index is then unusable).
  bool Build(const std::vector<Eigen::Vector3f>& points,
             NeighbourBackend backend = NeighbourBackend::kBatched,
             const ParallelFor& parallel_for = nullptr);

  size_t size() const { return order_.size(); }
  // Sorted position s -> index in the points given to Build().
  const std::vector<uint32_t>& order() const { return order_; }
  // The point at sorted position s.
  const float* sorted_point(size_t s) const { return &xyz_[3 * s]; }

  // The k nearest points to q (a query point may be one of the points; it is
  // then among the results at distance 0), nearest first: sorted positions
  // in idx, squared distances in d2. Returns how many (min(k, size())).
  // `near` is a sorted position near q (for the kd-tree's first piece),
  // or -1.
  int Knn(const float* q, int k, uint32_t* idx, float* d2, int64_t near = -1) const;

  // The nearest point to q among those at sorted positions s with
  // accept(s); false if none. Exact, one walk of the structure.
  bool NearestWhere(const float* q, const std::function<bool(uint32_t)>& accept, uint32_t* idx,
                    float* d2, int64_t near = -1) const;

  // The k nearest of every point at sorted positions [begin, end) (the
  // point itself included), k entries a point in idx and d2, in Morton
  // order (coherent walks through the tree). k <= size().
  void KnnRange(size_t begin, size_t end, int k, uint32_t* idx, float* d2) const;

  // Memory held, bytes.
  size_t MemoryBytes() const;

 private:
  struct Impl;
  std::vector<uint32_t> order_;
  std::vector<float> xyz_;  // sorted copy, x y z interleaved
  std::unique_ptr<Impl> impl_;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_EVALUATION_NEIGHBOURS_H_
