// Refined corners: the outer loop around FitBoardCorners and SolvePairs
// (board_fit.h).
#include <Eigen/Dense>
#include <cmath>
#include <string>
#include <vector>

#include "core/calibration/board_fit.h"
#include "core/calibration/combine.h"
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

// J = dr/dc, r = (corner_1 - corner_2) over the four corners (12 x 1) of the
// virtual pairs, by central differences.
Eigen::Matrix<double, 12, 3> DiscrepancyJacobian(const std::vector<ObservationPair>& pairs,
                                                 const RobotGeometry& geometry,
                                                 const MountingError& c) {
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
  return j;
}

// The first-order map from the corners' discrepancy to the angles: the
// pairs solve minimises |r|^2, so dc = -M dr with M = (J^T J)^-1 J^T. With
// the passes' range offsets d estimated beside the angles (G = dr/dd, the
// prior's weight lambda), M is the angles' rows of
// (A^T A + diag(0, 0, 0, lambda, lambda))^-1 A^T, A = [J G]: the offsets take
// their share of the discrepancy, and the angles' sigma grows accordingly.
// False if the normal matrix is singular.
bool DiscrepancyToAngles(const Eigen::Matrix<double, 12, 3>& j, const Eigen::Matrix<double, 12, 2>* g,
                         double lambda, Eigen::Matrix<double, 3, 12>* m) {
  if (g == nullptr) {
    Eigen::FullPivLU<Eigen::Matrix3d> lu(j.transpose() * j);
    if (!lu.isInvertible()) return false;
    *m = lu.inverse() * j.transpose();
    return true;
  }
  Eigen::Matrix<double, 12, 5> a;
  a << j, *g;
  Eigen::Matrix<double, 5, 5> n = a.transpose() * a;
  n(3, 3) += lambda;
  n(4, 4) += lambda;
  Eigen::FullPivLU<Eigen::Matrix<double, 5, 5>> lu(n);
  if (!lu.isInvertible()) return false;
  *m = (lu.inverse() * a.transpose()).topRows<3>();
  return true;
}

// The angles' covariance from the corners' own uncertainty, as the board
// fits give it (BoardCorners::covariance), not from the four pairs' misfit:
// cov(c) = M (S_1 + S_2) M^T. Four pairs leave nine degrees of freedom for
// the misfit, so its scale is itself uncertain (a chi^2 with 9 dof falls
// below a third of its mean one time in ten); the board fits see every edge
// point.
Eigen::Matrix3d CornerModelCovariance(const Eigen::Matrix<double, 3, 12>& m,
                                      const BoardCorners& k1, const BoardCorners& k2) {
  return m * (k1.covariance + k2.covariance) * m.transpose();
}

// The pass's samples with every range read as (1 + scale) rho + offset.
std::vector<LidarObservation> WithRangeError(const std::vector<LidarObservation>& pass,
                                             double offset_m, double scale) {
  std::vector<LidarObservation> out = pass;
  for (auto& o : out) {
    const double rho = o.p_lidar.norm();
    if (rho > 0.0) o.p_lidar *= ((1.0 + scale) * rho + offset_m) / rho;
  }
  return out;
}

Eigen::Matrix<double, 12, 1> Discrepancy(const BoardCorners& k1, const BoardCorners& k2) {
  Eigen::Matrix<double, 12, 1> r;
  for (int k = 0; k < 4; ++k) r.segment<3>(3 * k) = k1.corners[k] - k2.corners[k];
  return r;
}

// The passes' range offsets (d_1, d_2), a nuisance beside the angles. A
// range offset moves every sample along its beam, and the near pass's beams
// climb steeply to the board while the far pass's are nearly level, so a
// common offset moves the passes' corners apart, by an amount the angles
// cannot absorb (the board's edge points are beam crossings of the board's
// plane, which the offset moves). A range scale error e acts as an offset
// e rho, about 0.8 e m near and 2.4 e m far: one offset per pass covers
// both. The corners are re-fitted with ranges rho - d_p; per outer round one
// Gauss-Newton step of the linearised joint problem
//   min |r + J dc + G dd|^2 + lambda |d + dd|^2,  G = dr/dd (secants, 3 mm),
// lambda = (1 mm / 10 mm)^2: a prior of 10 mm on each offset against the
// corners' millimetre, so an offset the data do not determine stays near 0.
constexpr double kOffsetPriorWeight = 0.01;
constexpr double kOffsetSecant = 0.003;

std::vector<LidarObservation> Corrected(const std::vector<LidarObservation>& pass, double d) {
  return d == 0.0 ? pass : WithRangeError(pass, -d, 0.0);
}

// dr/dd at (c, d): each pass re-fitted with its offset moved by the secant.
bool OffsetJacobian(const std::vector<LidarObservation>& pass1,
                    const std::vector<LidarObservation>& pass2, const RobotGeometry& geometry,
                    const MountingError& c, const CalibrationOptions& options,
                    const Eigen::Vector2d& d, const BoardCorners& k1, const BoardCorners& k2,
                    Eigen::Matrix<double, 12, 2>* g) {
  const Eigen::Matrix<double, 12, 1> r0 = Discrepancy(k1, k2);
  BoardCorners a;
  if (!FitBoardCorners(Corrected(pass1, d[0] + kOffsetSecant), geometry, c,
                       options.board_thickness_m, &a)
           .ok()) {
    return false;
  }
  g->col(0) = (Discrepancy(a, k2) - r0) / kOffsetSecant;
  if (!FitBoardCorners(Corrected(pass2, d[1] + kOffsetSecant), geometry, c,
                       options.board_thickness_m, &a)
           .ok()) {
    return false;
  }
  g->col(1) = (Discrepancy(k1, a) - r0) / kOffsetSecant;
  return true;
}

// The angles' covariance from a range error shared by both passes, a
// nuisance the corners cannot see: the board of each pass re-fitted with
// every range changed by one sigma of the offset (then of the scale), the
// corners' discrepancy's change dr through dc = -M dr, and cov = sum dc dc^T
// (a secant at one sigma, not a derivative: the fit's end points are
// discrete). It does not cancel: a range error moves each sample along its
// beam, and the near pass's beams climb steeply to the board while the far
// pass's are nearly level, so the two passes' corners move apart.
Eigen::Matrix3d RangeErrorCovariance(const std::vector<LidarObservation>& pass1,
                                     const std::vector<LidarObservation>& pass2,
                                     const RobotGeometry& geometry, const MountingError& c,
                                     const CalibrationOptions& options,
                                     const Eigen::Matrix<double, 3, 12>& m,
                                     const BoardCorners& k1, const BoardCorners& k2) {
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  const Eigen::Matrix<double, 12, 1> r0 = Discrepancy(k1, k2);
  const double offsets[2][2] = {{options.range_offset_sigma_m, 0.0}, {0.0, options.range_scale_sigma}};
  for (const auto& e : offsets) {
    if (e[0] == 0.0 && e[1] == 0.0) continue;
    BoardCorners j1, j2;
    if (!FitBoardCorners(WithRangeError(pass1, e[0], e[1]), geometry, c,
                         options.board_thickness_m, &j1)
             .ok() ||
        !FitBoardCorners(WithRangeError(pass2, e[0], e[1]), geometry, c,
                         options.board_thickness_m, &j2)
             .ok()) {
      continue;
    }
    const Eigen::Vector3d dc = -m * (Discrepancy(j1, j2) - r0);
    cov += dc * dc.transpose();
  }
  return cov;
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
  // The passes' range offsets (nuisance, OffsetJacobian) and the samples
  // corrected by them.
  Eigen::Vector2d d = Eigen::Vector2d::Zero();
  std::vector<LidarObservation> p1 = pass1, p2 = pass2;
  BoardCorners k1, k2;
  std::vector<CalibrationIteration> trace;
  std::vector<std::string> warnings;
  CalibrationSummary inner;
  for (int outer = 0; outer < options.max_outer_iterations; ++outer) {
    Status s = FitBoardCorners(p1, geometry, c, options.board_thickness_m, &k1);
    if (!s.ok()) return Status::Error("pass 1: " + s.message());
    s = FitBoardCorners(p2, geometry, c, options.board_thickness_m, &k2);
    if (!s.ok()) return Status::Error("pass 2: " + s.message());
    if (outer == 0) summary->initial_rms_m = CornerRms(k1, k2);
    const std::vector<ObservationPair> pairs = VirtualCornerPairs(p1, p2, k1, k2, geometry, c);
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
    double change = AngleChange(c, next);
    c = next;
    if (options.estimate_range_offsets) {
      // One Gauss-Newton step of the offsets at the new angles (damped like
      // the angles), at most 5 mm a round.
      BoardCorners a1, a2;
      Eigen::Matrix<double, 12, 2> g;
      if (FitBoardCorners(p1, geometry, c, options.board_thickness_m, &a1).ok() &&
          FitBoardCorners(p2, geometry, c, options.board_thickness_m, &a2).ok() &&
          OffsetJacobian(pass1, pass2, geometry, c, options, d, a1, a2, &g)) {
        const Eigen::Matrix<double, 12, 3> j =
            DiscrepancyJacobian(VirtualCornerPairs(p1, p2, a1, a2, geometry, c), geometry, c);
        Eigen::Matrix<double, 12, 5> a;
        a << j, g;
        Eigen::Matrix<double, 5, 5> n = a.transpose() * a;
        Eigen::Matrix<double, 5, 1> rhs = -a.transpose() * Discrepancy(a1, a2);
        n(3, 3) += kOffsetPriorWeight;
        n(4, 4) += kOffsetPriorWeight;
        rhs.tail<2>() -= kOffsetPriorWeight * d;
        Eigen::FullPivLU<Eigen::Matrix<double, 5, 5>> lu(n);
        if (lu.isInvertible()) {
          const Eigen::Vector2d step =
              (w * lu.solve(rhs).tail<2>()).cwiseMax(-0.005).cwiseMin(0.005);
          d += step;
          change = std::max(change, step.cwiseAbs().maxCoeff());
          p1 = Corrected(pass1, d[0]);
          p2 = Corrected(pass2, d[1]);
        }
      }
    }
    if (change < options.outer_tolerance_rad) {
      summary->converged = true;
      break;
    }
  }
  Status s = FitBoardCorners(p1, geometry, c, options.board_thickness_m, &k1);
  if (s.ok()) s = FitBoardCorners(p2, geometry, c, options.board_thickness_m, &k2);
  if (!s.ok()) return Status::Error("final board fit: " + s.message());
  summary->angles = c;
  summary->range_offsets_m = d;
  summary->final_rms_m = CornerRms(k1, k2);
  summary->trace = trace;
  // The larger of the misfit's sigma and the corners' own, per angle; the
  // corners' own through the joint map when the offsets were estimated,
  // with the range errors given as sigmas (RangeErrorCovariance).
  const std::vector<ObservationPair> final_pairs = VirtualCornerPairs(p1, p2, k1, k2, geometry, c);
  const Eigen::Matrix<double, 12, 3> j = DiscrepancyJacobian(final_pairs, geometry, c);
  Eigen::Matrix<double, 12, 2> g;
  const bool joint = options.estimate_range_offsets &&
                     OffsetJacobian(pass1, pass2, geometry, c, options, d, k1, k2, &g);
  Eigen::Matrix<double, 3, 12> m;
  Eigen::Matrix3d corner_cov = Eigen::Matrix3d::Zero();
  if (DiscrepancyToAngles(j, joint ? &g : nullptr, kOffsetPriorWeight, &m)) {
    const Eigen::Matrix3d range_cov = RangeErrorCovariance(p1, p2, geometry, c, options, m, k1, k2);
    summary->sigma_range_rad = range_cov.diagonal().cwiseMax(0.0).cwiseSqrt();
    corner_cov = CornerModelCovariance(m, k1, k2) + range_cov;
  }
  summary->sigma_rad = inner.sigma_rad.cwiseMax(corner_cov.diagonal().cwiseMax(0.0).cwiseSqrt());
  // The correlations are the corners' (they see every edge point; the
  // misfit's four pairs only scale them).
  summary->covariance_rad2 =
      WithSigmas(corner_cov.isZero() ? inner.covariance_rad2 : corner_cov, summary->sigma_rad);
  summary->rejected_edge_points = static_cast<int>(k1.rejected_edge_points + k2.rejected_edge_points);
  summary->shifted_edge_points = static_cast<int>(k1.shifted_edge_points + k2.shifted_edge_points);
  summary->edge_points = static_cast<int>(k1.edge_points + k2.edge_points);
  summary->mixed_edge_samples = static_cast<int>(k1.mixed_edge_samples + k2.mixed_edge_samples);
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
