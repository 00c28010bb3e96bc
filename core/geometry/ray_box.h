// Ray / axis-aligned box test (the slab method), for picks: whether the ray
// o + t d, 0 <= t <= max_t, meets the box [lo, hi] grown by `margin` on
// every side, and where it enters it. Header-only.
#ifndef SWEEPSCAN_CORE_GEOMETRY_RAY_BOX_H_
#define SWEEPSCAN_CORE_GEOMETRY_RAY_BOX_H_

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace sweepscan {

// `enter`, if given, is where the ray enters the grown box (0 if it starts
// inside).
inline bool RayHitsBox(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                       const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double margin,
                       double max_t = std::numeric_limits<double>::infinity(),
                       double* enter = nullptr) {
  double t0 = 0.0, t1 = max_t;
  for (int k = 0; k < 3; ++k) {
    const double a = lo[k] - margin, b = hi[k] + margin;
    if (std::abs(d[k]) < 1e-12) {
      if (o[k] < a || o[k] > b) return false;
      continue;
    }
    double ta = (a - o[k]) / d[k], tb = (b - o[k]) / d[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  if (enter != nullptr) *enter = t0;
  return true;
}

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_GEOMETRY_RAY_BOX_H_
