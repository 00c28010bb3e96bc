// Automatic mode (no picks), solved with Ceres' Levenberg-Marquardt.
//
// Planes (walls, floor, ceiling, the board) are found by RANSAC in the cloud
// under the current c; each surface s gets a plane (n_s, d_s) as extra Ceres
// parameters (n_s on the unit sphere) and every point i of s a residual
// (n_s . p_W^i(c) + d_s) / sigma_i weighted by the range noise model; points
// of the two passes must then lie on one plane. Segmentation and solve
// alternate with a shrinking inlier band, since a miscalibrated cloud shows
// each wall twice, up to 20 cm apart; at the final band membership is per
// point (3 sigma_i) and scan-line runs offset from their plane (a parallel
// surface 2 cm away) are dropped. sigma is the larger of the iid and the
// cluster-robust estimate.
//
// Pure functions, no globals; may run on any thread; cancel through
// CalibrationOptions::progress.
#ifndef SWEEPSCAN_CORE_CALIBRATION_AUTOMATIC_H_
#define SWEEPSCAN_CORE_CALIBRATION_AUTOMATIC_H_

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/calibration/pairs_solver.h"
#include "core/calibration/samples.h"
#include "core/common/status.h"
#include "core/robot/robot_model.h"

namespace sweepscan {

struct AutoCalibrationOptions {
  CalibrationOptions solver;
  size_t max_segmentation_points = 60000;  // subsample of the cloud for RANSAC
  size_t max_points_per_plane = 20000;     // residuals per surface (evenly subsampled)
  int max_planes = 8;
  double min_plane_fraction = 0.02;  // of the segmentation sample
  int ransac_iterations = 400;
  double initial_band_m = 0.20;  // RANSAC inlier band at the first round
  double final_band_m = 0.03;
  double min_range_m = 0.3;  // ignore samples nearer than this
  uint64_t seed = 1;
  // Noise model of one point along a plane's normal (X4 data sheet, as in
  // core/sim): sigma_i = sqrt(a^2 + (b rho_i)^2 + m^2), with m a floor for
  // pose and model errors. Residuals are divided by sigma_i (weighted least
  // squares) and, at the final band, a point is a member only within
  // membership_sigmas * sigma_i of its plane. Why: a uniform 3 cm band lets
  // the board (y = 0.16) and the window sill 2 cm behind it (y = 0.14)
  // merge into one "plane" whose fit differs between the passes.
  double range_noise_m = 0.002;
  double range_noise_fraction = 0.002;
  double model_noise_m = 0.001;
  double membership_sigmas = 3.0;
  // A scan line's run of consecutive members whose mean distance from its
  // plane exceeds this is a parallel surface nearby, not the plane.
  double surface_step_m = 0.008;
  // A point within this distance of another kept plane is ambiguous (edges,
  // where two surfaces meet, and parallel surfaces a few cm apart) and gives
  // no residual.
  double edge_margin_m = 0.05;
  // Each round's LM solve ends once a successful step moves no angle by
  // more than this, besides Ceres' own tolerances. Why: the Huber loss makes
  // LM converge linearly (a tenth of the way per step at the final band,
  // half at the first), so Ceres' function tolerance of 1e-12 took 11-28
  // steps a round to settle the eighth digit; 1e-7 rad is a thousandth of
  // the smallest sigma the mode reports and a hundredth of the rounds' own
  // settling (a round at the final band that moves the angles less than
  // 1e-5 rad ends the mode).
  double lm_angle_tolerance_rad = 1e-7;
  // Huber scale on the normalised residuals r_i / sigma_i (used when
  // solver.loss is kNone; another loss uses this scale too).
  double robust_scale_sigmas = 2.0;
  // Cluster-robust ("sandwich") covariance: residuals are grouped into
  // blocks of this many seconds; errors correlated within a block (pose
  // errors of the EKF, a scan line's systematic offset) then widen sigma
  // instead of being counted as independent.
  double covariance_block_s = 2.0;
  // Refusals (docs/calibration.md, "What the automatic mode refuses").
  // Before solving: the drive must be a circle (FitCircleDrive on the
  // robot's positions at the samples' times): a straight or wandering drive
  // has no two passes of each wall, and the angles it gives are not
  // trustworthy. After solving: a result with any |angle| >= max_abs_angle_rad
  // (the calibration file accepts 0.5 rad; 0.45 is "at or near" that bound),
  // or whose residuals collapsed (RMS of r_i / sigma_i below min_rms_sigmas:
  // the X4's noise cannot vanish, so the cloud folded onto one plane) or
  // whose sigma collapsed (below min_sigma_rad), is refused.
  // The path's distance scale as a nuisance parameter (one number, about
  // the centre of the robot's positions): a wheel-radius error scales the
  // whole circle the EKF integrates (its yaw comes from the IMU, its speed
  // from the wheels alone), the two passes of a wall then disagree by twice
  // the radius error, and the angles absorbed it (1 % of wheel radius: ~1.5
  // mrad of alpha on the lab circle). The cloud's two passes observe it.
  bool estimate_path_scale = true;
  // The poses' own heading error over the drive, which alpha cannot tell
  // from a mounting yaw (a constant heading error turns the whole cloud
  // about z, as alpha does); added in quadrature to alpha's sigma. The
  // default is the smoothed EKF's (what `calibrate` and the app use),
  // measured by the robustness sweep (docs/results.md, "Robustness": over
  // 120 two-turn drives alpha's error is 0.39 mrad RMS on smoothed EKF
  // poses, of which ~0.3 is the poses' and ~0.2 the method's own, as truth
  // poses show; every error within 1.7 sigma). The CLI passes 1 mrad for the
  // forward filter (--no-smooth: 0.54 mrad RMS, up to 1.4), 0 for truth
  // poses, and more for odometry.
  double pose_heading_sigma_rad = 0.0005;
  // The same for the poses' tilt (roll and pitch, which beta and gamma
  // cannot tell from a tilted body), added to beta's and gamma's sigma:
  // the sweep's EKF-pose beta errors were 0.29 mrad RMS against a reported
  // 0.25 without it. Generous for gamma (its errors were 0.1 mrad RMS).
  double pose_tilt_sigma_rad = 0.00025;
  bool require_circle_drive = true;
  double max_abs_angle_rad = 0.45;
  double min_rms_sigmas = 0.05;
  // ... or whose residuals are out of line with the noise model the other
  // way: RMS of r_i / sigma_i above max_rms_sigmas. Members are taken within
  // 3 sigma_i, so a lidar far noisier than the model leaves a nearly flat
  // spread there (RMS up to 1.73) and truncated, biased planes; sigma,
  // computed as if the model held, then misleads (10 mm + 1 % of range
  // noise: alpha 15.7 mrad off at a sigma of 1.1, RMS 1.53). The data
  // sheet's worst X4 (3 mm + 0.4 %) gives 1.24, the model's own about 0.8.
  double max_rms_sigmas = 1.4;
  double min_sigma_rad = 1e-7;

  bool IsValid(std::string* error) const;
};

// Automatic mode on all samples of the recording. Refusals (see the
// options) return an error whose message starts with "refused: ", one line.
Status SolveAutomatic(const SampleStore& store, const RobotGeometry& geometry,
                      const MountingError& initial, const AutoCalibrationOptions& options,
                      CalibrationSummary* summary);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CALIBRATION_AUTOMATIC_H_
