// Refined corners: the outer loop around FitBoardCorners and SolvePairs
// (board_fit.h).
#include <Eigen/Dense>
#include <cmath>
#include <string>
#include <vector>

#include "core/calibration/board_fit.h"
#include "core/calibration/internal.h"

namespace sweepscan {

using calibration_internal::AngleChange;

namespace {

// Each fitted corner becomes a virtual sample: the point in the lidar frame
// that lands on the corner under c, attached to the pose of the nearest
// real sample: p_L = (T_WB(t_j) * T_BL(c))^-1 corner.
std::vector<ObservationPair> VirtualCornerPairs(const std::vector<LidarObservation>& pass1,
                                                const std::vector<LidarObservation>& pass2,
                                                const BoardCorners& k1, const BoardCorners& k2,
                                                const RobotGeometry& geometry,
                                                const MountingError& c) {
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
  return pairs;
}

// The angles' 1-sigma from the corners' own uncertainty, as the board fits
// give it (BoardCorners::covariance), not from the four pairs' misfit: the
// pairs solve minimises |r|^2 with r = (corner_1 - corner_2) over the four
// corners (12 x 1), so to first order dc = -(J^T J)^-1 J^T dr with J = dr/dc
// and cov(c) = (J^T J)^-1 J^T (S_1 + S_2) J (J^T J)^-1. Four pairs leave
// nine degrees of freedom for the misfit, so its scale is itself uncertain
// (a chi^2 with 9 dof falls below a third of its mean one time in ten); the
// board fits see every edge point. Zero if J^T J is singular.
Eigen::Vector3d CornerModelSigma(const std::vector<ObservationPair>& pairs,
                                 const BoardCorners& k1, const BoardCorners& k2,
                                 const RobotGeometry& geometry, const MountingError& c) {
  Eigen::Matrix<double, 12, 3> j;
  for (int q = 0; q < 3; ++q) {
    constexpr double h = 1e-7;
    MountingError lo = c, hi = c;
    double* plo[3] = {&lo.alpha, &lo.beta, &lo.gamma};
    double* phi[3] = {&hi.alpha, &hi.beta, &hi.gamma};
    *plo[q] -= h;
    *phi[q] += h;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d r_hi = ProjectObservation(pairs[k].pass1, geometry, hi) -
                                   ProjectObservation(pairs[k].pass2, geometry, hi);
      const Eigen::Vector3d r_lo = ProjectObservation(pairs[k].pass1, geometry, lo) -
                                   ProjectObservation(pairs[k].pass2, geometry, lo);
      j.block<3, 1>(3 * k, q) = (r_hi - r_lo) / (2.0 * h);
    }
  }
  Eigen::FullPivLU<Eigen::Matrix3d> lu(j.transpose() * j);
  if (!lu.isInvertible()) return Eigen::Vector3d::Zero();
  const Eigen::Matrix<double, 3, 12> m = lu.inverse() * j.transpose();
  const Eigen::Matrix3d cov = m * (k1.covariance + k2.covariance) * m.transpose();
  return cov.diagonal().cwiseMax(0.0).cwiseSqrt();
}

}  // namespace

Status SolveRefinedCorners(const std::vector<LidarObservation>& pass1,
                           const std::vector<LidarObservation>& pass2,
                           const RobotGeometry& geometry, const MountingError& initial,
                           const CalibrationOptions& options, CalibrationSummary* summary) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  *summary = CalibrationSummary();
  summary->method = "refined-corners";
  summary->board_thickness_m = options.board_thickness_m;
  summary->initial = initial;
  summary->angles = initial;
  MountingError c = initial;
  BoardCorners k1, k2;
  std::vector<CalibrationIteration> trace;
  std::vector<std::string> warnings;
  CalibrationSummary inner;
  for (int outer = 0; outer < options.max_outer_iterations; ++outer) {
    Status s = FitBoardCorners(pass1, geometry, c, options.board_thickness_m, &k1);
    if (!s.ok()) return Status::Error("pass 1: " + s.message());
    s = FitBoardCorners(pass2, geometry, c, options.board_thickness_m, &k2);
    if (!s.ok()) return Status::Error("pass 2: " + s.message());
    if (outer == 0) summary->initial_rms_m = CornerRms(k1, k2);
    const std::vector<ObservationPair> pairs = VirtualCornerPairs(pass1, pass2, k1, k2, geometry, c);
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
  Status s = FitBoardCorners(pass1, geometry, c, options.board_thickness_m, &k1);
  if (s.ok()) s = FitBoardCorners(pass2, geometry, c, options.board_thickness_m, &k2);
  if (!s.ok()) return Status::Error("final board fit: " + s.message());
  summary->angles = c;
  summary->final_rms_m = CornerRms(k1, k2);
  summary->trace = trace;
  // The larger of the misfit's sigma and the corners' own, per angle.
  summary->sigma_rad = inner.sigma_rad.cwiseMax(CornerModelSigma(
      VirtualCornerPairs(pass1, pass2, k1, k2, geometry, c), k1, k2, geometry, c));
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
