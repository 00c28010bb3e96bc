// Registration of recorded sessions into one frame (issue 29, "Scan a
// building"): each session's cloud lives in its own world frame (the robot's
// start pose, z up, gravity-aligned by the IMU); a project needs
// target_from_source for every pair of overlapping sessions.
//
// Three levels, each giving target_from_source, its residual and an
// uncertainty in a RegistrationResult:
//
//  1. AlignByPlanes: coarse and automatic. Both frames are gravity-aligned,
//     so the rotation between them is a yaw about z plus a small tilt; the
//     floors' normals must agree (refused otherwise). Hypotheses come from
//     matching pairs of non-parallel wall planes (yaw from the normals,
//     x and y from the two walls' offsets, z from the floors) and are scored
//     by how much of the source lands on target surfaces, so the 90-degree
//     ambiguity of rectangular rooms is decided by content. Refused when the
//     best hypothesis is not clearly better than the next distinct one, when
//     the clouds share too little, and when only parallel walls constrain it
//     (a corridor: free_direction says which way stays free).
//  2. AlignByPairs: coarse, by the operator: >= 3 picked point pairs give the
//     least-squares rigid transform (Horn / Umeyama without scale); refused
//     for collinear or coincident picks.
//  3. RefineIcp: fine. Point-to-plane ICP with a robust (Cauchy or
//     Geman-McClure) loss by iteratively reweighted least squares, trimmed by
//     a shrinking correspondence distance, Gauss-Newton on se(3); degeneracy
//     from the eigenvalues of the 6x6 normal matrix (a corridor's free axis
//     is refused, or held, and reported).
//
// docs/registration.md has the equations and the refusals.
//
// Conventions of every result:
//  * target_from_source maps source coordinates into the target's frame.
//  * The covariance is over a left perturbation in the target frame,
//    T = Exp(xi) * T_hat with xi = (omega_x, omega_y, omega_z [rad],
//    v_x, v_y, v_z [m]): rotation first, then translation.
//  * free_direction is a unit vector in the target frame.
//
// Pure functions, callable from any thread; the parallel loops run on
// oneTBB in blocks of a fixed size combined in block order, so results do
// not depend on the thread count. Progress and cancel through
// RegistrationControl (EvaluationControl's contract).
#ifndef SWEEPSCAN_CORE_REGISTRATION_REGISTRATION_H_
#define SWEEPSCAN_CORE_REGISTRATION_REGISTRATION_H_

#include <Eigen/Core>
#include <atomic>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/geometry/transform.h"

namespace sweepscan {

struct RegistrationResult {
  Rigid3d target_from_source;
  // Left perturbation in the target frame, (omega [rad], v [m]); see above.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  double rms_m = 0.0;          // RMS of the residuals at the result (point-to-plane, or per pair)
  double overlap = 0.0;        // fraction of the (sub-sampled) source matched in the target
  size_t correspondences = 0;  // residuals behind the result
  int iterations = 0;          // ICP iterations; hypotheses scored for planes; 0 for pairs
  bool degenerate = false;     // some direction is unconstrained (see free_direction)
  // Unit vector in the target frame: the translation that stays free (a
  // corridor's axis), or, if free_is_rotation, the axis of a free rotation.
  Eigen::Vector3d free_direction = Eigen::Vector3d::Zero();
  bool free_is_rotation = false;
  std::string method;  // "planes", "pairs", "icp"

  // Planes: the best and the next distinct hypothesis's scores (inlier
  // minus conflict fractions, PlaneAlignOptions); iterations holds how many
  // distinct hypotheses were scored.
  double best_score = 0.0;
  double second_score = 0.0;
  // Pairs: |T * source_i - target_i| for every pair, metres.
  std::vector<double> pair_residuals_m;
  // ICP: eigenvalues of the normalised 6x6 normal matrix (ascending; see
  // IcpOptions::degeneracy_threshold).
  Eigen::Matrix<double, 6, 1> eigenvalues = Eigen::Matrix<double, 6, 1>::Zero();

  // 1-sigma of the rotation (deg) and translation (m) along their worst
  // directions (the covariance blocks' largest eigenvalues).
  double RotationSigmaDeg() const;
  double TranslationSigmaM() const;
  // Several lines for a log or a report.
  std::string Report() const;
};

// Progress of a registration. Stages in order; kDone once, at the end.
enum class RegistrationStage { kPrepare, kPlanes, kHypotheses, kIcp, kDone };
const char* RegistrationStageName(RegistrationStage stage);

struct RegistrationProgress {
  RegistrationStage stage = RegistrationStage::kPrepare;
  double fraction = 0.0;  // 0..1 of the whole call; never decreases
  int iteration = 0;      // ICP iteration (kIcp)
  double rms_m = 0.0;     // ICP residual RMS at that iteration (kIcp)
};

// Same contract as EvaluationControl: `progress` is called one call at a
// time, possibly from worker threads, at most about 50 times a second;
// returning false cancels. `cancel` may be set from any thread. A cancelled
// call returns within about 100 ms with a Status whose message is
// kRegistrationCancelled.
struct RegistrationControl {
  std::function<bool(const RegistrationProgress&)> progress;
  const std::atomic<bool>* cancel = nullptr;
};
extern const char* const kRegistrationCancelled;

// Voxel-grid downsampling: the centroid of the points in each cube of side
// voxel_m (voxels ordered by their integer coordinates, so the output does
// not depend on the input's order within a voxel or on threads).
std::vector<Eigen::Vector3f> VoxelCentroids(const std::vector<Eigen::Vector3f>& points,
                                            double voxel_m);

// ---------------------------------------------------------------------------
// 1. Coarse, automatic, from planes.

struct PlaneAlignOptions {
  // Both clouds are downsampled to this voxel before plane extraction and
  // hypothesis scoring.
  double voxel_m = 0.08;
  // Plane extraction (RANSAC, core/evaluation ExtractPlanes) on the
  // downsampled cloud.
  double plane_distance_m = 0.04;
  int max_planes = 24;
  double min_plane_fraction = 0.004;
  // A plane within this angle of horizontal is a floor/ceiling candidate,
  // within this angle of vertical a wall.
  double classify_angle_deg = 5.0;
  // The floors' normals of source and target must agree within this (both
  // frames are gravity-aligned by the IMU); refused otherwise.
  double floor_agreement_deg = 3.0;
  // Two walls are non-parallel if their normals are at least this far apart.
  double min_wall_angle_deg = 30.0;
  // Source and target wall pairs match if their angles agree within this,
  // and both walls' yaws agree within this.
  double angle_tolerance_deg = 3.0;
  // Hypotheses closer than these are one (the best of them is kept).
  double same_yaw_deg = 0.5;
  double same_translation_m = 0.03;
  // Scoring: a source sample (walls and furniture sides: points whose
  // normal is not vertical) is an inlier if its nearest target point is
  // within inlier_distance_m, its point-to-plane distance within
  // inlier_plane_m and the normals within 30 deg; a conflict if its nearest
  // target point is within conflict_distance_m but it is no inlier (the
  // target saw that place, and something else there); otherwise neutral
  // (a place the target did not see). Score = inlier fraction -
  // conflict_weight * conflict fraction: overlap alone would prefer a pose
  // that piles the source onto the target's floor and corridor (they match
  // under many shifts) over the true pose with a partial overlap. First every
  // hypothesis on coarse_samples points, then the best rescore_count on
  // score_samples.
  // A sample parallel to its nearest target surface and within thin_wall_m
  // of it, but not within inlier_plane_m, is neutral, not a conflict: the
  // other face of a thin wall (0.1 m partitions), which the target may not
  // have seen.
  double conflict_distance_m = 0.5;
  double thin_wall_m = 0.15;
  double conflict_weight = 2.0;
  // Gauss-Newton steps polishing each rescored hypothesis on its inliers
  // before its final score (planes.cc says why).
  int polish_iterations = 4;
  double inlier_distance_m = 0.25;
  double inlier_plane_m = 0.05;
  size_t coarse_samples = 1500;
  size_t score_samples = 8000;
  int rescore_count = 24;
  // Refusals: the best hypothesis's inlier fraction below min_overlap (the
  // clouds share too little to be told apart from a look-alike: two similar
  // rooms put a quarter of their wall points on each other's surfaces), or
  // its score below min_score_ratio times the second's, where second is the
  // best hypothesis that differs from the best by at least distinct_yaw_deg
  // or distinct_translation_m (closer ones would converge to the same pose).
  double distinct_yaw_deg = 10.0;
  double distinct_translation_m = 1.0;
  double min_overlap = 0.3;
  double min_score_ratio = 1.25;
  int threads = 0;  // 0 = all hardware threads; the result does not depend on it

  bool IsValid(std::string* error) const;
};

// Coarse alignment from planes. On a refusal the Status says why and
// `result` still holds what was found (degenerate and free_direction for a
// corridor, best_score and second_score for an ambiguity).
Status AlignByPlanes(const std::vector<Eigen::Vector3f>& source,
                     const std::vector<Eigen::Vector3f>& target, const PlaneAlignOptions& options,
                     RegistrationResult* result, const RegistrationControl& control = {});

// ---------------------------------------------------------------------------
// 2. Coarse, by the operator: picked point pairs.

struct PointPair {
  Eigen::Vector3d source;  // in the source session's frame
  Eigen::Vector3d target;  // the same physical point in the target's frame
};

struct PairAlignOptions {
  // The picks' spread perpendicular to their best line must reach this
  // (RMS, metres), or the rotation about that line is free: refused.
  double min_spread_m = 0.05;
  // A pick is never trusted better than this (1-sigma per axis, metres): the
  // covariance uses max(residual estimate, pick_sigma_m^2), so three exact
  // pairs do not claim a zero covariance.
  double pick_sigma_m = 0.01;

  bool IsValid(std::string* error) const;
};

Status AlignByPairs(const std::vector<PointPair>& pairs, const PairAlignOptions& options,
                    RegistrationResult* result);
inline Status AlignByPairs(const std::vector<PointPair>& pairs, RegistrationResult* result) {
  return AlignByPairs(pairs, PairAlignOptions(), result);
}

// ---------------------------------------------------------------------------
// 3. Fine: robust point-to-plane ICP.

// Not RobustLoss: core/calibration/pairs_solver.h has that name (Ceres's
// losses), and one file may need both.
enum class IcpLoss { kNone, kCauchy, kGemanMcClure };
enum class DegeneracyPolicy {
  kRefuse,  // return an error naming the free direction
  kHold,    // keep the initial transform along the free directions, report them
};

struct IcpOptions {
  // Source downsampled to this voxel (0 = every point); the target to
  // target_voxel_m (0 = every point).
  double source_voxel_m = 0.04;
  double target_voxel_m = 0.02;
  // Target normals from this many nearest neighbours (PCA), computed once;
  // target points whose surface variation lambda_0 / (lambda_0 + lambda_1 +
  // lambda_2) exceeds max_surface_variation (edges, corners) are not used.
  int normal_k = 12;
  double max_surface_variation = 0.08;
  // Correspondences farther than the current distance are dropped; it
  // starts at max_distance_m and shrinks by distance_shrink per iteration
  // down to min_distance_m.
  double max_distance_m = 1.0;
  double min_distance_m = 0.08;
  double distance_shrink = 0.8;
  IcpLoss loss = IcpLoss::kCauchy;
  // Robust scale, re-estimated every iteration: c = robust_k * sigma with
  // sigma = 1.4826 * MAD(residuals) (the MAD of a Gaussian), sigma never
  // below min_scale_m. 2.3849 gives Cauchy 95 % efficiency on Gaussian
  // noise; Geman-McClure's weight c^4 / (c^2 + r^2)^2 uses the same c.
  double robust_k = 2.3849;
  double min_scale_m = 0.003;
  int max_iterations = 60;
  // Converged when the update is below both and the distance has stopped
  // shrinking.
  double convergence_rotation_rad = 1e-6;
  double convergence_translation_m = 1e-6;
  // A direction of the normalised normal matrix (correspondences centred,
  // rotation scaled by their RMS radius, divided by the weight sum) with an
  // eigenvalue below this is degenerate.
  double degeneracy_threshold = 2e-3;
  DegeneracyPolicy degeneracy = DegeneracyPolicy::kRefuse;
  // Fewer correspondences than this: refused.
  size_t min_correspondences = 200;
  int threads = 0;  // 0 = all hardware threads; the result does not depend on it
  // The covariance's clusters (icp.cc): correspondences in one cube of
  // this side count as one observation of the pose (0: the textbook
  // covariance of independent residuals).
  double covariance_cluster_m = 1.0;
  // The operator's picked pairs, kept as a prior while ICP refines (they
  // gave the coarse pose): each adds the residual T s_i - t_i, weighted as
  // a measurement of pair_sigma_m per axis against the points' robust
  // sigma. Where the surfaces constrain the pose the points outweigh them;
  // along a direction they barely constrain (a corridor's axis, fixed only
  // by door jambs) the pairs hold it instead of a bias in the residuals.
  std::vector<PointPair> pairs;
  double pair_sigma_m = 0.01;

  bool IsValid(std::string* error) const;
};

// Refines `initial` (target_from_source). On a refusal (degenerate with
// kRefuse, too few correspondences, cancelled) the Status says why and
// `result` holds the last estimate and the diagnosis.
Status RefineIcp(const std::vector<Eigen::Vector3f>& source,
                 const std::vector<Eigen::Vector3f>& target, const Rigid3d& initial,
                 const IcpOptions& options, const RegistrationControl& control,
                 RegistrationResult* result);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_REGISTRATION_REGISTRATION_H_
