// Writes a sweepscan result back into the ROS world as a ROS 1 bag that
// `rosbag info`, rosbag's Python reader and RViz read (docs/ros-bags.md,
// "Back to ROS"), with Debian's rosbag_storage itself:
//   /sweepscan/cloud  sensor_msgs/PointCloud2, one message: the assembled
//                     cloud, fields x y z intensity (float32) and time
//                     (float64, s since the epoch), in `frame_id`;
//   /sweepscan/path   nav_msgs/Path, one message: the poses the cloud was
//                     made with;
// both stamped at the cloud's last sample. The bag is written to a
// temporary name beside `path` and renamed into place only when complete.
//
// Pure function; any thread.
#ifndef SWEEPSCAN_CORE_IO_ROSBAG1_ROSBAG1_WRITER_H_
#define SWEEPSCAN_CORE_IO_ROSBAG1_ROSBAG1_WRITER_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/status.h"

namespace sweepscan::io {

struct RosExportPoint {
  float x = 0, y = 0, z = 0, intensity = 0;
  int64_t time_ns = 0;  // since the epoch
};

struct RosExportPose {
  int64_t time_ns = 0;                         // since the epoch
  std::array<double, 3> position{};            // m
  std::array<double, 4> orientation{0, 0, 0, 1};  // x, y, z, w
};

struct RosExport {
  std::string frame_id = "odom";
  std::vector<RosExportPoint> points;
  std::vector<RosExportPose> poses;
};

Status WriteRosbag1Export(const std::string& path, const RosExport& data);

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROSBAG1_ROSBAG1_WRITER_H_
