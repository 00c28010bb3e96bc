#include "core/robot/robot_model.h"

namespace sweepscan {

bool RobotGeometry::IsValid(std::string* error) const {
  if (!std::isfinite(lidar_height_m) || !std::isfinite(lidar_offset_x_m) ||
      !std::isfinite(imu_offset_x_m) || !std::isfinite(wheel_distance_m) ||
      !std::isfinite(lidar_offset_y_m) || !lidar_mount.coeffs().allFinite()) {
    *error = "robot geometry must be finite";
    return false;
  }
  // h may be 0 or below for another robot's lidar (a ROS bag's base_link
  // at the lidar's height or above it); sweepscan's own sessions and
  // scenarios check h > 0 when they read it.
  if (wheel_distance_m <= 0.0) {
    *error = "robot geometry: wheel_distance_m must be > 0";
    return false;
  }
  if (std::abs(lidar_mount.norm() - 1.0) > 1e-6) {
    *error = "robot geometry: the lidar's nominal mount rotation must be a unit quaternion";
    return false;
  }
  return true;
}

}  // namespace sweepscan
