// Two calibrations of one recording made into one: the board's corners and
// the room's planes see the mounting error through different geometry, and
// each pins down what the other leaves loose.
//
// The refined corners of a 0.6 m board read alpha and beta mostly through one
// combination, about alpha + beta (their errors correlate 0.88 over the
// sweep's drives, docs/calibration.md); the room's planes, seen from every
// heading of the circle, pin all three angles but lean on the room being
// made of planes. Both estimates are Gaussian to first order, with the
// measurement covariances A and B their solves report
// (CalibrationSummary::covariance_rad2), and their measurement errors are
// independent (one comes from the board's edge points, the other from the
// walls', floor's and ceiling's points), so the minimum-variance combination
// is the information-weighted mean
//
//   x = C (A^-1 a + B^-1 b),   C = (A^-1 + B^-1)^-1,
//
// the maximum a posteriori estimate of a with b as its prior, or equally one
// least-squares solve of both problems stacked. The errors the two share,
// the poses' heading and tilt, are not measurement errors of either: the
// caller adds them after combining, once.
//
// Before combining, the two are checked against each other: their
// difference has covariance A + B + E, E the errors outside both
// measurements that need not move the two alike (the poses': a heading error
// during the board's few sightings against the whole drive's), so
//
//   d^2 = (a - b)^T (A + B + E)^-1 (a - b)
//
// is chi^2 with 3 degrees of freedom when both hold. Above the bound (16.27:
// one drive in a thousand) one of them is biased (a board fitted to the
// wrong edges, a room whose "planes" are not), and the two are not combined.
// The workflow takes the poses' errors as independent between the two for
// the check (E = 2 P, the widest their difference can be) and as shared for
// the combination's sigma (P added once after combining, the widest its
// error can be). Without E, one of the sweep's 60 drives (seed 27) came to
// d^2 = 17.1 and was left uncombined; with it, the largest was 9.8
// (docs/calibration.md).
#ifndef SWEEPSCAN_CORE_CALIBRATION_COMBINE_H_
#define SWEEPSCAN_CORE_CALIBRATION_COMBINE_H_

#include <Eigen/Core>

#include "core/robot/robot_model.h"

namespace sweepscan {

// chi^2 with 3 degrees of freedom at p = 0.001.
inline constexpr double kMaxCombineChi2 = 16.27;

struct CombinedAngles {
  MountingError angles;
  Eigen::Matrix3d covariance_rad2 = Eigen::Matrix3d::Zero();  // C
  Eigen::Vector3d sigma_rad = Eigen::Vector3d::Zero();        // sqrt(diag C)
  double chi2 = 0.0;                                          // d^2 above
  bool combined = false;  // false: an input unusable, or d^2 above the bound
};

// a with covariance a_cov and b with b_cov, as above, checked with E =
// `unmodelled_cov`. Not combined (result .combined false, angles a) when a
// covariance is not positive definite or d^2 exceeds max_chi2; chi2 is
// filled whenever both are usable.
CombinedAngles CombineAngleEstimates(const MountingError& a, const Eigen::Matrix3d& a_cov,
                                     const MountingError& b, const Eigen::Matrix3d& b_cov,
                                     const Eigen::Matrix3d& unmodelled_cov,
                                     double max_chi2 = kMaxCombineChi2);

// The covariance with `shape`'s correlations and the given sigmas:
// D R D, R_ij = S_ij / sqrt(S_ii S_jj), D = diag(sigma). A method whose
// sigma is the larger of two estimates per angle (the automatic mode's iid
// and cluster-robust ones, the corners' and the pairs' misfit) keeps its
// sigmas and takes its correlations from the estimate that models the
// errors' structure. A shape with a zero diagonal entry gives that angle no
// correlation.
Eigen::Matrix3d WithSigmas(const Eigen::Matrix3d& shape, const Eigen::Vector3d& sigma);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CALIBRATION_COMBINE_H_
