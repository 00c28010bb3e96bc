// Shared pieces of the registration's sources (not part of the API).
#ifndef SWEEPSCAN_CORE_REGISTRATION_INTERNAL_H_
#define SWEEPSCAN_CORE_REGISTRATION_INTERNAL_H_

#include <Eigen/Core>
#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "core/evaluation/neighbours.h"
#include "core/registration/registration.h"

namespace sweepscan::registration_internal {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// Progress, cancel and deterministic parallel loops for one call. Work over
// [0, n) is cut into blocks of a fixed size (not depending on the thread
// count); callers write per-block results and combine them in block order,
// so sums are the same bit for bit on 1 and on N threads.
class Control {
 public:
  Control(const RegistrationControl& control, int threads);
  ~Control();
  Control(const Control&) = delete;
  Control& operator=(const Control&) = delete;

  int threads() const { return threads_; }
  static size_t Blocks(size_t n, size_t block) { return (n + block - 1) / block; }
  // body(block, begin, end) for every block; false if cancelled.
  bool For(size_t n, size_t block, const std::function<void(size_t, size_t, size_t)>& body);
  // For NeighbourIndex::Build.
  NeighbourIndex::ParallelFor ForFunction();

  // Reports the stage and the overall fraction (throttled to ~50 Hz unless
  // forced; never decreasing). Returns false once cancelled.
  bool Report(RegistrationStage stage, double fraction, int iteration = 0, double rms_m = 0.0,
              bool force = false);
  bool Cancelled() const;

 private:
  struct Arena;
  const RegistrationControl& control_;
  int threads_;
  std::unique_ptr<Arena> arena_;
  std::atomic<bool> cancelled_{false};
  std::mutex mutex_;
  double last_fraction_ = 0.0;
  std::chrono::steady_clock::time_point last_report_{};
};

// A cloud with its neighbour index and PCA normals (computed once; indexed
// by the index's sorted positions).
struct Surface {
  NeighbourIndex index;
  std::vector<Eigen::Vector3f> normals;  // unit, sign arbitrary
  std::vector<float> variation;          // lambda_0 / (lambda_0 + lambda_1 + lambda_2)
};
// False if cancelled. k neighbours (the point itself included).
bool BuildSurface(const std::vector<Eigen::Vector3f>& points, int k, Control* control,
                  Surface* surface);

// T <- Exp(xi) * T with xi = (omega, v): the retraction q' = R(omega) q + v
// whose first order is the linearisation dq = omega x q + v used by the
// Jacobians.
Rigid3d LeftUpdate(const Vector6d& xi, const Rigid3d& t);

// Normal equations of point-to-plane residuals r_i = n_i . (q_i - t_i) for a
// left perturbation: J_i = [(q_i x n_i)^T, n_i^T], H = sum w J^T J,
// g = sum w J^T r, plus the weighted sums the degeneracy analysis needs.
struct NormalSums {
  Matrix6d h = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  double w = 0.0, wr2 = 0.0, r2 = 0.0, wq2 = 0.0;
  Eigen::Vector3d wq = Eigen::Vector3d::Zero();
  size_t count = 0;
  void Add(const Eigen::Vector3d& q, const Eigen::Vector3d& n, double r, double w);
  void Add(const NormalSums& o);
};

// The degeneracy of H: re-expressed about the weighted centroid c of the
// q_i (xi' = (omega, v + omega x c)), the rotation scaled by the RMS radius
// L about c (omega'' = L omega, in metres), divided by the weight sum; its
// eigenvalues are then dimensionless fractions (the translation block is
// the weighted mean of n n^T). `basis` maps xi'' to xi.
struct Degeneracy {
  Vector6d eigenvalues = Vector6d::Zero();  // ascending
  Matrix6d eigenvectors = Matrix6d::Identity();  // columns, in xi'' coordinates
  Matrix6d basis = Matrix6d::Identity();         // xi = basis * xi''
  int free_count = 0;  // eigenvalues below the threshold
  Eigen::Vector3d free_direction = Eigen::Vector3d::Zero();
  bool free_is_rotation = false;
};
Degeneracy AnalyseDegeneracy(const NormalSums& sums, double threshold);

// The Gauss-Newton step of H xi = -g over the constrained directions only
// (in the normalised coordinates, so a free direction is an eigenvector
// there and is left where it is): xi'' = -sum_i u_i u_i^T g'' / lambda_i,
// xi = basis xi''.
Vector6d GaussNewtonStep(const NormalSums& sums, const Degeneracy& degeneracy);

// sigma^2 (J^T W J)^-1 with sigma^2 = sum w r^2 / (sum w - 6), restricted to
// the non-free directions (pseudo-inverse in the normalised coordinates).
Matrix6d Covariance(const NormalSums& sums, const Degeneracy& degeneracy);

std::string FormatDirection(const Eigen::Vector3d& v);

}  // namespace sweepscan::registration_internal

#endif  // SWEEPSCAN_CORE_REGISTRATION_INTERNAL_H_
