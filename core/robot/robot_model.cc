#include "core/robot/robot_model.h"

namespace sweepscan {

bool RobotGeometry::IsValid(std::string* error) const {
  if (!std::isfinite(lidar_height_m) || !std::isfinite(lidar_offset_x_m) ||
      !std::isfinite(imu_offset_x_m) || !std::isfinite(wheel_distance_m)) {
    *error = "robot geometry must be finite";
    return false;
  }
  if (lidar_height_m <= 0.0 || wheel_distance_m <= 0.0) {
    *error = "robot geometry: lidar_height_m and wheel_distance_m must be > 0";
    return false;
  }
  return true;
}

}  // namespace sweepscan
