// Pieces the calibration's translation units share; not part of the room's
// interface (include the public headers instead).
#ifndef SWEEPSCAN_CORE_CALIBRATION_INTERNAL_H_
#define SWEEPSCAN_CORE_CALIBRATION_INTERNAL_H_

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "core/calibration/pairs_solver.h"
#include "core/calibration/samples.h"
#include "core/geometry/plane.h"
#include "core/robot/robot_model.h"

namespace sweepscan::calibration_internal {

inline constexpr double kNsPerS = 1e9;

inline std::string Num(double v, int precision = 6) {
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

// "pair 3 (pairs[2])": counted from 1 as the Calibration panel counts
// them, with the pairs file's own path (counted from 0) beside it.
inline std::string PairName(size_t k) {
  return "pair " + std::to_string(k + 1) + " (pairs[" + std::to_string(k) + "])";
}

inline std::string RefName(const SampleRef& r) {
  return "(scan " + std::to_string(r.scan) + ", beam " + std::to_string(r.beam) + ")";
}

// What the cost functors need of an observation, in doubles: the lidar point
// in the nominal mount's axes N p_L (N = identity on sweepscan's robot, a
// tf mount for a ROS bag: robot_model.h), the mount translation
// t_BL = (l1, l_y, h) and the body pose.
struct Prepared {
  Eigen::Matrix3d r_wb;
  Eigen::Vector3d t_wb, t_bl, p_l;
};

inline Prepared Prepare(const LidarObservation& o, const RobotGeometry& g) {
  Prepared p;
  p.r_wb = o.world_from_body.rotation().toRotationMatrix();
  p.t_wb = o.world_from_body.translation();
  p.t_bl = g.LidarTranslation();
  p.p_l = g.NominalFromLidar(o.p_lidar);
  return p;
}

// p_W(c) = R_WB (Rz(alpha) Ry(beta) Rx(gamma) N p_L + t_BL) + t_WB   (Eq. 1, 13, 14)
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

// The same for many samples under one c, with R(c) computed once
// (MountingRotation, robot_model.h) instead of six sines and cosines a sample.
inline Eigen::Vector3d ProjectWith(const Prepared& o, const Eigen::Matrix3d& r_c) {
  return o.r_wb * (r_c * o.p_l + o.t_bl) + o.t_wb;
}

inline MountingError FromArray(const double* abg) { return {abg[0], abg[1], abg[2]}; }

inline double AngleChange(const MountingError& a, const MountingError& b) {
  return std::max(
      {std::abs(a.alpha - b.alpha), std::abs(a.beta - b.beta), std::abs(a.gamma - b.gamma)});
}

inline bool Finite(const Eigen::Vector3d& v) { return v.allFinite(); }

// The automatic mode's Levenberg-Marquardt problem (its Ceres part lives in
// pairs_solver.cc with the rest of the project's Ceres templates): the three
// angles and one plane (n_s on the unit sphere, d_s) per kept surface, one
// point-to-plane residual per chosen point, weighted by 1 / sigma_i.
class PlaneProblem {
 public:
  // abg: the angles (alpha, beta, gamma), the start on entry and the
  // solution after Solve; owned by the caller, who keeps them in its own
  // stack frame: Ceres orders the covariance's columns by parameter block
  // address, and angles on the stack, planes on the heap is the order the
  // reported sigma was computed in (a different order changes its last
  // bits). planes[s] starts the surface's parameters; chosen[s] indexes
  // `prepared` and `sigma`. Residuals are added surface by surface in chosen
  // order.
  //
  // scale (owned by the caller, starting at 1): the path's distance scale
  // about `centre`, a nuisance parameter: t_WB -> centre + scale (t_WB -
  // centre) (automatic.h, estimate_path_scale); held constant unless
  // estimate_scale.
  PlaneProblem(double* abg, const std::vector<Plane>& planes,
               const std::vector<std::vector<size_t>>& chosen,
               const std::vector<Prepared>& prepared, const std::vector<double>& sigma,
               RobustLoss loss, double loss_scale, double* scale, const Eigen::Vector3d& centre,
               bool estimate_scale);
  ~PlaneProblem();
  PlaneProblem(const PlaneProblem&) = delete;
  PlaneProblem& operator=(const PlaneProblem&) = delete;

  struct Outcome {
    bool cancelled = false;     // the progress callback asked to stop
    bool lm_converged = false;  // Ceres' CONVERGENCE, or the angles' step below the tolerance
    double initial_cost = 0.0, final_cost = 0.0;
    std::string message;
  };
  // One LM solve from the current angles; appends its iterations to `trace`.
  // It also stops, converged, once a successful step moves no angle by more
  // than angle_tolerance_rad (0: only Ceres' own tolerances).
  Outcome Solve(const CalibrationOptions& options, double angle_tolerance_rad,
                std::vector<CalibrationIteration>* trace);

  const std::array<double, 4>& plane(size_t s) const;  // n_s (3), d_s

  // The residuals and the Jacobian's angle columns at the current angles
  // and planes (for tests of the analytic Jacobian).
  bool EvaluateAngles(std::vector<double>* residuals, Eigen::MatrixXd* d_angles);

  // Final statistics on the solved problem: the angles' observability ...
  void CheckObservability(const CalibrationOptions& options, CalibrationSummary* summary);
  // ... and the angles' covariance from one Jacobian: iid, s2 (J'J)^-1, and
  // cluster-robust over the rows' groups (pairs_solver.cc).
  bool AngleCovariances(const std::vector<int>& group_of_row, double s2, Eigen::Matrix3d* iid,
                        Eigen::Matrix3d* clustered);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sweepscan::calibration_internal

#endif  // SWEEPSCAN_CORE_CALIBRATION_INTERNAL_H_
