// The Laser -> Body -> World model of Miao et al. 2022 (section 2).
//
// Frames (all right-handed, SI units):
//  * world W: fixed; z up, floor at z = 0 in the simulated scenes.
//  * body B: origin at the robot's centre of motion (midpoint of the wheel
//    axle) on the floor plane; x forward, y left, z up. The paper's "body xOy
//    plane" is the floor plane under the robot.
//  * lidar L: origin at the X4's optical centre. The scan plane is L's y-z
//    plane and x_L is its normal. With a perfect mount L is parallel to B:
//    the scan plane is vertical and perpendicular to the direction of travel.
//  * imu I: axes parallel to B, offset l2 along x_B. A rate gyro reads the
//    same angular velocity anywhere on a rigid body, so l2 only matters for
//    accelerometers, which the pose filter does not use.
//
// Lidar sample (the paper's Eq. 1, scan angle measured from the vertical,
// its Fig. 2): range rho and scan angle theta, theta = 0 straight up (+z_L),
// increasing towards +y_L (robot left):
//   p_L = (0, rho * sin(theta), rho * cos(theta)).
//
// Mount (Eq. 11-14): body_from_lidar = [R | t] with t = (l1, 0, h) and the
// mounting error as three small angles, alpha about z, beta about y, gamma
// about x, composed as (Eq. 13)
//   R = Rz(alpha) * Ry(beta) * Rx(gamma).
// gamma tilts the scan within its own plane (the cloud leans sideways), beta
// pitches the scan plane forwards, alpha yaws it away from perpendicular to
// the travel direction.
//
// Other robots (a ROS bag's tf tree, docs/ros-bags.md) mount their lidar
// elsewhere: a nominal mount rotation N (body_from_lidar as drawn, identity
// for sweepscan's own robot) and a sideways offset l_y. The mounting error
// stays in the body frame, applied on top of the nominal mount:
//   body_from_lidar = [R(alpha, beta, gamma) * N | (l1, l_y, h)],
// so the three angles mean the same for every robot: how far the real scan
// plane is turned from the drawn one, about the body's axes.
#ifndef SWEEPSCAN_CORE_ROBOT_ROBOT_MODEL_H_
#define SWEEPSCAN_CORE_ROBOT_ROBOT_MODEL_H_

#include <cmath>
#include <string>

#include "core/geometry/transform.h"

namespace sweepscan {

struct RobotGeometry {
  double lidar_height_m = 0.40;    // h: lidar optical centre above the body xOy plane.
  double lidar_offset_x_m = 0.10;  // l1: lidar ahead of the centre of motion.
  double imu_offset_x_m = 0.05;    // l2: IMU ahead of the centre of motion.
  double wheel_distance_m = 0.15;  // wheel contact point to the centre of motion (half the track).
  double lidar_offset_y_m = 0.0;   // l_y: lidar left of the centre of motion (0 on sweepscan's robot).
  // N: the nominal body_from_lidar rotation (identity: L parallel to B).
  Eigen::Quaterniond lidar_mount = Eigen::Quaterniond::Identity();

  // True when N is the identity to the last bit (sweepscan's own robot):
  // then no product with N is formed, so native sessions compute exactly
  // what they computed before N existed.
  bool HasNominalMountRotation() const {
    return !(lidar_mount.w() == 1.0 && lidar_mount.x() == 0.0 && lidar_mount.y() == 0.0 &&
             lidar_mount.z() == 0.0);
  }
  // N * p: a lidar-frame point in the nominal mount's axes (parallel to B).
  Eigen::Vector3d NominalFromLidar(const Eigen::Vector3d& p_lidar) const {
    return HasNominalMountRotation() ? Eigen::Vector3d(lidar_mount * p_lidar) : p_lidar;
  }
  Eigen::Vector3d LidarTranslation() const {
    return {lidar_offset_x_m, lidar_offset_y_m, lidar_height_m};
  }

  bool IsValid(std::string* error) const;
};

// The three mounting-error angles of the paper (radians).
struct MountingError {
  double alpha = 0.0;  // about z
  double beta = 0.0;   // about y
  double gamma = 0.0;  // about x
};

// How a raw X4 angle (degrees, clockwise seen from the lidar's top, as the
// device reports it) maps to the scan angle theta of Eq. 1:
//   theta = sign * deg2rad(x4_angle_deg) + offset_rad.
// Default: the X4 is mounted with its top facing forward (+x_B) and its 0 deg
// mark pointing up; seen from its top (from in front of the robot), clockwise
// runs from up towards the robot's left, i.e. towards +y_L, so sign = +1 and
// offset = 0.
struct LidarAngleConvention {
  int sign = +1;
  double offset_rad = 0.0;

  double ThetaFromX4Degrees(double x4_angle_deg) const {
    return sign * x4_angle_deg * (M_PI / 180.0) + offset_rad;
  }
  double X4DegreesFromTheta(double theta) const {
    double deg = (theta - offset_rad) * (180.0 / M_PI) * sign;
    deg = std::fmod(deg, 360.0);
    return deg < 0.0 ? deg + 360.0 : deg;
  }
};

// Eq. 1.
inline Eigen::Vector3d LidarPoint(double range_m, double theta) {
  return {0.0, range_m * std::sin(theta), range_m * std::cos(theta)};
}

// Eq. 13: R = Rz(alpha) Ry(beta) Rx(gamma).
inline Eigen::Quaterniond MountingRotation(const MountingError& e) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(e.alpha, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(e.beta, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(e.gamma, Eigen::Vector3d::UnitX()));
}

inline Rigid3d BodyFromLidar(const RobotGeometry& g, const MountingError& e) {
  if (!g.HasNominalMountRotation()) return Rigid3d(g.LidarTranslation(), MountingRotation(e));
  return Rigid3d(g.LidarTranslation(), (MountingRotation(e) * g.lidar_mount).normalized());
}

// Differential drive (Eq. 2-3): v = (v_r + v_l) / 2, w = (v_r - v_l) / (2 d),
// d = wheel_distance (wheel to centre).
struct Twist2d {
  double v = 0.0;  // m/s along x_B
  double w = 0.0;  // rad/s about z_B
};
inline Twist2d TwistFromWheels(double left_mps, double right_mps, double wheel_distance_m) {
  return {0.5 * (right_mps + left_mps), (right_mps - left_mps) / (2.0 * wheel_distance_m)};
}
inline void WheelsFromTwist(const Twist2d& t, double wheel_distance_m, double* left_mps,
                            double* right_mps) {
  *left_mps = t.v - t.w * wheel_distance_m;
  *right_mps = t.v + t.w * wheel_distance_m;
}

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_ROBOT_ROBOT_MODEL_H_
