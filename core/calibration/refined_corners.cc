// Refined corners: the outer loop around FitBoardCorners and SolvePairs
// (board_fit.h).
#include <cmath>
#include <string>
#include <vector>

#include "core/calibration/board_fit.h"
#include "core/calibration/internal.h"

namespace sweepscan {

using calibration_internal::AngleChange;

Status SolveRefinedCorners(const std::vector<LidarObservation>& pass1,
                           const std::vector<LidarObservation>& pass2,
                           const RobotGeometry& geometry, const MountingError& initial,
                           const CalibrationOptions& options, CalibrationSummary* summary) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  *summary = CalibrationSummary();
  summary->method = "refined-corners";
  summary->initial = initial;
  summary->angles = initial;
  MountingError c = initial;
  BoardCorners k1, k2;
  std::vector<CalibrationIteration> trace;
  std::vector<std::string> warnings;
  CalibrationSummary inner;
  for (int outer = 0; outer < options.max_outer_iterations; ++outer) {
    Status s = FitBoardCorners(pass1, geometry, c, &k1);
    if (!s.ok()) return Status::Error("pass 1: " + s.message());
    s = FitBoardCorners(pass2, geometry, c, &k2);
    if (!s.ok()) return Status::Error("pass 2: " + s.message());
    if (outer == 0) summary->initial_rms_m = CornerRms(k1, k2);
    // Each fitted corner becomes a virtual sample: the point in the lidar
    // frame that lands on the corner under c, attached to the pose of the
    // nearest real sample: p_L = (T_WB(t_j) * T_BL(c))^-1 corner.
    std::vector<ObservationPair> pairs(4);
    const Rigid3d bl = BodyFromLidar(geometry, c);
    for (int j = 0; j < 4; ++j) {
      LidarObservation* o[2] = {&pairs[j].pass1, &pairs[j].pass2};
      const BoardCorners* k[2] = {&k1, &k2};
      const std::vector<LidarObservation>* src[2] = {&pass1, &pass2};
      for (int side = 0; side < 2; ++side) {
        *o[side] = (*src[side])[k[side]->nearest[j]];
        o[side]->p_lidar = (o[side]->world_from_body * bl).inverse() * k[side]->corners[j];
      }
    }
    CalibrationOptions inner_options = options;
    inner_options.compute_covariance = true;
    inner = CalibrationSummary();
    s = SolvePairs(pairs, geometry, c, inner_options, &inner);
    for (auto it : inner.trace) {
      it.iteration = static_cast<int>(trace.size());
      trace.push_back(it);
    }
    summary->outer_iterations = outer + 1;
    if (!s.ok()) {
      summary->trace = trace;
      summary->message = inner.message;
      return Status::Error("refined corners, outer iteration " + std::to_string(outer + 1) + ": " +
                           s.message());
    }
    // The board fit is discrete (which samples are end points), so the
    // plain fixed-point iteration c_{k+1} = solve(fit(c_k)) can cycle
    // between two inlier sets. After four rounds the step shrinks fourfold each
    // round (c_{k+1} = c_k + w (solve - c_k), w = 4^-(k-3)), which settles
    // on the boundary between them.
    const double w = outer < 4 ? 1.0 : std::pow(0.25, outer - 3);
    const MountingError target = inner.angles;
    const MountingError next{c.alpha + w * (target.alpha - c.alpha),
                             c.beta + w * (target.beta - c.beta),
                             c.gamma + w * (target.gamma - c.gamma)};
    const double change = AngleChange(c, next);
    c = next;
    if (change < options.outer_tolerance_rad) {
      summary->converged = true;
      break;
    }
  }
  Status s = FitBoardCorners(pass1, geometry, c, &k1);
  if (s.ok()) s = FitBoardCorners(pass2, geometry, c, &k2);
  if (!s.ok()) return Status::Error("final board fit: " + s.message());
  summary->angles = c;
  summary->final_rms_m = CornerRms(k1, k2);
  summary->trace = trace;
  summary->sigma_rad = inner.sigma_rad;
  summary->condition_number = inner.condition_number;
  summary->warnings = inner.warnings;
  summary->initial_cost = trace.empty() ? 0.0 : trace.front().cost;
  summary->final_cost = inner.final_cost;
  summary->residual_blocks = 4;
  summary->message = summary->converged ? "corners and angles stopped changing"
                                        : "outer loop hit max_outer_iterations";
  if (!summary->converged) {
    return Status::Error("refined corners did not converge in " +
                         std::to_string(options.max_outer_iterations) + " outer iterations");
  }
  return Status::Ok();
}

}  // namespace sweepscan
