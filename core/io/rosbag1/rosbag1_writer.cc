#include "core/io/rosbag1/rosbag1_writer.h"

#include <nav_msgs/Path.h>
#include <rosbag/bag.h>
#include <sensor_msgs/PointCloud2.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include "core/common/checked_file.h"

namespace sweepscan::io {
namespace {

ros::Time Stamp(int64_t ns) {
  ros::Time t;
  t.fromNSec(static_cast<uint64_t>(ns));
  return t;
}

sensor_msgs::PointField Field(const char* name, uint32_t offset, uint8_t type) {
  sensor_msgs::PointField f;
  f.name = name;
  f.offset = offset;
  f.datatype = type;
  f.count = 1;
  return f;
}

}  // namespace

Status WriteRosbag1Export(const std::string& path, const RosExport& data) {
  if (data.points.empty() && data.poses.empty()) return Status::Error(path + ": nothing to write");
  // One PointCloud2 holds them all; its row_step is a uint32 (and a ROS 1
  // record's length too): 24 bytes a point reach 4 GiB at 178 956 971.
  constexpr size_t kMaxPoints = (size_t{1} << 32) / 24 - 1;
  if (data.points.size() > kMaxPoints) {
    return Status::Error(path + ": " + std::to_string(data.points.size()) +
                         " points do not fit one ROS 1 PointCloud2 (at most " +
                         std::to_string(kMaxPoints) + ")");
  }
  int64_t last = 0;
  for (const RosExportPoint& p : data.points) last = std::max(last, p.time_ns);
  for (const RosExportPose& p : data.poses) last = std::max(last, p.time_ns);
  const ros::Time stamp = Stamp(last);

  // x y z intensity (4 x float32) and time (float64): 24 bytes a point,
  // the time aligned to 8 bytes as PCL's PointXYZI-with-time layouts do.
  sensor_msgs::PointCloud2 cloud;
  cloud.header.stamp = stamp;
  cloud.header.frame_id = data.frame_id;
  cloud.height = 1;
  cloud.width = static_cast<uint32_t>(data.points.size());
  using PF = sensor_msgs::PointField;
  cloud.fields = {Field("x", 0, PF::FLOAT32), Field("y", 4, PF::FLOAT32), Field("z", 8, PF::FLOAT32),
                  Field("intensity", 12, PF::FLOAT32), Field("time", 16, PF::FLOAT64)};
  cloud.is_bigendian = false;
  cloud.point_step = 24;
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.is_dense = true;
  cloud.data.resize(static_cast<size_t>(cloud.row_step));
  uint8_t* out = cloud.data.data();
  for (const RosExportPoint& p : data.points) {
    const float xyzi[4] = {p.x, p.y, p.z, p.intensity};
    const double t = static_cast<double>(p.time_ns) * 1e-9;
    std::memcpy(out, xyzi, 16);
    std::memcpy(out + 16, &t, 8);
    out += 24;
  }

  nav_msgs::Path trajectory;
  trajectory.header.stamp = stamp;
  trajectory.header.frame_id = data.frame_id;
  trajectory.poses.reserve(data.poses.size());
  for (const RosExportPose& p : data.poses) {
    geometry_msgs::PoseStamped s;
    s.header.stamp = Stamp(p.time_ns);
    s.header.frame_id = data.frame_id;
    s.pose.position.x = p.position[0];
    s.pose.position.y = p.position[1];
    s.pose.position.z = p.position[2];
    s.pose.orientation.x = p.orientation[0];
    s.pose.orientation.y = p.orientation[1];
    s.pose.orientation.z = p.orientation[2];
    s.pose.orientation.w = p.orientation[3];
    trajectory.poses.push_back(s);
  }

  const std::string tmp = TemporaryPathFor(path);
  auto bag = std::make_unique<rosbag::Bag>();
  try {
    bag->open(tmp, rosbag::bagmode::Write);
    bag->setCompression(rosbag::compression::LZ4);
    if (!data.points.empty()) bag->write("/sweepscan/cloud", stamp, cloud);
    if (!data.poses.empty()) bag->write("/sweepscan/path", stamp, trajectory);
    bag->close();
  } catch (const std::exception& e) {
    // A bag whose writes failed (a full disk) is let go unclosed: ~Bag
    // closes it again, that close's writes fail too, and an exception out
    // of a destructor is std::terminate. Its descriptor lives until the
    // process ends (the CLI's next step is to exit); the file is unlinked.
    (void)bag.release();
    std::remove(tmp.c_str());
    return Status::Error(path + ": cannot write the ROS 1 bag: " + e.what());
  }
  // rosbag reports no fsync; a rename makes the bag appear whole or not at all.
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    std::remove(tmp.c_str());
    return Status::Error(path + ": cannot rename the written bag into place: " + why);
  }
  return Status::Ok();
}

}  // namespace sweepscan::io
