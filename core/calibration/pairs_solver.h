// The pairs problem (Miao et al. 2022, section 4, Eq. 15-17), solved with
// Ceres' Levenberg-Marquardt, and the options, progress and summary every
// solve of the calibration shares (pairs, refined corners, automatic mode).
//
// With pairs (a_k, b_k), k = 1..K, K >= 4 (Eq. 15-17):
//   c* = argmin_c  sum_k rho( |p_W^{a_k}(c) - p_W^{b_k}(c)|^2 )
// with rho the identity or a robust loss. Three residuals per pair.
//
// All functions are pure (no globals) and may run on any thread; a long
// solve can be cancelled through CalibrationProgress.
#ifndef SWEEPSCAN_CORE_CALIBRATION_PAIRS_SOLVER_H_
#define SWEEPSCAN_CORE_CALIBRATION_PAIRS_SOLVER_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/calibration/picks.h"
#include "core/common/status.h"
#include "core/robot/robot_model.h"

namespace sweepscan {

enum class RobustLoss { kNone = 0, kHuber = 1, kCauchy = 2 };
const char* RobustLossName(RobustLoss loss);
bool ParseRobustLoss(const std::string& name, RobustLoss* loss);

// Declared in core, implemented by the caller (e.g. the UI's progress dialog).
class CalibrationProgress {
 public:
  virtual ~CalibrationProgress() = default;
  // Called once per LM iteration from the solving thread; return false to cancel.
  virtual bool OnIteration(int iteration, const MountingError& angles, double cost) = 0;
};

struct CalibrationOptions {
  int max_iterations = 100;  // LM iterations per solve
  double function_tolerance = 1e-12;
  double gradient_tolerance = 1e-14;
  double parameter_tolerance = 1e-12;
  RobustLoss loss = RobustLoss::kNone;
  double loss_scale_m = 0.02;  // Huber/Cauchy scale (residuals in metres)
  int min_pairs = 4;
  bool compute_covariance = true;
  // Observability: the Jacobian's condition number (largest / smallest
  // singular value, columns in radians) above which an angle is reported
  // as unobservable.
  double max_condition_number = 1e3;
  // Pick geometry: pass-1 picks closer than this to each other, or spread
  // less than this across their second principal direction (collinear),
  // leave an angle weakly determined and give a warning.
  double min_pick_spread_m = 0.05;
  // Refined corners and automatic mode: outer iterations until the angles
  // change by less than outer_tolerance_rad.
  int max_outer_iterations = 15;
  double outer_tolerance_rad = 1e-6;
  // Refined corners: the target board's thickness (FitBoardCorners). The
  // simulated lab's board is 5 mm; measure yours (0 for a sheet on a
  // stand). docs/calibration.md, "The target".
  double board_thickness_m = 0.005;
  // Refined corners: the lidar's range errors, which the corners share with
  // every sample and the board fit cannot see, 1-sigma: a constant offset
  // and a scale error (range reads (1 + e) rho + offset). The solve's sigma
  // takes the angles' change under each (SolveRefinedCorners, marginalised
  // as nuisance parameters). 0 (the default) leaves them out: with the
  // path scale from the room's planes (PickCalibrationOptions) they largely
  // cancel (docs/calibration.md, "Range errors"), and a secant at fixed
  // poses overstated them 5-10 fold; set them for truth or unscaled poses.
  double range_offset_sigma_m = 0.0;
  double range_scale_sigma = 0.0;
  // Refined corners: estimate a range offset per pass beside the angles (a
  // nuisance: a constant offset, and a scale error as the offset it makes at
  // each pass's distance), with a 10 mm prior; SolveRefinedCorners. Off by
  // default: on the lab diamond the offsets and gamma are confounded (with
  // +10 / +18 mm of true offset the estimate came out -3.4 / +4.5 mm, the
  // corners' misfit fell from 7 to 0.3 mm and gamma stayed 2 mrad off, now
  // at 12 sigma; docs/calibration.md, "Range errors").
  bool estimate_range_offsets = false;
  CalibrationProgress* progress = nullptr;  // not owned; may be null

  bool IsValid(std::string* error) const;
};

struct CalibrationIteration {
  int iteration = 0;  // over all inner solves, from 0 (the start)
  MountingError angles;
  double cost = 0.0;  // Ceres cost 1/2 sum rho(r^2)
};

struct CalibrationSummary {
  std::string method;  // "pairs", "refined-corners", "auto-planes"
  bool converged = false;
  std::string message;  // Ceres' or ours: why it stopped
  MountingError initial;
  MountingError angles;
  Eigen::Vector3d sigma_rad =
      Eigen::Vector3d::Constant(-1.0);  // 1-sigma (alpha, beta, gamma); -1: unknown
  // The angles' covariance (rad^2) as the method measured it, sigma_rad^2 on
  // its diagonal before the poses' own heading and tilt sigmas join it (the
  // workflows add those; CombineAngleEstimates needs the correlations:
  // the board's alpha and beta err together). Zero: unknown.
  Eigen::Matrix3d covariance_rad2 = Eigen::Matrix3d::Zero();
  double initial_rms_m = 0.0;  // RMS pair distance (pairs) or point-to-plane distance (auto)
  double final_rms_m = 0.0;
  // Automatic mode: the RMS of the normalised residuals r_i / sigma_i at the
  // end (about 0.7-1 when the noise model holds; -1: not computed).
  double rms_sigmas = -1.0;
  double initial_cost = 0.0, final_cost = 0.0;
  double condition_number = 0.0;
  int weakest_angle = -1;  // 0 alpha, 1 beta, 2 gamma: the least determined (observability check)
  // Automatic mode: the path's distance scale estimated as a nuisance
  // (AutoCalibrationOptions::estimate_path_scale; 1 if not estimated).
  double path_scale = 1.0;
  Eigen::Vector3d path_centre = Eigen::Vector3d::Zero();  // the scale's centre
  double board_thickness_m = 0.0;  // refined corners: the target's, as the board fit took it
  // Refined corners, both passes' final board fits: the end points used
  // (edge_points), those of them a sample off (further from their edge than
  // half a spacing plus noise: lines a sample short or long, mixed returns
  // at the edges; they widen the sigma) and those rejected (further than a
  // whole spacing: dropouts, foreign returns); -1 for the other methods.
  int rejected_edge_points = -1;
  int shifted_edge_points = -1;
  int edge_points = -1;
  // Refined corners: samples beyond the lines' ends recognised as mixed
  // returns (BoardCorners::mixed_edge_samples), both passes; -1 otherwise.
  int mixed_edge_samples = -1;
  // Refined corners: the part of sigma_rad from the range offset and scale
  // (CalibrationOptions::range_offset_sigma_m, range_scale_sigma).
  Eigen::Vector3d sigma_range_rad = Eigen::Vector3d::Zero();
  // Refined corners: the range offsets estimated for pass 1 and pass 2
  // (CalibrationOptions::estimate_range_offsets; zero if not estimated).
  Eigen::Vector2d range_offsets_m = Eigen::Vector2d::Zero();
  int residual_blocks = 0;  // pairs, or points in the automatic mode
  int outer_iterations = 0;
  int planes = 0;  // automatic mode
  // Automatic mode: the kept surfaces at the end.
  struct PlaneReport {
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    double d = 0.0;
    int points = 0;     // residuals
    int sightings = 0;  // time-gap windows (> 1 s) of its points
    double rms_m = 0.0;
    double rms_sigmas = 0.0;  // RMS of r_i / sigma_i (1 if the noise model holds)
  };
  std::vector<PlaneReport> plane_reports;
  // Automatic mode: the 1-sigma of the plain (J'J)^-1 s^2 estimate, kept for
  // comparison; sigma_rad holds the larger of it and the cluster-robust one.
  Eigen::Vector3d sigma_iid_rad = Eigen::Vector3d::Constant(-1.0);
  std::vector<CalibrationIteration> trace;  // the paper's Fig. 8
  std::vector<std::string> warnings;

  bool IsSolutionUsable() const { return converged; }
  std::string BriefReport() const;
  std::string FullReport() const;
};

// The picks' part of the pairs' checks SolvePairs makes first: the two
// picks of a pair from different passes (at least 1 s apart), no pair
// twice. A failure is bad input (the picks), not a solve that failed (the
// samples and poses being finite is SolvePairs' check).
Status CheckObservationPairs(const std::vector<ObservationPair>& pairs,
                             const RobotGeometry& geometry, const MountingError& initial);

// Eq. 15-17 on resolved pairs. Fails (Status) on bad input: fewer than
// min_pairs pairs, non-finite values, a pair whose two samples are the same
// or from the same moment. `summary` is filled whenever the solve ran.
Status SolvePairs(const std::vector<ObservationPair>& pairs, const RobotGeometry& geometry,
                  const MountingError& initial, const CalibrationOptions& options,
                  CalibrationSummary* summary);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CALIBRATION_PAIRS_SOLVER_H_
