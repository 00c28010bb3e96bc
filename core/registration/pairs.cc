// Coarse registration from picked point pairs: the least-squares rigid
// transform without scale (Horn 1987; Umeyama 1991 with c = 1).
//
// Minimise sum_i |R s_i + t - t_i|^2. With the centroids s_bar, t_bar and
// the cross-covariance M = sum (t_i - t_bar)(s_i - s_bar)^T = U D V^T,
//   R = U diag(1, 1, det(U V^T)) V^T,   t = t_bar - R s_bar
// (the diag term keeps R a rotation when the best orthogonal fit is a
// reflection). The rotation about a line is unobservable when the picks are
// collinear: the second singular value of the centred source picks measures
// their spread off their best line, and below min_spread_m the pick is
// refused.
//
// Uncertainty: residuals e_i = T s_i - t_i have the left-perturbation
// Jacobian J_i = [-[q_i]x, I] (q_i = T s_i, d e_i = omega x q_i + v), so
// cov = sigma^2 (sum J_i^T J_i)^-1 with sigma^2 = sum |e_i|^2 / (3N - 6),
// never below pick_sigma_m^2.
#include <Eigen/SVD>
#include <cmath>

#include "core/geometry/skew.h"
#include "core/registration/internal.h"
#include "core/registration/registration.h"

namespace sweepscan {

using registration_internal::Matrix6d;

Status AlignByPairs(const std::vector<PointPair>& pairs, const PairAlignOptions& options,
                    RegistrationResult* result) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error("pairs: " + error);
  *result = RegistrationResult();
  result->method = "pairs";
  const size_t n = pairs.size();
  if (n < 3) {
    return Status::Error("pairs: " + std::to_string(n) + " pairs given, at least 3 needed");
  }
  for (const PointPair& p : pairs) {
    if (!p.source.allFinite() || !p.target.allFinite()) {
      return Status::Error("pairs: a pick is not finite");
    }
  }
  Eigen::Vector3d s_bar = Eigen::Vector3d::Zero(), t_bar = Eigen::Vector3d::Zero();
  for (const PointPair& p : pairs) {
    s_bar += p.source;
    t_bar += p.target;
  }
  s_bar /= static_cast<double>(n);
  t_bar /= static_cast<double>(n);
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero(), ss = Eigen::Matrix3d::Zero(),
                  tt = Eigen::Matrix3d::Zero();
  for (const PointPair& p : pairs) {
    m += (p.target - t_bar) * (p.source - s_bar).transpose();
    ss += (p.source - s_bar) * (p.source - s_bar).transpose();
    tt += (p.target - t_bar) * (p.target - t_bar).transpose();
  }
  // Spread off the best line, RMS: sqrt(lambda_2 / N) of the scatter, both
  // sides (a pick repeated in one session is as bad as collinear picks).
  for (const Eigen::Matrix3d* scatter : {&ss, &tt}) {
    const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::Matrix3d>(*scatter).singularValues();
    const double spread = std::sqrt(std::max(0.0, sv[1]) / static_cast<double>(n));
    if (spread < options.min_spread_m) {
      char buf[200];
      std::snprintf(buf, sizeof(buf),
                    "pairs: the %s picks are (nearly) collinear: %.3f m off their best line, at "
                    "least %.3f m needed (the rotation about that line would be free)",
                    scatter == &ss ? "source" : "target", spread, options.min_spread_m);
      return Status::Error(buf);
    }
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d u = svd.matrixU(), v = svd.matrixV();
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (u * v.transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  const Eigen::Matrix3d r = u * d * v.transpose();
  const Eigen::Vector3d t = t_bar - r * s_bar;
  result->target_from_source = Rigid3d(t, Eigen::Quaterniond(r));

  Matrix6d h = Matrix6d::Zero();
  double sum2 = 0.0;
  for (const PointPair& p : pairs) {
    const Eigen::Vector3d q = result->target_from_source * p.source;
    const double e = (q - p.target).norm();
    result->pair_residuals_m.push_back(e);
    sum2 += e * e;
    Eigen::Matrix<double, 3, 6> j;
    j.leftCols<3>() = -Skew(q);
    j.rightCols<3>() = Eigen::Matrix3d::Identity();
    h += j.transpose() * j;
  }
  const double sigma2 = std::max(sum2 / std::max<double>(1.0, 3.0 * n - 6.0),
                                 options.pick_sigma_m * options.pick_sigma_m);
  result->covariance = sigma2 * h.inverse();
  result->rms_m = std::sqrt(sum2 / static_cast<double>(n));
  result->correspondences = n;
  result->overlap = 1.0;
  return Status::Ok();
}

}  // namespace sweepscan
