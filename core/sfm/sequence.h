// The sequence pipeline of lidar-only structure from motion (Choi et al.
// 2017, section 4; docs/sfm.md, "The sequence pipeline"):
//
//  1. initialisation: three known planes, each with designated lines of the
//     first frame (or planes fitted from two lines each in the first frame,
//     the world then being the first rig frame); the first pose by the
//     minimal solver (p3l.h) when the planes are given;
//  2. per frame: line extraction in every scan (line_extraction.h), the
//     lines moved into the rig frame by the extrinsics;
//  3. association of lines to known planes from the predicted pose
//     (constant velocity) with the point-to-plane distance gate (Eq. 38) and
//     the line-plane angle gate (Eq. 39);
//  4. pose update by robust least squares over the associated lines
//     (Gauss-Newton on SE(3)), or the minimal solver over the associated lines
//     (RANSAC over triples) when the least squares is not constrained or fails;
//  5. new planes from the accumulated unassigned lines (at least 30): plane
//     candidates from pairs of non-parallel lines, most inlier lines wins
//     (inlier bound 0.05 m);
//  6. joint refinement of all poses and planes (Eq. 40, refine.h, Ceres).
//
// Frames: scans with the same time stamp (within 1 us) form one frame with
// one rig pose (a rig whose lidars scan together). A pose is
// x_world = R x_rig + t.
#ifndef SWEEPSCAN_CORE_SFM_SEQUENCE_H_
#define SWEEPSCAN_CORE_SFM_SEQUENCE_H_

#include <Eigen/Core>
#include <array>
#include <atomic>
#include <vector>

#include "core/common/status.h"
#include "core/sfm/line_extraction.h"
#include "core/sfm/p3l.h"

namespace sweepscan::sfm {

// One 2D scan: points in the lidar's scan plane (lidar x, y; the lidar
// frame's z = 0), in scan order, NaN for dropouts.
struct Scan {
  double time_s = 0.0;
  int lidar = 0;
  std::vector<Eigen::Vector2d> points;
  // Optional, empty or the same size as `points`: the samples deskewed to
  // `time_s` (lidar frame, NaN for dropouts). A scan taken while the sensor
  // moves (the X4's revolution lasts ~140 ms) is not rigid: its samples,
  // moved to one instant by another pose source, leave the scan plane by
  // the motion during the revolution. Lines are then found in `points`
  // (segmentation only needs the 2D order) and fitted to these 3D samples.
  std::vector<Eigen::Vector3d> deskewed;
};

// A line of the first frame, designated by the index of the extracted line
// in that lidar's first scan (`line` >= 0), or else by a point of the scan
// plane near it (the extracted line whose supporting samples pass nearest).
struct InitLineRef {
  int lidar = 0;
  int line = -1;
  Eigen::Vector2d near = Eigen::Vector2d::Zero();
};

struct InitPlane {
  bool known = false;  // `plane` given in the world frame
  WorldPlane plane;
  std::vector<InitLineRef> lines;
};

// Either all three planes known (world = the planes' frame; the first pose
// by the minimal solver; gauge: the three planes fixed), or none (world =
// first rig frame; each plane fitted from at least two non-parallel lines
// of the first frame; gauge: the first pose fixed).
struct SequenceInit {
  std::array<InitPlane, 3> planes;
};

struct SequenceOptions {
  LineExtractionOptions lines;
  // Association gates (Eq. 38-39), from the predicted pose: every point of
  // the line (its two extreme points and centroid) within `distance` of the
  // plane, and the line within `angle` of lying in the plane. A second pass
  // after the pose update uses the tight gates.
  double assoc_distance_m = 0.10;
  double assoc_angle_deg = 5.0;
  double assoc_tight_distance_m = 0.05;
  double assoc_tight_angle_deg = 2.0;
  // A line must also lie within the plane's seen extent grown by this.
  double extent_margin_m = 0.6;
  // Pose update: Huber threshold of the per-line RMS distance (m), iterations.
  double huber_m = 0.02;
  int pose_iterations = 6;
  // New planes (section 4): candidates once this many unassigned lines are
  // waiting, inlier bound, least inliers, line pairs tried per search.
  int new_plane_min_lines = 30;
  double new_plane_inlier_m = 0.05;
  int new_plane_min_inliers = 12;
  int new_plane_min_frames = 4;       // inliers from at least this many frames
  double new_plane_min_pair_angle_deg = 10.0;
  int new_plane_max_pairs = 400;
  int unassigned_max_age_frames = 120;  // older unassigned lines are dropped
  // Joint refinement (Eq. 40): passes (re-associating every frame with the
  // refined poses between passes); 0 skips it.
  int refine_passes = 2;
  // New planes also from pairs of (nearly) parallel lines whose centroids
  // lie at least this far apart across the lines (0: only non-parallel
  // pairs). A scanner that keeps its scan plane's orientation (the wheeled
  // scanner driving straight) sees every floor line parallel to every
  // other: the floor is the plane through two of them, n = u_i x (c_j - c_i).
  double new_plane_parallel_separation_m = 0.0;
  double refine_huber_m = 0.02;
  int refine_max_iterations = 50;
  int threads = 2;
  uint64_t seed = 1;
  // Set from another thread (the desktop app's Cancel) to stop the run:
  // checked once a frame while tracking and once an iteration of the
  // refinement, which then returns the error "cancelled". Not owned; may be
  // null.
  const std::atomic<bool>* cancel = nullptr;
};

// A line-plane observation (rig frame), in the compact form that Eq. 40
// needs: for the line's N samples with centroid c, principal direction u and
// spread sigma^2 = lambda_max / N along u,
//   (1/N) sum_k (n . (R p_k + t) + d)^2
//     = (n . (R c + t) + d)^2 + sigma^2 (n . R u)^2 + (noise across the line),
// so two residuals per line are exact for the point-to-plane cost.
struct LineObs {
  int frame = 0;
  int plane = -1;  // -1: unassigned
  int scan = 0;    // index into the input scans
  int line = 0;    // index of the line within its scan's extraction
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();   // rig frame
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // rig frame, unit
  double sigma = 0.0;                                    // spread along the line (m)
  double half_length = 0.0;                              // half the extent (m)
  int count = 0;                                         // supporting samples
};

struct FoundPlane {
  WorldPlane plane;
  bool initial = false;   // one of the three initial planes
  int first_frame = 0;    // frame at which it was initialised / found
  int observations = 0;   // lines assigned to it (after refinement)
  int frames = 0;         // distinct frames that see it
  Eigen::Vector3d extent_min = Eigen::Vector3d::Constant(1e300), extent_max = Eigen::Vector3d::Constant(-1e300);
};

struct RefineSummary {
  int passes = 0;
  int iterations = 0;
  double initial_cost = 0.0, final_cost = 0.0;
  double seconds = 0.0;  // wall time of the Ceres solves
  int residual_blocks = 0;
};

struct SequenceResult {
  std::vector<double> frame_times_s;
  std::vector<std::vector<int>> frame_scans;  // input scan indices per frame
  std::vector<Rigid3d> tracked;               // world_from_rig, before refinement
  std::vector<Rigid3d> poses;                 // world_from_rig, refined (= tracked if no refinement)
  std::vector<FoundPlane> planes;
  std::vector<LineObs> lines;                 // every extracted line, with its final plane
  bool gauge_first_pose = false;              // true: world = first rig frame
  int lines_total = 0, lines_assigned = 0;
  int frames_p3l = 0;                         // frames placed by the minimal solver (relocalisation)
  int frames_weak = 0;                        // frames whose least squares was rank-deficient
  RefineSummary refine;
  double tracking_seconds = 0.0;
};

// A motion prior from another pose source (the wheeled scanner's EKF or
// odometry; docs/sfm.md, "The wheeled scanner"): its pose of every frame.
// Only its relative motion between consecutive frames is trusted,
//   D_k = P_{k-1}^-1 P_k,
// with independent errors per axis of frame k-1's rig frame, each standard
// deviation a floor plus a part proportional to the motion (wheels slip in
// proportion to the distance, a gyro drifts with time):
//   sigma_t[a] = t0[a] + t_per_m[a] |D_k.t|,
//   sigma_r[a] = r0[a] + r_per_rad |angle(D_k.R)| + r_per_m |D_k.t|.
// The lines' cost (squared metres times samples, Eq. 40) and the prior's
// (squared, per unit sigma) are put on one scale by `point_sigma_m`: the
// prior's residuals are multiplied by it, as if each line sample had that
// standard deviation.
struct MotionPrior {
  std::vector<Rigid3d> world_from_rig;  // per frame
  // Prediction P: X_k = X_{k-1} D_k (else the constant-velocity model).
  bool predict = true;
  // The relative-motion terms in the pose update and in the refinement
  // (else the prior only predicts).
  bool constrain = true;
  // The defaults suit the wheeled scanner's EKF between two X4 scans
  // (143 ms, ~3 cm): 0.2 mm + 1 % of the distance along the motion, 0.2 %
  // across it, 0.1 mrad + 1 % of the turn + 2 mrad per metre. Softer chains
  // (0.5 mm + 2 %, 0.3 mrad) let the sequence bend to fit the lines'
  // millimetre biases: docs/sfm.md, "The wheeled scanner".
  Eigen::Vector3d t0_m = Eigen::Vector3d(0.0002, 0.0002, 0.0002);
  Eigen::Vector3d t_per_m = Eigen::Vector3d(0.01, 0.002, 0.002);
  Eigen::Vector3d r0_rad = Eigen::Vector3d(0.0001, 0.0001, 0.0001);
  double r_per_rad = 0.01;
  double r_per_m = 0.002;
  double point_sigma_m = 0.01;
  // Absolute orientation terms in the refinement (0: none): the prior's
  // tilt (roll, pitch: the EKF's come from the IMU's gravity reference) and
  // yaw (the EKF's is held by the IMU's yaw; odometry's drifts: none), as
  // standard deviations of the world-frame rotation error per frame. They
  // hold the gauge: one fixed first pose does not, since a chain of soft
  // relative terms lets the whole sequence turn about it at the cost of
  // one link, and the wheeled scanner's lines hardly see pitch and yaw.
  double abs_tilt_sigma_rad = 0.0;
  double abs_yaw_sigma_rad = 0.0;

  // Square-root information (diagonal) of D_k's error, in the prior's units
  // scaled by point_sigma_m: [rotation (3), translation (3)].
  Eigen::Matrix<double, 6, 1> SqrtInformation(const Rigid3d& delta) const;
};

// The rig-frame points of a scan (NaNs skipped) at a pose: the cloud.
std::vector<Eigen::Vector3d> ScanPointsInWorld(const Scan& scan, const Rig& rig, const Rigid3d& world_from_rig);

Status RunSequence(const std::vector<Scan>& scans, const Rig& rig, const SequenceInit& init,
                   const SequenceOptions& options, SequenceResult* result);
// With a motion prior (one pose per frame; `prior` may be null). Then the
// initialisation may give no plane at all (every `InitPlane::lines` empty:
// the planes are all found as the sequence goes, the world is the prior's,
// the gauge is the first pose at the prior's), or three known planes with
// lines of the first frame (their normals may share a direction: the first
// pose is the prior's, corrected by those lines, not the minimal solver's).
// The minimal solver does not relocalise: the prior's prediction stands for
// it.
Status RunSequence(const std::vector<Scan>& scans, const Rig& rig, const SequenceInit& init,
                   const SequenceOptions& options, const MotionPrior* prior, SequenceResult* result);

// Association test (Eq. 38-39) of a line (rig frame) at a pose: the largest
// point-to-plane distance of the line's extreme points and centroid, and the
// sine of the angle between the line and the plane. Exposed for tests.
void LinePlaneDistance(const LineObs& line, const Rigid3d& world_from_rig, const WorldPlane& plane,
                       double* max_distance_m, double* sin_angle);

// Robust least-squares pose from lines on known planes (Gauss-Newton on
// SE(3) from `*pose`, Huber weights, Eq. 40 restricted to one pose). Returns
// the smallest eigenvalue of the normalised 6x6 information matrix (0 when
// the lines do not fix the pose); a weak direction stays at the start pose.
double UpdatePose(const std::vector<const LineObs*>& lines, const std::vector<WorldPlane>& planes,
                  const SequenceOptions& options, Rigid3d* pose);
// The same with a prior on the pose: the cost gains
//   || diag(sqrt_info) [Log(R_p^T R); R_p^T (t - t_p)] ||^2
// (rotation first, in the prior pose's axes), which holds the directions
// the lines leave free at the prior. Returns the smallest eigenvalue of the
// lines' part alone (what the lines fix).
double UpdatePose(const std::vector<const LineObs*>& lines, const std::vector<WorldPlane>& planes,
                  const SequenceOptions& options, const Rigid3d& prior_pose,
                  const Eigen::Matrix<double, 6, 1>& sqrt_info, Rigid3d* pose);

}  // namespace sweepscan::sfm

#endif  // SWEEPSCAN_CORE_SFM_SEQUENCE_H_
