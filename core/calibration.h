// Mounting-error calibration (Miao et al. 2022, section 4, Eq. 15-17) and an
// automatic variant, solved with Ceres' Levenberg-Marquardt.
//
// Model. Sample i (range rho_i, scan angle theta_i, time t_i) lands at
//   p_W(c) = world_from_body(t_i) * body_from_lidar(g, c) * p_L(rho_i, theta_i)   (Eq. 1, 11-14)
// with body_from_lidar = [Rz(alpha) Ry(beta) Rx(gamma) | (l1, 0, h)] (Eq. 13)
// and c = (alpha, beta, gamma) the mounting error. The calibration re-projects
// raw samples for every candidate c; it never moves cloud points.
//
// Pairs (the paper's method). The operator picks the same physical feature
// (a corner of the target board) in the first and the second pass of a
// circle drive. With pairs (a_k, b_k), k = 1..K, K >= 4 (Eq. 15-17):
//   c* = argmin_c  sum_k rho( |p_W^{a_k}(c) - p_W^{b_k}(c)|^2 )
// with rho the identity or a robust loss. Three residuals per pair.
//
// Refined corners. A raw pick is the sample nearest a corner, which in the
// two passes are different physical points (scans ~5 cm apart on the board
// at 0.2 m/s, samples 0.5 deg apart), so a pick pair is only a corner pair to
// within centimetres. FitBoardCorners (board_fit.cc) replaces each pass's
// picks by the board corners fitted from that pass's samples (plane, then a
// rectangle through the scan lines' end points). The corners move with c,
// so the solve is an outer loop: fit corners under c_k, freeze each corner
// as a virtual lidar point attached to the pose of its nearest sample,
// solve for c_{k+1}, re-fit, until c stops changing (see
// docs/calibration.md for why that fixed point is the answer). An upright
// board's side edges run along the vertical scan lines and are located only
// to the line spacing; a thin board turned 45 deg (a diamond) on two slow
// turns gives millimetre corners and mrad angles (measured there).
//
// Automatic mode. No picks: planes (walls, floor, ceiling, the board) are
// found by RANSAC in the cloud under the current c; each surface s gets a
// plane (n_s, d_s) as extra Ceres parameters (n_s on the unit sphere) and
// every point i of s a residual (n_s . p_W^i(c) + d_s) / sigma_i weighted by
// the range noise model; points of the two passes must then lie on one
// plane. Segmentation and solve alternate with a shrinking inlier band,
// since a miscalibrated cloud shows each wall twice, up to 20 cm apart; at
// the final band membership is per point (3 sigma_i) and scan-line runs
// offset from their plane (a parallel surface 2 cm away) are dropped.
// sigma is the larger of the iid and the cluster-robust estimate.
//
// All functions are pure (no globals) and may run on any thread; a long
// solve can be cancelled through CalibrationProgress.
#ifndef SWEEPSCAN_CORE_CALIBRATION_H_
#define SWEEPSCAN_CORE_CALIBRATION_H_

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/passes.h"
#include "core/plane.h"
#include "core/pose_buffer.h"
#include "core/robot_model.h"
#include "core/sensor_data.h"
#include "core/status.h"

namespace sweepscan {

// A raw sample's address in the recording.
struct SampleRef {
  uint32_t scan = 0;
  uint16_t beam = 0;
  bool operator==(const SampleRef& o) const { return scan == o.scan && beam == o.beam; }
};

// What the solver re-projects: a point in the lidar frame (Eq. 1 for a real
// sample, any point for a virtual one such as a fitted corner) and the body
// pose at the sample's own time.
struct LidarObservation {
  SampleRef ref;
  int64_t time_ns = 0;
  Eigen::Vector3d p_lidar = Eigen::Vector3d::Zero();
  Rigid3d world_from_body;
};

// p_W(c) = world_from_body * body_from_lidar(g, c) * p_lidar.
Eigen::Vector3d ProjectObservation(const LidarObservation& o, const RobotGeometry& geometry,
                                   const MountingError& calibration);

// The valid raw samples of a recording with their interpolated poses,
// addressable by (scan, beam). Samples without a pose or out of range are
// left out (as the assembler leaves them out).
class SampleStore {
 public:
  SampleStore() = default;
  SampleStore(const SensorLog& log, const PoseBuffer& poses, double min_range_m = 0.12,
              double max_range_m = 10.0);

  const std::vector<LidarObservation>& observations() const { return observations_; }
  // Error if the recording has no such valid sample.
  Status Find(const SampleRef& ref, LidarObservation* out) const;
  // Indices of the observations whose time lies in the window.
  std::vector<size_t> InWindow(const PassWindow& window) const;
  // Nearest observation of the window to `world` under `calibration`;
  // error if the window is empty.
  Status Nearest(const PassWindow& window, const Eigen::Vector3d& world,
                 const RobotGeometry& geometry, const MountingError& calibration,
                 LidarObservation* out) const;

 private:
  std::vector<LidarObservation> observations_;  // time order
  std::unordered_map<uint64_t, size_t> by_ref_;
};

// One picked feature: a raw sample, or an approximate world position that
// snaps to the nearest sample of its pass.
struct Pick {
  bool has_sample = false;
  SampleRef sample;
  Eigen::Vector3d world = Eigen::Vector3d::Zero();  // used when !has_sample
};
struct PickPair {
  Pick pass1, pass2;
};
struct ObservationPair {
  LidarObservation pass1, pass2;
};

// Resolves picks against the recording: samples are looked up, world
// positions snap to their pass under `calibration`. Checks every pick
// belongs to the pass it claims (windows[0] for pass1, windows[1] for pass2).
Status ResolvePairs(const std::vector<PickPair>& picks, const SampleStore& store,
                    const std::vector<PassWindow>& windows, const RobotGeometry& geometry,
                    const MountingError& calibration, std::vector<ObservationPair>* pairs);

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
  double initial_rms_m = 0.0;  // RMS pair distance (pairs) or point-to-plane distance (auto)
  double final_rms_m = 0.0;
  double initial_cost = 0.0, final_cost = 0.0;
  double condition_number = 0.0;
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

// Eq. 15-17 on resolved pairs. Fails (Status) on bad input: fewer than
// min_pairs pairs, non-finite values, a pair whose two samples are the same
// or from the same moment. `summary` is filled whenever the solve ran.
Status SolvePairs(const std::vector<ObservationPair>& pairs, const RobotGeometry& geometry,
                  const MountingError& initial, const CalibrationOptions& options,
                  CalibrationSummary* summary);

// Board corners of one pass, from its samples under a calibration.
struct BoardCorners {
  Plane plane;
  // Corners in the board plane, clockwise seen from the front (the side the
  // samples came from), starting with the corner whose direction from the
  // centre is nearest 112.5 deg (u = 0 deg, v = 90 deg): top-left, top-right,
  // bottom-right, bottom-left for an upright board; top, right, bottom, left
  // for a diamond. u = normalize(z x n), n oriented so that u points along +x
  // (or +y if the board faces x); v = n x u points up.
  std::array<Eigen::Vector3d, 4> corners;
  // Index (into the input) of the sample nearest each corner: the corner is
  // attached to that sample's pose when the solver re-projects it.
  std::array<size_t, 4> nearest;
  Eigen::Vector2d size_m = Eigen::Vector2d::Zero();  // fitted rectangle: width, height
  double rotation_rad = 0.0;  // of the rectangle's first axis from u, in [-pi/4, pi/4)
  double edge_rms_m = 0.0;    // RMS of the edge-point residuals
  size_t points = 0;          // inliers used
  size_t scans = 0;
  size_t edge_points = 0;  // scan-line end points (and side points) in the rectangle fit
};

// Fits the board from the samples of one pass (points near the target, all
// from one sighting), re-projected under `calibration`:
//  1. a plane (RANSAC, 1 cm band, then least squares on the board's runs);
//  2. per scan line the longest gap-free run of in-plane samples, kept if it
//     reaches the height of the longest line's middle (a convex board
//     always does; a run on the sill below does not);
//  3. edge points: each line's top and bottom sample and, beyond each, where
//     the next beam of that scan would have met the plane; the edge lies
//     between the two, so the midpoint is unbiased with error
//     U(-s/2, s/2), s the local spacing (variance s^2/12);
//  4. a rectangle (centre, rotation, width, height) by weighted least
//     squares of the edge points' offsets along their scan line from the
//     rectangle's boundary. For a fixed rotation this is linear; the
//     rotation is found by golden-section search. An edge within 20 deg of
//     the scan lines is crossed by none: it is then placed half a line
//     spacing beyond the outermost line (the upright board's side edges,
//     located only to the scan spacing; mount the target as a diamond).
Status FitBoardCorners(const std::vector<LidarObservation>& samples, const RobotGeometry& geometry,
                       const MountingError& calibration, BoardCorners* corners);

// The target's samples on a circle drive: every valid sample whose world
// position under `calibration` lies in `region` (a box around the target,
// generous enough for uncalibrated ghosts), split into sightings by time
// gaps (FindPassWindows, gap_s, min_count). Sightings alternate near / far,
// so the even ones (k = 0, 2, ...) form pass 1 and the odd ones pass 2; with
// several turns each pass gathers the lines of all its sightings.
struct TargetSightings {
  std::vector<PassWindow> windows;           // all sightings, in time order
  std::vector<LidarObservation> passes[2];   // their samples, pass 1 and pass 2
};
TargetSightings CollectTargetSightings(const SampleStore& store, const RobotGeometry& geometry,
                                       const MountingError& calibration,
                                       const Eigen::AlignedBox3d& region, double gap_s = 1.0,
                                       size_t min_count = 20);

// RMS distance between the corners of two passes.
double CornerRms(const BoardCorners& a, const BoardCorners& b);

// Refined corners: the two passes' board samples (e.g. from
// SplitRegionIntoPasses via SampleStore) and the outer loop described above.
Status SolveRefinedCorners(const std::vector<LidarObservation>& pass1,
                           const std::vector<LidarObservation>& pass2,
                           const RobotGeometry& geometry, const MountingError& initial,
                           const CalibrationOptions& options, CalibrationSummary* summary);

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
  // Huber scale on the normalised residuals r_i / sigma_i (used when
  // solver.loss is kNone; another loss uses this scale too).
  double robust_scale_sigmas = 2.0;
  // Cluster-robust ("sandwich") covariance: residuals are grouped into
  // blocks of this many seconds; errors correlated within a block (pose
  // errors of the EKF, a scan line's systematic offset) then widen sigma
  // instead of being counted as independent.
  double covariance_block_s = 2.0;

  bool IsValid(std::string* error) const;
};

// Automatic mode on all samples of the recording.
Status SolveAutomatic(const SampleStore& store, const RobotGeometry& geometry,
                      const MountingError& initial, const AutoCalibrationOptions& options,
                      CalibrationSummary* summary);

// Files (docs/calibration.md).
Status LoadPairsFile(const std::string& path, std::vector<PickPair>* pairs);
Status ParsePairs(const std::string& text, const std::string& source, std::vector<PickPair>* pairs);
std::string PairsToJson(const std::vector<PickPair>& pairs);

Status SaveCalibrationFile(const std::string& path, const MountingError& calibration,
                           const CalibrationSummary* summary);
Status LoadCalibrationFile(const std::string& path, MountingError* calibration);
Status ParseCalibration(const std::string& text, const std::string& source,
                        MountingError* calibration);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CALIBRATION_H_
