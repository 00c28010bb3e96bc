// All Ceres templates of the project's calibration live in this translation
// unit (compile time on small machines).
#include "core/calibration.h"

#include <ceres/ceres.h>
#include <ceres/sphere_manifold.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <memory>
#include <random>
#include <sstream>

#include "core/json_reader.h"

namespace sweepscan {
namespace {

constexpr double kNsPerS = 1e9;

uint64_t Key(const SampleRef& r) { return (static_cast<uint64_t>(r.scan) << 16) | r.beam; }

std::string Num(double v, int precision = 6) {
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

std::string RefName(const SampleRef& r) {
  return "(scan " + std::to_string(r.scan) + ", beam " + std::to_string(r.beam) + ")";
}

// What the cost functors need of an observation, in doubles: the lidar-frame
// point p_L, the mount translation t_BL = (l1, 0, h) and the body pose.
struct Prepared {
  Eigen::Matrix3d r_wb;
  Eigen::Vector3d t_wb, t_bl, p_l;
};

Prepared Prepare(const LidarObservation& o, const RobotGeometry& g) {
  Prepared p;
  p.r_wb = o.world_from_body.rotation().toRotationMatrix();
  p.t_wb = o.world_from_body.translation();
  p.t_bl = Eigen::Vector3d(g.lidar_offset_x_m, 0.0, g.lidar_height_m);
  p.p_l = o.p_lidar;
  return p;
}

// p_W(c) = R_WB (Rz(alpha) Ry(beta) Rx(gamma) p_L + t_BL) + t_WB   (Eq. 1, 13, 14)
template <typename T>
void ProjectT(const Prepared& o, const T* abg, T* p_w) {
  using std::cos;
  using std::sin;
  const T ca = cos(abg[0]), sa = sin(abg[0]);
  const T cb = cos(abg[1]), sb = sin(abg[1]);
  const T cg = cos(abg[2]), sg = sin(abg[2]);
  const T px(o.p_l.x()), py(o.p_l.y()), pz(o.p_l.z());
  // Rx(gamma), then Ry(beta), then Rz(alpha).
  const T x1 = px, y1 = cg * py - sg * pz, z1 = sg * py + cg * pz;
  const T x2 = cb * x1 + sb * z1, y2 = y1, z2 = -sb * x1 + cb * z1;
  const T b[3] = {ca * x2 - sa * y2 + o.t_bl.x(), sa * x2 + ca * y2 + o.t_bl.y(), z2 + o.t_bl.z()};
  for (int r = 0; r < 3; ++r) {
    p_w[r] = o.r_wb(r, 0) * b[0] + o.r_wb(r, 1) * b[1] + o.r_wb(r, 2) * b[2] + o.t_wb[r];
  }
}

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
struct PointToPlaneCost {
  PointToPlaneCost(const Prepared& o, double inv_sigma) : o_(o), inv_sigma_(inv_sigma) {}
  template <typename T>
  bool operator()(const T* abg_radians, const T* normal, const T* d, T* residual) const {
    T p[3];
    ProjectT(o_, abg_radians, p);
    residual[0] = (normal[0] * p[0] + normal[1] * p[1] + normal[2] * p[2] + d[0]) * inv_sigma_;
    return true;
  }
  static ceres::CostFunction* Create(const Prepared& o, double inv_sigma) {
    return new ceres::AutoDiffCostFunction<PointToPlaneCost, 1, 3, 3, 1>(
        new PointToPlaneCost(o, inv_sigma));
  }
  Prepared o_;
  double inv_sigma_;
};

// Records the per-iteration trace (the paper's Fig. 8) and lets the caller
// cancel. Needs Solver::Options::update_state_every_iteration.
class TraceCallback : public ceres::IterationCallback {
 public:
  TraceCallback(const double* abg, std::vector<CalibrationIteration>* trace,
                CalibrationProgress* progress)
      : abg_(abg), trace_(trace), progress_(progress) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    CalibrationIteration it;
    it.iteration = static_cast<int>(trace_->size());
    it.angles = {abg_[0], abg_[1], abg_[2]};
    it.cost = s.cost;
    trace_->push_back(it);
    if (progress_ != nullptr && !progress_->OnIteration(it.iteration, it.angles, it.cost)) {
      return ceres::SOLVER_ABORT;
    }
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const double* abg_;
  std::vector<CalibrationIteration>* trace_;
  CalibrationProgress* progress_;
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

// Observability of the angles: the singular values of the Jacobian's angle
// columns after the other parameters (planes) are projected out, i.e. of the
// Schur complement S = Jc'Jc - Jc'Jp (Jp'Jp)^+ Jp'Jc. Condition =
// sqrt(lambda_max / lambda_min) of S.
void CheckObservability(ceres::Problem* problem, double* abg, const CalibrationOptions& options,
                        CalibrationSummary* summary) {
  ceres::CRSMatrix crs;
  ceres::Problem::EvaluateOptions eval;
  double cost = 0.0;
  if (!problem->Evaluate(eval, &cost, nullptr, nullptr, &crs)) return;
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) j(r, crs.cols[k]) = crs.values[k];
  }
  // The angle block is the first parameter block added (columns 0..2).
  const Eigen::MatrixXd jc = j.leftCols(3);
  Eigen::Matrix3d s = jc.transpose() * jc;
  if (j.cols() > 3) {
    const Eigen::MatrixXd jp = j.rightCols(j.cols() - 3);
    const Eigen::MatrixXd h = jp.transpose() * jp;
    const Eigen::MatrixXd hinv = h.completeOrthogonalDecomposition().pseudoInverse();
    s -= jc.transpose() * jp * hinv * jp.transpose() * jc;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(s);
  const double lmin = std::max(0.0, eig.eigenvalues()[0]);
  const double lmax = std::max(0.0, eig.eigenvalues()[2]);
  summary->condition_number =
      lmin > 0.0 ? std::sqrt(lmax / lmin) : std::numeric_limits<double>::infinity();
  if (!(summary->condition_number <= options.max_condition_number)) {
    Eigen::Vector3d v = eig.eigenvectors().col(0).cwiseAbs();
    int worst = 0;
    v.maxCoeff(&worst);
    summary->warnings.push_back(
        "the picks leave " + std::string(kAngleNames[worst]) +
        " (nearly) unobservable: Jacobian condition number " + Num(summary->condition_number, 3) +
        " > " + Num(options.max_condition_number, 3) + "; spread the picks over the target");
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
  for (int i = 0; i < 3; ++i) summary->sigma_rad[i] = std::sqrt(std::max(0.0, c[4 * i] * s2));
}

MountingError FromArray(const double* abg) { return {abg[0], abg[1], abg[2]}; }

double AngleChange(const MountingError& a, const MountingError& b) {
  return std::max(
      {std::abs(a.alpha - b.alpha), std::abs(a.beta - b.beta), std::abs(a.gamma - b.gamma)});
}

bool Finite(const Eigen::Vector3d& v) { return v.allFinite(); }

}  // namespace

Eigen::Vector3d ProjectObservation(const LidarObservation& o, const RobotGeometry& geometry,
                                   const MountingError& calibration) {
  return o.world_from_body * (BodyFromLidar(geometry, calibration) * o.p_lidar);
}

// ----------------------------------------------------------------------------
// SampleStore

SampleStore::SampleStore(const SensorLog& log, const PoseBuffer& poses, double min_range_m,
                         double max_range_m) {
  for (const LidarScan& scan : log.scans) {
    size_t hint = 0;
    for (const LidarSample& s : scan.samples) {
      if (!(s.range_m >= min_range_m && s.range_m <= max_range_m)) continue;
      LidarObservation o;
      if (!poses.LookupWithHint(s.time, &hint, &o.world_from_body)) continue;
      o.ref = {scan.index, s.beam};
      o.time_ns = ToNanoseconds(s.time);
      o.p_lidar = LidarPoint(s.range_m, s.theta);
      by_ref_[Key(o.ref)] = observations_.size();
      observations_.push_back(o);
    }
  }
}

Status SampleStore::Find(const SampleRef& ref, LidarObservation* out) const {
  const auto it = by_ref_.find(Key(ref));
  if (it == by_ref_.end()) {
    return Status::Error("sample " + RefName(ref) +
                         " is not a valid sample of the recording (unknown scan or beam, no "
                         "return, or no pose)");
  }
  *out = observations_[it->second];
  return Status::Ok();
}

std::vector<size_t> SampleStore::InWindow(const PassWindow& window) const {
  std::vector<size_t> out;
  const auto lo =
      std::lower_bound(observations_.begin(), observations_.end(), window.begin_ns,
                       [](const LidarObservation& o, int64_t t) { return o.time_ns < t; });
  for (auto it = lo; it != observations_.end() && it->time_ns <= window.end_ns; ++it) {
    out.push_back(static_cast<size_t>(it - observations_.begin()));
  }
  return out;
}

Status SampleStore::Nearest(const PassWindow& window, const Eigen::Vector3d& world,
                            const RobotGeometry& geometry, const MountingError& calibration,
                            LidarObservation* out) const {
  if (!Finite(world)) return Status::Error("pick position is not finite");
  double best = std::numeric_limits<double>::infinity();
  for (size_t i : InWindow(window)) {
    const double d =
        (ProjectObservation(observations_[i], geometry, calibration) - world).squaredNorm();
    if (d < best) {
      best = d;
      *out = observations_[i];
    }
  }
  if (!std::isfinite(best)) return Status::Error("the pass has no samples to snap to");
  return Status::Ok();
}

Status ResolvePairs(const std::vector<PickPair>& picks, const SampleStore& store,
                    const std::vector<PassWindow>& windows, const RobotGeometry& geometry,
                    const MountingError& calibration, std::vector<ObservationPair>* pairs) {
  if (windows.size() < 2) {
    return Status::Error("need two passes to resolve picks, found " +
                         std::to_string(windows.size()));
  }
  pairs->clear();
  for (size_t k = 0; k < picks.size(); ++k) {
    ObservationPair pair;
    const Pick* p[2] = {&picks[k].pass1, &picks[k].pass2};
    LidarObservation* o[2] = {&pair.pass1, &pair.pass2};
    for (int side = 0; side < 2; ++side) {
      const std::string where =
          "pair " + std::to_string(k + 1) + " pass" + std::to_string(side + 1) + ": ";
      Status s = p[side]->has_sample
                     ? store.Find(p[side]->sample, o[side])
                     : store.Nearest(windows[side], p[side]->world, geometry, calibration, o[side]);
      if (!s.ok()) return Status::Error(where + s.message());
      const int pass = PassOfTime(windows, o[side]->time_ns);
      if (pass != side) {
        return Status::Error(
            where + "sample " + RefName(o[side]->ref) + " is " +
            (pass < 0 ? std::string("in neither pass") : "in pass " + std::to_string(pass + 1)) +
            ", expected pass " + std::to_string(side + 1));
      }
    }
    pairs->push_back(pair);
  }
  return Status::Ok();
}

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
  if (!(max_condition_number > 1.0) || !(min_pick_spread_m >= 0.0)) {
    *error = "calibration: max_condition_number must be > 1 and min_pick_spread_m >= 0";
    return false;
  }
  if (max_outer_iterations < 1 || !(outer_tolerance_rad > 0.0)) {
    *error = "calibration: max_outer_iterations must be >= 1 and outer_tolerance_rad > 0";
    return false;
  }
  return true;
}

bool AutoCalibrationOptions::IsValid(std::string* error) const {
  if (!solver.IsValid(error)) return false;
  if (max_segmentation_points < 100 || max_points_per_plane < 10 || max_planes < 1 ||
      ransac_iterations < 1) {
    *error = "automatic calibration: point and plane counts too small";
    return false;
  }
  if (!(min_plane_fraction > 0.0 && min_plane_fraction < 1.0)) {
    *error = "automatic calibration: min_plane_fraction must be in (0, 1)";
    return false;
  }
  if (!(final_band_m > 0.0) || !(initial_band_m >= final_band_m) ||
      !std::isfinite(initial_band_m)) {
    *error = "automatic calibration: need 0 < final_band_m <= initial_band_m";
    return false;
  }
  if (!(min_range_m >= 0.0)) {
    *error = "automatic calibration: min_range_m must be >= 0";
    return false;
  }
  if (!(range_noise_m >= 0.0) || !(range_noise_fraction >= 0.0) || !(model_noise_m >= 0.0) ||
      !(range_noise_m + model_noise_m > 0.0) || !(membership_sigmas > 0.0) ||
      !(edge_margin_m >= 0.0) || !(surface_step_m > 0.0) || !(robust_scale_sigmas > 0.0) ||
      !(covariance_block_s > 0.0) ||
      !std::isfinite(range_noise_m + range_noise_fraction + model_noise_m + membership_sigmas +
                     edge_margin_m + robust_scale_sigmas + covariance_block_s)) {
    *error =
        "automatic calibration: noise model, membership, edge margin, robust scale and "
        "covariance block must be finite and positive";
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
  for (const auto& w : warnings) s << "  warning: " << w << "\n";
  return s.str();
}

// ----------------------------------------------------------------------------
// Pairs (Eq. 15-17)

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
  for (size_t k = 0; k < pairs.size(); ++k) {
    const std::string where = "pair " + std::to_string(k + 1) + ": ";
    const ObservationPair& p = pairs[k];
    for (const LidarObservation* o : {&p.pass1, &p.pass2}) {
      if (!Finite(o->p_lidar) || !Finite(o->world_from_body.translation()) ||
          !o->world_from_body.rotation().coeffs().allFinite()) {
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
        return Status::Error(where + "same samples as pair " + std::to_string(j + 1));
      }
    }
    first.push_back(ProjectObservation(p.pass1, geometry, initial));
  }

  summary->initial = initial;
  summary->angles = initial;
  summary->residual_blocks = static_cast<int>(pairs.size());
  summary->converged = false;

  // Pick geometry: three angles need picks spread in two directions.
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
  CheckObservability(&problem, abg, options, summary);
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

// ----------------------------------------------------------------------------
// Refined corners (the board fit itself is in board_fit.cc)

Status SolveRefinedCorners(const std::vector<LidarObservation>& pass1,
                           const std::vector<LidarObservation>& pass2,
                           const RobotGeometry& geometry, const MountingError& initial,
                           const CalibrationOptions& options, CalibrationSummary* summary) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  *summary = CalibrationSummary();
  summary->method = "refined-corners";
  summary->initial = initial;
  summary->angles = initial;
  MountingError c = initial;
  BoardCorners k1, k2;
  std::vector<CalibrationIteration> trace;
  std::vector<std::string> warnings;
  CalibrationSummary inner;
  for (int outer = 0; outer < options.max_outer_iterations; ++outer) {
    Status s = FitBoardCorners(pass1, geometry, c, &k1);
    if (!s.ok()) return Status::Error("pass 1: " + s.message());
    s = FitBoardCorners(pass2, geometry, c, &k2);
    if (!s.ok()) return Status::Error("pass 2: " + s.message());
    if (outer == 0) summary->initial_rms_m = CornerRms(k1, k2);
    // Each fitted corner becomes a virtual sample: the point in the lidar
    // frame that lands on the corner under c, attached to the pose of the
    // nearest real sample: p_L = (T_WB(t_j) * T_BL(c))^-1 corner.
    std::vector<ObservationPair> pairs(4);
    const Rigid3d bl = BodyFromLidar(geometry, c);
    for (int j = 0; j < 4; ++j) {
      LidarObservation* o[2] = {&pairs[j].pass1, &pairs[j].pass2};
      const BoardCorners* k[2] = {&k1, &k2};
      const std::vector<LidarObservation>* src[2] = {&pass1, &pass2};
      for (int side = 0; side < 2; ++side) {
        *o[side] = (*src[side])[k[side]->nearest[j]];
        o[side]->p_lidar = (o[side]->world_from_body * bl).inverse() * k[side]->corners[j];
      }
    }
    CalibrationOptions inner_options = options;
    inner_options.compute_covariance = true;
    inner = CalibrationSummary();
    s = SolvePairs(pairs, geometry, c, inner_options, &inner);
    for (auto it : inner.trace) {
      it.iteration = static_cast<int>(trace.size());
      trace.push_back(it);
    }
    summary->outer_iterations = outer + 1;
    if (!s.ok()) {
      summary->trace = trace;
      summary->message = inner.message;
      return Status::Error("refined corners, outer iteration " + std::to_string(outer + 1) + ": " +
                           s.message());
    }
    // The board fit is discrete (which samples are end points), so the
    // plain fixed-point iteration c_{k+1} = solve(fit(c_k)) can cycle
    // between two inlier sets. After four rounds the step shrinks fourfold each
    // round (c_{k+1} = c_k + w (solve - c_k), w = 4^-(k-3)), which settles
    // on the boundary between them.
    const double w = outer < 4 ? 1.0 : std::pow(0.25, outer - 3);
    const MountingError target = inner.angles;
    const MountingError next{c.alpha + w * (target.alpha - c.alpha),
                             c.beta + w * (target.beta - c.beta),
                             c.gamma + w * (target.gamma - c.gamma)};
    const double change = AngleChange(c, next);
    c = next;
    if (change < options.outer_tolerance_rad) {
      summary->converged = true;
      break;
    }
  }
  Status s = FitBoardCorners(pass1, geometry, c, &k1);
  if (s.ok()) s = FitBoardCorners(pass2, geometry, c, &k2);
  if (!s.ok()) return Status::Error("final board fit: " + s.message());
  summary->angles = c;
  summary->final_rms_m = CornerRms(k1, k2);
  summary->trace = trace;
  summary->sigma_rad = inner.sigma_rad;
  summary->condition_number = inner.condition_number;
  summary->warnings = inner.warnings;
  summary->initial_cost = trace.empty() ? 0.0 : trace.front().cost;
  summary->final_cost = inner.final_cost;
  summary->residual_blocks = 4;
  summary->message = summary->converged ? "corners and angles stopped changing"
                                        : "outer loop hit max_outer_iterations";
  if (!summary->converged) {
    return Status::Error("refined corners did not converge in " +
                         std::to_string(options.max_outer_iterations) + " outer iterations");
  }
  return Status::Ok();
}

// ----------------------------------------------------------------------------
// Automatic mode

namespace {

struct FoundPlane {
  Plane plane;
  std::vector<size_t> members;  // indices into the segmentation sample
};

// Sequential RANSAC (seeded): the largest plane first, its inliers removed,
// until the best plane holds fewer than min_count points. Point i is an
// inlier when |n . p_i + d| < threshold[i].
std::vector<FoundPlane> SegmentPlanes(const std::vector<Eigen::Vector3d>& pts,
                                      const std::vector<double>& threshold, size_t min_count,
                                      int max_planes, int iterations, std::mt19937_64* rng) {
  std::vector<FoundPlane> out;
  std::vector<size_t> remaining(pts.size());
  for (size_t i = 0; i < remaining.size(); ++i) remaining[i] = i;
  while (static_cast<int>(out.size()) < max_planes && remaining.size() >= min_count) {
    std::uniform_int_distribution<size_t> pick(0, remaining.size() - 1);
    size_t best_count = 0;
    Eigen::Vector3d best_n = Eigen::Vector3d::UnitZ();
    double best_d = 0.0;
    for (int it = 0; it < iterations; ++it) {
      const Eigen::Vector3d& a = pts[remaining[pick(*rng)]];
      const Eigen::Vector3d& b = pts[remaining[pick(*rng)]];
      const Eigen::Vector3d& c = pts[remaining[pick(*rng)]];
      Eigen::Vector3d n = (b - a).cross(c - a);
      if (n.norm() < 1e-6) continue;
      n.normalize();
      const double d = -n.dot(a);
      size_t count = 0;
      for (size_t i : remaining) count += std::abs(n.dot(pts[i]) + d) < threshold[i];
      if (count > best_count) best_count = count, best_n = n, best_d = d;
    }
    if (best_count < min_count) break;
    // Refine by least squares on the inliers, then take the final inliers.
    std::vector<Eigen::Vector3d> in;
    for (size_t i : remaining) {
      if (std::abs(best_n.dot(pts[i]) + best_d) < threshold[i]) in.push_back(pts[i]);
    }
    FoundPlane fp;
    if (!FitPlane(in, &fp.plane)) break;
    std::vector<size_t> rest;
    for (size_t i : remaining) {
      (std::abs(fp.plane.SignedDistance(pts[i])) < threshold[i] ? fp.members : rest).push_back(i);
    }
    if (fp.members.size() < min_count) break;
    remaining.swap(rest);
    out.push_back(std::move(fp));
  }
  return out;
}

// Cluster-robust covariance of the angles (the "sandwich"):
//   Cov = H^-1 (sum_g J_g' r_g r_g' J_g) H^-1,  H = J'J,
// J and r over all parameters (angles and planes, tangent space), rows
// grouped by g. With independent rows it reduces to the familiar
// (J'J)^-1 s^2; with errors shared inside a group (a pose error lasting a
// second) it grows accordingly, where the iid formula would not.
bool ClusteredAngleSigma(ceres::Problem* problem, const std::vector<int>& group_of_row,
                         Eigen::Vector3d* sigma) {
  ceres::CRSMatrix crs;
  std::vector<double> residuals;
  double cost = 0.0;
  if (!problem->Evaluate(ceres::Problem::EvaluateOptions(), &cost, &residuals, nullptr, &crs)) {
    return false;
  }
  if (static_cast<size_t>(crs.num_rows) != group_of_row.size()) return false;
  const int n = crs.num_cols;
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(n, n);
  std::unordered_map<int, Eigen::VectorXd> score;  // sum_rows_in_g J_row' r_row
  Eigen::VectorXd row(n);
  for (int r = 0; r < crs.num_rows; ++r) {
    row.setZero();
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) row[crs.cols[k]] = crs.values[k];
    h.selfadjointView<Eigen::Lower>().rankUpdate(row);
    auto it = score.find(group_of_row[r]);
    if (it == score.end()) it = score.emplace(group_of_row[r], Eigen::VectorXd::Zero(n)).first;
    it->second += row * residuals[r];
  }
  h = h.selfadjointView<Eigen::Lower>();
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(n, n);
  for (const auto& [g, s] : score) meat += s * s.transpose();
  // Small-sample correction G / (G - 1) for G groups.
  const double groups = static_cast<double>(score.size());
  if (groups > 1) meat *= groups / (groups - 1.0);
  const Eigen::MatrixXd hinv = h.completeOrthogonalDecomposition().pseudoInverse();
  const Eigen::MatrixXd cov = hinv * meat * hinv;
  for (int i = 0; i < 3; ++i) (*sigma)[i] = std::sqrt(std::max(0.0, cov(i, i)));
  return sigma->allFinite();
}

}  // namespace

Status SolveAutomatic(const SampleStore& store, const RobotGeometry& geometry,
                      const MountingError& initial, const AutoCalibrationOptions& options,
                      CalibrationSummary* summary) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  if (!geometry.IsValid(&error)) return Status::Error(error);
  *summary = CalibrationSummary();
  summary->method = "auto-planes";
  summary->initial = initial;
  summary->angles = initial;
  std::vector<size_t> sample;
  {
    std::vector<size_t> valid;
    for (size_t i = 0; i < store.observations().size(); ++i) {
      if (store.observations()[i].p_lidar.norm() >= options.min_range_m) valid.push_back(i);
    }
    sample = std::move(valid);
  }
  // RANSAC runs on an even subsample (seg_index into `sample`); the planes'
  // members, and so the residuals, come from every sample: the walls seen
  // sideways (x = 0, x = 10), which carry alpha and beta, hold only ~1 % of
  // the recording each.
  std::vector<size_t> seg_index;
  {
    const size_t stride = std::max<size_t>(
        1, (sample.size() + options.max_segmentation_points - 1) / options.max_segmentation_points);
    for (size_t i = 0; i < sample.size(); i += stride) seg_index.push_back(i);
  }
  if (sample.size() < 100) {
    return Status::Error("automatic calibration: only " + std::to_string(sample.size()) +
                         " samples in the recording");
  }
  std::vector<Prepared> prepared;
  std::vector<double> sigma;  // per point, metres (the noise model in the header)
  prepared.reserve(sample.size());
  sigma.reserve(sample.size());
  for (size_t i : sample) {
    const LidarObservation& o = store.observations()[i];
    prepared.push_back(Prepare(o, geometry));
    const double rho = o.p_lidar.norm();
    sigma.push_back(std::sqrt(options.range_noise_m * options.range_noise_m +
                              std::pow(options.range_noise_fraction * rho, 2) +
                              options.model_noise_m * options.model_noise_m));
  }
  const int64_t t0 = store.observations()[sample.front()].time_ns;

  MountingError c = initial;
  int final_rounds = 0;
  double band = options.initial_band_m;
  std::vector<CalibrationIteration> trace;
  const CalibrationOptions& so_opts = options.solver;
  std::vector<double> threshold(sample.size());
  for (int outer = 0; outer < so_opts.max_outer_iterations; ++outer) {
    double abg[3] = {c.alpha, c.beta, c.gamma};
    std::vector<Eigen::Vector3d> pts(sample.size());
    for (size_t i = 0; i < sample.size(); ++i) {
      double p[3];
      ProjectT(prepared[i], abg, p);
      pts[i] = Eigen::Vector3d(p[0], p[1], p[2]);
    }
    const bool last_band = band <= options.final_band_m;
    // While the ghosts are being pulled together a wide band keeps both
    // copies of a wall in one plane; at the final band, membership follows
    // each point's own noise, so surfaces a few cm apart separate.
    for (size_t i = 0; i < sample.size(); ++i) {
      threshold[i] = last_band ? std::min(band, options.membership_sigmas * sigma[i]) : band;
    }
    const size_t min_count = static_cast<size_t>(options.min_plane_fraction * seg_index.size());
    // Same seed every round: the segmentation depends on the points only.
    std::mt19937_64 rng(options.seed);
    std::vector<Eigen::Vector3d> seg_pts;
    std::vector<double> seg_threshold;
    for (size_t i : seg_index) seg_pts.push_back(pts[i]), seg_threshold.push_back(threshold[i]);
    std::vector<FoundPlane> planes =
        SegmentPlanes(seg_pts, seg_threshold, std::max<size_t>(min_count, 50), options.max_planes,
                      options.ransac_iterations, &rng);
    // Members over all samples, each to the first plane (largest first)
    // whose band holds it, as SegmentPlanes assigns them.
    {
      std::vector<char> taken(sample.size(), 0);
      for (auto& fp : planes) {
        fp.members.clear();
        for (size_t i = 0; i < sample.size(); ++i) {
          if (!taken[i] && std::abs(fp.plane.SignedDistance(pts[i])) < threshold[i]) {
            fp.members.push_back(i);
            taken[i] = 1;
          }
        }
      }
    }
    // Keep surfaces seen from more than one place: at least two sightings
    // (time gaps > 1 s) or one long sighting (floor, ceiling: seen from
    // every heading of the circle).
    std::vector<FoundPlane> used;
    std::vector<int> sightings;
    for (auto& fp : planes) {
      std::vector<int64_t> times;
      for (size_t m : fp.members) times.push_back(store.observations()[sample[m]].time_ns);
      const auto windows = SplitByTimeGaps(times, 1.0, 20);
      double span = 0.0;
      for (const auto& w : windows) span += w.duration_s();
      if (windows.size() >= 2 || span >= 5.0) {
        used.push_back(std::move(fp));
        sightings.push_back(static_cast<int>(windows.size()));
      }
    }
    if (used.size() < 2) {
      summary->trace = trace;
      return Status::Error("automatic calibration: found " + std::to_string(used.size()) +
                           " plane(s) seen in both passes, need at least 2");
    }
    // At the final band, drop whole scan-line runs that sit off the plane:
    // a run (consecutive members of one scan line) is a piece of one
    // surface, and a run whose mean offset exceeds surface_step_m belongs to
    // a parallel surface a little in front or behind (the board 2 cm in
    // front of the sill), which the per-point band cannot separate at 3
    // sigma. Two rounds of reject-and-refit.
    if (last_band) {
      for (auto& fp : used) {
        for (int round = 0; round < 2; ++round) {
          std::vector<size_t> keep;
          size_t begin = 0;
          const auto& mem = fp.members;  // ascending sample index = time order
          for (size_t i = 1; i <= mem.size(); ++i) {
            const bool split = i == mem.size() ||
                               store.observations()[sample[mem[i]]].ref.scan !=
                                   store.observations()[sample[mem[i - 1]]].ref.scan ||
                               mem[i] - mem[i - 1] > 1;  // a sample between them is off this plane
            if (!split) continue;
            double sum = 0.0, var = 0.0;
            for (size_t k = begin; k < i; ++k) {
              sum += fp.plane.SignedDistance(pts[mem[k]]);
              var += sigma[mem[k]] * sigma[mem[k]];
            }
            const double n_run = static_cast<double>(i - begin);
            const double mean = sum / n_run;
            // Off by more than the step and more than 3 standard errors.
            if (std::abs(mean) <= std::max(options.surface_step_m, 3.0 * std::sqrt(var) / n_run)) {
              keep.insert(keep.end(), mem.begin() + begin, mem.begin() + i);
            }
            begin = i;
          }
          if (keep.size() == mem.size() || keep.size() < 50) break;
          std::vector<Eigen::Vector3d> in;
          for (size_t m : keep) in.push_back(pts[m]);
          Plane refit;
          if (!FitPlane(in, &refit)) break;
          fp.plane = refit;
          fp.members.swap(keep);
        }
      }
    }
    // Residual points: members not within edge_margin_m of another kept
    // plane (edges where two surfaces meet, where membership is a guess),
    // then evenly subsampled to max_points_per_plane.
    std::vector<std::vector<size_t>> chosen(used.size());
    for (size_t s = 0; s < used.size(); ++s) {
      std::vector<size_t> clean;
      for (size_t m : used[s].members) {
        bool ambiguous = false;
        for (size_t t = 0; t < used.size() && !ambiguous; ++t) {
          ambiguous =
              t != s && std::abs(used[t].plane.SignedDistance(pts[m])) < options.edge_margin_m;
        }
        if (!ambiguous) clean.push_back(m);
      }
      const size_t stride = std::max<size_t>(
          1, (clean.size() + options.max_points_per_plane - 1) / options.max_points_per_plane);
      for (size_t k = 0; k < clean.size(); k += stride) chosen[s].push_back(clean[k]);
    }
    ceres::Problem::Options po;
    ceres::Problem problem(po);
    problem.AddParameterBlock(abg, 3);
    std::vector<std::array<double, 4>> params(used.size());
    std::vector<int> group_of_row;
    int residuals = 0;
    double sq_before = 0.0;
    const RobustLoss loss = so_opts.loss == RobustLoss::kNone ? RobustLoss::kHuber : so_opts.loss;
    for (size_t s = 0; s < used.size(); ++s) {
      const Plane& pl = used[s].plane;
      params[s] = {pl.normal.x(), pl.normal.y(), pl.normal.z(), pl.d};
      problem.AddParameterBlock(params[s].data(), 3, new ceres::SphereManifold<3>());
      problem.AddParameterBlock(params[s].data() + 3, 1);
      for (size_t m : chosen[s]) {
        problem.AddResidualBlock(PointToPlaneCost::Create(prepared[m], 1.0 / sigma[m]),
                                 MakeLoss(loss, options.robust_scale_sigmas), abg, params[s].data(),
                                 params[s].data() + 3);
        group_of_row.push_back(
            static_cast<int>((store.observations()[sample[m]].time_ns - t0) /
                             static_cast<int64_t>(options.covariance_block_s * kNsPerS)));
        const double r = pl.SignedDistance(pts[m]);
        sq_before += r * r;
        ++residuals;
      }
    }
    if (residuals == 0) return Status::Error("automatic calibration: no residual points left");
    if (outer == 0) summary->initial_rms_m = std::sqrt(sq_before / residuals);
    ceres::Solver::Options so = SolverOptions(so_opts);
    std::vector<CalibrationIteration> inner_trace;
    TraceCallback callback(abg, &inner_trace, so_opts.progress);
    so.callbacks.push_back(&callback);
    ceres::Solver::Summary cs;
    ceres::Solve(so, &problem, &cs);
    for (auto it : inner_trace) {
      it.iteration = static_cast<int>(trace.size());
      trace.push_back(it);
    }
    summary->outer_iterations = outer + 1;
    summary->message = cs.message;
    if (outer == 0) summary->initial_cost = cs.initial_cost;
    if (cs.termination_type == ceres::USER_FAILURE) {
      summary->trace = trace;
      return Status::Error("calibration cancelled");
    }
    if (cs.termination_type != ceres::CONVERGENCE ||
        !Eigen::Vector3d(abg[0], abg[1], abg[2]).allFinite()) {
      summary->trace = trace;
      return Status::Error("automatic calibration did not converge: " + cs.message);
    }
    const MountingError next = FromArray(abg);
    const double change = AngleChange(c, next);
    c = next;
    if (last_band) ++final_rounds;
    // Re-segmenting can flip a few boundary points in or out of a plane, so
    // the angles settle to within ~1e-5 rad, not to the LM tolerance: stop
    // when a round at the final band moves them less than
    // max(outer_tolerance_rad, 1e-5), or after three rounds at that band.
    const bool settled = change < std::max(so_opts.outer_tolerance_rad, 1e-5);
    if (last_band && (settled || final_rounds >= 3 || outer + 1 == so_opts.max_outer_iterations)) {
      // Final statistics on the last problem.
      summary->converged = settled || final_rounds >= 3;
      summary->final_cost = cs.final_cost;
      summary->planes = static_cast<int>(used.size());
      summary->residual_blocks = residuals;
      double sq = 0.0, sq_norm = 0.0;
      for (size_t s = 0; s < used.size(); ++s) {
        CalibrationSummary::PlaneReport rep;
        rep.normal = Eigen::Vector3d(params[s][0], params[s][1], params[s][2]);
        rep.d = params[s][3];
        rep.points = static_cast<int>(chosen[s].size());
        rep.sightings = sightings[s];
        double ps = 0.0, pn = 0.0;
        for (size_t m : chosen[s]) {
          double p[3];
          ProjectT(prepared[m], abg, p);
          const double r = rep.normal.dot(Eigen::Vector3d(p[0], p[1], p[2])) + rep.d;
          ps += r * r;
          pn += (r / sigma[m]) * (r / sigma[m]);
        }
        sq += ps;
        sq_norm += pn;
        rep.rms_m = std::sqrt(ps / std::max<size_t>(1, chosen[s].size()));
        rep.rms_sigmas = std::sqrt(pn / std::max<size_t>(1, chosen[s].size()));
        summary->plane_reports.push_back(rep);
      }
      summary->final_rms_m = std::sqrt(sq / residuals);
      CheckObservability(&problem, abg, so_opts, summary);
      if (so_opts.compute_covariance) {
        // The iid estimate, with s^2 from the normalised residuals
        // themselves (not the robust cost), ...
        const double saved_cost = cs.final_cost;
        summary->final_cost = 0.5 * sq_norm;
        ComputeCovariance(&problem, abg, residuals, summary);
        summary->final_cost = saved_cost;
        summary->sigma_iid_rad = summary->sigma_rad;
        // ... and the cluster-robust one; report the larger per angle.
        Eigen::Vector3d clustered;
        if (ClusteredAngleSigma(&problem, group_of_row, &clustered)) {
          summary->sigma_rad = summary->sigma_rad.cwiseMax(clustered);
        }
      }
      break;
    }
    band = std::max(options.final_band_m, 0.5 * band);
  }
  summary->angles = c;
  summary->trace = trace;
  if (!summary->converged) {
    return Status::Error("automatic calibration did not settle in " +
                         std::to_string(so_opts.max_outer_iterations) + " outer iterations");
  }
  summary->message = "angles stopped changing at the final inlier band";
  return Status::Ok();
}

// ----------------------------------------------------------------------------
// Files

namespace {

Pick ParsePick(const JsonObject& o) {
  Pick p;
  o.AllowOnly({"scan", "beam", "world"});
  const bool has_sample = o.Has("scan") || o.Has("beam");
  if (has_sample == o.Has("world")) {
    o.Fail("", "give either scan and beam, or world, not " +
                   std::string(has_sample ? "both" : "neither"));
  }
  if (has_sample) {
    const int64_t scan = o.Integer("scan");
    const int64_t beam = o.Integer("beam");
    if (scan < 0 || scan > 0xffffffffLL) o.Fail("scan", "out of range: " + std::to_string(scan));
    if (beam < 0 || beam > 0xffff) o.Fail("beam", "out of range: " + std::to_string(beam));
    p.has_sample = true;
    p.sample = {static_cast<uint32_t>(scan), static_cast<uint16_t>(beam)};
  } else {
    const nlohmann::json& w = o.Array("world");
    if (w.size() != 3)
      o.Fail("world", "expected [x, y, z], got " + std::to_string(w.size()) + " values");
    for (int i = 0; i < 3; ++i) {
      if (!w[i].is_number())
        o.Fail("world", "element " + std::to_string(i) + " is " + JsonTypeName(w[i]));
      p.world[i] = w[i].get<double>();
      if (!std::isfinite(p.world[i]))
        o.Fail("world", "element " + std::to_string(i) + " is not finite");
    }
  }
  return p;
}

void CheckHeader(const JsonObject& root, const std::string& format) {
  if (root.String("format") != format) {
    root.Fail("format", "expected \"" + format + "\", got \"" + root.String("format") + "\"");
  }
  if (root.Integer("version") != 1) {
    root.Fail("version", "unsupported version " + std::to_string(root.Integer("version")));
  }
}

}  // namespace

// ParseJson (core/json_reader.cc) catches only parse_error; a number that
// overflows a double ("1e999") throws out_of_range, so guard here.
static Status ParseJsonNoThrow(const std::string& text, const std::string& source,
                               nlohmann::json* j) {
  try {
    return ParseJson(text, source, j);
  } catch (const nlohmann::json::exception& e) {
    return Status::Error(source + ": not valid JSON (" + e.what() + ")");
  }
}

Status ParsePairs(const std::string& text, const std::string& source,
                  std::vector<PickPair>* pairs) {
  nlohmann::json j;
  Status s = ParseJsonNoThrow(text, source, &j);
  if (!s.ok()) return s;
  try {
    const JsonObject root(j, "");
    root.AllowOnly({"format", "version", "pairs", "comment"});
    CheckHeader(root, "sweepscan-pairs");
    const nlohmann::json& list = root.Array("pairs");
    std::vector<PickPair> out;
    for (size_t k = 0; k < list.size(); ++k) {
      const JsonObject pair(list[k], "pairs[" + std::to_string(k) + "]");
      pair.AllowOnly({"pass1", "pass2", "label"});
      if (pair.Has("label")) pair.String("label");
      PickPair pp;
      pp.pass1 = ParsePick(pair.Object("pass1"));
      pp.pass2 = ParsePick(pair.Object("pass2"));
      out.push_back(pp);
    }
    *pairs = std::move(out);
  } catch (const JsonError& e) {
    return Status::Error(source + ": " + e.what());
  }
  return Status::Ok();
}

static Status ReadText(const std::string& path, std::string* text) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path + ": cannot open for reading");
  std::stringstream buffer;
  buffer << in.rdbuf();
  *text = buffer.str();
  return Status::Ok();
}

Status LoadPairsFile(const std::string& path, std::vector<PickPair>* pairs) {
  std::string text;
  Status s = ReadText(path, &text);
  if (!s.ok()) return s;
  return ParsePairs(text, path, pairs);
}

std::string PairsToJson(const std::vector<PickPair>& pairs) {
  nlohmann::json list = nlohmann::json::array();
  auto pick = [](const Pick& p) {
    nlohmann::json o;
    if (p.has_sample) {
      o["scan"] = p.sample.scan;
      o["beam"] = p.sample.beam;
    } else {
      o["world"] = {p.world.x(), p.world.y(), p.world.z()};
    }
    return o;
  };
  for (const auto& p : pairs) list.push_back({{"pass1", pick(p.pass1)}, {"pass2", pick(p.pass2)}});
  nlohmann::json root = {{"format", "sweepscan-pairs"}, {"version", 1}, {"pairs", list}};
  return root.dump(2) + "\n";
}

Status SaveCalibrationFile(const std::string& path, const MountingError& c,
                           const CalibrationSummary* summary) {
  if (!std::isfinite(c.alpha) || !std::isfinite(c.beta) || !std::isfinite(c.gamma)) {
    return Status::Error(path + ": refusing to save non-finite angles");
  }
  nlohmann::json root = {
      {"format", "sweepscan-calibration"},
      {"version", 1},
      {"mounting_error_rad", {{"alpha", c.alpha}, {"beta", c.beta}, {"gamma", c.gamma}}}};
  if (summary != nullptr) {
    root["method"] = summary->method;
    root["converged"] = summary->converged;
    if (summary->sigma_rad.minCoeff() >= 0.0 && summary->sigma_rad.allFinite()) {
      root["sigma_rad"] = {{"alpha", summary->sigma_rad[0]},
                           {"beta", summary->sigma_rad[1]},
                           {"gamma", summary->sigma_rad[2]}};
    }
    root["rms_before_m"] = summary->initial_rms_m;
    root["rms_after_m"] = summary->final_rms_m;
  }
  return WriteFileAtomically(path, root.dump(2) + "\n");
}

Status ParseCalibration(const std::string& text, const std::string& source, MountingError* c) {
  nlohmann::json j;
  Status s = ParseJsonNoThrow(text, source, &j);
  if (!s.ok()) return s;
  try {
    const JsonObject root(j, "");
    root.AllowOnly({"format", "version", "mounting_error_rad", "method", "converged", "sigma_rad",
                    "rms_before_m", "rms_after_m", "comment"});
    CheckHeader(root, "sweepscan-calibration");
    const JsonObject m = root.Object("mounting_error_rad");
    m.AllowOnly({"alpha", "beta", "gamma"});
    // A mounting error is a small angle; beyond 0.5 rad the file is wrong
    // (degrees written as radians, most likely).
    MountingError out;
    out.alpha = m.InRange("alpha", -0.5, 0.5, 0.0);
    out.beta = m.InRange("beta", -0.5, 0.5, 0.0);
    out.gamma = m.InRange("gamma", -0.5, 0.5, 0.0);
    for (const char* k : {"alpha", "beta", "gamma"}) {
      if (!m.Has(k)) m.Fail(k, "missing");
    }
    if (root.Has("method")) root.String("method");
    root.Bool("converged", true);
    if (root.Has("sigma_rad")) {
      const JsonObject sg = root.Object("sigma_rad");
      sg.AllowOnly({"alpha", "beta", "gamma"});
      for (const char* k : {"alpha", "beta", "gamma"}) sg.NonNegative(k, 0.0);
    }
    root.NonNegative("rms_before_m", 0.0);
    root.NonNegative("rms_after_m", 0.0);
    *c = out;
  } catch (const JsonError& e) {
    return Status::Error(source + ": " + e.what());
  }
  return Status::Ok();
}

Status LoadCalibrationFile(const std::string& path, MountingError* c) {
  std::string text;
  Status s = ReadText(path, &text);
  if (!s.ok()) return s;
  return ParseCalibration(text, path, c);
}

}  // namespace sweepscan
