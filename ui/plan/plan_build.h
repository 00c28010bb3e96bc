// The floor plan of clouds placed in one frame, for the desktop app's plan
// view (ui/plan/plan_panel.h): a project's placed, visible sessions each
// under its project_from_session, or an opened session's cloud under the
// identity, and its vertical sections. The same plan as `sweepscan-cli
// plan` draws (core/plan/floor_plan.h), the sections cut here so that the
// work reports progress and stops when cancelled, and so that no cloud is
// copied whole into the project's frame (only the slab's points are).
//
// No Qt; any thread (the app runs it on a job thread).
#ifndef SWEEPSCAN_UI_PLAN_PLAN_BUILD_H_
#define SWEEPSCAN_UI_PLAN_PLAN_BUILD_H_

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <vector>

#include "core/common/status.h"
#include "core/geometry/transform.h"
#include "core/plan/floor_plan.h"

namespace sweepscan::ui {

struct PlanInput {
  std::shared_ptr<const std::vector<Eigen::Vector3f>> positions;  // in the cloud's own frame
  Rigid3d frame_from_cloud;
};

// The text a cancelled build returns as its status.
inline constexpr const char* kPlanCancelled = "cancelled";

// The vertical section along options.a -> options.b (core/plan/section.h:
// (s, z), |n . (p - a)| <= band) of the same inputs in the common frame,
// decimated to one point a 1 cm cell for its drawing and export (as
// `sweepscan-cli plan --section-svg` writes it); `stats` count every input
// point and the slab's points before the decimation.
struct SectionOf {
  plan::VerticalSectionOptions options;
  std::vector<Eigen::Vector2d> s_z;
  plan::SectionStats stats;
};
inline constexpr double kSectionCellM = 0.01;
// `progress` as BuildPlanOf's: 0..1, false cancels.
Status BuildSectionOf(const std::vector<PlanInput>& inputs, const plan::VerticalSectionOptions& options,
                      const std::function<bool(double)>& progress, SectionOf* section);

// The horizontal section at options.section (|z - height| <= band in the
// common frame) of every input, then BuildFloorPlanFromSection; the plan's
// section statistics count every input point. `progress` gets 0..1 (the
// cut is the first 60 %, the fit the rest, reported at its start and end)
// and returns false to cancel. If `level_near_cut` is given it is set to
// the height of a floor or ceiling within 3 cm of the cut's slab, NaN when
// there is none (plan::LevelSurfaceNearCut: the CLI's warning).
Status BuildPlanOf(const std::vector<PlanInput>& inputs, const plan::FloorPlanOptions& options,
                   const std::function<bool(double)>& progress, plan::FloorPlan* plan,
                   double* level_near_cut = nullptr);

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PLAN_PLAN_BUILD_H_
