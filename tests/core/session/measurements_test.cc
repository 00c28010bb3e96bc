#include "core/session/measurements.h"

#include <gtest/gtest.h>

namespace sweepscan {
namespace {

RobotGeometry Geometry() { return RobotGeometry(); }  // d = 0.15 m

TEST(MeasurementsTest, TwistRecordIsTheDocumentedBytes) {
  // docs/session-format.md, "Measurement records": a twist at 1.5 s,
  // 0.2 m/s, 0.1 rad/s.
  std::vector<uint8_t> b;
  EncodeTwistRecord({TimeFromNanoseconds(1500000000), 0.2, 0.1}, &b);
  const std::vector<uint8_t> expected = {0x01, 0x00, 0x2F, 0x68, 0x59, 0x00, 0x00, 0x00, 0x00,
                                         0x9A, 0x99, 0x99, 0x99, 0x99, 0x99, 0xC9, 0x3F,
                                         0x9A, 0x99, 0x99, 0x99, 0x99, 0x99, 0xB9, 0x3F};
  EXPECT_EQ(b, expected);
  SensorLog log;
  std::string why;
  ASSERT_TRUE(DecodeMeasurementRecord(b.data(), b.size(), Geometry(), &log, &why)) << why;
  ASSERT_EQ(log.wheels.size(), 1u);
  // v_l = v - w d, v_r = v + w d.
  EXPECT_DOUBLE_EQ(log.wheels[0].left_mps, 0.2 - 0.1 * 0.15);
  EXPECT_DOUBLE_EQ(log.wheels[0].right_mps, 0.2 + 0.1 * 0.15);
}

TEST(MeasurementsTest, ImuAndScanRoundTrip) {
  ImuMeasurement m;
  m.time = TimeFromNanoseconds(2000000123);
  m.gyro_z = -0.25;
  m.roll = 0.01;
  m.pitch = -0.02;
  m.yaw = 3.0;
  m.has_attitude = false;
  LidarScan scan;
  scan.index = 7;
  for (int i = 0; i < 5; ++i) {
    LidarSample s;
    s.time = TimeFromNanoseconds(3000000000LL + 1000 * i);
    s.range_m = 1.5f + i;
    s.theta = 0.1f * i;
    s.beam = static_cast<uint16_t>(2 * i);
    s.intensity = 40.0f + i;
    scan.samples.push_back(s);
  }
  std::vector<SessionRecord> records(2);
  EncodeImuRecord(m, &records[0].bytes);
  ASSERT_TRUE(EncodeScanRecord(scan, &records[1].bytes).ok());
  EXPECT_EQ(records[0].bytes.size(), 42u);
  EXPECT_EQ(records[1].bytes.size(), 17u + 18u * 5);
  SensorLog log;
  MeasurementDecodeStats stats;
  DecodeMeasurementRecords(records, Geometry(), &log, &stats);
  EXPECT_EQ(stats.refused, 0u);
  ASSERT_EQ(log.imu.size(), 1u);
  EXPECT_EQ(log.imu[0].time, m.time);
  EXPECT_EQ(log.imu[0].gyro_z, m.gyro_z);
  EXPECT_EQ(log.imu[0].yaw, m.yaw);
  EXPECT_TRUE(log.imu[0].has_gyro);
  EXPECT_FALSE(log.imu[0].has_attitude);
  ASSERT_EQ(log.scans.size(), 1u);
  EXPECT_EQ(log.scans[0].index, 7u);
  for (int i = 0; i < 5; ++i) {
    const LidarSample& s = log.scans[0].samples[i];
    EXPECT_EQ(s.time, scan.samples[i].time);
    EXPECT_EQ(s.range_m, scan.samples[i].range_m);
    EXPECT_EQ(s.theta, scan.samples[i].theta);
    EXPECT_EQ(s.beam, scan.samples[i].beam);
    EXPECT_EQ(s.intensity, scan.samples[i].intensity);
  }
  EXPECT_EQ(stats.first_time, m.time);
  EXPECT_EQ(stats.last_time, scan.samples.back().time);
}

TEST(MeasurementsTest, MalformedRecordsAreCountedAndSkipped) {
  std::vector<SessionRecord> records(5);
  EncodeTwistRecord({TimeFromNanoseconds(5), 1.0, 0.0}, &records[0].bytes);
  records[1].bytes = {0x09, 0x00};                      // unknown type
  EncodeTwistRecord({TimeFromNanoseconds(6), 1.0, 0.0}, &records[2].bytes);
  records[2].bytes.pop_back();                          // one byte short
  LidarScan scan;
  scan.samples.resize(2);
  ASSERT_TRUE(EncodeScanRecord(scan, &records[3].bytes).ok());
  records[3].bytes.resize(40);                          // claims 2 samples, holds 1
  records[4].bytes = {};                                // empty
  SensorLog log;
  MeasurementDecodeStats stats;
  DecodeMeasurementRecords(records, Geometry(), &log, &stats);
  EXPECT_EQ(stats.refused, 4u);
  EXPECT_EQ(stats.first_refusal, "record 1: unknown measurement type 9");
  EXPECT_EQ(log.wheels.size(), 1u);
  std::string why;
  SensorLog ignored;
  EXPECT_FALSE(DecodeMeasurementRecord(records[3].bytes.data(), 40, Geometry(), &ignored, &why));
  EXPECT_EQ(why, "scan record: 40 bytes, needs 53 for 2 samples");
}

TEST(MeasurementsTest, StreamsAreSortedByTime) {
  std::vector<SessionRecord> records(3);
  EncodeTwistRecord({TimeFromNanoseconds(300), 3.0, 0.0}, &records[0].bytes);
  EncodeTwistRecord({TimeFromNanoseconds(100), 1.0, 0.0}, &records[1].bytes);
  EncodeTwistRecord({TimeFromNanoseconds(200), 2.0, 0.0}, &records[2].bytes);
  SensorLog log;
  DecodeMeasurementRecords(records, Geometry(), &log, nullptr);
  ASSERT_EQ(log.wheels.size(), 3u);
  EXPECT_EQ(ToNanoseconds(log.wheels[0].time), 100);
  EXPECT_EQ(ToNanoseconds(log.wheels[2].time), 300);
}

// A measurements session's scan index is whatever its file says: looked up
// without a table sized by the largest (one scan numbered 2^32 - 2 made a
// 32 GiB table; 2^32 - 1 wrapped the size to 0 and wrote past it).
TEST(MeasurementsTest, ScansAreFoundByIndexWhateverTheIndices) {
  std::vector<LidarScan> scans(5);
  const uint32_t indices[] = {7, 0xFFFFFFFFu, 0, 0xFFFFFFFEu, 7};
  for (size_t i = 0; i < scans.size(); ++i) {
    scans[i].index = indices[i];
    scans[i].samples.resize(i + 1);
  }
  const ScansByIndex found(scans);
  EXPECT_EQ(found.Find(0), &scans[2]);
  EXPECT_EQ(found.Find(0xFFFFFFFFu), &scans[1]);
  EXPECT_EQ(found.Find(0xFFFFFFFEu), &scans[3]);
  EXPECT_EQ(found.Find(7), &scans[4]);  // the last of those sharing it
  EXPECT_EQ(found.Find(1), nullptr);
  EXPECT_EQ(found.Find(8), nullptr);
  EXPECT_EQ(ScansByIndex({}).Find(0), nullptr);
}

TEST(MeasurementsTest, OverlongScansAreRefused) {
  LidarScan scan;
  scan.samples.resize(2);
  scan.samples[1].time = TimeFromNanoseconds(3000000000LL);  // 3 s after the first
  std::vector<uint8_t> b;
  EXPECT_FALSE(EncodeScanRecord(scan, &b).ok());
  scan.samples.resize(70000);
  EXPECT_FALSE(EncodeScanRecord(scan, &b).ok());
}

}  // namespace
}  // namespace sweepscan

namespace sweepscan {
namespace {

TEST(MeasurementSessionMetaTest, MountAndContentKeysRoundTripAndAreOptional) {
  SessionMeta m;
  m.created_utc = "2026-11-25T10:00:00Z";
  // sweepscan's own robot: none of the new keys is written.
  nlohmann::json j = SessionMetaToJson(m);
  EXPECT_FALSE(j.contains("content"));
  EXPECT_FALSE(j["robot"].contains("lidar_mount"));
  EXPECT_FALSE(j["robot"].contains("lidar_offset_y_m"));
  m.content = kSessionContentMeasurements;
  m.geometry.lidar_offset_y_m = -0.05;
  m.geometry.lidar_height_m = -0.1;  // below the base frame: allowed for an imported robot
  m.geometry.lidar_mount = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()));
  j = SessionMetaToJson(m);
  SessionMeta back;
  const Status s = SessionMetaFromJson(j, "meta.json", &back);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(back.content, kSessionContentMeasurements);
  EXPECT_EQ(back.geometry.lidar_offset_y_m, -0.05);
  EXPECT_EQ(back.geometry.lidar_height_m, -0.1);
  EXPECT_TRUE(back.geometry.lidar_mount.isApprox(m.geometry.lidar_mount, 1e-15));
  // A link-frame session keeps h > 0; a non-unit mount and unknown content are refused.
  j.erase("content");
  EXPECT_EQ(SessionMetaFromJson(j, "meta.json", &back).message(),
            "meta.json: robot.lidar_height_m: must be > 0, got -0.1");
  j = SessionMetaToJson(m);
  j["robot"]["lidar_mount"]["w"] = 2.0;
  EXPECT_NE(SessionMetaFromJson(j, "meta.json", &back).message().find("not a unit quaternion"),
            std::string::npos);
  j = SessionMetaToJson(m);
  j["content"] = "pointclouds";
  EXPECT_NE(SessionMetaFromJson(j, "meta.json", &back).message().find("unknown content \"pointclouds\""),
            std::string::npos);
}

}  // namespace
}  // namespace sweepscan
