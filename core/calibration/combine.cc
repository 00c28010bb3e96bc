// The information-weighted mean of two calibrations (combine.h).
#include "core/calibration/combine.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

namespace sweepscan {

namespace {

Eigen::Vector3d Vec(const MountingError& m) { return {m.alpha, m.beta, m.gamma}; }

// The inverse of a symmetric positive definite matrix, or false.
bool Inverse(const Eigen::Matrix3d& m, Eigen::Matrix3d* inv) {
  if (!m.allFinite()) return false;
  const Eigen::LLT<Eigen::Matrix3d> llt(m);
  if (llt.info() != Eigen::Success) return false;
  *inv = llt.solve(Eigen::Matrix3d::Identity());
  return inv->allFinite();
}

}  // namespace

CombinedAngles CombineAngleEstimates(const MountingError& a, const Eigen::Matrix3d& a_cov,
                                     const MountingError& b, const Eigen::Matrix3d& b_cov,
                                     const Eigen::Matrix3d& unmodelled_cov, double max_chi2) {
  CombinedAngles out;
  out.angles = a;
  out.covariance_rad2 = a_cov;
  out.sigma_rad = a_cov.diagonal().cwiseMax(0.0).cwiseSqrt();
  Eigen::Matrix3d a_inv, b_inv, sum_inv;
  if (!Inverse(a_cov, &a_inv) || !Inverse(b_cov, &b_inv) || !Inverse(a_cov + b_cov + unmodelled_cov, &sum_inv)) {
    return out;
  }
  const Eigen::Vector3d d = Vec(a) - Vec(b);
  out.chi2 = d.dot(sum_inv * d);
  if (!(out.chi2 <= max_chi2)) return out;
  Eigen::Matrix3d c;
  if (!Inverse(a_inv + b_inv, &c)) return out;
  const Eigen::Vector3d x = c * (a_inv * Vec(a) + b_inv * Vec(b));
  out.angles = {x[0], x[1], x[2]};
  out.covariance_rad2 = 0.5 * (c + c.transpose());
  out.sigma_rad = out.covariance_rad2.diagonal().cwiseMax(0.0).cwiseSqrt();
  out.combined = true;
  return out;
}

Eigen::Matrix3d WithSigmas(const Eigen::Matrix3d& shape, const Eigen::Vector3d& sigma) {
  Eigen::Matrix3d out = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (i == j) {
        out(i, j) = sigma[i] * sigma[i];
        continue;
      }
      const double norm = std::sqrt(shape(i, i) * shape(j, j));
      if (norm > 0.0 && std::isfinite(norm)) {
        out(i, j) = std::clamp(shape(i, j) / norm, -1.0, 1.0) * sigma[i] * sigma[j];
      }
    }
  }
  return out;
}

}  // namespace sweepscan
