// The pose of one scan against the planes tracked so far (sequence.h):
// the line-to-plane distances of Choi et al. 2017, Eq. 38-39, and the
// Gauss-Newton update of the rig's pose with an optional motion prior.
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/geometry/skew.h"
#include "core/sfm/sequence.h"

namespace sweepscan::sfm {
namespace {

Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a < 1e-12) return Eigen::Matrix3d::Identity() + Skew(w);
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

}  // namespace

void LinePlaneDistance(const LineObs& line, const Rigid3d& world_from_rig, const WorldPlane& plane,
                       double* max_distance_m, double* sin_angle) {
  const Eigen::Vector3d c = world_from_rig * line.centroid;
  const Eigen::Vector3d v = world_from_rig.rotation() * line.direction;
  // Eq. 38: point-to-plane distances of the line's points (its extreme
  // points and centroid bound those of all its samples).
  const double dc = plane.SignedDistance(c);
  const double dv = plane.normal.dot(v) * line.half_length;
  *max_distance_m = std::max(std::abs(dc + dv), std::abs(dc - dv));
  *max_distance_m = std::max(*max_distance_m, std::abs(dc));
  // Eq. 39: the line lies in the plane: |n . v| = sin(angle to the plane).
  *sin_angle = std::abs(plane.normal.dot(v));
}

Eigen::Matrix<double, 6, 1> MotionPrior::SqrtInformation(const Rigid3d& delta) const {
  const double dist = delta.translation().norm();
  const double angle = Eigen::AngleAxisd(delta.rotation()).angle();
  Eigen::Matrix<double, 6, 1> s;
  for (int a = 0; a < 3; ++a) {
    s[a] = point_sigma_m / (r0_rad[a] + r_per_rad * angle + r_per_m * dist);
    s[3 + a] = point_sigma_m / (t0_m[a] + t_per_m[a] * dist);
  }
  return s;
}

namespace {

// UpdatePose with an optional prior (sequence.h).
double UpdatePoseImpl(const std::vector<const LineObs*>& lines,
                      const std::vector<WorldPlane>& planes, const SequenceOptions& options,
                      const Rigid3d* prior_pose, const Eigen::Matrix<double, 6, 1>* sqrt_info,
                      Rigid3d* pose) {
  Eigen::Matrix3d R = pose->rotation().toRotationMatrix();
  Eigen::Vector3d t = pose->translation();
  double lambda_min = 0.0;
  for (int it = 0; it < options.pose_iterations; ++it) {
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    double wsum = 0.0;
    for (const LineObs* l : lines) {
      const WorldPlane& p = planes[l->plane];
      const Eigen::Vector3d Rc = R * l->centroid, Ru = R * l->direction;
      // Residuals of Eq. 40 for one pose; left perturbation R <- exp([w]x) R,
      // t <- t + dt: d(n . (R c)) / dw = (R c x n)^T.
      const double r0 = p.normal.dot(Rc + t) + p.d;
      const double r1 = l->sigma * p.normal.dot(Ru);
      Eigen::Matrix<double, 6, 1> J0, J1;
      J0 << Rc.cross(p.normal), p.normal;
      J1 << l->sigma * Ru.cross(p.normal), Eigen::Vector3d::Zero();
      // Huber weight (IRLS) on the line's RMS distance, times its samples.
      const double e = std::sqrt(r0 * r0 + r1 * r1);
      const double w = l->count * (e <= options.huber_m ? 1.0 : options.huber_m / e);
      H += w * (J0 * J0.transpose() + J1 * J1.transpose());
      g += w * (J0 * r0 + J1 * r1);
      wsum += w;
    }
    if (wsum <= 0.0 && prior_pose == nullptr) return 0.0;
    if (wsum > 0.0) {
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(H / wsum);
      lambda_min = std::max(0.0, es.eigenvalues()[0]);
    }
    if (prior_pose != nullptr) {
      // e = [Log(R_p^T R); R_p^T (t - t_p)]; under R <- exp([w]x) R,
      // t <- t + dt: de/dw = R^T (to first order), de/dt = R_p^T.
      const Eigen::Matrix3d Rp = prior_pose->rotation().toRotationMatrix();
      const Eigen::AngleAxisd aa(Rp.transpose() * R);
      Eigen::Matrix<double, 6, 1> e;
      e << aa.angle() * aa.axis(), Rp.transpose() * (t - prior_pose->translation());
      Eigen::Matrix<double, 6, 6> J = Eigen::Matrix<double, 6, 6>::Zero();
      J.topLeftCorner<3, 3>() = R.transpose();
      J.bottomRightCorner<3, 3>() = Rp.transpose();
      const Eigen::Matrix<double, 6, 6> SJ = sqrt_info->asDiagonal() * J;
      H += SJ.transpose() * SJ;
      g += SJ.transpose() * sqrt_info->cwiseProduct(e);
    }
    // Damping keeps directions the lines do not constrain at the start pose.
    const double mu = 1e-6 * H.trace() + 1e-12;
    const Eigen::Matrix<double, 6, 1> delta =
        -(H + mu * Eigen::Matrix<double, 6, 6>::Identity()).ldlt().solve(g);
    if (!delta.allFinite()) return 0.0;
    R = ExpSO3(delta.head<3>()) * R;
    t += delta.tail<3>();
    if (delta.norm() < 1e-10) break;
  }
  *pose = Rigid3d(t, Eigen::Quaterniond(R));
  return lambda_min;
}

}  // namespace

double UpdatePose(const std::vector<const LineObs*>& lines, const std::vector<WorldPlane>& planes,
                  const SequenceOptions& options, Rigid3d* pose) {
  return UpdatePoseImpl(lines, planes, options, nullptr, nullptr, pose);
}

double UpdatePose(const std::vector<const LineObs*>& lines, const std::vector<WorldPlane>& planes,
                  const SequenceOptions& options, const Rigid3d& prior_pose,
                  const Eigen::Matrix<double, 6, 1>& sqrt_info, Rigid3d* pose) {
  return UpdatePoseImpl(lines, planes, options, &prior_pose, &sqrt_info, pose);
}

}  // namespace sweepscan::sfm
