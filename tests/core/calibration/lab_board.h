// The lab's target board and the angle errors, shared by the calibration
// tests.
#ifndef SWEEPSCAN_TESTS_CORE_CALIBRATION_LAB_BOARD_H_
#define SWEEPSCAN_TESTS_CORE_CALIBRATION_LAB_BOARD_H_

#include <Eigen/Geometry>
#include <cmath>

#include "core/calibration/calibration.h"

namespace sweepscan {

// The lab's target board (core/sim/scene.cc), front face y = 0.16 facing the
// circle. Upright: x 4.7..5.3, z 0.9..1.5; corners in FitBoardCorners' order
// top-left, top-right, bottom-right, bottom-left. Diamond: the same 0.6 m
// board turned 45 deg about its centre (5, 1.35); corners top, right,
// bottom, left.
inline constexpr double kHalfDiagonal = 0.3 * M_SQRT2;
inline const Eigen::Vector3d kSquareCorners[4] = {
    {4.7, 0.16, 1.5}, {5.3, 0.16, 1.5}, {5.3, 0.16, 0.9}, {4.7, 0.16, 0.9}};
inline const Eigen::Vector3d kDiamondCorners[4] = {{5.0, 0.16, 1.35 + kHalfDiagonal},
                                                   {5.0 + kHalfDiagonal, 0.16, 1.35},
                                                   {5.0, 0.16, 1.35 - kHalfDiagonal},
                                                   {5.0 - kHalfDiagonal, 0.16, 1.35}};
// Around the board, generous enough for the uncalibrated ghosts (a few cm),
// clear of the wall (y = 0) behind it; the sill's top (0.85 m) may be inside.
inline const Eigen::AlignedBox3d kSquareRegion(Eigen::Vector3d(4.55, 0.06, 0.75),
                                               Eigen::Vector3d(5.45, 0.30, 1.65));
inline const Eigen::AlignedBox3d kDiamondRegion(Eigen::Vector3d(4.45, 0.06, 0.80),
                                                Eigen::Vector3d(5.55, 0.30, 1.90));

// A mounting error of a few degrees, signs mixed (the sweeps' set B).
inline const MountingError kSetB{0.0150, -0.0100, -0.0200};

inline Eigen::Vector3d ErrorMrad(const MountingError& got, const MountingError& truth) {
  return 1e3 *
         Eigen::Vector3d(got.alpha - truth.alpha, got.beta - truth.beta, got.gamma - truth.gamma);
}

}  // namespace sweepscan

#endif  // SWEEPSCAN_TESTS_CORE_CALIBRATION_LAB_BOARD_H_
