// The skew-symmetric (cross-product) matrix: Skew(v) w = v x w. It is the
// hat map of so(3) (Skew(omega) is the generator of the rotation exp), and
// the Jacobian of a rotated point: d(R q) / d(omega) = -Skew(R q) for a left
// perturbation R <- Exp(omega) R. Header-only.
#ifndef SWEEPSCAN_CORE_GEOMETRY_SKEW_H_
#define SWEEPSCAN_CORE_GEOMETRY_SKEW_H_

#include <Eigen/Core>

namespace sweepscan {

inline Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_GEOMETRY_SKEW_H_
