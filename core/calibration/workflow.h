// Workflows: what a front end (sweepscan-cli, the desktop app's calibration
// panel) runs between reading its inputs and showing the result, so that
// both calibrate the same way.
//
// Pure functions, no globals; may run on any thread (the app runs them on a
// worker thread; cancel through options.solver.progress).
#ifndef SWEEPSCAN_CORE_CALIBRATION_WORKFLOW_H_
#define SWEEPSCAN_CORE_CALIBRATION_WORKFLOW_H_

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "core/calibration/board_fit.h"
#include "core/calibration/pairs_solver.h"
#include "core/calibration/picks.h"
#include "core/calibration/samples.h"
#include "core/common/status.h"
#include "core/pose/ekf.h"
#include "core/robot/robot_model.h"

namespace sweepscan {

// The target's region on a circle drive: the picks' bounding box (world
// positions under `calibration`; sample picks that are not valid samples
// are skipped) grown by 0.25 m along the board (its two large extents) and
// by 0.08 m across a flat set of picks (the board's normal, when the box is
// thinner than 0.1 m there), which still holds the uncalibrated ghosts (a
// few cm) but not a wall 0.16 m behind. Empty if no pick is usable.
Eigen::AlignedBox3d TargetRegionFromPicks(const std::vector<PickPair>& picks,
                                          const SampleStore& store, const RobotGeometry& geometry,
                                          const MountingError& calibration);

// What a picks solve may end at and still be a calibration: angles within
// kMaxPickAngleRad (a mounting error is a small angle; the calibration file
// refuses beyond 0.5 rad), else refused; and pairs within kMaxPickRmsM
// after the solve (RMS; raw picks snap to the sample nearest them, a scan
// line's spacing off: 8.5 cm on the upright board of the lab circle,
// refined corners within millimetres), else a warning (drifting poses
// leave pairs apart too). Picks that pair different points across the
// passes (corners given in another order) make the solve find the rotation
// that best maps one wrong set onto the other: up to 3.7 rad, 0.3-0.7 m.
inline constexpr double kMaxPickAngleRad = 0.45;
inline constexpr double kMaxPickRmsM = 0.20;

struct PickCalibrationOptions {
  // Replace the picks by the board corners fitted in every sighting of the
  // target (SolveRefinedCorners), and solve the raw picks too as the paper's
  // baseline. Best with a thin board turned 45 deg (docs/calibration.md).
  bool refine = false;
  CalibrationOptions solver;
  MountingError initial;  // the angles the target region and the solve start from
  // Correct the poses' distance scale first: the automatic mode's path
  // scale (SolveAutomatic on the same recording, from the room's planes
  // seen in both passes) applied to every pose. A wheel-radius error scales
  // the circle the EKF integrates, and the target's two passes then
  // disagree by twice the radius error, which the picks' solve cannot tell
  // from the angles (docs/results.md, "Robustness": 4.5 mrad RMS of alpha
  // without it on drives with +-1 % wheel errors). Costs one automatic
  // solve; skipped, with a warning, if that fails. Off for truth poses.
  bool path_scale_from_planes = false;
  // refine with path_scale_from_planes: combine the board's angles with the
  // room's planes' (that automatic solve's) by their covariances
  // (CombineAngleEstimates, combine.h), unless the two disagree beyond
  // chance. The board's corners read alpha and beta mostly as one
  // combination and the planes pin it (docs/calibration.md, "The board and
  // the room's planes together"). The board's own result stays in
  // PickCalibrationResult::board_alone.
  bool combine_with_planes = false;
  // The poses' own heading and tilt errors, added in quadrature to the
  // solve's sigma (alpha; beta and gamma), as in the automatic mode
  // (AutoCalibrationOptions::pose_heading_sigma_rad): four corner pairs
  // give sigma from their own misfit only. 0 for truth poses; the default
  // is the smoothed EKF's, 1 mrad for the forward filter's (the CLI's
  // --no-smooth).
  double pose_heading_sigma_rad = 0.0005;
  double pose_tilt_sigma_rad = 0.00025;
};

struct PickCalibrationResult {
  // Why a calibration failed: the picks or the recording do not allow one
  // (bad input), or the solve failed.
  enum class Failure {
    kNone,
    kNoValidPick,         // no pick refers to a valid sample of the recording
    kTargetNotSeenTwice,  // refine: the region was seen in fewer than 2 sightings
    kUnresolvedPicks,     // a pick could not be resolved in the pass it claims
    kSolveFailed,         // the solver failed (summary says how far it got)
    kImplausible,         // solved, but to no mounting error: the picks pair different points
  };
  Failure failure = Failure::kNone;
  CalibrationSummary summary;  // method "pairs", "refined-corners" or "refined-corners+planes"
  // refine: the raw picks' solve (method "pairs"), when it succeeded.
  bool has_baseline = false;
  CalibrationSummary baseline;
  double path_scale = 1.0;      // applied to the poses (path_scale_from_planes)
  // path_scale_from_planes: the automatic solve that gave the scale (its
  // angles and sigma: the room's planes alone), when it succeeded.
  bool has_planes = false;
  CalibrationSummary planes;
  // combine_with_planes: the board's result before combining (the poses'
  // sigmas added as to `summary`), and the two estimates' disagreement
  // d^2 (chi^2, 3 dof; -1: not compared). `summary` holds the combination
  // (method "refined-corners+planes") when d^2 was within the bound.
  bool has_board_alone = false;
  CalibrationSummary board_alone;
  double planes_chi2 = -1.0;
  Eigen::AlignedBox3d region;  // the target region used
  TargetSightings sightings;   // the target's sightings in that region

  // What a front end shows beside the angles, one per pick pair: the
  // pair's two world positions under the solved angles and their distance
  // under the initial and the solved angles (the pair's residual, Eq. 17,
  // before and after). Pairs: the two samples the picks resolve to;
  // refine: the fitted board corner nearest the pick, in each pass.
  struct PairCheck {
    Eigen::Vector3d pass1_world = Eigen::Vector3d::Zero();  // solved angles
    Eigen::Vector3d pass2_world = Eigen::Vector3d::Zero();
    double before_m = 0.0, after_m = 0.0;
  };
  std::vector<PairCheck> pair_checks;  // empty if the picks did not resolve
  // refine: the board corners fitted in each pass under the solved angles
  // (FitBoardCorners), which the solve made coincide.
  bool has_corners = false;
  BoardCorners corners[2];
};

// Picks -> mounting error: the target region from the picks, the target's
// sightings (pass windows) in it, then the pairs solve on the resolved picks
// or, with refine, the refined-corners solve plus the raw-pick baseline.
// The Status message says why it failed (result->failure: which kind);
// pairs-count and file checks are the caller's.
Status CalibrateFromPicks(const SampleStore& store, const RobotGeometry& geometry,
                          const std::vector<PickPair>& picks,
                          const PickCalibrationOptions& options, PickCalibrationResult* result);

// The IMU's tilt readings against its data sheet, before a calibration on
// EKF poses (docs/calibration.md, "What the automatic mode refuses"). The
// EKF takes the body's roll and pitch from these readings with the HI219's
// 0.3 deg of noise (EkfOptions::imu_tilt_sigma); an IMU far noisier (a
// vibrating mount, a bad unit) makes the filter's tilt wander, which beta
// and gamma cannot tell from a mounting error, with residuals that look
// normal: on the two-turn lab circle, 1.5 deg of white tilt noise put gamma
// 2.96 mrad off at a sigma of 0.45, 3 deg put beta 14 mrad off at 1.17.
//
// The white noise of the readings is measured from consecutive differences
// (the body's true tilt on a floor changes by far less in 10 ms):
//   sigma = 1.4826 median(|r_{i+1} - r_i|) / sqrt(2)
// per axis (the median so that a bump or a threshold does not count), over
// pairs of attitude readings at most `max_gap_s` apart.
struct ImuTiltNoise {
  double roll_rad = 0.0, pitch_rad = 0.0;
  int pairs = 0;  // consecutive pairs used
  double worst_rad() const { return roll_rad > pitch_rad ? roll_rad : pitch_rad; }
};
ImuTiltNoise MeasureImuTiltNoise(const SensorLog& log, double max_gap_s = 0.05);

// Refuses ("refused: ..." in the message) when the larger of the two
// exceeds `max_rad`: 1 deg by default, twice the HI219 data sheet's worst
// (0.1-0.5 deg); up to 1 deg the sweep's results stay within 2 sigma. Ok
// when there are fewer than 100 pairs (nothing to judge).
Status CheckImuTiltNoise(const SensorLog& log, double max_rad = 0.0174533);

// The calibration's EKF takes the tilt readings' noise as measured on the
// recording when it is above the data sheet's (ekf->imu_tilt_sigma, which
// stays otherwise). A random walk seen through white readings of variance r
// is followed with a memory of sqrt(r dt / q) (docs/models.md): told the
// readings are less noisy than they are, the smoother averages too few of
// them, and a scan line's pitch error moves the target's corners along the
// board (seed 36 of the refined sweep, 0.45 deg of tilt noise: alpha -3.27
// -> -2.67 mrad). Never below the data sheet: the HI219 low-passes its tilt,
// and a correlated noise's consecutive differences under-read it.
void UseMeasuredTiltNoise(const SensorLog& log, EkfOptions* ekf);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CALIBRATION_WORKFLOW_H_
