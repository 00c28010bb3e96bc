// A square floor of random points at z = 0, in time order (1 000 points a
// scan line, 5 kHz): every chunk of the view spans the whole floor, which
// is what the view's level-of-detail and pick tests want.
#ifndef SWEEPSCAN_TESTS_UI_RANDOM_FLOOR_H_
#define SWEEPSCAN_TESTS_UI_RANDOM_FLOOR_H_

#include <cstdint>
#include <random>
#include <vector>

#include "core/cloud/cloud.h"

namespace sweepscan::testing {

// `n` points uniform over [0, side) x [0, side) metres.
inline std::vector<CloudPoint> RandomFloor(size_t n, float side, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, side);
  std::vector<CloudPoint> points(n);
  for (size_t i = 0; i < n; ++i) {
    CloudPoint& p = points[i];
    p.x = u(rng), p.y = u(rng), p.z = 0.0f;
    p.range_m = 2.0f;
    p.scan = static_cast<uint32_t>(i / 1000);
    p.time_ns = static_cast<int64_t>(i) * 200000;
  }
  return points;
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_UI_RANDOM_FLOOR_H_
