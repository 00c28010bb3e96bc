// Fine registration: robust point-to-plane ICP, Gauss-Newton on se(3).
//
// Source points p_i (downsampled), target points t_j with PCA normals n_j
// (computed once). At the current T = target_from_source each source point
// q_i = T p_i is matched to its nearest target point t_j (exact, through the
// NeighbourIndex) if |q_i - t_j| < d_k, the current correspondence distance,
// and t_j lies on a surface (variation below the limit). The residual is
//   r_i = n_j . (q_i - t_j).
// Perturbing T on the left, T(xi) = Exp(xi) T with xi = (omega, v),
// q_i(xi) ~ q_i + omega x q_i + v, so
//   J_i = dr_i/dxi = [ (q_i x n_j)^T, n_j^T ].
// IRLS: with weights w_i = w(r_i / c) fixed, one Gauss-Newton step solves
//   (sum w_i J_i^T J_i) xi = - sum w_i J_i^T r_i      (6x6 normal matrix H)
// and T <- Exp(xi) T (retraction q' = R(omega) q + v, exact to first order).
// Weights: Cauchy w = 1 / (1 + (r/c)^2); Geman-McClure w = 1 / (1 +
// (r/c)^2)^2; c = robust_k * 1.4826 * median |r_i| (the MAD about zero, re-
// estimated every iteration, never below min_scale_m * robust_k). d_k
// shrinks geometrically from max_distance_m to min_distance_m, so early
// iterations see far correspondences (basin of attraction) and late ones
// only near ones (trimming what is not shared).
//
// Degeneracy: H re-expressed about the correspondences' centroid with the
// rotation scaled by their RMS radius and divided by the weight sum has
// dimensionless eigenvalues (its translation block is the weighted mean of
// n n^T): an eigenvalue below degeneracy_threshold is a direction no surface
// constrains (a corridor's axis). Refused, or the update is held at zero
// along it (pseudo-inverse) and the direction reported.
//
// Covariance: the residuals are not independent: neighbouring points share
// the trajectory's errors (a wall seen from one stretch of a drive is off
// as one), so the textbook sigma^2 H^-1 (sigma^2 = sum w r^2 / (sum w - 6))
// claims far too much; drive c of the office floor, placed from pairs, came
// out 34 mm off along its corridor with a 0.2 mm 1-sigma. The result's
// covariance is the cluster-robust ("sandwich") estimate instead (Liang and
// Zeger 1986; Cameron and Miller 2015, Eq. 11):
//   Cov = H^-1 M H^-1,  M = G/(G-1) sum_c s_c s_c^T,  s_c = sum_{i in c} w_i r_i J_i,
// with the correspondences grouped into clusters c (G of them) by the cube
// of side covariance_cluster_m their source point lies in: errors shared
// within a cube count once, not once per point. It equals the textbook one
// when residuals are independent and the clusters many; it is never smaller
// than it here because the larger of the two is reported (per the trace).
//
// Parallel: correspondences and normal sums in blocks of 2048 points,
// combined in block order: the result does not depend on the thread count.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "core/geometry/skew.h"
#include "core/registration/internal.h"
#include "core/registration/registration.h"

namespace sweepscan {

using registration_internal::Control;
using registration_internal::Degeneracy;
using registration_internal::Matrix6d;
using registration_internal::NormalSums;
using registration_internal::Surface;
using registration_internal::Vector6d;

namespace {

constexpr size_t kBlock = 2048;
constexpr double kPrepareShare = 0.2;

double RobustWeight(IcpLoss loss, double r, double c) {
  const double u = (r / c) * (r / c);
  switch (loss) {
    case IcpLoss::kNone: return 1.0;
    case IcpLoss::kCauchy: return 1.0 / (1.0 + u);
    case IcpLoss::kGemanMcClure: return 1.0 / ((1.0 + u) * (1.0 + u));
  }
  return 1.0;
}

// The larger (by trace) of the textbook and the cluster-robust covariance of
// the correspondences at T (see the header comment).
Matrix6d RobustCovariance(const std::vector<Eigen::Vector3f>& source, const std::vector<float>& residual,
                          const std::vector<uint32_t>& match, const Surface& surface, const Rigid3d& t,
                          const NormalSums& sums, const Degeneracy& degeneracy, IcpLoss loss, double c,
                          double cluster_m, const std::vector<PointPair>& pairs, double pair_lambda) {
  const Matrix6d textbook = registration_internal::Covariance(sums, degeneracy);
  if (!(sums.w > 6.0) || !(cluster_m > 0.0)) return textbook;
  Matrix6d inv = Matrix6d::Zero();
  for (int i = degeneracy.free_count; i < 6; ++i) {
    const Vector6d u = degeneracy.eigenvectors.col(i);
    inv += u * u.transpose() / degeneracy.eigenvalues[i];
  }
  const Matrix6d h_inv = degeneracy.basis * inv * degeneracy.basis.transpose() / sums.w;
  std::map<std::array<int64_t, 3>, Vector6d> clusters;  // ordered: the sum's order is fixed
  for (size_t i = 0; i < source.size(); ++i) {
    if (std::isnan(residual[i])) continue;
    const Eigen::Vector3d q = t * source[i].cast<double>();
    const float* p = surface.index.sorted_point(match[i]);
    const Eigen::Vector3d nj = surface.normals[match[i]].cast<double>();
    const double r = nj.dot(q - Eigen::Vector3d(p[0], p[1], p[2]));
    Vector6d j;
    j.head<3>() = q.cross(nj);
    j.tail<3>() = nj;
    const std::array<int64_t, 3> key = {static_cast<int64_t>(std::floor(q.x() / cluster_m)),
                                        static_cast<int64_t>(std::floor(q.y() / cluster_m)),
                                        static_cast<int64_t>(std::floor(q.z() / cluster_m))};
    auto [it, added] = clusters.try_emplace(key, Vector6d::Zero());
    it->second += RobustWeight(loss, r, c) * r * j;
  }
  // Each picked pair is a cluster of its own (its error is its own).
  std::vector<Vector6d> pair_scores;
  for (const PointPair& pp : pairs) {
    const Eigen::Vector3d q = t * pp.source;
    Eigen::Matrix<double, 3, 6> j;
    j.leftCols<3>() = -Skew(q);
    j.rightCols<3>() = Eigen::Matrix3d::Identity();
    pair_scores.push_back(pair_lambda * j.transpose() * (q - pp.target));
  }
  const double g = static_cast<double>(clusters.size() + pair_scores.size());
  if (g < 2.0) return textbook;
  Matrix6d meat = Matrix6d::Zero();
  for (const auto& [key, s] : clusters) meat += s * s.transpose();
  for (const Vector6d& s : pair_scores) meat += s * s.transpose();
  meat *= g / (g - 1.0);
  const Matrix6d sandwich = h_inv * meat * h_inv;
  return sandwich.trace() > textbook.trace() ? sandwich : textbook;
}

}  // namespace

Status RefineIcp(const std::vector<Eigen::Vector3f>& source_in,
                 const std::vector<Eigen::Vector3f>& target_in, const Rigid3d& initial,
                 const IcpOptions& options, const RegistrationControl& control_in,
                 RegistrationResult* result) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error("icp: " + error);
  *result = RegistrationResult();
  result->method = "icp";
  result->target_from_source = initial;
  Control control(control_in, options.threads);
  const auto cancelled = [] { return Status::Error(kRegistrationCancelled); };
  if (!control.Report(RegistrationStage::kPrepare, 0.0, 0, 0.0, true)) return cancelled();

  const std::vector<Eigen::Vector3f> source = VoxelCentroids(source_in, options.source_voxel_m);
  const std::vector<Eigen::Vector3f> target = VoxelCentroids(target_in, options.target_voxel_m);
  if (source.size() < options.min_correspondences || target.size() < static_cast<size_t>(options.normal_k)) {
    return Status::Error("icp: too few points (source " + std::to_string(source.size()) +
                         ", target " + std::to_string(target.size()) + " after downsampling)");
  }
  Surface surface;
  if (!registration_internal::BuildSurface(target, options.normal_k, &control, &surface)) {
    return cancelled();
  }
  if (!control.Report(RegistrationStage::kIcp, kPrepareShare, 0, 0.0, true)) return cancelled();

  const size_t n = source.size();
  const size_t blocks = Control::Blocks(n, kBlock);
  // Source points per covariance cluster (1 when there are none): how many
  // points count as one observation when they are weighed against picks.
  double design_effect = 1.0;
  if (!options.pairs.empty() && options.covariance_cluster_m > 0.0) {
    std::set<std::array<int64_t, 3>> cubes;
    for (const Eigen::Vector3f& p : source) {
      cubes.insert({static_cast<int64_t>(std::floor(p.x() / options.covariance_cluster_m)),
                    static_cast<int64_t>(std::floor(p.y() / options.covariance_cluster_m)),
                    static_cast<int64_t>(std::floor(p.z() / options.covariance_cluster_m))});
    }
    design_effect = static_cast<double>(n) / static_cast<double>(cubes.size());
  }
  std::vector<int64_t> hint(n, -1);
  std::vector<uint32_t> match(n);
  std::vector<float> residual(n, std::numeric_limits<float>::quiet_NaN());
  std::vector<NormalSums> block_sums(blocks);
  std::vector<float> abs_r;
  abs_r.reserve(n);

  Rigid3d t = initial;
  double distance = options.max_distance_m;
  bool converged = false;
  for (int it = 0;; ++it) {
    // (1) Correspondences at T.
    const Eigen::Matrix3f rf = t.rotation().toRotationMatrix().cast<float>();
    const Eigen::Vector3f tf = t.translation().cast<float>();
    const float d2max = static_cast<float>(distance * distance);
    const bool ok = control.For(n, kBlock, [&](size_t, size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        const Eigen::Vector3f q = rf * source[i] + tf;
        uint32_t idx = 0;
        float d2 = 0.0f;
        residual[i] = std::numeric_limits<float>::quiet_NaN();
        if (surface.index.Knn(q.data(), 1, &idx, &d2, hint[i]) < 1) continue;
        hint[i] = idx;
        if (d2 > d2max || surface.variation[idx] > options.max_surface_variation) continue;
        const float* p = surface.index.sorted_point(idx);
        residual[i] = surface.normals[idx].dot(q - Eigen::Vector3f(p[0], p[1], p[2]));
        match[i] = idx;
      }
    });
    if (!ok) return cancelled();

    // (2) Robust scale: the median absolute residual (MAD about zero).
    abs_r.clear();
    for (size_t i = 0; i < n; ++i) {
      if (!std::isnan(residual[i])) abs_r.push_back(std::abs(residual[i]));
    }
    if (abs_r.size() < options.min_correspondences) {
      result->target_from_source = t;
      result->correspondences = abs_r.size();
      result->iterations = it;
      char buf[200];
      std::snprintf(buf, sizeof(buf),
                    "icp: %zu correspondences within %.3f m at iteration %d, at least %zu needed "
                    "(no overlap, or the initial pose is too far off)",
                    abs_r.size(), distance, it, options.min_correspondences);
      return Status::Error(buf);
    }
    std::nth_element(abs_r.begin(), abs_r.begin() + abs_r.size() / 2, abs_r.end());
    const double sigma = std::max(1.4826 * abs_r[abs_r.size() / 2], options.min_scale_m);
    const double c = options.robust_k * sigma;

    // (3) IRLS weights and the normal equations, summed in block order.
    const bool ok_sums = control.For(n, kBlock, [&](size_t b, size_t begin, size_t end) {
      NormalSums s;
      for (size_t i = begin; i < end; ++i) {
        if (std::isnan(residual[i])) continue;
        const Eigen::Vector3d q = t * source[i].cast<double>();
        const float* p = surface.index.sorted_point(match[i]);
        const Eigen::Vector3d nj = surface.normals[match[i]].cast<double>();
        const double r = nj.dot(q - Eigen::Vector3d(p[0], p[1], p[2]));
        s.Add(q, nj, r, RobustWeight(options.loss, r, c));
      }
      block_sums[b] = s;
    });
    if (!ok_sums) return cancelled();
    NormalSums sums;
    for (const NormalSums& s : block_sums) sums.Add(s);
    // The picked pairs as a prior: e_i = T s_i - t_i with de/dxi = [-[q]x, I]
    // (q = T s_i), weighted sigma^2 / pair_sigma^2 against the points'
    // unit-weight residuals (both then in units of the points' sigma), times
    // the points' design effect: points in one covariance cluster share
    // their errors (see the covariance above), so N of them in G cubes
    // weigh as G observations, not N, and each pick as N / G points.
    const double pair_lambda =
        design_effect * sigma * sigma / (options.pair_sigma_m * options.pair_sigma_m);
    if (!options.pairs.empty()) {
      const double lambda = pair_lambda;
      for (const PointPair& pp : options.pairs) {
        const Eigen::Vector3d q = t * pp.source;
        Eigen::Matrix<double, 3, 6> j;
        j.leftCols<3>() = -Skew(q);
        j.rightCols<3>() = Eigen::Matrix3d::Identity();
        sums.h += lambda * j.transpose() * j;
        sums.g += lambda * j.transpose() * (q - pp.target);
      }
    }
    const Degeneracy degeneracy =
        registration_internal::AnalyseDegeneracy(sums, options.degeneracy_threshold);

    result->target_from_source = t;
    result->iterations = it;
    result->correspondences = sums.count;
    result->overlap = static_cast<double>(sums.count) / static_cast<double>(n);
    result->rms_m = std::sqrt(sums.r2 / static_cast<double>(sums.count));
    result->eigenvalues = degeneracy.eigenvalues;
    if (degeneracy.free_count > 0) {
      result->degenerate = true;
      result->free_direction = degeneracy.free_direction;
      result->free_is_rotation = degeneracy.free_is_rotation;
      if (options.degeneracy == DegeneracyPolicy::kRefuse) {
        result->covariance = registration_internal::Covariance(sums, degeneracy);
        char buf[320];
        std::snprintf(buf, sizeof(buf),
                      "icp: degenerate: the clouds do not constrain the %s %s in the target frame "
                      "(normalised eigenvalue %.2g < %.2g; %d free direction%s); refusing rather "
                      "than answering along it",
                      degeneracy.free_is_rotation ? "rotation about" : "translation along",
                      registration_internal::FormatDirection(degeneracy.free_direction).c_str(),
                      degeneracy.eigenvalues[0], options.degeneracy_threshold,
                      degeneracy.free_count, degeneracy.free_count > 1 ? "s" : "");
        return Status::Error(buf);
      }
    }
    if (converged || it >= options.max_iterations) {
      result->covariance = RobustCovariance(source, residual, match, surface, t, sums, degeneracy, options.loss, c,
                                            options.covariance_cluster_m, options.pairs, pair_lambda);
      break;
    }

    // (4) The Gauss-Newton step, in the normalised coordinates xi'' (so a
    // held direction is the eigenvector there): xi'' = -sum_i u_i u_i^T g'' /
    // lambda_i over the constrained directions, xi = basis xi''.
    const Vector6d xi = registration_internal::GaussNewtonStep(sums, degeneracy);
    t = registration_internal::LeftUpdate(xi, t);
    converged = distance <= options.min_distance_m &&
                xi.head<3>().norm() < options.convergence_rotation_rad &&
                xi.tail<3>().norm() < options.convergence_translation_m;
    distance = std::max(options.min_distance_m, distance * options.distance_shrink);
    if (!control.Report(RegistrationStage::kIcp,
                        kPrepareShare + (1.0 - kPrepareShare) * (it + 1) / (options.max_iterations + 1),
                        it + 1, result->rms_m)) {
      return cancelled();
    }
  }
  control.Report(RegistrationStage::kDone, 1.0, result->iterations, result->rms_m, true);
  return Status::Ok();
}

}  // namespace sweepscan
