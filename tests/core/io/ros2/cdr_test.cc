// CDR decoding of the four ROS 2 messages against bytes written by
// @foxglove/rosmsg2-serialization (little-endian) and @foxglove/cdr
// (big-endian), tests/data/ros2/cdr/ (make_ros2_bags.mjs).
#include "core/io/ros2/cdr.h"

#include <gtest/gtest.h>

#include <cstring>

#include "tests/core/io/ros2/ros2_test_bags.h"

namespace sweepscan::io {
namespace {

using testing::ExpectedImu;
using testing::ExpectedOdom;
using testing::ExpectedScan;
using testing::ExpectedTfStatic;
using testing::ReadBytes;
using testing::Ros2Data;

std::vector<uint8_t> Sample(const std::string& name) { return ReadBytes(Ros2Data("cdr/" + name)); }

void PutU32Le(std::vector<uint8_t>* b, size_t at, uint32_t v) { memcpy(b->data() + at, &v, 4); }

TEST(CdrTest, LittleEndianSamplesDecodeFieldForField) {
  std::vector<uint8_t> b = Sample("laserscan_le.cdr");
  RosLaserScan scan;
  Status s = DecodeCdrLaserScan(b.data(), b.size(), &scan);
  ASSERT_TRUE(s.ok()) << s.message();
  testing::ExpectScan(scan, ExpectedScan(3));  // with an inf and a NaN range

  b = Sample("odometry_le.cdr");
  RosOdometry odom;
  s = DecodeCdrOdometry(b.data(), b.size(), &odom);
  ASSERT_TRUE(s.ok()) << s.message();
  testing::ExpectOdom(odom, ExpectedOdom(1));

  b = Sample("imu_le.cdr");
  RosImu imu;
  s = DecodeCdrImu(b.data(), b.size(), &imu);
  ASSERT_TRUE(s.ok()) << s.message();
  testing::ExpectImu(imu, ExpectedImu(2));

  b = Sample("tf_le.cdr");
  RosTfMessage tf;
  s = DecodeCdrTfMessage(b.data(), b.size(), &tf);
  ASSERT_TRUE(s.ok()) << s.message();
  testing::ExpectTf(tf, ExpectedTfStatic());
}

TEST(CdrTest, BigEndianSamplesDecodeFieldForField) {
  std::vector<uint8_t> b = Sample("laserscan_be.cdr");
  ASSERT_EQ(b[1], 0x00);  // CDR_BE
  RosLaserScan scan;
  Status s = DecodeCdrLaserScan(b.data(), b.size(), &scan);
  ASSERT_TRUE(s.ok()) << s.message();
  testing::ExpectScan(scan, ExpectedScan(7));

  b = Sample("odometry_be.cdr");
  RosOdometry odom;
  s = DecodeCdrOdometry(b.data(), b.size(), &odom);
  ASSERT_TRUE(s.ok()) << s.message();
  testing::ExpectOdom(odom, ExpectedOdom(3));

  b = Sample("imu_be.cdr");
  RosImu imu;
  s = DecodeCdrImu(b.data(), b.size(), &imu);
  ASSERT_TRUE(s.ok()) << s.message();
  testing::ExpectImu(imu, ExpectedImu(1));
  EXPECT_EQ(imu.orientation_covariance[0], -1.0);  // "no orientation"

  b = Sample("tf_be.cdr");
  RosTfMessage tf;
  s = DecodeCdrTfMessage(b.data(), b.size(), &tf);
  ASSERT_TRUE(s.ok()) << s.message();
  testing::ExpectTf(tf, ExpectedTfStatic());
}

// The worked example of docs/ros-bags.md: where each field of
// laserscan_le.cdr sits.
TEST(CdrTest, LaserScanByteOffsetsAsDocumented) {
  const std::vector<uint8_t> b = Sample("laserscan_le.cdr");
  ASSERT_EQ(b.size(), 156u);
  auto u32 = [&](size_t at) {
    uint32_t v;
    memcpy(&v, b.data() + at, 4);
    return v;
  };
  auto f32 = [&](size_t at) {
    float v;
    memcpy(&v, b.data() + at, 4);
    return v;
  };
  EXPECT_EQ(b[0], 0x00);
  EXPECT_EQ(b[1], 0x01);           // CDR_LE
  EXPECT_EQ(u32(4), 1700000000u);  // stamp.sec
  EXPECT_EQ(u32(8), 300000000u);   // stamp.nanosec
  EXPECT_EQ(u32(12), 6u);          // strlen("laser") + NUL
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(b.data() + 16)), "laser");
  EXPECT_EQ(f32(24), -1.0f);         // angle_min after 2 bytes of padding
  EXPECT_EQ(f32(48), 12.0f);         // range_max
  EXPECT_EQ(u32(52), 12u);           // ranges count
  EXPECT_EQ(f32(56 + 4 * 2), 3.0f);  // ranges[2] = 1 + 0.25 * 2 + 0.5 * 3
  EXPECT_EQ(u32(104), 12u);          // intensities count
  EXPECT_EQ(f32(108 + 4), 13.0f);    // intensities[1]
}

TEST(CdrTest, HugeSequenceCountIsRefusedBeforeAllocating) {
  std::vector<uint8_t> b = Sample("laserscan_le.cdr");
  PutU32Le(&b, 52, 0xFFFFFFFFu);
  RosLaserScan scan;
  Status s = DecodeCdrLaserScan(b.data(), b.size(), &scan);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message(),
            "LaserScan: ranges: sequence of 4294967295 elements needs 17179869180 bytes, "
            "100 left at byte 56");

  b = Sample("tf_le.cdr");
  PutU32Le(&b, 4, 100000000u);
  RosTfMessage tf;
  s = DecodeCdrTfMessage(b.data(), b.size(), &tf);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("TFMessage: transforms: sequence of 100000000 elements"),
            std::string::npos)
      << s.message();
}

TEST(CdrTest, EveryTruncationFailsWithAnOffset) {
  for (const char* name :
       {"laserscan_le.cdr", "laserscan_be.cdr", "odometry_le.cdr", "odometry_be.cdr", "imu_le.cdr",
        "imu_be.cdr", "tf_le.cdr", "tf_be.cdr"}) {
    const std::vector<uint8_t> full = Sample(name);
    const std::string n(name);
    for (size_t len = 0; len < full.size(); ++len) {
      // A fresh copy of exactly `len` bytes, so ASan would see an overrun.
      std::vector<uint8_t> b(full.begin(), full.begin() + len);
      Status s;
      if (n.rfind("laserscan", 0) == 0) {
        RosLaserScan m;
        s = DecodeCdrLaserScan(b.data(), b.size(), &m);
      } else if (n.rfind("odometry", 0) == 0) {
        RosOdometry m;
        s = DecodeCdrOdometry(b.data(), b.size(), &m);
      } else if (n.rfind("imu", 0) == 0) {
        RosImu m;
        s = DecodeCdrImu(b.data(), b.size(), &m);
      } else {
        RosTfMessage m;
        s = DecodeCdrTfMessage(b.data(), b.size(), &m);
      }
      ASSERT_FALSE(s.ok()) << name << " cut at " << len;
      EXPECT_TRUE(s.message().find("left at byte") != std::string::npos ||
                  s.message().find("needs 4 bytes, the message has") != std::string::npos)
          << s.message();
    }
  }
  RosLaserScan scan;
  Status s = DecodeCdrLaserScan(nullptr, 0, &scan);
  EXPECT_EQ(s.message(), "LaserScan: encapsulation header: needs 4 bytes, the message has 0");
}

TEST(CdrTest, OtherRepresentationsAreRefused) {
  std::vector<uint8_t> b = Sample("imu_le.cdr");
  b[1] = 0x07;  // XCDR2 little-endian (PLAIN_CDR2)
  RosImu imu;
  Status s = DecodeCdrImu(b.data(), b.size(), &imu);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("representation 0x0007 is not supported"), std::string::npos)
      << s.message();
}

TEST(CdrTest, StringWithoutNulIsRefused) {
  std::vector<uint8_t> b = Sample("laserscan_le.cdr");
  b[21] = 'x';  // the NUL after "laser"
  RosLaserScan scan;
  Status s = DecodeCdrLaserScan(b.data(), b.size(), &scan);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message(),
            "LaserScan: header.frame_id: string of 6 bytes does not end with NUL at byte 21");

  b = Sample("laserscan_le.cdr");
  PutU32Le(&b, 12, 1000);
  s = DecodeCdrLaserScan(b.data(), b.size(), &scan);
  EXPECT_EQ(s.message(), "LaserScan: header.frame_id: string of 1000 bytes, 140 left at byte 16");
}

TEST(CdrTest, TrailingPaddingIsIgnored) {
  std::vector<uint8_t> b = Sample("imu_le.cdr");
  b.insert(b.end(), {0, 0, 0});
  RosImu imu;
  ASSERT_TRUE(DecodeCdrImu(b.data(), b.size(), &imu).ok());
  testing::ExpectImu(imu, ExpectedImu(2));
}

TEST(CdrTest, DispatchCountsAndReportsUndecodableMessages) {
  testing::RecordingSink sink;
  RosReadStats stats;
  const std::string topic = "/scan", type = "sensor_msgs/msg/LaserScan";
  RosMessageInfo info;
  info.topic = &topic;
  info.type = &type;
  std::vector<uint8_t> b = Sample("laserscan_le.cdr");
  EXPECT_TRUE(
      DispatchCdrMessage(RosMessageKind::kLaserScan, info, b.data(), b.size(), &sink, &stats));
  b.resize(30);
  EXPECT_TRUE(
      DispatchCdrMessage(RosMessageKind::kLaserScan, info, b.data(), b.size(), &sink, &stats));
  EXPECT_TRUE(DispatchCdrMessage(RosMessageKind::kOther, info, b.data(), b.size(), &sink, &stats));
  EXPECT_EQ(stats.messages_read, 1u);
  EXPECT_EQ(stats.messages_undecodable, 1u);
  EXPECT_EQ(stats.messages_skipped, 1u);
  ASSERT_EQ(sink.undecodable.size(), 1u);
  EXPECT_EQ(sink.undecodable[0], "/scan: LaserScan: angle_max: needs 4 bytes, 2 left at byte 28");
  sink.stop_after = 1;
  b = Sample("laserscan_le.cdr");
  EXPECT_FALSE(
      DispatchCdrMessage(RosMessageKind::kLaserScan, info, b.data(), b.size(), &sink, &stats));
}

}  // namespace
}  // namespace sweepscan::io
