// nanoflann and PCL's KdTreeFLANN live in this translation unit only.
#include "core/evaluation/neighbours.h"

#include "core/evaluation/batched_tree.h"
#include "core/evaluation/k_best.h"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <nanoflann.hpp>

namespace sweepscan {
namespace {

constexpr int kMortonBits = 16;  // per axis: 48-bit keys, 1.5 mm cells at 100 m extent

// Spreads the low 16 bits of v to every third bit.
uint64_t Spread(uint64_t v) {
  v &= 0xFFFF;
  v = (v | (v << 16)) & 0x0000FF0000FFull;
  v = (v | (v << 8)) & 0x00F00F00F00Full;
  v = (v | (v << 4)) & 0x0C30C30C30C3ull;
  v = (v | (v << 2)) & 0x249249249249ull;
  return v;
}

uint64_t Morton(uint32_t x, uint32_t y, uint32_t z) {
  return Spread(x) | (Spread(y) << 1) | (Spread(z) << 2);
}

// LSD radix sort of (key, index) by the low 48 bits of key, 12 bits a pass.
void RadixSort(std::vector<uint64_t>* keys, std::vector<uint32_t>* index) {
  const size_t n = keys->size();
  std::vector<uint64_t> k2(n);
  std::vector<uint32_t> i2(n);
  constexpr int kDigit = 12;
  constexpr size_t kBuckets = size_t{1} << kDigit;
  std::vector<size_t> count(kBuckets);
  for (int shift = 0; shift < 3 * kMortonBits; shift += kDigit) {
    std::fill(count.begin(), count.end(), 0);
    for (size_t i = 0; i < n; ++i) ++count[((*keys)[i] >> shift) & (kBuckets - 1)];
    size_t sum = 0;
    for (size_t& c : count) {
      const size_t t = c;
      c = sum;
      sum += t;
    }
    for (size_t i = 0; i < n; ++i) {
      const size_t pos = count[((*keys)[i] >> shift) & (kBuckets - 1)]++;
      k2[pos] = (*keys)[i];
      i2[pos] = (*index)[i];
    }
    keys->swap(k2);
    index->swap(i2);
  }
}

// nanoflann's view of one piece of the sorted copy.
struct FlatCloud {
  const float* xyz = nullptr;
  size_t n = 0;
  size_t kdtree_get_point_count() const { return n; }
  float kdtree_get_pt(uint32_t i, size_t dim) const { return xyz[3 * i + dim]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, FlatCloud>,
                                                   FlatCloud, 3, uint32_t>;

// Hash grid over the Morton-sorted points: a cell is a Morton prefix, so its
// points are contiguous.
struct Grid {
  int shift = 0;                 // cell = key >> (3 * shift)
  double cell_m = 0.0;           // edge length
  Eigen::Vector3d origin;        // of quantised coordinates
  double quantum = 0.0;          // metres per quantised step
  std::vector<uint64_t> table_key;  // open addressing; ~0 = empty
  std::vector<uint32_t> table_begin, table_end;
  uint64_t mask = 0;
  uint32_t max_cell = 0;         // cells per axis - 1

  static uint64_t Hash(uint64_t k) {
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdull;
    k ^= k >> 33;
    return k;
  }
  void Insert(uint64_t cell, uint32_t begin, uint32_t end) {
    uint64_t h = Hash(cell) & mask;
    while (table_key[h] != ~uint64_t{0}) h = (h + 1) & mask;
    table_key[h] = cell;
    table_begin[h] = begin;
    table_end[h] = end;
  }
  bool Find(uint64_t cell, uint32_t* begin, uint32_t* end) const {
    uint64_t h = Hash(cell) & mask;
    while (true) {
      const uint64_t k = table_key[h];
      if (k == cell) {
        *begin = table_begin[h];
        *end = table_end[h];
        return true;
      }
      if (k == ~uint64_t{0}) return false;
      h = (h + 1) & mask;
    }
  }
};


// nanoflann result set over the forest: indices offset by the piece's start.
struct ForestResult {
  KBest* best;
  uint32_t offset;
  float worstDist() const { return best->Worst(); }
  bool addPoint(float d, uint32_t i) {
    best->Add(d, i + offset);
    return true;
  }
  bool full() const { return best->n == best->k; }
};

constexpr int kPieceBits = 18;  // 262 144 points a kd-tree piece

// nanoflann result set: the nearest accepted point.
struct NearestAccepted {
  const std::function<bool(uint32_t)>* accept;
  uint32_t offset;
  float best = std::numeric_limits<float>::max();
  uint32_t index = 0;
  bool found = false;
  float worstDist() const { return best; }
  bool addPoint(float d, uint32_t i) {
    if (d < best && (*accept)(i + offset)) {
      best = d;
      index = i + offset;
      found = true;
    }
    return true;
  }
  bool full() const { return found; }
};

struct Piece {
  FlatCloud cloud;
  std::unique_ptr<KdTree> tree;
  Eigen::Vector3f lo, hi;
};

}  // namespace

const char* NeighbourBackendName(NeighbourBackend backend) {
  switch (backend) {
    case NeighbourBackend::kKdTree: return "nanoflann kd-tree";
    case NeighbourBackend::kVoxelGrid: return "voxel hash grid";
    case NeighbourBackend::kPclKdTree: return "PCL KdTreeFLANN";
    case NeighbourBackend::kBatched: return "batched Morton kd-tree";
  }
  return "?";
}

struct NeighbourIndex::Impl {
  NeighbourBackend backend = NeighbourBackend::kKdTree;
  std::vector<Piece> pieces;
  Grid grid;
  pcl::KdTreeFLANN<pcl::PointXYZ> flann;
  BatchedKdTree batched;
  size_t extra_bytes = 0;

  int GridKnn(const std::vector<float>& xyz, const float* q, int k, uint32_t* idx,
              float* d2) const;
};

NeighbourIndex::NeighbourIndex() : impl_(std::make_unique<Impl>()) {}
NeighbourIndex::~NeighbourIndex() = default;

bool NeighbourIndex::Build(const std::vector<Eigen::Vector3f>& points, NeighbourBackend backend,
                           const ParallelFor& parallel_for_in) {
  const ParallelFor parallel_for =
      parallel_for_in ? parallel_for_in
                      : ParallelFor([](size_t n, size_t block,
                                       const std::function<void(size_t, size_t, size_t)>& body) {
                          for (size_t b = 0, begin = 0; begin < n; ++b, begin += block) {
                            body(b, begin, std::min(n, begin + block));
                          }
                          return true;
                        });
  impl_ = std::make_unique<Impl>();
  impl_->backend = backend;
  const size_t n = points.size();
  assert(n < std::numeric_limits<uint32_t>::max());
  order_.resize(n);
  xyz_.clear();
  if (n == 0) return true;
  Eigen::Vector3f lo = points[0], hi = points[0];
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double extent = std::max(1e-6, static_cast<double>((hi - lo).maxCoeff()));
  const double steps = static_cast<double>((uint32_t{1} << kMortonBits) - 1);
  const double quantum = extent / steps;
  std::vector<uint64_t> keys(n);
  constexpr size_t kBlock = 1 << 16;
  if (!parallel_for(n, kBlock, [&](size_t, size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
          const Eigen::Vector3d c = (points[i] - lo).cast<double>() / quantum;
          keys[i] = Morton(static_cast<uint32_t>(std::min(steps, c.x())),
                           static_cast<uint32_t>(std::min(steps, c.y())),
                           static_cast<uint32_t>(std::min(steps, c.z())));
          order_[i] = static_cast<uint32_t>(i);
        }
      })) {
    return false;
  }
  RadixSort(&keys, &order_);
  xyz_.resize(3 * n);
  if (!parallel_for(n, kBlock, [&](size_t, size_t begin, size_t end) {
        for (size_t s = begin; s < end; ++s) {
          const Eigen::Vector3f& p = points[order_[s]];
          xyz_[3 * s] = p.x();
          xyz_[3 * s + 1] = p.y();
          xyz_[3 * s + 2] = p.z();
        }
      })) {
    return false;
  }
  switch (backend) {
    case NeighbourBackend::kBatched:
      impl_->batched.Build(xyz_.data(), keys.data(), n);
      impl_->extra_bytes = impl_->batched.MemoryBytes();
      break;
    case NeighbourBackend::kKdTree: {
      keys = std::vector<uint64_t>();
      const size_t piece = size_t{1} << kPieceBits;
      impl_->pieces.resize((n + piece - 1) / piece);
      // One piece a block: each builds in about 60 ms.
      if (!parallel_for(n, piece, [&](size_t b, size_t begin, size_t end) {
            Piece& p = impl_->pieces[b];
            p.cloud.xyz = &xyz_[3 * begin];
            p.cloud.n = end - begin;
            p.lo = p.hi = Eigen::Vector3f(p.cloud.xyz);
            for (size_t s = 0; s < p.cloud.n; ++s) {
              const Eigen::Vector3f q(p.cloud.xyz + 3 * s);
              p.lo = p.lo.cwiseMin(q);
              p.hi = p.hi.cwiseMax(q);
            }
            p.tree = std::make_unique<KdTree>(3, p.cloud,
                                              nanoflann::KDTreeSingleIndexAdaptorParams(16));
          })) {
        return false;
      }
      // Indices (4 B) and about one node (~40 B) per 8 points.
      impl_->extra_bytes = n * 4 + n * 5;
      break;
    }
    case NeighbourBackend::kPclKdTree: {
      auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
      cloud->resize(n);
      for (size_t s = 0; s < n; ++s) (*cloud)[s] = pcl::PointXYZ(xyz_[3 * s], xyz_[3 * s + 1], xyz_[3 * s + 2]);
      impl_->flann.setInputCloud(cloud);
      impl_->extra_bytes = n * (16 + 4 + 8);
      break;
    }
    case NeighbourBackend::kVoxelGrid: {
      // The Morton prefix level whose occupied cells hold about 6 points on
      // average: a query's 27 cells then hold its 20 neighbours on a surface.
      Grid& g = impl_->grid;
      g.shift = 0;
      for (int level = 0; level <= kMortonBits; ++level) {
        size_t cells = 0;
        uint64_t prev = ~uint64_t{0};
        for (size_t s = 0; s < n; ++s) {
          const uint64_t c = keys[s] >> (3 * level);
          cells += c != prev;
          prev = c;
        }
        g.shift = level;
        if (static_cast<double>(n) / static_cast<double>(cells) >= 6.0) break;
      }
      g.quantum = quantum;
      g.cell_m = quantum * static_cast<double>(uint64_t{1} << g.shift);
      g.origin = lo.cast<double>();
      g.max_cell = static_cast<uint32_t>(((uint32_t{1} << kMortonBits) - 1) >> g.shift);
      size_t cells = 0;
      uint64_t prev = ~uint64_t{0};
      for (size_t s = 0; s < n; ++s) {
        const uint64_t c = keys[s] >> (3 * g.shift);
        cells += c != prev;
        prev = c;
      }
      size_t cap = 16;
      while (cap < 2 * cells) cap *= 2;
      g.mask = cap - 1;
      g.table_key.assign(cap, ~uint64_t{0});
      g.table_begin.assign(cap, 0);
      g.table_end.assign(cap, 0);
      size_t begin = 0;
      for (size_t s = 1; s <= n; ++s) {
        if (s == n || (keys[s] >> (3 * g.shift)) != (keys[begin] >> (3 * g.shift))) {
          g.Insert(keys[begin] >> (3 * g.shift), static_cast<uint32_t>(begin),
                   static_cast<uint32_t>(s));
          begin = s;
        }
      }
      impl_->extra_bytes = cap * 16;
      break;
    }
  }
  return true;
}

int NeighbourIndex::Impl::GridKnn(const std::vector<float>& xyz, const float* q, int k,
                                  uint32_t* idx, float* d2) const {
  const Grid& g = grid;
  KBest best{k, 0, idx, d2};
  const auto scan = [&](uint32_t b, uint32_t e) {
    for (uint32_t s = b; s < e; ++s) {
      const float dx = xyz[3 * s] - q[0], dy = xyz[3 * s + 1] - q[1], dz = xyz[3 * s + 2] - q[2];
      best.Add(dx * dx + dy * dy + dz * dz, s);
    }
  };
  int c[3];
  double margin = std::numeric_limits<double>::max();
  for (int a = 0; a < 3; ++a) {
    const double u = (static_cast<double>(q[a]) - g.origin[a]) / g.cell_m;
    c[a] = static_cast<int>(std::floor(u));
    margin = std::min({margin, (u - c[a]) * g.cell_m, (c[a] + 1 - u) * g.cell_m});
  }
  const int max_ring = static_cast<int>(g.max_cell) + 1;
  constexpr int kRingLimit = 4;
  for (int r = 0; r <= max_ring; ++r) {
    if (r > kRingLimit) {
      // Far from everything (an outlier): every point, then done.
      best.n = 0;
      scan(0, static_cast<uint32_t>(xyz.size() / 3));
      return best.n;
    }
    for (int dz = -r; dz <= r; ++dz) {
      for (int dy = -r; dy <= r; ++dy) {
        const bool inner = std::abs(dz) < r && std::abs(dy) < r;
        for (int dx = -r; dx <= r; dx += (inner ? 2 * r : 1)) {
          const int x = c[0] + dx, y = c[1] + dy, z = c[2] + dz;
          if (x < 0 || y < 0 || z < 0 || x > static_cast<int>(g.max_cell) ||
              y > static_cast<int>(g.max_cell) || z > static_cast<int>(g.max_cell)) {
            if (r == 0) break;
            continue;
          }
          uint32_t b, e;
          if (g.Find(Morton(static_cast<uint32_t>(x), static_cast<uint32_t>(y),
                            static_cast<uint32_t>(z)),
                     &b, &e)) {
            scan(b, e);
          }
          if (r == 0) break;
        }
      }
    }
    const double bound = r * g.cell_m + margin;
    if (best.n == k && static_cast<double>(best.Worst()) <= bound * bound) break;
  }
  return best.n;
}

int NeighbourIndex::Knn(const float* q, int k, uint32_t* idx, float* d2, int64_t near) const {
  const int n = static_cast<int>(std::min<size_t>(static_cast<size_t>(k), size()));
  if (n <= 0) return 0;
  switch (impl_->backend) {
    case NeighbourBackend::kKdTree: {
      KBest best{n, 0, idx, d2};
      const auto& pieces = impl_->pieces;
      const size_t first = near >= 0 ? static_cast<size_t>(near) >> kPieceBits : 0;
      const nanoflann::SearchParams params;
      const Eigen::Vector3f qv(q);
      for (size_t j = 0; j < pieces.size(); ++j) {
        const size_t pi = j == 0 ? first : (j <= first ? j - 1 : j);
        const Piece& p = pieces[pi];
        if (j > 0) {
          const float box2 =
              (p.lo - qv).cwiseMax(qv - p.hi).cwiseMax(0.0f).squaredNorm();
          if (box2 > best.Worst()) continue;
        }
        ForestResult r{&best, static_cast<uint32_t>(pi << kPieceBits)};
        p.tree->findNeighbors(r, q, params);
      }
      return best.n;
    }
    case NeighbourBackend::kVoxelGrid:
      return impl_->GridKnn(xyz_, q, n, idx, d2);
    case NeighbourBackend::kBatched:
      return impl_->batched.Knn(q, n, idx, d2);
    case NeighbourBackend::kPclKdTree: {
      thread_local pcl::Indices i;
      thread_local std::vector<float> d;
      const int got = impl_->flann.nearestKSearch(pcl::PointXYZ(q[0], q[1], q[2]), n, i, d);
      for (int j = 0; j < got; ++j) {
        idx[j] = static_cast<uint32_t>(i[j]);
        d2[j] = d[j];
      }
      return got;
    }
  }
  return 0;
}

bool NeighbourIndex::NearestWhere(const float* q, const std::function<bool(uint32_t)>& accept,
                                  uint32_t* idx, float* d2, int64_t near) const {
  if (size() == 0) return false;
  if (impl_->backend == NeighbourBackend::kBatched) {
    return impl_->batched.NearestWhere(q, accept, idx, d2);
  }
  if (impl_->backend != NeighbourBackend::kKdTree) {
    // Growing k-nearest queries until an accepted point comes up.
    std::vector<uint32_t> i;
    std::vector<float> d;
    for (size_t k = 32;; k *= 4) {
      k = std::min(k, size());
      i.resize(k);
      d.resize(k);
      const int got = Knn(q, static_cast<int>(k), i.data(), d.data(), near);
      for (int j = 0; j < got; ++j) {
        if (accept(i[static_cast<size_t>(j)])) {
          *idx = i[static_cast<size_t>(j)];
          *d2 = d[static_cast<size_t>(j)];
          return true;
        }
      }
      if (k == size()) return false;
    }
  }
  NearestAccepted r{&accept, 0};
  const auto& pieces = impl_->pieces;
  const size_t first = near >= 0 ? static_cast<size_t>(near) >> kPieceBits : 0;
  const nanoflann::SearchParams params;
  const Eigen::Vector3f qv(q);
  for (size_t j = 0; j < pieces.size(); ++j) {
    const size_t pi = j == 0 ? first : (j <= first ? j - 1 : j);
    const Piece& p = pieces[pi];
    if (j > 0 && (p.lo - qv).cwiseMax(qv - p.hi).cwiseMax(0.0f).squaredNorm() > r.best) continue;
    r.offset = static_cast<uint32_t>(pi << kPieceBits);
    p.tree->findNeighbors(r, q, params);
  }
  if (!r.found) return false;
  *idx = r.index;
  *d2 = r.best;
  return true;
}

void NeighbourIndex::KnnRange(size_t begin, size_t end, int k, uint32_t* idx, float* d2) const {
  if (impl_->backend == NeighbourBackend::kBatched) {
    impl_->batched.KnnRange(begin, end, k, idx, d2);
    return;
  }
  for (size_t s = begin; s < end; ++s) {
    Knn(sorted_point(s), k, idx + (s - begin) * static_cast<size_t>(k),
        d2 + (s - begin) * static_cast<size_t>(k), static_cast<int64_t>(s));
  }
}

size_t NeighbourIndex::MemoryBytes() const {
  return order_.size() * sizeof(uint32_t) + xyz_.size() * sizeof(float) + impl_->extra_bytes;
}

}  // namespace sweepscan
