#include "core/evaluation/batched_tree.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "core/evaluation/k_best.h"

#if defined(__x86_64__)
#include <immintrin.h>
#define SWEEPSCAN_BATCHED_AVX2 1
#endif

namespace sweepscan {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Squared distance from q to the box [lo, hi] (0 inside).
inline float PointBox2(const float* q, const float* lo, const float* hi) {
  float s = 0.0f;
  for (int a = 0; a < 3; ++a) {
    const float g = std::max({0.0f, lo[a] - q[a], q[a] - hi[a]});
    s += g * g;
  }
  return s;
}

// Squared distance between two boxes (0 if they touch).
inline float BoxBox2(const float* alo, const float* ahi, const float* blo, const float* bhi) {
  float s = 0.0f;
  for (int a = 0; a < 3; ++a) {
    const float g = std::max({0.0f, blo[a] - ahi[a], alo[a] - bhi[a]});
    s += g * g;
  }
  return s;
}


// A group's candidates as a structure of arrays, reused across groups.
struct Candidates {
  std::vector<float> x, y, z, d, sel_d, tmp_d;
  std::vector<uint32_t> s, sel_s, rank, tmp_s;
  size_t m = 0;
  void Reserve(size_t cap) {
    if (x.size() >= cap) return;
    const size_t c = std::max(cap, 2 * x.size());
    x.resize(c);
    y.resize(c);
    z.resize(c);
    d.resize(c);
    s.resize(c);
    sel_d.resize(c);
    sel_s.resize(c);
    rank.resize(c);
    tmp_d.resize(c);
    tmp_s.resize(c);
  }
};

// The arrays both rank-selection kernels (portable and AVX2) work on:
// candidates (x, y, z, sample), their distances, the selection and ranks.
struct RankArrays {
  explicit RankArrays(Candidates* c)
      : cx(c->x.data()), cy(c->y.data()), cz(c->z.data()), cs(c->s.data()), cd(c->d.data()),
        sd(c->sel_d.data()), ss(c->sel_s.data()), rank(c->rank.data()) {}
  const float *cx, *cy, *cz;
  const uint32_t* cs;
  float *cd, *sd;
  uint32_t *ss, *rank;
};

thread_local size_t t_fallbacks = 0;
// Above kRankMax candidates within a query's bound (after Shrink, which
// aims at kRankTarget) the selection inserts instead of ranking (quadratic).
constexpr size_t kRankMax = 64;
constexpr size_t kRankTarget = 40;

// One query against its group's candidates (RankSelect below): their
// squared distances into c->d; then, if between k and kRankMax of them are
// under t2, the k nearest in order into oi, od (true). Otherwise false: the
// caller selects from c->d.
//
// Selection by ranks: a candidate's rank is the number of smaller ones.
// Without ties the ranks are a permutation of 0..p-1 (their sum tells), and
// scattering every candidate to its rank sorts them; the first k are the
// answer. No data-dependent branches, unlike a heap or an insertion sort
// whose mispredictions cost more than the arithmetic.

// Fewer candidates for the ranking (quadratic): while more than
// kRankTarget are under the bound, try a lower one where about k + 8 would
// be if the count grew with the squared radius (points on surfaces); keep
// the candidates under it if at least k are, else try halfway (a locally
// volumetric cloud). Any bound with k candidates under it keeps the answer
// exact.
void Shrink(size_t kk, float t2, float* sd, uint32_t* ss, size_t* p_inout) {
  size_t p = *p_inout;
  float t = t2 * static_cast<float>(kk + 8) / static_cast<float>(p);
  for (int round = 0; round < 6 && p > kRankTarget; ++round) {
    size_t count = 0;
    for (size_t j = 0; j < p; ++j) count += sd[j] < t ? 1 : 0;
    if (count < kk) {
      t = 0.5f * (t + t2);
      continue;
    }
    size_t w = 0;
    for (size_t j = 0; j < p; ++j) {
      const float d = sd[j];
      const uint32_t i = ss[j];
      sd[w] = d;
      ss[w] = i;
      w += d < t ? 1 : 0;
    }
    p = w;
    t2 = t;
    t = t2 * static_cast<float>(kk + 8) / static_cast<float>(p);
  }
  *p_inout = p;
}

bool FinishRanks(size_t p, size_t kk, const float* sd, const uint32_t* ss, const uint32_t* rank,
                 Candidates* c, uint32_t* oi, float* od) {
  size_t sum = 0;
  for (size_t i = 0; i < p; ++i) sum += rank[i];
  if (sum != p * (p - 1) / 2) return false;  // ties
  float* td = c->tmp_d.data();
  uint32_t* ts = c->tmp_s.data();
  for (size_t i = 0; i < p; ++i) {
    td[rank[i]] = sd[i];
    ts[rank[i]] = ss[i];
  }
  std::copy(td, td + kk, od);
  std::copy(ts, ts + kk, oi);
  return true;
}

bool RankSelectPortable(const float* q, float t2, size_t kk, Candidates* c, uint32_t* oi,
                        float* od) {
  const RankArrays a(c);
  const float *cx = a.cx, *cy = a.cy, *cz = a.cz;
  const uint32_t* cs = a.cs;
  float *cd = a.cd, *sd = a.sd;
  uint32_t *ss = a.ss, *rank = a.rank;
  const size_t m = c->m;
  const float qx = q[0], qy = q[1], qz = q[2];
  for (size_t j = 0; j < m; ++j) {
    const float ex = cx[j] - qx, ey = cy[j] - qy, ez = cz[j] - qz;
    cd[j] = ex * ex + ey * ey + ez * ez;
  }
  size_t p = 0;
  for (size_t j = 0; j < m; ++j) {
    sd[p] = cd[j];
    ss[p] = cs[j];
    p += cd[j] < t2 ? 1 : 0;
  }
  if (p < kk) return false;
  Shrink(kk, t2, sd, ss, &p);
  if (p > kRankMax) return false;
  for (size_t i = 0; i < p; ++i) {
    uint32_t r = 0;
    for (size_t j = 0; j < p; ++j) r += sd[j] < sd[i] ? 1u : 0u;
    rank[i] = r;
  }
  return FinishRanks(p, kk, sd, ss, rank, c, oi, od);
}

#if SWEEPSCAN_BATCHED_AVX2
// The same with AVX2: eight candidates a step; the compaction by a table of
// permutations (kCompress[mask] moves the lanes set in mask to the front);
// the ranks of eight candidates at once against each candidate broadcast.
// The arithmetic is the portable version's (no FMA), so both give the same
// distances bit for bit.
struct CompressTable {
  alignas(32) int32_t lanes[256][8];
  CompressTable() {
    for (int mask = 0; mask < 256; ++mask) {
      int n = 0;
      for (int b = 0; b < 8; ++b) {
        if (mask & (1 << b)) lanes[mask][n++] = b;
      }
      for (; n < 8; ++n) lanes[mask][n] = 0;
    }
  }
};
const CompressTable kCompress;

__attribute__((target("avx2,popcnt"))) bool RankSelectAvx2(const float* q, float t2, size_t kk,
                                                         Candidates* c, uint32_t* oi, float* od) {
  const RankArrays a(c);
  const float *cx = a.cx, *cy = a.cy, *cz = a.cz;
  const uint32_t* cs = a.cs;
  float *cd = a.cd, *sd = a.sd;
  uint32_t *ss = a.ss, *rank = a.rank;
  const size_t m = c->m;
  const size_t m8 = (m + 7) & ~size_t{7};  // the arrays hold m + 8, padded
  const __m256 vqx = _mm256_set1_ps(q[0]), vqy = _mm256_set1_ps(q[1]), vqz = _mm256_set1_ps(q[2]);
  const __m256 vt = _mm256_set1_ps(t2);
  size_t p = 0;
  for (size_t j = 0; j < m8; j += 8) {
    const __m256 ex = _mm256_sub_ps(_mm256_loadu_ps(cx + j), vqx);
    const __m256 ey = _mm256_sub_ps(_mm256_loadu_ps(cy + j), vqy);
    const __m256 ez = _mm256_sub_ps(_mm256_loadu_ps(cz + j), vqz);
    const __m256 d = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ex, ex), _mm256_mul_ps(ey, ey)),
                                   _mm256_mul_ps(ez, ez));
    _mm256_storeu_ps(cd + j, d);
    int mask = _mm256_movemask_ps(_mm256_cmp_ps(d, vt, _CMP_LT_OQ));
    if (j + 8 > m) mask &= (1 << (m - j)) - 1;  // the padding
    const __m256i perm =
        _mm256_load_si256(reinterpret_cast<const __m256i*>(kCompress.lanes[mask]));
    _mm256_storeu_ps(sd + p, _mm256_permutevar8x32_ps(d, perm));
    _mm256_storeu_si256(
        reinterpret_cast<__m256i*>(ss + p),
        _mm256_permutevar8x32_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(cs + j)),
                                    perm));
    p += static_cast<size_t>(__builtin_popcount(static_cast<unsigned>(mask)));
  }
  if (p < kk) return false;
  Shrink(kk, t2, sd, ss, &p);
  if (p > kRankMax) return false;
  const size_t p8 = (p + 7) & ~size_t{7};
  for (size_t i = p; i < p8; ++i) sd[i] = kInf;
  for (size_t i = 0; i < p8; i += 8) {
    const __m256 di = _mm256_loadu_ps(sd + i);
    __m256i r = _mm256_setzero_si256();
    for (size_t j = 0; j < p; ++j) {
      // sd[j] < di is all ones (-1) in a lane: subtracting counts it.
      const __m256 lt = _mm256_cmp_ps(_mm256_set1_ps(sd[j]), di, _CMP_LT_OQ);
      r = _mm256_sub_epi32(r, _mm256_castps_si256(lt));
    }
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(rank + i), r);
  }
  return FinishRanks(p, kk, sd, ss, rank, c, oi, od);
}

#endif

bool HasAvx2() {
#if SWEEPSCAN_BATCHED_AVX2
  static const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("popcnt");
  return avx2;
#else
  return false;
#endif
}
std::atomic<bool> g_allow_avx2{true};

bool RankSelect(const float* q, float t2, size_t kk, Candidates* c, uint32_t* oi, float* od) {
#if SWEEPSCAN_BATCHED_AVX2
  if (HasAvx2() && g_allow_avx2.load(std::memory_order_relaxed)) {
    return RankSelectAvx2(q, t2, kk, c, oi, od);
  }
#endif
  return RankSelectPortable(q, t2, kk, c, oi, od);
}

}  // namespace

size_t BatchedKdTree::ThreadFallbacks() { return t_fallbacks; }
bool BatchedKdTree::UsesAvx2() { return HasAvx2() && g_allow_avx2.load(); }
void BatchedKdTree::AllowAvx2(bool allow) { g_allow_avx2.store(allow); }

int32_t BatchedKdTree::Join(int32_t id, int32_t left, int32_t right) {
  // nodes_ may have grown while the children were built: index, not a reference.
  Node& node = nodes_[static_cast<size_t>(id)];
  const Node& l = nodes_[static_cast<size_t>(left)];
  const Node& r = nodes_[static_cast<size_t>(right)];
  node.left = left;
  node.right = right;
  for (int a = 0; a < 3; ++a) {
    node.lo[a] = std::min(l.lo[a], r.lo[a]);
    node.hi[a] = std::max(l.hi[a], r.hi[a]);
  }
  return id;
}

uint32_t BatchedKdTree::SplitOf(const uint64_t* keys, uint32_t begin, uint32_t end, int bit,
                                int* child_bit) {
  // Within [begin, end) the codes share every bit above `bit`, so bit `bit`
  // runs 0...0 1...1: the split is one binary search. A bit on which all
  // points agree splits nothing and is skipped.
  for (; end - begin > kLeafSize && bit >= 0; --bit) {
    const uint64_t m = uint64_t{1} << bit;
    const uint32_t split = static_cast<uint32_t>(
        std::partition_point(keys + begin, keys + end, [m](uint64_t key) { return (key & m) == 0; }) -
        keys);
    if (split == begin || split == end) continue;
    *child_bit = bit - 1;
    return split;
  }
  if (end - begin > kLeafSize) {
    // Identical codes (points within one 1.5 mm cell at 100 m; thousands at
    // one place when a tool writes its no-returns as (0, 0, 0)): halved by
    // position in the array, so that leaves stay small and a descent that
    // has its k nearest at distance 0 skips the rest. One leaf of 50 000
    // such points made every query among them scan all of them: 27 s for
    // the neighbours of 175 000 points instead of 0.09.
    *child_bit = -1;
    return begin + (end - begin) / 2;
  }
  return end;
}

size_t BatchedKdTree::CountNodes(const uint64_t* keys, uint32_t begin, uint32_t end, int bit) {
  int child_bit = -1;
  const uint32_t split = SplitOf(keys, begin, end, bit, &child_bit);
  if (split == end) return 1;
  return 1 + CountNodes(keys, begin, split, child_bit) + CountNodes(keys, split, end, child_bit);
}

int32_t BatchedKdTree::BuildNode(const uint64_t* keys, uint32_t begin, uint32_t end, int bit) {
  const int32_t id = static_cast<int32_t>(nodes_.size());
  nodes_.push_back(Node());
  nodes_[static_cast<size_t>(id)].begin = begin;
  nodes_[static_cast<size_t>(id)].end = end;
  int child_bit = -1;
  const uint32_t split = SplitOf(keys, begin, end, bit, &child_bit);
  if (split != end) {
    const int32_t left = BuildNode(keys, begin, split, child_bit);
    return Join(id, left, BuildNode(keys, split, end, child_bit));
  }
  // A leaf.
  Node& node = nodes_[static_cast<size_t>(id)];
  for (int a = 0; a < 3; ++a) {
    node.lo[a] = kInf;
    node.hi[a] = -kInf;
  }
  for (uint32_t s = begin; s < end; ++s) {
    for (int a = 0; a < 3; ++a) {
      node.lo[a] = std::min(node.lo[a], xyz_[3 * s + a]);
      node.hi[a] = std::max(node.hi[a], xyz_[3 * s + a]);
    }
  }
  return id;
}

void BatchedKdTree::Build(const float* xyz, const uint64_t* keys, size_t n) {
  xyz_ = xyz;
  n_ = n;
  nodes_.clear();
  groups_.clear();
  group_begin_.clear();
  if (n == 0) return;
  // Counted first (the same binary searches again, a few per cent of the
  // build): a vector reserved for the most nodes there could be (n / 2,
  // 20 bytes a point) and shrunk after held the nodes twice while it
  // copied them, 16 bytes a point, the evaluation's peak.
  nodes_.reserve(CountNodes(keys, 0, static_cast<uint32_t>(n), 47));
  BuildNode(keys, 0, static_cast<uint32_t>(n), 47);
  // The groups: the largest nodes of at most kGroupSize points, in order.
  std::vector<int32_t> stack{0};
  while (!stack.empty()) {
    const int32_t id = stack.back();
    stack.pop_back();
    const Node& node = nodes_[static_cast<size_t>(id)];
    if (node.end - node.begin <= kGroupSize || node.left < 0) {
      groups_.push_back(static_cast<uint32_t>(id));
      group_begin_.push_back(node.begin);
      continue;
    }
    stack.push_back(node.right);
    stack.push_back(node.left);
  }
}

template <class Worst, class Visit>
void BatchedKdTree::Descend(const float* q, const Worst& worst, const Visit& visit) const {
  // Depth first, the nearer child first; a node is skipped when its box is
  // no nearer than worst(). The depth is at most kMaxDepth splits.
  struct Entry {
    int32_t node;
    float d2;
  };
  Entry stack[2 * (kMaxDepth + 1) + 2];
  int sp = 0;
  stack[sp++] = {0, 0.0f};
  while (sp > 0) {
    const Entry e = stack[--sp];
    if (e.d2 >= worst()) continue;
    const Node& node = nodes_[static_cast<size_t>(e.node)];
    if (node.left < 0) {
      for (uint32_t s = node.begin; s < node.end; ++s) {
        const float dx = xyz_[3 * s] - q[0], dy = xyz_[3 * s + 1] - q[1], dz = xyz_[3 * s + 2] - q[2];
        visit(s, dx * dx + dy * dy + dz * dz);
      }
      continue;
    }
    const Node& l = nodes_[static_cast<size_t>(node.left)];
    const Node& r = nodes_[static_cast<size_t>(node.right)];
    const float dl = PointBox2(q, l.lo, l.hi), dr = PointBox2(q, r.lo, r.hi);
    if (dl <= dr) {
      stack[sp++] = {node.right, dr};
      stack[sp++] = {node.left, dl};
    } else {
      stack[sp++] = {node.left, dl};
      stack[sp++] = {node.right, dr};
    }
  }
}

int BatchedKdTree::Knn(const float* q, int k, uint32_t* idx, float* d2) const {
  const int want = static_cast<int>(std::min<size_t>(static_cast<size_t>(std::max(k, 0)), n_));
  if (want == 0) return 0;
  KBest best{want, 0, idx, d2};
  Descend(q, [&best] { return best.Worst(); }, [&best](uint32_t s, float d) { best.Add(d, s); });
  return best.n;
}

bool BatchedKdTree::NearestWhere(const float* q, const std::function<bool(uint32_t)>& accept,
                                 uint32_t* idx, float* d2) const {
  if (n_ == 0) return false;
  float best = kInf;
  uint32_t best_s = 0;
  bool found = false;
  Descend(
      q, [&best] { return best; },
      [&](uint32_t s, float d) {
        if (d < best && accept(s)) {
          best = d;
          best_s = s;
          found = true;
        }
      });
  if (!found) return false;
  *idx = best_s;
  *d2 = best;
  return true;
}

void BatchedKdTree::KnnRange(size_t begin, size_t end, int k, uint32_t* idx, float* d2) const {
  if (begin >= end) return;
  const size_t kk = static_cast<size_t>(k);
  if (static_cast<size_t>(k) > n_ || k <= 0) {
    for (size_t s = begin; s < end; ++s) Knn(&xyz_[3 * s], k, idx + (s - begin) * kk, d2 + (s - begin) * kk);
    return;
  }
  thread_local Candidates c;
  // The first group holding `begin`.
  size_t g = static_cast<size_t>(
      std::upper_bound(group_begin_.begin(), group_begin_.end(), static_cast<uint32_t>(begin)) -
      group_begin_.begin() - 1);
  float estimate = -1.0f;  // the previous group's largest k-th squared distance
  const uint32_t* prev_oi = nullptr;  // the previous query's k nearest
  for (; g < groups_.size() && group_begin_[g] < end; ++g) {
    const Node& group = nodes_[groups_[g]];
    float dx = group.hi[0] - group.lo[0], dy = group.hi[1] - group.lo[1],
          dz = group.hi[2] - group.lo[2];
    const float diag2 = dx * dx + dy * dy + dz * dz;
    // r2: every query of the group is expected (the estimate) or known (the
    // diagonal bound) to have its k-th neighbour nearer than sqrt(r2).
    float r2 = kInf;
    if (group.end - group.begin >= static_cast<uint32_t>(k)) r2 = diag2 * 1.0001f + 1e-12f;
    if (estimate >= 0.0f) {
      r2 = std::min(r2, estimate * 1.5f + 1e-12f);
    } else if (r2 == kInf) {
      // First group, fewer than k points: the k-th neighbour of its first
      // point t bounds every other's by t + the diagonal.
      thread_local std::vector<uint32_t> ti;
      thread_local std::vector<float> td;
      ti.resize(kk);
      td.resize(kk);
      Knn(&xyz_[3 * group.begin], k, ti.data(), td.data());
      const float t = std::sqrt(td[kk - 1]) + std::sqrt(diag2);
      r2 = t * t * 1.0001f + 1e-12f;
    }
    // Gather: every leaf within the (slightly widened, for rounding) radius
    // of the group's box.
    const float gather2 = r2 * 1.0002f;
    c.m = 0;
    bool crowded = false;  // More candidates than kMaxCandidates.
    {
      int32_t stack[kMaxDepth + 2];
      int sp = 0;
      stack[sp++] = 0;
      while (sp > 0 && !crowded) {
        const Node& node = nodes_[static_cast<size_t>(stack[--sp])];
        if (BoxBox2(node.lo, node.hi, group.lo, group.hi) > gather2) continue;
        if (node.left < 0) {
          const size_t add = node.end - node.begin;
          if (c.m + add > kMaxCandidates) {
            crowded = true;
            break;
          }
          c.Reserve(c.m + add);
          for (uint32_t s = node.begin; s < node.end; ++s, ++c.m) {
            c.x[c.m] = xyz_[3 * s];
            c.y[c.m] = xyz_[3 * s + 1];
            c.z[c.m] = xyz_[3 * s + 2];
            c.s[c.m] = s;
          }
          continue;
        }
        stack[sp++] = node.right;
        stack[sp++] = node.left;
      }
    }
    const size_t q_begin = std::max<size_t>(begin, group.begin);
    const size_t q_end = std::min<size_t>(end, group.end);
    float largest = 0.0f;
    if (crowded) {
      // Many points within the radius of a small group (points piled at
      // one place): scanning them all for every query is quadratic in the
      // pile; one descent a query stops once it has k at its distance.
      for (size_t s = q_begin; s < q_end; ++s) {
        uint32_t* oi = idx + (s - begin) * kk;
        float* od = d2 + (s - begin) * kk;
        ++t_fallbacks;
        Knn(&xyz_[3 * s], k, oi, od);
        prev_oi = oi;
        largest = std::max(largest, od[kk - 1]);
      }
      estimate = largest;
      continue;
    }
    c.Reserve(c.m + 8);  // the ranking pads to whole vectors
    const float* cd = c.d.data();
    const size_t m = c.m;
    for (size_t s = q_begin; s < q_end; ++s) {
      uint32_t* oi = idx + (s - begin) * kk;
      float* od = d2 + (s - begin) * kk;
      const float qx = xyz_[3 * s], qy = xyz_[3 * s + 1], qz = xyz_[3 * s + 2];
      // This query's bound: k known points (the previous query's k nearest)
      // lie within the farthest of them, so its k-th neighbour does too.
      float t2 = r2;
      if (prev_oi != nullptr) {
        float far2 = 0.0f;
        for (size_t j = 0; j < kk; ++j) {
          const float* x = &xyz_[3 * prev_oi[j]];
          const float ex = x[0] - qx, ey = x[1] - qy, ez = x[2] - qz;
          far2 = std::max(far2, ex * ex + ey * ey + ez * ez);
        }
        t2 = std::min(t2, far2 * 1.0001f + 1e-12f);
      }
      const float q[3] = {qx, qy, qz};
      const bool done = RankSelect(q, t2, kk, &c, oi, od);
      if (!done) {
        KBest best{k, 0, oi, od, r2};
        for (size_t j = 0; j < m; ++j) {
          best.Add(cd[j], c.s[j]);
        }
        if (best.n < k) {
          ++t_fallbacks;
          Knn(&xyz_[3 * s], k, oi, od);
        }
      }
      prev_oi = oi;
      largest = std::max(largest, od[kk - 1]);
    }
    estimate = largest;
  }
}

size_t BatchedKdTree::MemoryBytes() const {
  return nodes_.capacity() * sizeof(Node) + groups_.capacity() * 4 + group_begin_.capacity() * 4;
}

}  // namespace sweepscan
