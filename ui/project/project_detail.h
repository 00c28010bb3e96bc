// A project's rest level planned for the camera (ProjectLayer's detail).
//
// A project's sessions are drawn every k-th point once they hold more than
// the view's rest budget (ProjectLayer), the same k whatever the camera
// looks at: zoomed onto a doorway of a 100 M-point building an operator saw
// one point in a hundred of it, while the session view draws a corner it is
// zoomed onto in full. The detail spends the rest budget as the session
// view's rest plan does (core/cloud/cube_budget.h, Potree's rule: the
// budget goes to what is nearest and largest on screen) on the sessions'
// census cubes:
//
//   * the camera's frustum side planes, its eye and the clip are carried into
//     each session's frame through its pose (x_p = R x_s + t: a plane
//     n . x_p + d >= 0 is (R^T n) . x_s + (n . t + d) >= 0, the clip
//     z_p <= h is -(R^T e_z) . x_s + (h - t_z) >= 0);
//   * the 64-point pick pieces whose boxes meet the view (their 4 096-point
//     blocks' first: a block wholly in view brings its pieces untested)
//     count their points in the 0.5 m cube of their box's centre
//     (ProjectCloud::piece_cubes);
//   * the cubes counted, of every session, share one CubeShifts(budget):
//     cube c draws every 2^shift_c-th point, nearer cubes finer;
//   * a piece in view draws the points of index i (in its session) with
//     i mod 2^shift = 0, shift its cube's: a finer stride's points include
//     a coarser one's, and every point on screen is in a piece in view.
//
// Pure functions of immutable clouds: any thread.
#ifndef SWEEPSCAN_UI_PROJECT_PROJECT_DETAIL_H_
#define SWEEPSCAN_UI_PROJECT_PROJECT_DETAIL_H_

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/geometry/transform.h"
#include "ui/project/project_jobs.h"

namespace sweepscan::ui {

struct DetailSession {
  const ProjectCloud* cloud = nullptr;
  Rigid3d project_from_session;
};

struct DetailCamera {
  Eigen::Vector3d eye = Eigen::Vector3d::Zero();  // the project's frame
  // The frustum's six planes (a, b, c, d), a x + b y + c z + d >= 0 inside,
  // as vtkCamera::GetFrustumPlanes gives them (left, right, bottom, top,
  // near, far; the plan uses the four sides).
  std::array<double, 24> planes{};
  double clip_z = std::numeric_limits<double>::quiet_NaN();  // NaN: no clip
};

// Sets `cloud`'s piece_cubes and cube_keys from its piece_bounds
// (IndexForPicks calls it).
void CountCubes(ProjectCloud* cloud);

// The points each session draws at rest, as ascending indices into its
// positions, about `budget` of them in all (CubeShifts' rounding), none of a
// piece out of view; every point of the pieces in view when they hold no
// more than the budget.
std::vector<std::vector<uint32_t>> PlanDetail(const std::vector<DetailSession>& sessions,
                                              const DetailCamera& camera, size_t budget);

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PROJECT_PROJECT_DETAIL_H_
