// Wheel odometry, the paper's Eq. 2-5, integrated with the midpoint rule.
//
// With v and w from the wheel speeds (Eq. 2-3) held over dt, the pose
// recurrence is (Eq. 4-5, midpoint form, exact for the straight line and
// second-order accurate on arcs):
//   x_{k+1}   = x_k + v dt cos(psi_k + w dt / 2)
//   y_{k+1}   = y_k + v dt sin(psi_k + w dt / 2)
//   psi_{k+1} = psi_k + w dt
#ifndef SWEEPSCAN_CORE_POSE_ODOMETRY_H_
#define SWEEPSCAN_CORE_POSE_ODOMETRY_H_

#include <cmath>

#include "core/common/time.h"
#include "core/robot/robot_model.h"
#include "core/robot/sensor_data.h"

namespace sweepscan {

struct Pose2d {
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;
};

inline Pose2d IntegrateMidpoint(const Pose2d& p, const Twist2d& t, double dt) {
  const double heading = p.yaw + 0.5 * t.w * dt;
  return {p.x + t.v * dt * std::cos(heading), p.y + t.v * dt * std::sin(heading),
          WrapAngle(p.yaw + t.w * dt)};
}

// Exact pose after holding (v, w) for dt (an arc, or a line when w = 0).
// Used by the simulator for ground truth and by tests.
inline Pose2d IntegrateExact(const Pose2d& p, const Twist2d& t, double dt) {
  const double dpsi = t.w * dt;
  if (std::abs(dpsi) < 1e-9) return IntegrateMidpoint(p, t, dt);
  const double r = t.v / t.w;
  return {p.x + r * (std::sin(p.yaw + dpsi) - std::sin(p.yaw)),
          p.y - r * (std::cos(p.yaw + dpsi) - std::cos(p.yaw)), WrapAngle(p.yaw + dpsi)};
}

// Dead reckoning from wheel speeds alone. Lives on one thread.
class WheelOdometry {
 public:
  explicit WheelOdometry(double wheel_distance_m) : wheel_distance_m_(wheel_distance_m) {}

  void Reset(Time time, const Pose2d& pose) {
    time_ = time;
    pose_ = pose;
    initialized_ = true;
  }
  // Each measurement is the average speed over (previous time, m.time].
  void Add(const WheelSpeedMeasurement& m) {
    if (!initialized_) {
      Reset(m.time, Pose2d());
      return;
    }
    const double dt = ToSeconds(m.time - time_);
    if (dt <= 0.0) return;
    pose_ = IntegrateMidpoint(pose_, TwistFromWheels(m.left_mps, m.right_mps, wheel_distance_m_), dt);
    time_ = m.time;
  }
  const Pose2d& pose() const { return pose_; }
  Time time() const { return time_; }
  bool initialized() const { return initialized_; }

 private:
  double wheel_distance_m_;
  Time time_;
  Pose2d pose_;
  bool initialized_ = false;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_POSE_ODOMETRY_H_
