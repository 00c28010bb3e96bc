// The k best (smallest squared distance) candidates of one query so far,
// kept sorted ascending in the caller's arrays: the result set of the
// neighbour structures' single-query searches (neighbours.cc,
// batched_tree.cc).
#ifndef SWEEPSCAN_CORE_EVALUATION_K_BEST_H_
#define SWEEPSCAN_CORE_EVALUATION_K_BEST_H_

#include <cstdint>
#include <limits>

namespace sweepscan {

struct KBest {
  int k = 0, n = 0;
  uint32_t* idx = nullptr;
  float* d2 = nullptr;
  // While fewer than k are held, only distances under `bound` enter.
  float bound = std::numeric_limits<float>::infinity();
  float Worst() const { return n < k ? bound : d2[k - 1]; }
  // Insertion into the sorted arrays (k is small: about 20).
  void Add(float d, uint32_t i) {
    if (!(d < Worst())) return;
    int j = n < k ? n++ : k - 1;
    while (j > 0 && d2[j - 1] > d) {
      d2[j] = d2[j - 1];
      idx[j] = idx[j - 1];
      --j;
    }
    d2[j] = d;
    idx[j] = i;
  }
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_EVALUATION_K_BEST_H_
