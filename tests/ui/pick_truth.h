// Picks in tests: the truth a layer's pick is checked against (the nearest
// point along the ray within its tolerance, testing every point of a cloud
// placed at a pose: what ProjectLayer::Pick must find however it culls),
// and an operator's Shift + click, answered on the view's pick thread.
#ifndef SWEEPSCAN_TESTS_UI_PICK_TRUTH_H_
#define SWEEPSCAN_TESTS_UI_PICK_TRUTH_H_

#include <Eigen/Core>
#include <QTest>
#include <limits>
#include <vector>

#include "core/geometry/transform.h"
#include "tests/testing/qt_wait.h"
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

// Shift + clicks `at` in the view and waits until the pick has been
// reported (CloudView::pointPicked) or dropped; false if it took 30 s.
inline bool ShiftClick(ui::CloudView* view, const QPoint& at) {
  QTest::mouseClick(view, Qt::LeftButton, Qt::ShiftModifier, at);
  return WaitFor([view] { return view->picks_in_flight() == 0; }, 30000);
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_UI_PICK_TRUTH_H_
