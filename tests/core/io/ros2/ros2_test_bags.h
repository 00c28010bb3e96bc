// The known content of the ROS 2 test bags in tests/data/ros2/, written by
// make_ros2_bags.mjs (independent writers; see tests/data/ros2/README.md).
// The formulas here mirror the script's: same IEEE operations on the same
// constants, so the expected values are bit-identical to what was written.
// Plus a sink that records what a reader hands it.
#ifndef SWEEPSCAN_TESTS_CORE_IO_ROS2_ROS2_TEST_BAGS_H_
#define SWEEPSCAN_TESTS_CORE_IO_ROS2_ROS2_TEST_BAGS_H_

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "core/io/ros/ros_messages.h"

namespace sweepscan::io::testing {

inline std::string Ros2Data(const std::string& name) {
  return std::string(SWEEPSCAN_SOURCE_DIR) + "/tests/data/ros2/" + name;
}

// An MCAP file's top-level records, walked test-side (opcode u8, length
// u64 LE, content), up to the Footer.
struct McapRecord {
  uint8_t op;
  size_t pos, len;  // len: content bytes
};
inline std::vector<McapRecord> McapRecords(const std::vector<uint8_t>& b) {
  std::vector<McapRecord> r;
  for (size_t pos = 8; pos + 9 <= b.size();) {
    uint64_t len;
    std::memcpy(&len, b.data() + pos + 1, 8);
    r.push_back({b[pos], pos, static_cast<size_t>(len)});
    if (b[pos] == 0x02) break;  // Footer
    pos += 9 + len;
  }
  return r;
}

inline std::vector<uint8_t> ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in.good()) << path;
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}

constexpr int64_t kBaseNs = int64_t{1700000000} * 1000000000;
constexpr int64_t kLatencyNs = 2000000;  // log time = header stamp + 2 ms
// /tf_static is logged 1 ms before the first scan (no two messages share a log time).
constexpr int64_t kTfStaticLogNs = kBaseNs + kLatencyNs - 1000000;
constexpr int kScans = 20, kOdoms = 10, kImus = 10, kTfs = 5, kChatters = 3;
constexpr int kMessages = kScans + kOdoms + kImus + kTfs + 1 + kChatters;  // 49

inline int64_t ScanStampNs(int k) { return kBaseNs + int64_t{k} * 100000000; }
inline int64_t OdomStampNs(int k) { return kBaseNs + int64_t{k} * 200000000 + 50000000; }
inline int64_t ImuStampNs(int k) { return kBaseNs + int64_t{k} * 200000000 + 10000000; }
inline int64_t TfStampNs(int k) { return kBaseNs + int64_t{k} * 400000000 + 30000000; }

inline RosLaserScan ExpectedScan(int k) {
  RosLaserScan m;
  const int n = 9 + k;
  m.header.stamp_ns = ScanStampNs(k);
  m.header.frame_id = "laser";
  m.angle_min = -1.0f;
  m.angle_max = static_cast<float>(-1 + (n - 1) * 0.125);
  m.angle_increment = 0.125f;
  m.time_increment = static_cast<float>(0.0001);
  m.scan_time = static_cast<float>(0.1);
  m.range_min = static_cast<float>(0.05);
  m.range_max = 12.0f;
  for (int i = 0; i < n; ++i) m.ranges.push_back(static_cast<float>(1 + 0.25 * i + 0.5 * k));
  if (k % 5 != 4) {
    for (int i = 0; i < n; ++i) m.intensities.push_back(static_cast<float>(10 * i + k));
  }
  if (k == 3) {
    m.ranges[0] = std::numeric_limits<float>::infinity();
    m.ranges[1] = std::numeric_limits<float>::quiet_NaN();
  }
  return m;
}

inline RosOdometry ExpectedOdom(int k) {
  RosOdometry m;
  m.header.stamp_ns = OdomStampNs(k);
  m.header.frame_id = "odom";
  m.child_frame_id = "base_link";
  m.position = {0.5 * k, -0.25 * k, 0.125};
  m.orientation = k % 2 ? std::array<double, 4>{0, 0, 0.6, 0.8} : std::array<double, 4>{0, 0, 0, 1};
  for (int i = 0; i < 36; ++i) m.pose_covariance[i] = 0.001 * i + k;
  m.linear_velocity = {0.25 + 0.01 * k, 0, 0};
  m.angular_velocity = {0, 0, -0.125 * k};
  for (int i = 0; i < 36; ++i) m.twist_covariance[i] = 0.002 * i - k;
  return m;
}

inline RosImu ExpectedImu(int k) {
  RosImu m;
  m.header.stamp_ns = ImuStampNs(k);
  m.header.frame_id = "imu_link";
  m.orientation = {0.1 * k, 0.2, 0.3, 0.9};
  for (int i = 0; i < 9; ++i) {
    m.orientation_covariance[i] = k % 2 ? (i == 0 ? -1 : 0) : 0.01 * (i + 1);
    m.angular_velocity_covariance[i] = 0.0001 * i;
    m.linear_acceleration_covariance[i] = 0.001 * i;
  }
  m.angular_velocity = {0.01 * k, -0.02 * k, 0.03 * k};
  m.linear_acceleration = {0.1, 0.2, 9.81};
  return m;
}

inline RosTfMessage ExpectedTfStatic() {
  RosTfMessage m;
  m.transforms.resize(2);
  m.transforms[0].header = {kBaseNs, "base_link"};
  m.transforms[0].child_frame_id = "laser";
  m.transforms[0].translation = {0.1, 0, 0.2};
  m.transforms[0].rotation = {0, 0, 0, 1};
  m.transforms[1].header = {kBaseNs, "base_link"};
  m.transforms[1].child_frame_id = "imu_link";
  m.transforms[1].translation = {-0.05, 0.01, 0.1};
  m.transforms[1].rotation = {0, 0, 0.7071067811865476, 0.7071067811865476};
  return m;
}

inline RosTfMessage ExpectedTf(int k) {
  RosTfMessage m;
  m.transforms.resize(1);
  m.transforms[0].header = {TfStampNs(k), "odom"};
  m.transforms[0].child_frame_id = "base_link";
  m.transforms[0].translation = {0.5 * k, -0.25 * k, 0};
  m.transforms[0].rotation = {0, 0, 0, 1};
  return m;
}

// Field-for-field comparisons (exact: the values are bit-identical; NaN
// matches NaN).
inline void ExpectSameFloats(const std::vector<float>& a, const std::vector<float>& b,
                             const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::isnan(b[i])) {
      EXPECT_TRUE(std::isnan(a[i])) << what << "[" << i << "]";
    } else {
      EXPECT_EQ(a[i], b[i]) << what << "[" << i << "]";
    }
  }
}

inline void ExpectScan(const RosLaserScan& a, const RosLaserScan& b) {
  EXPECT_EQ(a.header.stamp_ns, b.header.stamp_ns);
  EXPECT_EQ(a.header.frame_id, b.header.frame_id);
  EXPECT_EQ(a.angle_min, b.angle_min);
  EXPECT_EQ(a.angle_max, b.angle_max);
  EXPECT_EQ(a.angle_increment, b.angle_increment);
  EXPECT_EQ(a.time_increment, b.time_increment);
  EXPECT_EQ(a.scan_time, b.scan_time);
  EXPECT_EQ(a.range_min, b.range_min);
  EXPECT_EQ(a.range_max, b.range_max);
  ExpectSameFloats(a.ranges, b.ranges, "ranges");
  ExpectSameFloats(a.intensities, b.intensities, "intensities");
}

inline void ExpectOdom(const RosOdometry& a, const RosOdometry& b) {
  EXPECT_EQ(a.header.stamp_ns, b.header.stamp_ns);
  EXPECT_EQ(a.header.frame_id, b.header.frame_id);
  EXPECT_EQ(a.child_frame_id, b.child_frame_id);
  EXPECT_EQ(a.position, b.position);
  EXPECT_EQ(a.orientation, b.orientation);
  EXPECT_EQ(a.pose_covariance, b.pose_covariance);
  EXPECT_EQ(a.linear_velocity, b.linear_velocity);
  EXPECT_EQ(a.angular_velocity, b.angular_velocity);
  EXPECT_EQ(a.twist_covariance, b.twist_covariance);
}

inline void ExpectImu(const RosImu& a, const RosImu& b) {
  EXPECT_EQ(a.header.stamp_ns, b.header.stamp_ns);
  EXPECT_EQ(a.header.frame_id, b.header.frame_id);
  EXPECT_EQ(a.orientation, b.orientation);
  EXPECT_EQ(a.orientation_covariance, b.orientation_covariance);
  EXPECT_EQ(a.angular_velocity, b.angular_velocity);
  EXPECT_EQ(a.angular_velocity_covariance, b.angular_velocity_covariance);
  EXPECT_EQ(a.linear_acceleration, b.linear_acceleration);
  EXPECT_EQ(a.linear_acceleration_covariance, b.linear_acceleration_covariance);
}

inline void ExpectTf(const RosTfMessage& a, const RosTfMessage& b) {
  ASSERT_EQ(a.transforms.size(), b.transforms.size());
  for (size_t i = 0; i < a.transforms.size(); ++i) {
    const RosTransform &x = a.transforms[i], &y = b.transforms[i];
    EXPECT_EQ(x.header.stamp_ns, y.header.stamp_ns) << i;
    EXPECT_EQ(x.header.frame_id, y.header.frame_id) << i;
    EXPECT_EQ(x.child_frame_id, y.child_frame_id) << i;
    EXPECT_EQ(x.translation, y.translation) << i;
    EXPECT_EQ(x.rotation, y.rotation) << i;
  }
}

// Keeps everything a reader hands over, in order.
class RecordingSink : public RosMessageSink {
 public:
  struct Entry {
    std::string topic, type;
    int64_t log_time_ns;
  };
  bool OnLaserScan(const RosMessageInfo& info, const RosLaserScan& m) override {
    scans.push_back(m);
    return Note(info);
  }
  bool OnOdometry(const RosMessageInfo& info, const RosOdometry& m) override {
    odoms.push_back(m);
    return Note(info);
  }
  bool OnImu(const RosMessageInfo& info, const RosImu& m) override {
    imus.push_back(m);
    return Note(info);
  }
  bool OnTf(const RosMessageInfo& info, const RosTfMessage& m) override {
    (*info.topic == "/tf_static" ? tf_static : tfs).push_back(m);
    return Note(info);
  }
  void OnUndecodable(const RosMessageInfo& info, const std::string& why) override {
    undecodable.push_back(*info.topic + ": " + why);
  }

  std::vector<Entry> order;
  std::vector<RosLaserScan> scans;
  std::vector<RosOdometry> odoms;
  std::vector<RosImu> imus;
  std::vector<RosTfMessage> tfs, tf_static;
  std::vector<std::string> undecodable;
  size_t stop_after = SIZE_MAX;  // return false after this many messages

 private:
  bool Note(const RosMessageInfo& info) {
    order.push_back({*info.topic, *info.type, info.log_time_ns});
    return order.size() < stop_after;
  }
};

// Every known message, field for field, and the log-time order.
inline void ExpectAllKnownMessages(const RecordingSink& sink) {
  ASSERT_EQ(sink.scans.size(), size_t{kScans});
  ASSERT_EQ(sink.odoms.size(), size_t{kOdoms});
  ASSERT_EQ(sink.imus.size(), size_t{kImus});
  ASSERT_EQ(sink.tfs.size(), size_t{kTfs});
  ASSERT_EQ(sink.tf_static.size(), 1u);
  for (int k = 0; k < kScans; ++k) ExpectScan(sink.scans[k], ExpectedScan(k));
  for (int k = 0; k < kOdoms; ++k) ExpectOdom(sink.odoms[k], ExpectedOdom(k));
  for (int k = 0; k < kImus; ++k) ExpectImu(sink.imus[k], ExpectedImu(k));
  for (int k = 0; k < kTfs; ++k) ExpectTf(sink.tfs[k], ExpectedTf(k));
  ExpectTf(sink.tf_static[0], ExpectedTfStatic());
  EXPECT_TRUE(sink.undecodable.empty());
  for (size_t i = 1; i < sink.order.size(); ++i) {
    EXPECT_LE(sink.order[i - 1].log_time_ns, sink.order[i].log_time_ns) << i;
  }
  ASSERT_FALSE(sink.order.empty());
  EXPECT_EQ(sink.order.front().topic, "/tf_static");
  EXPECT_EQ(sink.order.front().type, "tf2_msgs/msg/TFMessage");
  EXPECT_EQ(sink.order.front().log_time_ns, kTfStaticLogNs);
}

}  // namespace sweepscan::io::testing

#endif  // SWEEPSCAN_TESTS_CORE_IO_ROS2_ROS2_TEST_BAGS_H_
