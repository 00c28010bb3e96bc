// The truth a layer's pick is checked against: the nearest point along the
// ray within its tolerance, testing every point of a cloud placed at a pose
// (what ProjectLayer::Pick must find however it culls).
#ifndef SWEEPSCAN_TESTS_UI_PICK_TRUTH_H_
#define SWEEPSCAN_TESTS_UI_PICK_TRUTH_H_

#include <Eigen/Core>
#include <limits>
#include <vector>

#include "core/geometry/transform.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::testing {

// The least t of a point of `positions` (through `pose`) under the ray;
// infinity if none.
inline double NearestAlongRay(const std::vector<Eigen::Vector3f>& positions, const Rigid3d& pose,
                              const ui::CloudView::PickRay& ray) {
  double best = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3f& q : positions) {
    const Eigen::Vector3d w = pose * q.cast<double>() - ray.origin;
    const double along = w.dot(ray.direction);
    const double tol = ray.tolerance_per_t * along;
    if (along > 0 && along < best && w.squaredNorm() - along * along <= tol * tol) best = along;
  }
  return best;
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_UI_PICK_TRUTH_H_
