// Eq. 40 with Ceres (see refine.h). Ceres templates stay in this file.
#include "core/sfm/refine.h"

#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <ceres/sphere_manifold.h>

#include <chrono>
#include <map>
#include <memory>

namespace sweepscan::sfm {
namespace {

// Stops the solve at the next iteration once `cancel` is set.
class CancelCallback : public ceres::IterationCallback {
 public:
  explicit CancelCallback(const std::atomic<bool>* cancel) : cancel_(cancel) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return cancel_ != nullptr && cancel_->load() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* cancel_;
};

// Residuals of one line on one plane (Eq. 40): the plane distance of the
// line's centroid, and sigma times the sine of the line-plane angle. Pose
// block: quaternion (x, y, z, w; Eigen's storage) then translation; plane
// block: unit normal then offset.
struct LinePlaneCost {
  LinePlaneCost(const Eigen::Vector3d& c, const Eigen::Vector3d& u, double sigma) : c_(c), u_(u), sigma_(sigma) {}

  template <typename T>
  bool operator()(const T* pose, const T* plane, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(pose);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(pose + 4);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> n(plane);
    const Eigen::Matrix<T, 3, 1> pc = q * c_.cast<T>() + t;  // centroid in the world
    const Eigen::Matrix<T, 3, 1> pu = q * u_.cast<T>();      // direction in the world
    r[0] = n.dot(pc) + plane[3];
    r[1] = T(sigma_) * n.dot(pu);
    return true;
  }

  Eigen::Vector3d c_, u_;
  double sigma_;
};

// A weak prior of a pose at its tracked value (unary: it keeps the Schur
// structure). Lines on fewer than three independent planes leave a pose
// free along some direction (e.g. a frame seeing only walls that share a
// direction); the prior holds it where tracking put it. Its weight (1 / 1 m,
// 1 / 0.3 rad) is negligible beside the lines' (each weighted by its
// ~100 samples, residuals of millimetres): it moves a well-constrained pose
// by about 1e-3 of its correction.
struct PosePriorCost {
  PosePriorCost(const Eigen::Quaterniond& q, const Eigen::Vector3d& t, double sigma_t, double sigma_r)
      : q_(q), t_(t), wt_(1.0 / sigma_t), wr_(1.0 / sigma_r) {}
  template <typename T>
  bool operator()(const T* pose, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(pose);
    const Eigen::Quaternion<T> dq = q_.conjugate().cast<T>() * q;
    // Small-angle rotation vector of q0^-1 q: 2 vec(dq) (sign of w fixed).
    const T s = dq.w() < T(0) ? T(-2) : T(2);
    r[0] = T(wr_) * s * dq.x();
    r[1] = T(wr_) * s * dq.y();
    r[2] = T(wr_) * s * dq.z();
    for (int i = 0; i < 3; ++i) r[3 + i] = T(wt_) * (pose[4 + i] - T(t_[i]));
    return true;
  }
  Eigen::Quaterniond q_;
  Eigen::Vector3d t_;
  double wt_, wr_;
};

// The motion prior between two consecutive poses (refine.h).
struct RelativeMotionCost {
  RelativeMotionCost(const Rigid3d& delta, const Eigen::Matrix<double, 6, 1>& sqrt_info)
      : q_(delta.rotation().normalized()), t_(delta.translation()), s_(sqrt_info) {}
  template <typename T>
  bool operator()(const T* a, const T* b, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> qa(a), qb(b);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> ta(a + 4), tb(b + 4);
    const Eigen::Quaternion<T> qa_inv = qa.conjugate();
    const Eigen::Quaternion<T> q_rel = qa_inv * qb;
    const Eigen::Matrix<T, 3, 1> t_rel = qa_inv * (tb - ta);
    const Eigen::Quaternion<T> dq = q_.conjugate().cast<T>() * q_rel;
    const T s = dq.w() < T(0) ? T(-2) : T(2);
    r[0] = T(s_[0]) * s * dq.x();
    r[1] = T(s_[1]) * s * dq.y();
    r[2] = T(s_[2]) * s * dq.z();
    for (int i = 0; i < 3; ++i) r[3 + i] = T(s_[3 + i]) * (t_rel[i] - T(t_[i]));
    return true;
  }
  Eigen::Quaterniond q_;
  Eigen::Vector3d t_;
  Eigen::Matrix<double, 6, 1> s_;
};

// The prior's absolute orientation (refine.h): the world-frame rotation
// error 2 vec(q q_p^-1), its x and y (tilt) and z (yaw) weighted apart.
struct AbsoluteOrientationCost {
  AbsoluteOrientationCost(const Eigen::Quaterniond& q, double s_tilt, double s_yaw)
      : q_(q.normalized()), s_tilt_(s_tilt), s_yaw_(s_yaw) {}
  template <typename T>
  bool operator()(const T* pose, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(pose);
    const Eigen::Quaternion<T> dq = q * q_.conjugate().cast<T>();
    const T s = dq.w() < T(0) ? T(-2) : T(2);
    r[0] = T(s_tilt_) * s * dq.x();
    r[1] = T(s_tilt_) * s * dq.y();
    r[2] = T(s_yaw_) * s * dq.z();
    return true;
  }
  Eigen::Quaterniond q_;
  double s_tilt_, s_yaw_;
};

using PoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;
using PlaneManifold = ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>>;

}  // namespace

Status RefinePosesAndPlanes(const std::vector<LineObs>& lines, const RefineOptions& options,
                            std::vector<Rigid3d>* poses, std::vector<WorldPlane>* planes,
                            RefineSummary* summary) {
  const auto start = std::chrono::steady_clock::now();
  const int num_poses = static_cast<int>(poses->size());
  const int num_planes = static_cast<int>(planes->size());
  std::vector<std::array<double, 7>> pose_blocks(num_poses);
  std::vector<std::array<double, 4>> plane_blocks(num_planes);
  for (int i = 0; i < num_poses; ++i) {
    const Eigen::Quaterniond q = (*poses)[i].rotation().normalized();
    const Eigen::Vector3d& t = (*poses)[i].translation();
    pose_blocks[i] = {q.x(), q.y(), q.z(), q.w(), t.x(), t.y(), t.z()};
  }
  for (int j = 0; j < num_planes; ++j) {
    const WorldPlane& p = (*planes)[j];
    const double s = p.normal.norm();
    plane_blocks[j] = {p.normal.x() / s, p.normal.y() / s, p.normal.z() / s, p.d / s};
  }

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PoseManifold pose_manifold;
  PlaneManifold plane_manifold;
  std::vector<bool> pose_used(num_poses, false), plane_used(num_planes, false);
  int blocks = 0;
  for (const LineObs& l : lines) {
    if (l.plane < 0) continue;
    if (l.frame < 0 || l.frame >= num_poses || l.plane >= num_planes) {
      return Status::Error("refinement: line refers to an unknown frame or plane");
    }
    auto* cost = new ceres::AutoDiffCostFunction<LinePlaneCost, 2, 7, 4>(
        new LinePlaneCost(l.centroid, l.direction, l.sigma));
    // Huber on the line's RMS point distance, weighted by its sample count.
    ceres::LossFunction* loss = new ceres::ScaledLoss(new ceres::HuberLoss(options.huber_m),
                                                      static_cast<double>(l.count), ceres::TAKE_OWNERSHIP);
    problem.AddResidualBlock(cost, loss, pose_blocks[l.frame].data(), plane_blocks[l.plane].data());
    pose_used[l.frame] = true;
    plane_used[l.plane] = true;
    ++blocks;
  }
  if (blocks == 0) return Status::Error("refinement: no assigned lines");
  const MotionPrior* motion = options.motion;
  if (motion != nullptr) {
    if (static_cast<int>(motion->world_from_rig.size()) != num_poses) {
      return Status::Error("refinement: the motion prior has " + std::to_string(motion->world_from_rig.size()) +
                           " poses for " + std::to_string(num_poses));
    }
    for (int i = 1; i < num_poses; ++i) {
      const Rigid3d delta = motion->world_from_rig[i - 1].inverse() * motion->world_from_rig[i];
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RelativeMotionCost, 6, 7, 7>(
                                   new RelativeMotionCost(delta, motion->SqrtInformation(delta))),
                               nullptr, pose_blocks[i - 1].data(), pose_blocks[i].data());
      pose_used[i - 1] = pose_used[i] = true;
    }
    if (motion->abs_tilt_sigma_rad > 0.0 || motion->abs_yaw_sigma_rad > 0.0) {
      const double s_tilt = motion->abs_tilt_sigma_rad > 0.0 ? motion->point_sigma_m / motion->abs_tilt_sigma_rad : 0.0;
      const double s_yaw = motion->abs_yaw_sigma_rad > 0.0 ? motion->point_sigma_m / motion->abs_yaw_sigma_rad : 0.0;
      for (int i = 0; i < num_poses; ++i) {
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<AbsoluteOrientationCost, 3, 7>(
                                     new AbsoluteOrientationCost(motion->world_from_rig[i].rotation(), s_tilt, s_yaw)),
                                 nullptr, pose_blocks[i].data());
      }
    }
  } else if (options.prior_translation_m > 0.0) {
    for (int i = 0; i < num_poses; ++i) {
      if (!pose_used[i]) continue;
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PosePriorCost, 6, 7>(new PosePriorCost(
                                   (*poses)[i].rotation(), (*poses)[i].translation(), options.prior_translation_m,
                                   options.prior_rotation_rad)),
                               nullptr, pose_blocks[i].data());
    }
  }
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (int i = 0; i < num_poses; ++i) {
    if (!pose_used[i]) continue;
    problem.SetManifold(pose_blocks[i].data(), &pose_manifold);
    ordering->AddElementToGroup(pose_blocks[i].data(), 0);  // eliminated (Schur complement)
  }
  for (int j = 0; j < num_planes; ++j) {
    if (!plane_used[j]) continue;
    problem.SetManifold(plane_blocks[j].data(), &plane_manifold);
    ordering->AddElementToGroup(plane_blocks[j].data(), 1);
  }
  // The gauge.
  int fixed = 0;
  if (options.fix_first_pose) {
    if (!pose_used[0]) return Status::Error("refinement: the first pose sees no plane; the gauge is not fixed");
    problem.SetParameterBlockConstant(pose_blocks[0].data());
    ++fixed;
  }
  for (int j : options.fixed_planes) {
    if (j >= 0 && j < num_planes && plane_used[j]) {
      problem.SetParameterBlockConstant(plane_blocks[j].data());
      ++fixed;
    }
  }
  if (fixed == 0) return Status::Error("refinement: no gauge (fix the first pose or the initial planes)");

  ceres::Solver::Options so;
  // Every residual touches one pose and one plane: eliminate the poses
  // (6 x 6 blocks) and solve the small dense system of the planes.
  if (motion != nullptr) {
    so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  } else {
    so.linear_solver_type = ceres::DENSE_SCHUR;
    so.linear_solver_ordering = ordering;
  }
  so.max_num_iterations = options.max_iterations;
  so.num_threads = std::max(1, options.threads);
  so.function_tolerance = 1e-9;
  so.gradient_tolerance = 1e-12;
  so.parameter_tolerance = 1e-10;
  so.logging_type = ceres::SILENT;
  CancelCallback cancel(options.cancel);
  if (options.cancel != nullptr) so.callbacks.push_back(&cancel);
  ceres::Solver::Summary cs;
  ceres::Solve(so, &problem, &cs);
  if (options.cancel != nullptr && options.cancel->load()) return Status::Error("cancelled");
  if (!cs.IsSolutionUsable()) return Status::Error("refinement failed: " + cs.message);

  for (int i = 0; i < num_poses; ++i) {
    if (!pose_used[i]) continue;
    const auto& b = pose_blocks[i];
    (*poses)[i] = Rigid3d({b[4], b[5], b[6]}, Eigen::Quaterniond(b[3], b[0], b[1], b[2]));
  }
  for (int j = 0; j < num_planes; ++j) {
    const auto& b = plane_blocks[j];
    (*planes)[j].normal = Eigen::Vector3d(b[0], b[1], b[2]).normalized();
    (*planes)[j].d = b[3];
  }
  if (summary != nullptr) {
    summary->passes += 1;
    summary->iterations += static_cast<int>(cs.iterations.size());
    if (summary->passes == 1) summary->initial_cost = cs.initial_cost;
    summary->final_cost = cs.final_cost;
    summary->residual_blocks = blocks;
    summary->seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return Status::Ok();
}

}  // namespace sweepscan::sfm
