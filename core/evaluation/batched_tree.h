// A kd-tree over Morton-sorted points that answers "the k nearest of every
// point" a group of neighbouring points at a time.
//
// The tree: a binary radix tree over the points' 48-bit Morton codes. A node
// splits its range where the next code bit flips, which is a midpoint split
// of its cell along x, y or z in turn, so every node is a contiguous range of
// the sorted array (no index indirection) with a tight bounding box. Leaves
// hold at most kLeafSize points; the query groups are the largest nodes of at
// most kGroupSize points.
//
// All k nearest, a group G at a time (KnnRange): with a radius R such that
// every query q in G has its k-th neighbour within R, the candidates are the
// points of the leaves whose box is within R of G's box; every q in G then
// scans the same two or three hundred candidates, laid out as a structure of
// arrays so that the distance loop vectorises. The answer is exact whenever
// q finds k candidates nearer than R: a point outside the candidates is
// farther from G's box, hence from q, than R. R comes from the previous
// group's largest k-th distance (neighbouring groups have similar
// densities), capped by the diagonal of G's box when G holds k points or
// more (its own points are then k points within the diagonal of q); a query
// that finds fewer than k candidates within R (a density change) falls back
// to one ordinary descent of the tree.
//
// Per query, the candidates are first cut to those nearer than the farthest
// of the previous query's k nearest (k real points, so q's k-th neighbour
// is no farther), then to about k + 8 by lowering that bound while k stay
// under it; the k nearest of the 25-40 left are found by ranking (each
// candidate's rank is the number of smaller distances), which has no
// data-dependent branches. An AVX2 kernel (chosen at run time) does eight
// candidates a step; the portable one gives the same answers bit for bit.
// docs/performance.md, "Neighbour structures", has the measurements against
// nanoflann, a hash grid and PCL's KdTreeFLANN.
#ifndef SWEEPSCAN_CORE_EVALUATION_BATCHED_TREE_H_
#define SWEEPSCAN_CORE_EVALUATION_BATCHED_TREE_H_

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace sweepscan {

class BatchedKdTree {
 public:
  static constexpr uint32_t kLeafSize = 16;
  static constexpr uint32_t kGroupSize = 32;
  // Splits from the root to a leaf: 48 on the code's bits, then up to 32
  // halvings of points whose codes are identical.
  static constexpr int kMaxDepth = 48 + 32;
  // A group whose radius holds more points than this (points piled at one
  // place) is answered a query at a time by the ordinary descent.
  static constexpr size_t kMaxCandidates = 4096;

  // xyz: n points, x y z interleaved, sorted by their Morton codes `keys`
  // (ascending, 48 significant bits). Both must outlive the queries; only
  // xyz is read after Build().
  void Build(const float* xyz, const uint64_t* keys, size_t n);

  // The k nearest of q, nearest first (sorted positions and squared
  // distances); returns min(k, n). Exact.
  int Knn(const float* q, int k, uint32_t* idx, float* d2) const;

  // The nearest point with accept(s); false if none. Exact.
  bool NearestWhere(const float* q, const std::function<bool(uint32_t)>& accept, uint32_t* idx,
                    float* d2) const;

  // The k nearest of every point at sorted positions [begin, end), k entries
  // a point, as Knn() would give them (the same distances; among equal
  // distances the order may differ). Exact.
  void KnnRange(size_t begin, size_t end, int k, uint32_t* idx, float* d2) const;

  size_t MemoryBytes() const;
  // The tree's nodes, and the room held for them: the same after Build(),
  // which counts the nodes before it makes them.
  size_t node_count() const { return nodes_.size(); }
  size_t node_capacity() const { return nodes_.capacity(); }
  // Queries of KnnRange calls on this thread so far that needed the
  // fallback descent (for tests and the benchmark's report).
  static size_t ThreadFallbacks();
  // Whether KnnRange uses its AVX2 kernel (when the processor has AVX2);
  // tests compare the two, which give the same answers bit for bit.
  static bool UsesAvx2();
  static void AllowAvx2(bool allow);

 private:
  struct Node {
    float lo[3], hi[3];
    uint32_t begin, end;
    int32_t left = -1, right = -1;  // leaf: both -1
  };
  // Makes node id the parent of left and right (its box theirs); returns id.
  int32_t Join(int32_t id, int32_t left, int32_t right);
  int32_t BuildNode(const uint64_t* keys, uint32_t begin, uint32_t end, int bit);
  // Where BuildNode splits [begin, end), splitting on bit `bit` or below:
  // the split position (its children split on *child_bit and below), or
  // end for a leaf.
  static uint32_t SplitOf(const uint64_t* keys, uint32_t begin, uint32_t end, int bit,
                          int* child_bit);
  static size_t CountNodes(const uint64_t* keys, uint32_t begin, uint32_t end, int bit);
  // The nearest-first descent shared by Knn and NearestWhere: visit(s, d2)
  // for every point of the leaves nearer than worst().
  template <class Worst, class Visit>
  void Descend(const float* q, const Worst& worst, const Visit& visit) const;

  const float* xyz_ = nullptr;
  size_t n_ = 0;
  std::vector<Node> nodes_;
  std::vector<uint32_t> groups_;       // node indices, in sorted order
  std::vector<uint32_t> group_begin_;  // their first sorted positions
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_EVALUATION_BATCHED_TREE_H_
