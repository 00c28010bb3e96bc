#include "core/evaluation/plane_scoring.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <cstdint>

namespace sweepscan {

size_t CountWithinPlane(const PointsSoa& s, const Eigen::Vector4f& q, float band) {
  const size_t m = s.size();
  const float* x = s.x.data();
  const float* y = s.y.data();
  const float* z = s.z.data();
  const float a = q[0], b = q[1], c = q[2], d = q[3];
  // 32-bit counters: the loops vectorise (a subsample holds < 2^32 points).
  uint32_t count = 0;
  if (band < 0.0f && s.band.size() == m) {
    const float* t = s.band.data();
    for (size_t i = 0; i < m; ++i) {
      count += std::abs((a * x[i] + c * z[i]) + (b * y[i] + d)) <= t[i] ? 1u : 0u;
    }
  } else {
    for (size_t i = 0; i < m; ++i) {
      count += std::abs((a * x[i] + c * z[i]) + (b * y[i] + d)) <= band ? 1u : 0u;
    }
  }
  return count;
}

void ForBlocks(size_t n, size_t block, bool parallel,
               const std::function<void(size_t, size_t)>& body) {
  if (!parallel) {
    for (size_t begin = 0; begin < n; begin += block) body(begin, std::min(n, begin + block));
    return;
  }
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, block),
                    [&](const tbb::blocked_range<size_t>& r) { body(r.begin(), r.end()); },
                    tbb::simple_partitioner());
}

void ScoreHypotheses(const PointsSoa& s, const std::vector<Eigen::Vector4f>& hypotheses,
                     float band, bool parallel, std::vector<size_t>* counts) {
  counts->resize(hypotheses.size());
  ForBlocks(hypotheses.size(), 1, parallel, [&](size_t begin, size_t end) {
    for (size_t h = begin; h < end; ++h) (*counts)[h] = CountWithinPlane(s, hypotheses[h], band);
  });
}

}  // namespace sweepscan
