// The ROS messages sweepscan reads from bags, as plain structs, and the
// interface every bag reader (ROS 1 .bag, ROS 2 sqlite3 and MCAP) streams
// them through. No ROS header appears here: the ROS 1 reader converts from
// rosbag_storage's message classes, the ROS 2 readers decode CDR bytes
// (docs/ros-bags.md), and everything downstream sees only these structs.
//
// Field names, units and conventions are the messages' own
// (sensor_msgs/LaserScan, nav_msgs/Odometry, sensor_msgs/Imu,
// geometry_msgs/TransformStamped in tf2_msgs/TFMessage); quaternions are
// stored x, y, z, w as in the messages. Times are nanoseconds since the Unix
// epoch (ROS 1 `time` = sec + nsec, ROS 2 builtin_interfaces/Time likewise).
//
// Thread: none of its own; a reader calls its sink on the caller's thread.
#ifndef SWEEPSCAN_CORE_IO_ROS_ROS_MESSAGES_H_
#define SWEEPSCAN_CORE_IO_ROS_ROS_MESSAGES_H_

#include <array>
#include <cstdint>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "core/common/status.h"

namespace sweepscan::io {

struct RosHeader {
  int64_t stamp_ns = 0;
  std::string frame_id;
};

// sensor_msgs/LaserScan.
struct RosLaserScan {
  RosHeader header;
  float angle_min = 0.0f;        // rad
  float angle_max = 0.0f;        // rad
  float angle_increment = 0.0f;  // rad between measurements
  float time_increment = 0.0f;   // s between measurements
  float scan_time = 0.0f;        // s between scans
  float range_min = 0.0f;        // m
  float range_max = 0.0f;        // m
  std::vector<float> ranges;       // m
  std::vector<float> intensities;  // device units; empty if the lidar has none
};

// nav_msgs/Odometry: pose in header.frame_id, twist in child_frame_id.
struct RosOdometry {
  RosHeader header;
  std::string child_frame_id;
  std::array<double, 3> position{};                // x, y, z (m)
  std::array<double, 4> orientation{0, 0, 0, 1};   // x, y, z, w
  std::array<double, 36> pose_covariance{};        // row-major 6x6 (x y z rx ry rz)
  std::array<double, 3> linear_velocity{};         // m/s
  std::array<double, 3> angular_velocity{};        // rad/s
  std::array<double, 36> twist_covariance{};       // row-major 6x6
};

// sensor_msgs/Imu. A covariance whose element 0 is -1 means "this quantity is
// not provided" (the message's own convention).
struct RosImu {
  RosHeader header;
  std::array<double, 4> orientation{0, 0, 0, 1};  // x, y, z, w
  std::array<double, 9> orientation_covariance{};
  std::array<double, 3> angular_velocity{};        // rad/s
  std::array<double, 9> angular_velocity_covariance{};
  std::array<double, 3> linear_acceleration{};     // m/s^2
  std::array<double, 9> linear_acceleration_covariance{};
};

// geometry_msgs/TransformStamped: parent = header.frame_id, child = child_frame_id,
// parent_from_child.
struct RosTransform {
  RosHeader header;
  std::string child_frame_id;
  std::array<double, 3> translation{};
  std::array<double, 4> rotation{0, 0, 0, 1};  // x, y, z, w
};

// tf2_msgs/TFMessage.
struct RosTfMessage {
  std::vector<RosTransform> transforms;
};

// The message types sweepscan decodes. Type names are accepted in both
// spellings: ROS 1 "sensor_msgs/LaserScan", ROS 2 "sensor_msgs/msg/LaserScan".
enum class RosMessageKind : uint8_t { kOther = 0, kLaserScan, kOdometry, kImu, kTf };
RosMessageKind RosMessageKindFromType(const std::string& type);
const char* RosMessageKindName(RosMessageKind kind);  // "LaserScan", ..., "other"

// Where a message came from in the bag.
struct RosMessageInfo {
  const std::string* topic = nullptr;
  const std::string* type = nullptr;
  int64_t log_time_ns = 0;  // when the recorder received it (bag time)
};

// Receives decoded messages in log-time order: the ROS 1 reader's View,
// sqlite3's ORDER BY timestamp, MCAP's chunks by their times (only
// messages outside chunks that go back in time keep their file order; the
// MCAP reader counts them). Each
// callback returns false to stop reading (the reader then fails with
// "cancelled").
class RosMessageSink {
 public:
  virtual ~RosMessageSink() = default;
  virtual bool OnLaserScan(const RosMessageInfo& info, const RosLaserScan& m) = 0;
  virtual bool OnOdometry(const RosMessageInfo& info, const RosOdometry& m) = 0;
  virtual bool OnImu(const RosMessageInfo& info, const RosImu& m) = 0;
  // Both /tf and /tf_static (info.topic says which).
  virtual bool OnTf(const RosMessageInfo& info, const RosTfMessage& m) = 0;
  // A message of a decodable type whose bytes could not be decoded: the
  // reader counts and skips it, and tells the sink where and why.
  virtual void OnUndecodable(const RosMessageInfo& info, const std::string& why) {}
};

// One topic (ROS 1: all connections of a topic merged).
struct RosTopicInfo {
  std::string topic;
  std::string type;                 // as stored in the bag
  std::string serialization;        // "ros1", "cdr", ...
  uint64_t message_count = 0;
  int64_t first_ns = 0, last_ns = 0;  // log times; 0 if unknown
  RosMessageKind kind() const { return RosMessageKindFromType(type); }
};

// What a bag holds, without decoding its messages.
struct RosBagSummary {
  // Whether `t`'s messages can be decoded here: a decodable type in the
  // encoding this format's reader reads (ROS 1 serialisation in a ROS 1 bag,
  // CDR in MCAP and sqlite3; an MCAP converted from a ROS 1 bag keeps "ros1").
  bool Decodable(const RosTopicInfo& t) const {
    return t.kind() != RosMessageKind::kOther &&
           t.serialization == (format == "rosbag1" ? "ros1" : "cdr");
  }
  std::string format;       // "rosbag1", "rosbag2-sqlite3", "mcap"
  std::string compression;  // "none", "bz2", "lz4", "zstd", or a list "lz4,zstd"
  uint64_t file_bytes = 0;
  uint64_t message_count = 0;
  int64_t start_ns = 0, end_ns = 0;  // log times of the first and last message
  std::vector<RosTopicInfo> topics;  // sorted by topic name
  // The summary's own index met damage (an MCAP summary whose CRC or
  // offsets fail: described by scanning the file instead, its warning says
  // so); `info --strict` refuses it as it refuses damaged messages.
  bool damaged = false;
};

struct RosReadOptions {
  // Topics to decode and hand to the sink; empty = every topic of a
  // decodable type. Messages of other topics are skipped undecoded.
  std::set<std::string> topics;
  // Progress 0..1 by bytes read; return false to cancel.
  std::function<bool(double)> progress;
};

// Counters a reader fills while reading.
struct RosReadStats {
  uint64_t messages_read = 0;         // handed to the sink
  uint64_t messages_skipped = 0;      // other topics or types
  uint64_t messages_undecodable = 0;  // decodable type, bad bytes (sink told)
  uint64_t bytes_read = 0;
  // What the reader noticed and read past (a file cut short, a damaged
  // summary, messages back in time), each once however often it was read.
  std::vector<std::string> warnings;
  // Whether any of them tells of damage read past (a torn file, a damaged
  // database or summary), not of an intact file's quirks.
  bool damaged = false;
};

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROS_ROS_MESSAGES_H_
