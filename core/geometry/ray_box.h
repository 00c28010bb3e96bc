// Ray / axis-aligned box test (the slab method), for picks: whether the ray
// o + t d, 0 <= t <= max_t, meets a box grown by `margin` on every side,
// and where it enters it. Header-only.
#ifndef SWEEPSCAN_CORE_GEOMETRY_RAY_BOX_H_
#define SWEEPSCAN_CORE_GEOMETRY_RAY_BOX_H_

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace sweepscan {

// Many boxes against one ray (a pick on a few hundred million points tests
// a million): the direction's reciprocals taken once. Boxes in VTK's order
// (x min, x max, y min, y max, z min, z max); `enter` is where the ray
// enters the grown box (0 if it starts inside).
class RaySlabs {
 public:
  RaySlabs(const Eigen::Vector3d& o, const Eigen::Vector3d& d) : o_(o) {
    for (int k = 0; k < 3; ++k) {
      parallel_[k] = std::abs(d[k]) < 1e-12;
      inv_[k] = parallel_[k] ? 0.0 : 1.0 / d[k];
    }
  }
  bool Hits(const double box[6], double margin, double max_t, double* enter) const {
    double t0 = 0.0, t1 = max_t;
    for (int k = 0; k < 3; ++k) {
      const double a = box[2 * k] - margin, b = box[2 * k + 1] + margin;
      if (parallel_[k]) {
        if (o_[k] < a || o_[k] > b) return false;
        continue;
      }
      double ta = (a - o_[k]) * inv_[k], tb = (b - o_[k]) * inv_[k];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      if (t0 > t1) return false;
    }
    *enter = t0;
    return true;
  }

 private:
  Eigen::Vector3d o_;
  double inv_[3];
  bool parallel_[3];
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_GEOMETRY_RAY_BOX_H_
