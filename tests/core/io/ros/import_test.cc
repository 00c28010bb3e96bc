// ImportRosBag on small ROS 1 bags written by ROS's own Python writer
// (tests/tools/make_test_rosbags.py, Debian's python3-rosbag): every value
// below is what that script wrote, worked through the rules of import.h by
// hand.
#include "core/io/ros/import.h"

#include <dirent.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/io/ros/ros_bag.h"
#include "core/session/measurements.h"
#include "core/session/session.h"
#include "tests/testing/run_command.h"

namespace sweepscan::io {
namespace {

std::string Shell(const std::string& command) {
  std::string out;
  std::unique_ptr<FILE, int (*)(FILE*)> p(popen(command.c_str(), "r"), &pclose);
  char buf[512];
  while (p && fgets(buf, sizeof(buf), p.get())) out += buf;
  return out;
}

bool Exists(const std::string& path) {
  struct stat st;
  return stat(path.c_str(), &st) == 0;
}

class ImportTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    char tmpl[] = "/tmp/ros_import_test.XXXXXX";
    dir_ = mkdtemp(tmpl);
    const std::string cmd = std::string(SWEEPSCAN_PYTHON3) + " " + SWEEPSCAN_SOURCE_DIR +
                            "/tests/tools/make_test_rosbags.py " + dir_ + " 2>&1";
    const std::string out = Shell(cmd);
    ASSERT_TRUE(Exists(dir_ + "/rules.bag")) << cmd << "\n" << out;
  }
  static void TearDownTestSuite() { sweepscan::testing::ShellOrFail("rm -rf " + dir_); }

  static std::string Bag(const std::string& name) { return dir_ + "/" + name + ".bag"; }
  static std::string Out(const std::string& name) { return dir_ + "/" + name + ".sweepscan"; }

  // Imports and loads the session's measurements.
  static void ImportAndLoad(const std::string& name, const RosImportOptions& options,
                            RosImportReport* report, SessionMeta* meta, SensorLog* log) {
    sweepscan::testing::ShellOrFail("rm -rf " + Out(name));
    const Status s = ImportRosBag(Bag(name), Out(name), options, report);
    ASSERT_TRUE(s.ok()) << s.message();
    Session session;
    const Status l = LoadSession(Out(name), FramesLoadOptions(), &session);
    ASSERT_TRUE(l.ok()) << l.message();
    *meta = session.meta;
    MeasurementDecodeStats stats;
    DecodeMeasurementRecords(session.records, session.meta.geometry, log, &stats);
    EXPECT_EQ(stats.refused, 0u) << stats.first_refusal;
  }

  static std::string dir_;
};
std::string ImportTest::dir_;

// Robot time = header stamp - (T0 - 1 s): the script's t(s) is 1 + s here.
// The script builds stamps through doubles, so times agree to a microsecond.
constexpr double kTimeTol = 1e-6;

TEST_F(ImportTest, ScansFollowTheMessageRules) {
  RosImportReport r;
  SessionMeta meta;
  SensorLog log;
  ImportAndLoad("rules", RosImportOptions(), &r, &meta, &log);
  EXPECT_EQ(r.scan_topic, "/scan");
  EXPECT_EQ(r.scans, 4u);              // scan 2 refused
  EXPECT_EQ(r.scans_refused, 1u);
  EXPECT_NE(r.first_scan_refusal.find("/scan message 2: 10 ranges"), std::string::npos) << r.first_scan_refusal;
  EXPECT_EQ(r.no_returns, 3u);         // NaN, inf, -inf
  EXPECT_EQ(r.out_of_range, 2u);       // 0.05 < range_min, 12 > range_max
  EXPECT_EQ(r.out_of_order, 1u);       // scan 4 stamped before scan 3
  EXPECT_EQ(r.intensities_dropped, 1u);  // scan 4: one intensity for two ranges
  EXPECT_NE(std::find(r.warnings.begin(), r.warnings.end(),
                      "1 scans with their intensities dropped: not one for each range"),
            r.warnings.end());
  EXPECT_EQ(r.time_origin_ns, (1700000100LL - 1) * 1000000000LL);
  ASSERT_EQ(log.scans.size(), 4u);

  // Scan 0: t_i = stamp + i * 1 ms; theta_i = -0.4 + 0.1 i; intensities kept.
  const auto& s0 = log.scans[0].samples;
  ASSERT_EQ(s0.size(), 3u);
  const int beams[] = {0, 6, 7};
  const float ranges[] = {1.0f, 2.5f, 3.0f};
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(s0[k].beam, beams[k]);
    EXPECT_EQ(s0[k].range_m, ranges[k]);
    EXPECT_NEAR(s0[k].theta, -0.4 + 0.1 * beams[k], 1e-6);
    EXPECT_NEAR(ToSeconds(s0[k].time.time_since_epoch()), 1.0 + 0.001 * beams[k], kTimeTol);
    EXPECT_EQ(s0[k].intensity, 10.0f + beams[k]);
  }
  // Scan 1: time_increment 0, scan_time 0.2 s, pi/2 a beam: 0.05 s a beam.
  const auto& s1 = log.scans[1].samples;
  ASSERT_EQ(s1.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(ToSeconds(s1[i].time.time_since_epoch()), 1.2 + 0.05 * i, kTimeTol);
    EXPECT_EQ(s1[i].intensity, 0.0f);  // the message has none
  }
  EXPECT_NE(r.time_rule.find("scan_time * angle_increment / (2 pi)"), std::string::npos) << r.time_rule;
  // Sorted by start: scan 4 (stamped 1.5 s) before scan 3 (beams at 1.598..1.6).
  EXPECT_NEAR(ToSeconds(log.scans[2].start_time().time_since_epoch()), 1.5, kTimeTol);
  // Scan 3, time_increment -1 ms: beam 2 first (1.598 s), beam 0 last (the stamp, 1.6 s).
  const auto& s3 = log.scans[3].samples;
  ASSERT_EQ(s3.size(), 3u);
  EXPECT_EQ(s3[0].beam, 2);
  EXPECT_EQ(s3[2].beam, 0);
  EXPECT_NEAR(ToSeconds(s3[0].time.time_since_epoch()), 1.598, kTimeTol);
  EXPECT_NEAR(ToSeconds(s3[2].time.time_since_epoch()), 1.6, kTimeTol);
}

TEST_F(ImportTest, MountComesFromTheTfChain) {
  RosImportReport r;
  SessionMeta meta;
  SensorLog log;
  ImportAndLoad("rules", RosImportOptions(), &r, &meta, &log);
  EXPECT_EQ(r.base_frame, "base_footprint");  // the odometry's child frame
  EXPECT_EQ(r.scan_frame, "laser");
  EXPECT_EQ(r.mount_source, "tf: base_footprint -> mast -> laser");
  // base_footprint -> mast (0.1, 0, 0.3), mast -> laser (0, 0.05, 0.2).
  EXPECT_NEAR(meta.geometry.lidar_offset_x_m, 0.1, 1e-12);
  EXPECT_NEAR(meta.geometry.lidar_offset_y_m, 0.05, 1e-12);
  EXPECT_NEAR(meta.geometry.lidar_height_m, 0.5, 1e-12);
  // The laser is turned -90 deg about y: exactly sweepscan's vertical mount,
  // so N = R_S Ry(pi/2) is the identity (and not written to meta.json).
  EXPECT_FALSE(meta.geometry.HasNominalMountRotation());
  EXPECT_LT(meta.geometry.lidar_mount.angularDistance(Eigen::Quaterniond::Identity()), 1e-7);
  // A beam at angle 0 (along x_S) points up, as Eq. 1's theta 0 does.
  const Rigid3d bl = BodyFromLidar(meta.geometry, MountingError());
  EXPECT_TRUE((bl * LidarPoint(1.0, 0.0)).isApprox(Eigen::Vector3d(0.1, 0.05, 1.5), 1e-6));
  EXPECT_EQ(meta.content, kSessionContentMeasurements);
  EXPECT_EQ(meta.link, "rosbag1:" + Bag("rules"));
}

TEST_F(ImportTest, OdometryAndImuBecomeTwistsAndAttitude) {
  RosImportReport r;
  SessionMeta meta;
  SensorLog log;
  ImportAndLoad("rules", RosImportOptions(), &r, &meta, &log);
  // Twist (0.25 m/s, 0.1 rad/s) through d = 0.15 m: 0.235, 0.265 m/s.
  ASSERT_EQ(log.wheels.size(), 2u);
  EXPECT_NEAR(log.wheels[0].left_mps, 0.235, 1e-12);
  EXPECT_NEAR(log.wheels[0].right_mps, 0.265, 1e-12);
  const Twist2d t = TwistFromWheels(log.wheels[1].left_mps, log.wheels[1].right_mps, 0.15);
  EXPECT_NEAR(t.v, 0.3, 1e-12);
  EXPECT_NEAR(t.w, -0.2, 1e-12);
  // The session's world is the odometry frame: the first pose (1, 2, 0.5).
  const Pose2d start = SessionStartPose(meta);
  EXPECT_EQ(start.x, 1.0);
  EXPECT_EQ(start.y, 2.0);
  EXPECT_NEAR(start.yaw, 0.5, 1e-12);
  // IMU frame turned +90 deg about z: yaw 1.0 in the IMU's frame is
  // 1 - pi/2 for the body; its gyro (0.2, 0, 0.3) is (0, 0.2, 0.3) there.
  ASSERT_EQ(log.imu.size(), 2u);
  EXPECT_TRUE(log.imu[0].has_attitude);
  EXPECT_NEAR(log.imu[0].yaw, 1.0 - M_PI / 2, 1e-9);
  EXPECT_NEAR(log.imu[0].roll, 0.0, 1e-9);
  EXPECT_NEAR(log.imu[0].gyro_z, 0.3, 1e-12);
  // orientation_covariance[0] = -1: no attitude, the yaw rate kept.
  EXPECT_FALSE(log.imu[1].has_attitude);
  EXPECT_TRUE(log.imu[1].has_gyro);
  EXPECT_NEAR(log.imu[1].gyro_z, 0.4, 1e-12);
  EXPECT_EQ(r.imu_without_attitude, 1u);
}

TEST_F(ImportTest, ProvenanceNamesTheBagAndItsHash) {
  RosImportReport r;
  SessionMeta meta;
  SensorLog log;
  ImportAndLoad("rules", RosImportOptions(), &r, &meta, &log);
  const std::string sha = Shell("sha256sum " + Bag("rules")).substr(0, 64);
  ASSERT_EQ(sha.size(), 64u);
  EXPECT_EQ(meta.settings["import"]["sha256"], sha);
  EXPECT_EQ(meta.settings["import"]["topics"]["scan"], "/scan");
  EXPECT_EQ(meta.settings["import"]["format"], "rosbag1");
}

TEST_F(ImportTest, PoseOnlyOdometryIsDifferentiated) {
  RosImportReport r;
  SessionMeta meta;
  SensorLog log;
  ImportAndLoad("pose_only_odom", RosImportOptions(), &r, &meta, &log);
  EXPECT_TRUE(r.twist_from_poses);
  EXPECT_TRUE(log.scans.empty());
  ASSERT_EQ(log.wheels.size(), 10u);  // one per interval
  for (const WheelSpeedMeasurement& w : log.wheels) {
    const Twist2d t = TwistFromWheels(w.left_mps, w.right_mps, 0.15);
    EXPECT_NEAR(t.v, 0.5, 1e-9);   // 0.05 m each 0.1 s along the mean heading
    EXPECT_NEAR(t.w, 0.2, 1e-9);   // 0.02 rad each 0.1 s
  }
}

TEST_F(ImportTest, ClockJumpIsRefusedAndLeavesNothing) {
  const Status s = ImportRosBag(Bag("clock_jump"), Out("clock_jump"), RosImportOptions(), nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("/scan: message 3 is stamped 5.2"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("clock jumped back"), std::string::npos) << s.message();
  EXPECT_FALSE(Exists(Out("clock_jump")));
}

TEST_F(ImportTest, BagWithoutSensorsIsRefused) {
  const Status s = ImportRosBag(Bag("no_sensor"), Out("no_sensor"), RosImportOptions(), nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("nothing sweepscan reads"), std::string::npos) << s.message();
  EXPECT_FALSE(Exists(Out("no_sensor")));
}

TEST_F(ImportTest, MissingTfPathNamesTheFramesAndTheOverride) {
  Status s = ImportRosBag(Bag("no_tf_path"), Out("no_tf_path"), RosImportOptions(), nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("tf has no path from base_footprint to laser (frames in tf: base_footprint, camera)"),
            std::string::npos)
      << s.message();
  EXPECT_NE(s.message().find("--mount"), std::string::npos);
  // The override gives the mount instead.
  RosImportOptions o;
  o.has_mount = true;
  o.base_from_scan = Rigid3d::FromPose(0.2, 0.0, 0.3, 0.0, -M_PI / 2, 0.0);
  RosImportReport r;
  s = ImportRosBag(Bag("no_tf_path"), Out("no_tf_path"), o, &r);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(r.mount_source, "--mount");
  SessionMeta meta;
  ASSERT_TRUE(ReadSessionMeta(Out("no_tf_path") + "/meta.json", &meta).ok());
  EXPECT_NEAR(meta.geometry.lidar_offset_x_m, 0.2, 1e-12);
  EXPECT_NEAR(meta.geometry.lidar_height_m, 0.3, 1e-12);
}

TEST_F(ImportTest, SeveralScanTopicsNeedAChoice) {
  Status s = ImportRosBag(Bag("two_scans"), Out("two_scans"), RosImportOptions(), nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("2 LaserScan topics (/scan_front, /scan_rear): choose one with --scan"),
            std::string::npos)
      << s.message();
  RosImportOptions o;
  o.scan_topic = "/scan_rear";
  RosImportReport r;
  s = ImportRosBag(Bag("two_scans"), Out("two_scans"), o, &r);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(r.scan_topic, "/scan_rear");
  o.scan_topic = "/odom";
  s = ImportRosBag(Bag("rules"), Out("odom_as_scan"), o, nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("/odom is nav_msgs/Odometry, not LaserScan"), std::string::npos) << s.message();
}

TEST_F(ImportTest, CancelLeavesNoSession) {
  RosImportOptions o;
  // Pass 1 (tf, first messages) is 0..0.1 of the work: cancel as pass 2 starts.
  o.progress = [](double f) { return f < 0.08; };
  RosImportFailure failure = RosImportFailure::kNone;
  Status s = ImportRosBag(Bag("rules"), Out("cancelled"), o, nullptr, &failure);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("cancelled"), std::string::npos) << s.message();
  EXPECT_FALSE(Exists(Out("cancelled")));
  EXPECT_EQ(failure, RosImportFailure::kCancelled);
  // Cancelled in pass 1.
  o.progress = [](double) { return false; };
  s = ImportRosBag(Bag("rules"), Out("cancelled"), o, nullptr, &failure);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(failure, RosImportFailure::kCancelled) << s.message();
}

// Names in `dir_` that start with `prefix`.
std::vector<std::string> Listed(const std::string& dir, const std::string& prefix) {
  std::vector<std::string> names;
  if (DIR* d = opendir(dir.c_str())) {
    while (const dirent* e = readdir(d)) {
      if (std::string(e->d_name).rfind(prefix, 0) == 0) names.push_back(e->d_name);
    }
    closedir(d);
  }
  return names;
}

// The session's name appears only once it is whole: written beside it
// (hidden) and renamed, so an import killed midway (or a power loss) leaves
// no session that opens as if complete. A cancel leaves neither.
TEST_F(ImportTest, TheSessionAppearsOnlyWhenWhole) {
  RosImportOptions o;
  bool looked = false, named_midway = true, written_there = false;
  std::vector<std::string> writing;
  o.progress = [&](double f) {
    // Pass 2 (0.1 .. 1 of the work) writes the session.
    if (f >= 0.1 && !looked) {
      looked = true;
      named_midway = Exists(Out("whole"));
      writing = Listed(dir_, ".whole.sweepscan.importing-");
      written_there = writing.size() == 1 && Exists(dir_ + "/" + writing[0] + "/frames.bin");
    }
    return true;
  };
  ASSERT_TRUE(ImportRosBag(Bag("rules"), Out("whole"), o, nullptr).ok());
  ASSERT_TRUE(looked);
  EXPECT_FALSE(named_midway);
  ASSERT_EQ(writing.size(), 1u);
  EXPECT_TRUE(written_there);
  EXPECT_TRUE(Exists(Out("whole") + "/frames.bin"));
  EXPECT_TRUE(Listed(dir_, ".whole.sweepscan.importing-").empty());
  Session session;
  ASSERT_TRUE(LoadSession(Out("whole"), FramesLoadOptions(), &session).ok());
  EXPECT_TRUE(session.meta.settings.contains("import"));  // the last thing written
  // Cancelled as pass 2 writes: nothing under either name.
  o.progress = [](double f) { return f < 0.1; };
  RosImportFailure failure = RosImportFailure::kNone;
  ASSERT_FALSE(ImportRosBag(Bag("rules"), Out("halfway"), o, nullptr, &failure).ok());
  EXPECT_EQ(failure, RosImportFailure::kCancelled);
  EXPECT_FALSE(Exists(Out("halfway")));
  EXPECT_TRUE(Listed(dir_, ".halfway.sweepscan").empty());
  // An empty folder waiting for it (the app's chooser may make one) takes it.
  ASSERT_EQ(mkdir(Out("waiting").c_str(), 0755), 0);
  ASSERT_TRUE(ImportRosBag(Bag("rules"), Out("waiting"), RosImportOptions(), nullptr).ok());
  EXPECT_TRUE(Exists(Out("waiting") + "/frames.bin"));
}

TEST_F(ImportTest, ExistingSessionIsNotOverwritten) {
  ASSERT_TRUE(ImportRosBag(Bag("rules"), Out("twice"), RosImportOptions(), nullptr).ok());
  RosImportFailure failure = RosImportFailure::kNone;
  Status s = ImportRosBag(Bag("rules"), Out("twice"), RosImportOptions(), nullptr, &failure);
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(Exists(Out("twice") + "/frames.bin"));  // the first import is intact
  EXPECT_EQ(failure, RosImportFailure::kOutput);      // the output's fault (exit 1), not the bag's
  s = ImportRosBag(Bag("no_such"), Out("none"), RosImportOptions(), nullptr, &failure);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(failure, RosImportFailure::kBag);
}

// A bag cut in half is refused with where it broke.
TEST_F(ImportTest, TruncatedBagIsRefused) {
  std::ifstream in(Bag("rules"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string cut = dir_ + "/cut.bag";
  std::ofstream(cut, std::ios::binary).write(bytes.data(), bytes.size() / 2);
  const Status s = ImportRosBag(cut, Out("cut"), RosImportOptions(), nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find(cut + ":"), std::string::npos) << s.message();
  EXPECT_FALSE(Exists(Out("cut")));
}

// What `rosbag record` leaves when it is killed: the chunks, and a bag
// header whose index_pos is still 0 (the index is written at the end).
TEST_F(ImportTest, UnindexedBagIsRefusedWithTheReindexAdvice) {
  std::ifstream in(Bag("rules"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t at = bytes.find("index_pos=");
  ASSERT_NE(at, std::string::npos);
  std::fill_n(bytes.begin() + static_cast<std::ptrdiff_t>(at + 10), 8, '\0');
  const std::string unindexed = dir_ + "/unindexed.bag";
  std::ofstream(unindexed, std::ios::binary).write(bytes.data(), bytes.size());
  const Status s = ImportRosBag(unindexed, Out("unindexed"), RosImportOptions(), nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("run `rosbag reindex " + unindexed + "`"), std::string::npos)
      << s.message();
  EXPECT_FALSE(Exists(Out("unindexed")));
}

// Beams that cannot be timed (time_increment NaN, a span of 20 s, scan_time
// infinite) refuse their scan instead of placing beams at -9.2e18 ns; a
// span of 4 s too, which a session's scan record cannot hold (it passed the
// import's check and was refused by the session writer).
TEST_F(ImportTest, ScansWhoseBeamsCannotBeTimedAreRefused) {
  RosImportReport r;
  SessionMeta meta;
  SensorLog log;
  ImportAndLoad("bad_times", RosImportOptions(), &r, &meta, &log);
  EXPECT_EQ(r.scans, 1u);
  EXPECT_EQ(r.scans_refused, 4u);
  EXPECT_NE(r.first_scan_refusal.find("/scan message 1: time_increment nan"), std::string::npos)
      << r.first_scan_refusal;
  ASSERT_EQ(log.scans.size(), 1u);
  ASSERT_EQ(log.scans[0].samples.size(), 2u);
  EXPECT_NEAR(ToSeconds(log.scans[0].samples[1].time.time_since_epoch()), 1.001, kTimeTol);
  // Only such scans: the import's own rule says why, before a session is written.
  const Status s = ImportRosBag(Bag("long_span"), Out("long_span"), RosImportOptions(), nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("cannot time the beams (span over 2.1 s"), std::string::npos)
      << s.message();
  EXPECT_FALSE(Exists(Out("long_span")));
}

TEST_F(ImportTest, UnknownChunkCompressionIsRefused) {
  std::ifstream in(Bag("rules"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t at = bytes.find("compression=none");
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, 16, "compression=brot");
  const std::string odd = dir_ + "/odd.bag";
  std::ofstream(odd, std::ios::binary).write(bytes.data(), bytes.size());
  const Status s = ImportRosBag(odd, Out("odd"), RosImportOptions(), nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find(odd + ":"), std::string::npos) << s.message();
  EXPECT_FALSE(Exists(Out("odd")));
}

// The records of a ROS 1 bag image from `at` to `end`: where each starts,
// its header's fields and where its data start (the format's framing,
// docs/ros-bags.md).
struct BagRecord {
  size_t at, data_at;
  uint32_t data_len;
  std::map<std::string, std::string> fields;
};
std::vector<BagRecord> Records(const std::string& bag, size_t at, size_t end) {
  std::vector<BagRecord> out;
  while (at + 4 <= end) {
    uint32_t header_len, data_len, len;
    std::memcpy(&header_len, bag.data() + at, 4);
    BagRecord r{at, at + 8 + header_len, 0, {}};
    for (size_t i = at + 4; i < at + 4 + header_len; i += 4 + len) {
      std::memcpy(&len, bag.data() + i, 4);
      const std::string field = bag.substr(i + 4, len);
      r.fields[field.substr(0, field.find('='))] = field.substr(field.find('=') + 1);
    }
    std::memcpy(&data_len, bag.data() + at + 4 + header_len, 4);
    r.data_len = data_len;
    out.push_back(r);
    at = r.data_at + data_len;
  }
  return out;
}

// rosbag_storage trusts a bag's lengths and offsets: each damage below made
// it read out of bounds (a crash, of the app too) or allocate what a flipped
// count said (17 GB). Each is now refused with the byte and why, before a
// session exists, or (a damaged message) skipped and counted.
TEST_F(ImportTest, DamagedLengthsAndOffsetsAreRefusedNotTrusted) {
  std::ifstream in(Bag("rules"), std::ios::binary);
  const std::string good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::vector<BagRecord> records = Records(good, 13, good.size());
  const auto op = [](const BagRecord& r, char c) { return r.fields.at("op") == std::string(1, c); };
  const auto index =
      std::find_if(records.begin(), records.end(), [&](const BagRecord& r) { return op(r, 4); });
  const auto chunk =
      std::find_if(records.begin(), records.end(), [&](const BagRecord& r) { return op(r, 5); });
  ASSERT_NE(index, records.end());
  ASSERT_NE(chunk, records.end());
  ASSERT_EQ(chunk->fields.at("compression"), "none");
  const auto damaged = [&](const std::string& name, const std::string& bytes,
                           const std::string& expect) {
    const std::string path = dir_ + "/" + name + ".bag";
    std::ofstream(path, std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    const Status s = ImportRosBag(path, Out(name), RosImportOptions(), nullptr);
    ASSERT_FALSE(s.ok()) << name;
    EXPECT_NE(s.message().find(path + ": "), std::string::npos) << s.message();
    EXPECT_NE(s.message().find(expect), std::string::npos) << s.message();
    EXPECT_FALSE(Exists(Out(name))) << name;
    RosBagSummary summary;
    EXPECT_FALSE(SummarizeRosBag(path, &summary).ok()) << name;  // `info`, the app's Inspect
  };
  // An index entry pointing past its chunk (rosbag read the message's
  // header from beyond its buffer).
  std::string bytes = good;
  const uint32_t far = 0x00f50000;
  std::memcpy(&bytes[index->data_at + 8], &far, 4);
  damaged("index_offset", bytes, "index entry 0 points at byte 16056320 of a chunk of ");
  // An index record's header field longer than its header (ros::Header::parse
  // read beyond it).
  bytes = good;
  const uint32_t huge = 0x00ffffff;
  std::memcpy(&bytes[index->at + 4], &huge, 4);
  damaged("index_header", bytes, "overruns its header");
  // The index said to start beyond the end: a copy cut short.
  bytes = good;
  const uint64_t beyond = good.size() + 100;
  std::memcpy(&bytes[good.find("index_pos=") + 10], &beyond, 8);
  damaged("index_beyond", bytes, "beyond the end of the file");
  EXPECT_EQ(bytes.size(), good.size());

  // One LaserScan's ranges count flipped (in the uncompressed chunk): that
  // message is skipped and counted, the rest imported, nothing allocated
  // for 4 G floats.
  bytes = good;
  std::string scan_conn;
  size_t count_at = 0;
  for (const BagRecord& r : Records(good, chunk->data_at, chunk->data_at + chunk->data_len)) {
    if (op(r, 7) && r.fields.at("topic") == "/scan") scan_conn = r.fields.at("conn");
    if (op(r, 2) && !scan_conn.empty() && r.fields.at("conn") == scan_conn) {
      // header: seq, stamp, frame_id (u32 length + bytes); then 7 floats.
      uint32_t frame_len;
      std::memcpy(&frame_len, good.data() + r.data_at + 12, 4);
      count_at = r.data_at + 16 + frame_len + 7 * 4;
      break;
    }
  }
  ASSERT_NE(count_at, 0u);
  const uint32_t count = 0xff000000;
  std::memcpy(&bytes[count_at], &count, 4);
  const std::string path = dir_ + "/ranges_count.bag";
  std::ofstream(path, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  RosImportReport clean, report;
  ASSERT_TRUE(ImportRosBag(Bag("rules"), Out("rules_again"), RosImportOptions(), &clean).ok());
  const Status s = ImportRosBag(path, Out("ranges_count"), RosImportOptions(), &report);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(report.undecodable, clean.undecodable + 1);
  EXPECT_EQ(report.scans + report.scans_refused + 1, clean.scans + clean.scans_refused);
  bool said = false;
  for (const std::string& w : report.warnings)
    said |= w.find("ranges: 4278190080 elements") != std::string::npos;
  EXPECT_TRUE(said) << ::testing::PrintToString(report.warnings);
}

// A bag that fails to read is the bag's fault (exit 2), whatever the words
// of its path: one under a folder named "cancelled" whose chunk is damaged
// (seen when the messages are first read, after the summary from the index)
// was taken for the operator's cancel, because the kind was told by the
// message's text.
TEST_F(ImportTest, AFailedReadIsNotACancelWhateverThePathSays) {
  std::ifstream in(Bag("rules"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::vector<BagRecord> records = Records(bytes, 13, bytes.size());
  const auto chunk = std::find_if(records.begin(), records.end(),
                                  [](const BagRecord& r) { return r.fields.at("op") == "\x05"; });
  ASSERT_NE(chunk, records.end());
  // The chunk's first record's header length, far beyond the chunk.
  const uint32_t huge = 0x00ffffff;
  std::memcpy(&bytes[chunk->data_at], &huge, 4);
  ASSERT_EQ(mkdir((dir_ + "/cancelled").c_str(), 0755), 0);
  const std::string odd = dir_ + "/cancelled/chunk.bag";
  std::ofstream(odd, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  RosBagSummary summary;
  ASSERT_TRUE(SummarizeRosBag(odd, &summary).ok());  // the index is whole
  RosImportFailure failure = RosImportFailure::kNone;
  const Status s = ImportRosBag(odd, Out("odd_cancelled"), RosImportOptions(), nullptr, &failure);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find(odd + ": "), std::string::npos) << s.message();
  EXPECT_EQ(failure, RosImportFailure::kBag) << s.message();
  EXPECT_FALSE(Exists(Out("odd_cancelled")));
}

// A topic is chosen only if its messages can be decoded here: an MCAP
// converted from a ROS 1 bag keeps the "ros1" encoding, which the MCAP reader
// does not read; it was chosen, read whole, and refused as "holds no message".
// An empty topic is passed over too (rosbag2 lists every subscribed topic).
// What rosbag itself reads, no more: a bag `rosbag reindex` repaired (its
// cut old index left before the new one) and a bag with bytes after its
// index are read as ROS's own reader reads them.
TEST_F(ImportTest, BagsRosReadsAreNotRefused) {
  const std::string script = dir_ + "/reindex.py";
  std::ofstream(script) << "import rosbag, rospy, struct, sys\n"
                           "from std_msgs.msg import String\n"
                           "d = sys.argv[1]\n"
                           "b = rosbag.Bag(d + '/small.bag', 'w', chunk_threshold=100)\n"
                           "for i in range(40): b.write('/chatter', String('hi %d' % i), "
                           "rospy.Time(1700000000 + i))\n"
                           "b.close()\n"
                           "data = open(d + '/small.bag', 'rb').read()\n"
                           "i = data.find(b'index_pos=')\n"
                           "ip = struct.unpack('<Q', data[i + 10:i + 18])[0]\n"
                           "open(d + '/reindexed.bag', 'wb').write(data[:ip + 30])\n"
                           // as `rosbag reindex` does
                           "b = rosbag.Bag(d + '/reindexed.bag', 'a', allow_unindexed=True)\n"
                           "for _ in b.reindex(): pass\n"
                           "b.close()\n"
                           "open(d + '/padded.bag', 'wb').write(data + bytes(4096))\n"
                           "print(rosbag.Bag(d + '/reindexed.bag').get_message_count())\n";
  const std::string count =
      Shell(std::string(SWEEPSCAN_PYTHON3) + " " + script + " " + dir_ + " 2>&1");
  ASSERT_EQ(count, "39\n") << count;
  for (const std::string name : {"reindexed", "padded"}) {
    RosBagSummary summary;
    const Status s = SummarizeRosBag(Bag(name), &summary);
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(summary.message_count, name == "reindexed" ? 39u : 40u) << name;
    RosReadOptions chatter;
    chatter.topics = {"/chatter"};
    struct Sink : RosMessageSink {
      bool OnLaserScan(const RosMessageInfo&, const RosLaserScan&) override { return true; }
      bool OnOdometry(const RosMessageInfo&, const RosOdometry&) override { return true; }
      bool OnImu(const RosMessageInfo&, const RosImu&) override { return true; }
      bool OnTf(const RosMessageInfo&, const RosTfMessage&) override { return true; }
    } sink;
    RosReadStats stats;
    const Status r = ReadRosBag(Bag(name), chatter, &sink, &stats);  // the chunks walked too
    EXPECT_TRUE(r.ok()) << r.message();
    EXPECT_EQ(stats.messages_skipped, summary.message_count)
        << name;  // std_msgs/String: not decoded
  }
}

// RosReadStats are added to (ros_messages.h), so that several reads share
// one: a ROS 1 read used to overwrite the caller's counts and warnings.
TEST_F(ImportTest, AReadAddsToTheCallersStats) {
  struct Sink : RosMessageSink {
    bool OnLaserScan(const RosMessageInfo&, const RosLaserScan&) override { return ++n, true; }
    bool OnOdometry(const RosMessageInfo&, const RosOdometry&) override { return ++n, true; }
    bool OnImu(const RosMessageInfo&, const RosImu&) override { return ++n, true; }
    bool OnTf(const RosMessageInfo&, const RosTfMessage&) override { return ++n, true; }
    uint64_t n = 0;
  } sink;
  RosReadStats stats;
  stats.messages_read = 1000;
  stats.bytes_read = 7;
  stats.warnings = {"an earlier read's warning"};
  ASSERT_TRUE(ReadRosBag(Bag("rules"), RosReadOptions(), &sink, &stats).ok());
  ASSERT_GT(sink.n, 5u);
  EXPECT_EQ(stats.messages_read, 1000 + sink.n);
  EXPECT_GT(stats.bytes_read, 7u);
  EXPECT_EQ(stats.warnings, std::vector<std::string>{"an earlier read's warning"});
}

TEST(ChooseTopicTest, OnlyTopicsWithMessagesInAnEncodingReadHereAreChosen) {
  RosBagSummary s;
  s.format = "mcap";
  s.topics = {{"/imu", "sensor_msgs/msg/Imu", "cdr", 0, 0, 0},
              {"/imu/data", "sensor_msgs/msg/Imu", "cdr", 20, 0, 0},
              {"/scan", "sensor_msgs/LaserScan", "ros1", 50, 0, 0}};
  std::string topic;
  std::vector<std::string> warnings;
  ASSERT_TRUE(ChooseTopic(s, RosMessageKind::kImu, "", false, &topic, &warnings).ok());
  EXPECT_EQ(topic, "/imu/data");
  ASSERT_TRUE(ChooseTopic(s, RosMessageKind::kLaserScan, "", false, &topic, &warnings).ok());
  EXPECT_EQ(topic, "");
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0],
            "/scan is in encoding 'ros1': sweepscan reads cdr from mcap bags: not used");
  const Status asked = ChooseTopic(s, RosMessageKind::kLaserScan, "/scan", false, &topic);
  ASSERT_FALSE(asked.ok());
  EXPECT_EQ(asked.message(), "/scan is in encoding 'ros1': sweepscan reads cdr from mcap bags");
  s.format = "rosbag1";
  s.topics[2].serialization = "ros1";
  ASSERT_TRUE(ChooseTopic(s, RosMessageKind::kLaserScan, "", true, &topic).ok());
  EXPECT_EQ(topic, "/scan");
}

// A scan with more returns than a session record holds (60 000: over the
// session writer's 1 MiB record cap, under the 65 535 samples a record
// counts) is skipped and counted, and the import goes on; it used to stop
// the whole import with the writer's error.
TEST_F(ImportTest, AScanTooLargeForASessionRecordIsSkippedNotTheImport) {
  const std::string bag = dir_ + "/big_scan.bag";
  const std::string out = Shell(std::string(SWEEPSCAN_PYTHON3) + " " + SWEEPSCAN_SOURCE_DIR +
                                "/tests/core/io/ros/big_scan_bag.py " + bag + " 2>&1");
  ASSERT_TRUE(Exists(bag)) << out;
  RosImportReport report;
  SessionMeta meta;
  SensorLog log;
  RosImportOptions options;
  options.base_frame = "base_link";
  ImportAndLoad("big_scan", options, &report, &meta, &log);
  ASSERT_EQ(log.scans.size(), 2u);
  EXPECT_EQ(log.scans[0].samples.size(), 360u);
  EXPECT_EQ(log.scans[1].samples.size(), 360u);
  EXPECT_EQ(report.scans, 2u);
  EXPECT_EQ(report.scans_refused, 1u);
  EXPECT_EQ(report.scans_too_large, 1u);
  EXPECT_EQ(
      report.first_scan_refusal,
      "/scan message 1: 60000 returns make a 1080017-byte session record, more than its 1048576");
}

TEST_F(ImportTest, NotABagIsRefused) {
  const std::string text = dir_ + "/notes.txt";
  std::ofstream(text) << "not a bag\n";
  const Status s = ImportRosBag(text, Out("notes"), RosImportOptions(), nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("not a ROS bag"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace sweepscan::io
