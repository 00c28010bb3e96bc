// The calibration's Levenberg-Marquardt problems. All Ceres templates of the
// project live in this translation unit (compile time on small machines):
// the pairs problem (Eq. 15-17, SolvePairs) and the automatic mode's plane
// problem (PlaneProblem in internal.h, driven by automatic.cc).
#include "core/calibration/pairs_solver.h"

#include <ceres/ceres.h>
#include <ceres/product_manifold.h>
#include <ceres/sphere_manifold.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <memory>
#include <sstream>
#include <thread>
#include <unordered_map>

#include "core/calibration/internal.h"

namespace sweepscan {
namespace calibration_internal {
namespace {

// Eq. 15-16: r_k(c) = p_W^{a_k}(c) - p_W^{b_k}(c)  (metres, 3 residuals).
struct PairCost {
  PairCost(const Prepared& a, const Prepared& b) : a_(a), b_(b) {}
  template <typename T>
  bool operator()(const T* abg_radians, T* residual) const {
    T pa[3], pb[3];
    ProjectT(a_, abg_radians, pa);
    ProjectT(b_, abg_radians, pb);
    for (int i = 0; i < 3; ++i) residual[i] = pa[i] - pb[i];
    return true;
  }
  static ceres::CostFunction* Create(const Prepared& a, const Prepared& b) {
    return new ceres::AutoDiffCostFunction<PairCost, 3, 3>(new PairCost(a, b));
  }
  Prepared a_, b_;
};

// Automatic mode: r_i(c, n_s, d_s) = n_s . p_W^i(c) + d_s  (metres), |n_s| = 1
// kept by the sphere manifold.
// Weighted by the point's noise: r_i = (n_s . p_W^i(c) + d_s) / sigma_i
// (dimensionless), so that the least-squares estimate is the maximum
// likelihood one under the range noise model and s^2 is ~1 when it holds.
//
// Analytic Jacobian (the problem has ~60 000 of these residuals and LM
// evaluates them a few dozen times; automatic differentiation spent most of
// the solve recomputing the same sines and cosines per point). With
// p_W = R_WB q + u, q = R(c) p_L, u = R_WB t_BL + t_WB, R(c) = Rz(alpha)
// Ry(beta) Rx(gamma) (Eq. 1, 13, 14), each derivative of R(c) is a cross
// product with an axis after R(c):
//   dR/dalpha = [a_0]x R,  dR/dbeta = [a_1]x R,  dR/dgamma = [a_2]x R,
//   a_0 = e_z,  a_1 = Rz(alpha) e_y,  a_2 = Rz(alpha) Ry(beta) e_x,
// so with m = R_WB' n (scalar triple product, m . (a x q) = a . (q x m)):
//   dr/dc_k = a_k . (q x m) / sigma,   dr/dn = p_W / sigma,   dr/dd = 1 / sigma;
// the plane block is (n, d) with the sphere manifold on n (ProductManifold),
// so that the planes can be eliminated (Schur) from the normal equations.
// R(c) and the axes depend on c only: computed once per thread and value of
// c.
struct RotationAndAxes {
  double abg[3] = {std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0};
  Eigen::Matrix3d r;
  Eigen::Vector3d axis[3];

  void Update(const double* c) {
    if (c[0] == abg[0] && c[1] == abg[1] && c[2] == abg[2]) return;
    std::copy(c, c + 3, abg);
    r = MountingRotation(FromArray(c)).toRotationMatrix();
    const double ca = std::cos(c[0]), sa = std::sin(c[0]);
    const double cb = std::cos(c[1]), sb = std::sin(c[1]);
    axis[0] = Eigen::Vector3d::UnitZ();
    axis[1] = Eigen::Vector3d(-sa, ca, 0.0);
    axis[2] = Eigen::Vector3d(ca * cb, sa * cb, -sb);
  }
};

// The robust loss, inside the residual: r~ = sign(r) sqrt(rho(r^2)), so
// that sum r~^2 is the robust cost sum rho(r^2) of Ceres' loss functions
// (Huber: rho(s) = s for s <= k^2, 2 k sqrt(s) - k^2 beyond; Cauchy: rho(s)
// = k^2 log(1 + s / k^2)) and a block can hold many points, each with its
// own loss: dr~/dr = rho'(r^2) r / r~. The minimiser is the same as with a
// LossFunction per point; the Gauss-Newton model of the outliers' curvature
// differs (this one is exact for a least-squares problem in r~).
void RobustResidual(RobustLoss loss, double k, double r, double* r_tilde, double* scale) {
  const double s = r * r, k2 = k * k;
  switch (loss) {
    case RobustLoss::kHuber:
      if (s <= k2) break;
      *r_tilde = std::copysign(std::sqrt(2.0 * k * std::abs(r) - k2), r);
      *scale = k / std::abs(*r_tilde);
      return;
    case RobustLoss::kCauchy:
      if (s <= 1e-12 * k2) break;  // rho(s) = s to first order
      *r_tilde = std::copysign(k * std::sqrt(std::log1p(s / k2)), r);
      *scale = r / (*r_tilde * (1.0 + s / k2));
      return;
    case RobustLoss::kNone:
      break;
  }
  *r_tilde = r;
  *scale = 1.0;
}

// Up to kPointsPerBlock points of one plane in one residual block: Ceres'
// per-block overhead (its evaluation, loss and Jacobian plumbing) was most
// of the solve with a block per point. 256 rather than 64: the two-turn
// solve (BM_SolveAutomaticTwoTurnsEkf, 86 k rows) took 15 % less time;
// 1024 was no faster, 4096 slower (too few blocks to share out).
class PlanePointsCost final : public ceres::CostFunction {
 public:
  static constexpr int kPointsPerBlock = 256;

  // Parameter blocks: the angles (3), the plane (n, d) (4), the path scale
  // s (1): t_WB -> centre + s (t_WB - centre), so p_W gains (s - 1) w with
  // w = t_WB - centre, and dr/ds = n . w / sigma.
  PlanePointsCost(RobustLoss loss, double loss_scale, const Eigen::Vector3d& centre)
      : loss_(loss), loss_scale_(loss_scale), centre_(centre) {
    mutable_parameter_block_sizes()->assign({3, 4, 1});
  }
  void Add(const Prepared& o, double inv_sigma) {
    points_.push_back({o.r_wb, o.r_wb * o.t_bl + o.t_wb, o.p_l, o.t_wb - centre_, inv_sigma});
    set_num_residuals(static_cast<int>(points_.size()));
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    thread_local RotationAndAxes rot;
    rot.Update(parameters[0]);
    const Eigen::Map<const Eigen::Vector3d> n(parameters[1]);
    const double d = parameters[1][3];
    const double s1 = parameters[2][0] - 1.0;
    for (size_t i = 0; i < points_.size(); ++i) {
      const Point& pt = points_[i];
      // lazyProduct: the 3 x 3 products inline (Eigen's general product
      // was a call per point, ~5 % of the solve).
      const Eigen::Vector3d q = rot.r.lazyProduct(pt.p_l);
      const Eigen::Vector3d p_w = pt.r_wb.lazyProduct(q) + pt.u + s1 * pt.w;
      double scale = 1.0;
      RobustResidual(loss_, loss_scale_, (n.dot(p_w) + d) * pt.inv_sigma, &residuals[i], &scale);
      if (jacobians == nullptr) continue;
      const double w = scale * pt.inv_sigma;
      if (jacobians[0] != nullptr) {
        const Eigen::Vector3d c = q.cross(pt.r_wb.transpose().lazyProduct(n));
        for (int k = 0; k < 3; ++k) jacobians[0][3 * i + k] = rot.axis[k].dot(c) * w;
      }
      if (jacobians[1] != nullptr) {
        for (int k = 0; k < 3; ++k) jacobians[1][4 * i + k] = p_w[k] * w;
        jacobians[1][4 * i + 3] = w;
      }
      if (jacobians[2] != nullptr) jacobians[2][i] = n.dot(pt.w) * w;
    }
    return true;
  }

 private:
  struct Point {
    Eigen::Matrix3d r_wb;
    Eigen::Vector3d u, p_l;  // u = R_WB t_BL + t_WB
    Eigen::Vector3d w;       // t_WB - centre
    double inv_sigma;
  };
  RobustLoss loss_;
  double loss_scale_;
  Eigen::Vector3d centre_;
  std::vector<Point> points_;
};

using PlaneManifold = ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>>;

// Records the per-iteration trace (the paper's Fig. 8), lets the caller
// cancel and, with angle_tolerance_rad > 0, ends the solve once a
// successful step moves no angle by more than that. Needs
// Solver::Options::update_state_every_iteration.
class TraceCallback : public ceres::IterationCallback {
 public:
  TraceCallback(const double* abg, std::vector<CalibrationIteration>* trace,
                CalibrationProgress* progress, double angle_tolerance_rad = 0.0)
      : abg_(abg), trace_(trace), progress_(progress), angle_tolerance_rad_(angle_tolerance_rad) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    CalibrationIteration it;
    it.iteration = static_cast<int>(trace_->size());
    it.angles = {abg_[0], abg_[1], abg_[2]};
    it.cost = s.cost;
    trace_->push_back(it);
    if (progress_ != nullptr && !progress_->OnIteration(it.iteration, it.angles, it.cost)) {
      return ceres::SOLVER_ABORT;
    }
    const bool small_step = s.iteration > 0 && s.step_is_successful &&
                            std::max({std::abs(abg_[0] - previous_[0]), std::abs(abg_[1] - previous_[1]),
                                      std::abs(abg_[2] - previous_[2])}) < angle_tolerance_rad_;
    std::copy(abg_, abg_ + 3, previous_);
    return small_step ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }

 private:
  const double* abg_;
  std::vector<CalibrationIteration>* trace_;
  CalibrationProgress* progress_;
  double angle_tolerance_rad_;
  double previous_[3] = {0.0, 0.0, 0.0};
};

ceres::LossFunction* MakeLoss(RobustLoss loss, double scale) {
  switch (loss) {
    case RobustLoss::kHuber:
      return new ceres::HuberLoss(scale);
    case RobustLoss::kCauchy:
      return new ceres::CauchyLoss(scale);
    case RobustLoss::kNone:
      break;
  }
  return nullptr;
}

ceres::Solver::Options SolverOptions(const CalibrationOptions& o) {
  ceres::Solver::Options s;
  s.minimizer_type = ceres::TRUST_REGION;
  s.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  s.linear_solver_type = ceres::DENSE_QR;
  s.max_num_iterations = o.max_iterations;
  s.function_tolerance = o.function_tolerance;
  s.gradient_tolerance = o.gradient_tolerance;
  s.parameter_tolerance = o.parameter_tolerance;
  s.num_threads = 1;
  s.logging_type = ceres::SILENT;
  s.minimizer_progress_to_stdout = false;
  s.update_state_every_iteration = true;
  return s;
}

const char* kAngleNames[3] = {"alpha", "beta", "gamma"};

// H = J'J from a Jacobian in Ceres' compressed rows, one row's few non-zeros
// at a time (a plane-point row touches 3 angles, 4 plane parameters and the
// path scale; a dense row would cost n^2 each).
Eigen::MatrixXd NormalMatrix(const ceres::CRSMatrix& crs) {
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(crs.num_cols, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int a = crs.rows[r]; a < crs.rows[r + 1]; ++a) {
      for (int b = crs.rows[r]; b < crs.rows[r + 1]; ++b) {
        h(crs.cols[a], crs.cols[b]) += crs.values[a] * crs.values[b];
      }
    }
  }
  return h;
}

// `what`: what constrains the angles and what to change when it does not
// ("the picks" / "spread the picks over the target"; the planes'
// equivalents in the automatic mode).
struct ObservabilityHint {
  const char* what;
  const char* remedy;
};
constexpr ObservabilityHint kPicksHint{"the picks", "spread the picks over the target"};
constexpr ObservabilityHint kPlanesHint{
    "the planes seen in both passes",
    "drive the circle where the floor and walls facing different ways are within the lidar's "
    "range from both sides of it"};

// Observability of the angles: the singular values of the Jacobian's angle
// columns after the other parameters (planes) are projected out, i.e. of the
// Schur complement S = Jc'Jc - Jc'Jp (Jp'Jp)^+ Jp'Jc, all blocks of H = J'J.
// Condition = sqrt(lambda_max / lambda_min) of S.
void CheckObservability(ceres::Problem* problem, double* abg, const CalibrationOptions& options,
                        const ObservabilityHint& hint, CalibrationSummary* summary) {
  ceres::CRSMatrix crs;
  ceres::Problem::EvaluateOptions eval;
  double cost = 0.0;
  if (!problem->Evaluate(eval, &cost, nullptr, nullptr, &crs)) return;
  const Eigen::MatrixXd h = NormalMatrix(crs);
  // The angle block is the first parameter block added (columns 0..2).
  Eigen::Matrix3d s = h.topLeftCorner<3, 3>();
  const Eigen::Index np = h.cols() - 3;
  if (np > 0) {
    const Eigen::MatrixXd hpp_inv =
        h.bottomRightCorner(np, np).completeOrthogonalDecomposition().pseudoInverse();
    s -= h.topRightCorner(3, np) * hpp_inv * h.bottomLeftCorner(np, 3);
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(s);
  const double lmin = std::max(0.0, eig.eigenvalues()[0]);
  const double lmax = std::max(0.0, eig.eigenvalues()[2]);
  summary->condition_number =
      lmin > 0.0 ? std::sqrt(lmax / lmin) : std::numeric_limits<double>::infinity();
  eig.eigenvectors().col(0).cwiseAbs().maxCoeff(&summary->weakest_angle);
  if (!(summary->condition_number <= options.max_condition_number)) {
    Eigen::Vector3d v = eig.eigenvectors().col(0).cwiseAbs();
    int worst = 0;
    v.maxCoeff(&worst);
    summary->warnings.push_back(
        std::string(hint.what) + " leave " + kAngleNames[worst] +
        " (nearly) unobservable: Jacobian condition number " + Num(summary->condition_number, 3) +
        " > " + Num(options.max_condition_number, 3) + "; " + hint.remedy);
  }
}

void ComputeCovariance(ceres::Problem* problem, double* abg, int num_residuals,
                       CalibrationSummary* summary) {
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = -1;
  co.min_reciprocal_condition_number = 1e-14;
  ceres::Covariance covariance(co);
  std::vector<std::pair<const double*, const double*>> blocks = {{abg, abg}};
  if (!covariance.Compute(blocks, problem)) {
    summary->warnings.push_back("covariance could not be computed (rank-deficient Jacobian)");
    return;
  }
  double c[9];
  covariance.GetCovarianceBlock(abg, abg, c);
  // Ceres returns (J'J)^-1, i.e. for unit residual variance; scale by the
  // residual variance estimate s^2 = 2 cost / (m - n), n = 3 angles (plus the
  // planes' parameters in the automatic mode, few against thousands of rows).
  const int dof = std::max(1, num_residuals - 3);
  const double s2 = 2.0 * summary->final_cost / dof;
  summary->covariance_rad2 = Eigen::Map<const Eigen::Matrix3d>(c) * s2;
  for (int i = 0; i < 3; ++i) {
    summary->sigma_rad[i] = std::sqrt(std::max(0.0, summary->covariance_rad2(i, i)));
  }
}

}  // namespace

// ----------------------------------------------------------------------------
// The automatic mode's plane problem

struct PlaneProblem::Impl {
  double* abg;    // the caller's
  double* scale;  // the caller's
  std::vector<std::array<double, 4>> params;  // n (unit), d per plane
  ceres::Problem problem;
};

PlaneProblem::PlaneProblem(double* abg, const std::vector<Plane>& planes,
                           const std::vector<std::vector<size_t>>& chosen,
                           const std::vector<Prepared>& prepared, const std::vector<double>& sigma,
                           RobustLoss loss, double loss_scale, double* scale,
                           const Eigen::Vector3d& centre, bool estimate_scale)
    : impl_(std::make_unique<Impl>()) {
  impl_->abg = abg;
  impl_->scale = scale;
  ceres::Problem& problem = impl_->problem;
  problem.AddParameterBlock(abg, 3);
  std::vector<std::array<double, 4>>& params = impl_->params;
  params.resize(planes.size());
  for (size_t s = 0; s < planes.size(); ++s) {
    const Plane& pl = planes[s];
    params[s] = {pl.normal.x(), pl.normal.y(), pl.normal.z(), pl.d};
    problem.AddParameterBlock(params[s].data(), 4, new PlaneManifold());
    // Rows stay in the order of `chosen` (ClusteredAngleSigma's groups).
    for (size_t begin = 0; begin < chosen[s].size(); begin += PlanePointsCost::kPointsPerBlock) {
      auto cost = std::make_unique<PlanePointsCost>(loss, loss_scale, centre);
      const size_t end = std::min(chosen[s].size(), begin + PlanePointsCost::kPointsPerBlock);
      for (size_t j = begin; j < end; ++j) cost->Add(prepared[chosen[s][j]], 1.0 / sigma[chosen[s][j]]);
      problem.AddResidualBlock(cost.release(), nullptr, abg, params[s].data(), scale);
    }
  }
  if (problem.HasParameterBlock(scale) && !estimate_scale) problem.SetParameterBlockConstant(scale);
}

PlaneProblem::~PlaneProblem() = default;

PlaneProblem::Outcome PlaneProblem::Solve(const CalibrationOptions& options,
                                          double angle_tolerance_rad,
                                          std::vector<CalibrationIteration>* trace) {
  ceres::Solver::Options so = SolverOptions(options);
  // Every residual holds the angles and one plane: eliminating the planes
  // (Schur complement) leaves a 3 x 3 system per LM step instead of a dense
  // QR of the whole tall Jacobian; residuals are evaluated on every core.
  so.linear_solver_type = ceres::DENSE_SCHUR;
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (auto& p : impl_->params) ordering->AddElementToGroup(p.data(), 0);
  ordering->AddElementToGroup(impl_->abg, 1);
  if (impl_->problem.HasParameterBlock(impl_->scale)) {
    ordering->AddElementToGroup(impl_->scale, 1);
  }
  so.linear_solver_ordering = ordering;
  so.num_threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  TraceCallback callback(impl_->abg, trace, options.progress, angle_tolerance_rad);
  so.callbacks.push_back(&callback);
  ceres::Solver::Summary cs;
  ceres::Solve(so, &impl_->problem, &cs);
  Outcome out;
  out.cancelled = cs.termination_type == ceres::USER_FAILURE;
  out.lm_converged =
      cs.termination_type == ceres::CONVERGENCE || cs.termination_type == ceres::USER_SUCCESS;
  out.initial_cost = cs.initial_cost;
  out.final_cost = cs.final_cost;
  out.message = cs.message;
  return out;
}

const std::array<double, 4>& PlaneProblem::plane(size_t s) const { return impl_->params[s]; }

bool PlaneProblem::EvaluateAngles(std::vector<double>* residuals, Eigen::MatrixXd* d_angles) {
  ceres::Problem::EvaluateOptions eval;
  eval.parameter_blocks = {impl_->abg};
  ceres::CRSMatrix crs;
  if (!impl_->problem.Evaluate(eval, nullptr, residuals, nullptr, &crs)) return false;
  d_angles->setZero(crs.num_rows, 3);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int a = crs.rows[r]; a < crs.rows[r + 1]; ++a) (*d_angles)(r, crs.cols[a]) = crs.values[a];
  }
  return true;
}

void PlaneProblem::CheckObservability(const CalibrationOptions& options,
                                      CalibrationSummary* summary) {
  calibration_internal::CheckObservability(&impl_->problem, impl_->abg, options, kPlanesHint,
                                           summary);
}

// The angles' covariance from one evaluation of the Jacobian J (tangent
// space) and the residuals r: the iid estimate s^2 (J'J)^-1 (the angles'
// block of it, i.e. the inverse of their Schur complement) and the
// cluster-robust one ("sandwich"):
//   Cov = H^-1 (sum_g J_g' r_g r_g' J_g) H^-1,  H = J'J,
// J and r over all parameters (angles and planes, tangent space), rows
// grouped by g. With independent rows it reduces to the familiar
// (J'J)^-1 s^2; with errors shared inside a group (a pose error lasting a
// second) it grows accordingly, where the iid formula would not.
bool PlaneProblem::AngleCovariances(const std::vector<int>& group_of_row, double s2,
                                    Eigen::Matrix3d* iid, Eigen::Matrix3d* clustered) {
  ceres::Problem* problem = &impl_->problem;
  ceres::CRSMatrix crs;
  std::vector<double> residuals;
  double cost = 0.0;
  if (!problem->Evaluate(ceres::Problem::EvaluateOptions(), &cost, &residuals, nullptr, &crs)) {
    return false;
  }
  if (static_cast<size_t>(crs.num_rows) != group_of_row.size()) return false;
  const int n = crs.num_cols;
  const Eigen::MatrixXd h = NormalMatrix(crs);
  std::unordered_map<int, Eigen::VectorXd> score;  // sum_rows_in_g J_row' r_row
  for (int r = 0; r < crs.num_rows; ++r) {
    auto it = score.find(group_of_row[r]);
    if (it == score.end()) it = score.emplace(group_of_row[r], Eigen::VectorXd::Zero(n)).first;
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) {
      it->second[crs.cols[k]] += crs.values[k] * residuals[r];
    }
  }
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(n, n);
  for (const auto& [g, s] : score) meat += s * s.transpose();
  // Small-sample correction G / (G - 1) for G groups.
  const double groups = static_cast<double>(score.size());
  if (groups > 1) meat *= groups / (groups - 1.0);
  const Eigen::MatrixXd hinv = h.completeOrthogonalDecomposition().pseudoInverse();
  *iid = hinv.topLeftCorner<3, 3>() * s2;
  *clustered = (hinv * meat * hinv).topLeftCorner<3, 3>();
  return iid->allFinite() && clustered->allFinite();
}

}  // namespace calibration_internal

using namespace calibration_internal;  // NOLINT(build/namespaces): this file's own helpers

const char* RobustLossName(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::kHuber:
      return "huber";
    case RobustLoss::kCauchy:
      return "cauchy";
    case RobustLoss::kNone:
      break;
  }
  return "none";
}

bool ParseRobustLoss(const std::string& name, RobustLoss* loss) {
  for (RobustLoss l : {RobustLoss::kNone, RobustLoss::kHuber, RobustLoss::kCauchy}) {
    if (name == RobustLossName(l)) {
      *loss = l;
      return true;
    }
  }
  return false;
}

bool CalibrationOptions::IsValid(std::string* error) const {
  if (max_iterations < 1) {
    *error = "calibration: max_iterations must be >= 1";
    return false;
  }
  if (!(function_tolerance >= 0.0) || !(gradient_tolerance >= 0.0) ||
      !(parameter_tolerance >= 0.0)) {
    *error = "calibration: tolerances must be >= 0";
    return false;
  }
  if (loss != RobustLoss::kNone && !(loss_scale_m > 0.0 && std::isfinite(loss_scale_m))) {
    *error = "calibration: loss_scale_m must be > 0";
    return false;
  }
  if (min_pairs < 2) {
    *error = "calibration: min_pairs must be >= 2 (three angles need at least two pairs)";
    return false;
  }
  if (!(board_thickness_m >= 0.0 && board_thickness_m <= 0.05)) {
    *error = "calibration: board_thickness_m must be within 0-0.05 m (a target board, not a box)";
    return false;
  }
  if (!(max_condition_number > 1.0) || !(min_pick_spread_m >= 0.0)) {
    *error = "calibration: max_condition_number must be > 1 and min_pick_spread_m >= 0";
    return false;
  }
  if (!(range_offset_sigma_m >= 0.0 && range_offset_sigma_m <= 0.1) ||
      !(range_scale_sigma >= 0.0 && range_scale_sigma <= 0.1)) {
    *error = "calibration: range_offset_sigma_m and range_scale_sigma must be within 0-0.1";
    return false;
  }
  if (max_outer_iterations < 1 || !(outer_tolerance_rad > 0.0)) {
    *error = "calibration: max_outer_iterations must be >= 1 and outer_tolerance_rad > 0";
    return false;
  }
  return true;
}

// ----------------------------------------------------------------------------
// Reports

std::string CalibrationSummary::BriefReport() const {
  std::ostringstream s;
  s << method << ": " << (converged ? "converged" : "FAILED") << ", alpha " << angles.alpha
    << " beta " << angles.beta << " gamma " << angles.gamma << " rad, RMS " << initial_rms_m
    << " -> " << final_rms_m << " m";
  return s.str();
}

std::string CalibrationSummary::FullReport() const {
  std::ostringstream s;
  s << std::setprecision(6);
  s << "Calibration (" << method << ")\n";
  s << "  converged:        " << (converged ? "yes" : "no") << " (" << message << ")\n";
  s << "  residual blocks:  " << residual_blocks;
  if (planes > 0) s << " points on " << planes << " planes";
  s << "\n  outer iterations: " << outer_iterations << ", LM iterations: " << trace.size() << "\n";
  s << "  initial angles:   " << initial.alpha << " " << initial.beta << " " << initial.gamma
    << " rad\n";
  s << "  final angles:     " << angles.alpha << " " << angles.beta << " " << angles.gamma
    << " rad\n";
  s << "  1-sigma:          " << sigma_rad[0] << " " << sigma_rad[1] << " " << sigma_rad[2]
    << " rad\n";
  s << "  RMS distance:     " << initial_rms_m << " -> " << final_rms_m << " m\n";
  s << "  cost:             " << initial_cost << " -> " << final_cost << "\n";
  s << "  condition number: " << condition_number << "\n";
  if (rejected_edge_points >= 0) {
    s << "  edge points:      " << edge_points << " kept, " << rejected_edge_points
      << " rejected (lines more than a sample off at the board's edges), " << shifted_edge_points
      << " a sample off (mixed returns at the edges: kept, in the sigma), " << mixed_edge_samples
      << " mixed returns beyond the lines' ends\n";
    s << "  range offsets:    " << range_offsets_m[0] << " " << range_offsets_m[1]
      << " m (pass 1, pass 2; estimated beside the angles)\n";
  }
  for (const auto& w : warnings) s << "  warning: " << w << "\n";
  return s.str();
}

// ----------------------------------------------------------------------------
// Pairs (Eq. 15-17)

namespace {

// `first`: the pass-1 picks in the world under `initial`.
// `check_finite`: also that the samples and poses are finite (not the
// picks' fault: the poses' or the recording's).
Status CheckPairs(const std::vector<ObservationPair>& pairs, const RobotGeometry& geometry,
                  const MountingError& initial, std::vector<Eigen::Vector3d>* first_out,
                  bool check_finite = true) {
  std::vector<Eigen::Vector3d>& first = *first_out;
  for (size_t k = 0; k < pairs.size(); ++k) {
    const std::string where = PairName(k) + ": ";
    const ObservationPair& p = pairs[k];
    for (const LidarObservation* o : {&p.pass1, &p.pass2}) {
      if (check_finite && (!Finite(o->p_lidar) || !Finite(o->world_from_body.translation()) ||
                           !o->world_from_body.rotation().coeffs().allFinite())) {
        return Status::Error(where + "a sample or its pose is not finite");
      }
    }
    // Both picks of a pair from the same sighting: a corner seen once cannot
    // be compared with itself (the two passes are seconds apart).
    const double dt = std::abs(static_cast<double>(p.pass1.time_ns - p.pass2.time_ns)) / kNsPerS;
    if (dt < 1.0) {
      return Status::Error(where + "both picks are from one pass (" + Num(dt, 3) +
                           " s apart); pick the feature once in each pass");
    }
    for (size_t j = 0; j < k; ++j) {
      if (pairs[j].pass1.ref == p.pass1.ref && pairs[j].pass2.ref == p.pass2.ref &&
          pairs[j].pass1.p_lidar == p.pass1.p_lidar && pairs[j].pass2.p_lidar == p.pass2.p_lidar) {
        return Status::Error(where + "same samples as " + PairName(j));
      }
    }
    first.push_back(ProjectObservation(p.pass1, geometry, initial));
  }
  return Status::Ok();
}

}  // namespace

Status CheckObservationPairs(const std::vector<ObservationPair>& pairs,
                             const RobotGeometry& geometry, const MountingError& initial) {
  std::vector<Eigen::Vector3d> first;
  return CheckPairs(pairs, geometry, initial, &first, /*check_finite=*/false);
}

namespace {

// Pick geometry: three angles need picks spread in two directions.
void WarnOnPickSpread(const std::vector<Eigen::Vector3d>& first, const CalibrationOptions& options,
                      CalibrationSummary* summary) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : first) c += p;
  c /= static_cast<double>(first.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& p : first) scatter += (p - c) * (p - c).transpose();
  const Eigen::Vector3d ev =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter / first.size()).eigenvalues();
  if (std::sqrt(std::max(0.0, ev[2])) < options.min_pick_spread_m) {
    summary->warnings.push_back("the picks are within " + Num(std::sqrt(std::max(0.0, ev[2])), 3) +
                                " m of each other; spread them over the target's corners");
  } else if (std::sqrt(std::max(0.0, ev[1])) < options.min_pick_spread_m) {
    summary->warnings.push_back("the picks are (nearly) collinear (spread " +
                                Num(std::sqrt(std::max(0.0, ev[1])), 3) +
                                " m across their line); pick corners on both edges");
  }
}

}  // namespace

Status SolvePairs(const std::vector<ObservationPair>& pairs, const RobotGeometry& geometry,
                  const MountingError& initial, const CalibrationOptions& options,
                  CalibrationSummary* summary) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  if (!geometry.IsValid(&error)) return Status::Error(error);
  const Eigen::Vector3d init(initial.alpha, initial.beta, initial.gamma);
  if (!init.allFinite()) return Status::Error("initial angles are not finite");
  if (static_cast<int>(pairs.size()) < options.min_pairs) {
    return Status::Error("need at least " + std::to_string(options.min_pairs) + " pairs, got " +
                         std::to_string(pairs.size()));
  }
  std::vector<Eigen::Vector3d> first;
  const Status checked = CheckPairs(pairs, geometry, initial, &first);
  if (!checked.ok()) return checked;

  summary->initial = initial;
  summary->angles = initial;
  summary->residual_blocks = static_cast<int>(pairs.size());
  summary->converged = false;

  WarnOnPickSpread(first, options, summary);

  std::vector<Prepared> a, b;
  for (const auto& p : pairs) {
    a.push_back(Prepare(p.pass1, geometry));
    b.push_back(Prepare(p.pass2, geometry));
  }
  double abg[3] = {initial.alpha, initial.beta, initial.gamma};
  ceres::Problem problem;
  problem.AddParameterBlock(abg, 3);
  for (size_t k = 0; k < pairs.size(); ++k) {
    problem.AddResidualBlock(PairCost::Create(a[k], b[k]),
                             MakeLoss(options.loss, options.loss_scale_m), abg);
  }
  auto rms = [&]() {
    double s = 0.0;
    for (size_t k = 0; k < pairs.size(); ++k) {
      double pa[3], pb[3];
      ProjectT(a[k], abg, pa);
      ProjectT(b[k], abg, pb);
      s += (Eigen::Vector3d(pa[0], pa[1], pa[2]) - Eigen::Vector3d(pb[0], pb[1], pb[2]))
               .squaredNorm();
    }
    return std::sqrt(s / pairs.size());
  };
  summary->initial_rms_m = rms();

  ceres::Solver::Options so = SolverOptions(options);
  TraceCallback callback(abg, &summary->trace, options.progress);
  so.callbacks.push_back(&callback);
  ceres::Solver::Summary cs;
  ceres::Solve(so, &problem, &cs);

  summary->initial_cost = cs.initial_cost;
  summary->final_cost = cs.final_cost;
  summary->angles = FromArray(abg);
  summary->final_rms_m = rms();
  summary->message = cs.message;
  summary->outer_iterations = 1;
  CheckObservability(&problem, abg, options, kPicksHint, summary);
  if (cs.termination_type == ceres::USER_FAILURE) {
    return Status::Error("calibration cancelled");
  }
  if (cs.termination_type != ceres::CONVERGENCE ||
      !Eigen::Vector3d(abg[0], abg[1], abg[2]).allFinite()) {
    return Status::Error("calibration did not converge: " + cs.message);
  }
  summary->converged = true;
  if (options.compute_covariance) {
    ComputeCovariance(&problem, abg, 3 * static_cast<int>(pairs.size()), summary);
  }
  return Status::Ok();
}

}  // namespace sweepscan
