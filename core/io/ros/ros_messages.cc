#include "core/io/ros/ros_messages.h"

namespace sweepscan::io {

RosMessageKind RosMessageKindFromType(const std::string& type) {
  // ROS 2 spells "pkg/msg/Name", ROS 1 "pkg/Name".
  std::string t = type;
  const std::string::size_type msg = t.find("/msg/");
  if (msg != std::string::npos) t.erase(msg, 4);
  if (t == "sensor_msgs/LaserScan") return RosMessageKind::kLaserScan;
  if (t == "nav_msgs/Odometry") return RosMessageKind::kOdometry;
  if (t == "sensor_msgs/Imu") return RosMessageKind::kImu;
  if (t == "tf2_msgs/TFMessage" || t == "tf/tfMessage") return RosMessageKind::kTf;
  return RosMessageKind::kOther;
}

const char* RosMessageKindName(RosMessageKind kind) {
  switch (kind) {
    case RosMessageKind::kLaserScan: return "LaserScan";
    case RosMessageKind::kOdometry: return "Odometry";
    case RosMessageKind::kImu: return "Imu";
    case RosMessageKind::kTf: return "TFMessage";
    case RosMessageKind::kOther: break;
  }
  return "other";
}

}  // namespace sweepscan::io
