// `sweepscan-cli import` and `info BAG` as a ROS user runs them, on bags
// written by ROS's own Python writer (python3-rosbag) from simulated drives
// with ground truth (tests/tools/session_to_rosbag1.py), and on real bags
// recorded by others (tests/data/ros/README.md).
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/cloud/cloud_io.h"
#include "tests/testing/binned_cloud.h"
#include "tests/testing/cli_files.h"
#include "tests/testing/run_command.h"

namespace {

using sweepscan::testing::CommandRun;
using sweepscan::testing::ExpectScenarioMountingError;
using sweepscan::testing::RunCommand;

std::string Source(const std::string& path) { return sweepscan::testing::SourcePath(path); }
std::string Tmp(const std::string& name) { return sweepscan::testing::ProcessTmp(name); }
CommandRun Cli(const std::string& args) { return RunCommand(std::string(SWEEPSCAN_CLI) + " " + args); }

std::string ReadFile(const std::string& path) { return sweepscan::testing::ReadWholeFile(path); }

// Simulates SCENARIO into a native session, then writes the same drive as a
// ROS 1 bag with python3-rosbag (compression none, bz2 or lz4).
void SimulateAndWriteBag(const std::string& scenario, const std::string& name,
                         const std::vector<std::string>& compressions) {
  CommandRun r = Cli("simulate --scenario " + Source("resources/scenarios/" + scenario + ".json") + " --out " +
                     Tmp(name + ".ply") + " --session " + Tmp(name + ".sweepscan") + " --overwrite");
  ASSERT_EQ(r.code, 0) << r.out;
  RunCommand("rm -rf " + Tmp(name + "_csv"));
  r = Cli("export " + Tmp(name + ".sweepscan") + " --out " + Tmp(name + "_csv"));
  ASSERT_EQ(r.code, 0) << r.out;
  for (const std::string& c : compressions) {
    r = RunCommand(std::string(SWEEPSCAN_PYTHON3) + " " + Source("tests/tools/session_to_rosbag1.py") + " " +
                   Tmp(name + "_csv") + " " + Tmp(name + ".sweepscan/meta.json") + " " + Tmp(name + "_" + c + ".bag") +
                   " --compression " + c);
    ASSERT_EQ(r.code, 0) << r.out;
  }
}

CommandRun Import(const std::string& bag, const std::string& session, const std::string& extra = "") {
  RunCommand("rm -rf " + session);
  return Cli("import " + bag + " --out " + session + " " + extra);
}

class CliRosTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { SimulateAndWriteBag("lab", "lab", {"none", "bz2", "lz4"}); }
  static void TearDownTestSuite() { RunCommand("rm -rf " + Tmp("")); }
};

// The drive as a bag, imported, gives the native session's cloud: the same
// points in the same order, each within the test writer's binning
// (0.05 deg bins: 0.025 deg at most, 2.2 mm at 5 m).
TEST_F(CliRosTest, ImportedDriveGivesTheNativeCloud) {
  CommandRun r = Import(Tmp("lab_lz4.bag"), Tmp("imported.sweepscan"), "--json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["format"], "rosbag1");
  EXPECT_EQ(report["topics"]["scan"], "/scan");
  EXPECT_EQ(report["topics"]["odometry"], "/odom");
  EXPECT_EQ(report["topics"]["imu"], "/imu/data");
  EXPECT_EQ(report["mount"]["source"], "tf: base_footprint -> laser");
  EXPECT_EQ(report["out_of_order"], 0);
  ASSERT_EQ(Cli("reconstruct " + Tmp("lab.sweepscan") + " --out " + Tmp("native.ply")).code, 0);
  r = Cli("reconstruct " + Tmp("imported.sweepscan") + " --out " + Tmp("imported.ply") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["samples_without_pose"], 0);

  std::vector<sweepscan::CloudPoint> native, imported;
  ASSERT_TRUE(sweepscan::LoadCloud(Tmp("native.ply"), &native).ok());
  ASSERT_TRUE(sweepscan::LoadCloud(Tmp("imported.ply"), &imported).ok());
  ASSERT_GT(native.size(), 200000u);
  ASSERT_EQ(imported.size(), native.size());
  EXPECT_TRUE(sweepscan::testing::SameCloudWithinBinning(native, imported));
}

TEST_F(CliRosTest, EveryCompressionGivesTheSameCloud) {
  std::string first;
  for (const char* c : {"none", "bz2", "lz4"}) {
    const std::string session = Tmp(std::string("c_") + c + ".sweepscan");
    const CommandRun r = Import(Tmp(std::string("lab_") + c + ".bag"), session);
    ASSERT_EQ(r.code, 0) << r.out;
    ASSERT_EQ(Cli("reconstruct " + session + " --out " + session + ".ply").code, 0);
    const std::string cloud = ReadFile(session + ".ply");
    ASSERT_GT(cloud.size(), 1000000u);
    if (first.empty()) {
      first = cloud;
    } else {
      EXPECT_TRUE(cloud == first) << c;
    }
  }
}

TEST_F(CliRosTest, InfoDescribesTheBag) {
  CommandRun r = Cli("info " + Tmp("lab_bz2.bag") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["format"], "rosbag1");
  EXPECT_EQ(j["compression"], "bz2");
  std::map<std::string, int> counts;
  for (const auto& t : j["topics"]) counts[t["topic"]] = t["messages"];
  // The native session's records, one message each (export's CSV rows).
  EXPECT_EQ(counts["/odom"], counts["/tf"]);
  EXPECT_GT(counts["/scan"], 350);
  EXPECT_EQ(counts["/tf_static"], 1);
  EXPECT_EQ(j["tf"], nlohmann::json::array({"base_footprint -> imu_link (static)", "base_footprint -> laser (static)",
                                            "odom -> base_footprint"}));
  r = Cli("info " + Tmp("lab_bz2.bag"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("/scan                        sensor_msgs/LaserScan"), std::string::npos) << r.out;
}

TEST_F(CliRosTest, BadInputExitsTwoWithOneLine) {
  std::ofstream(Tmp("not_a.bag")) << "hello\n";
  CommandRun r = Import(Tmp("not_a.bag"), Tmp("x.sweepscan"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("not a ROS bag"), std::string::npos) << r.out;
  r = Import(Tmp("lab_none.bag"), Tmp("x.sweepscan"), "--mount 1,2,3");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--mount wants six numbers"), std::string::npos) << r.out;
  r = Import(Tmp("lab_none.bag"), Tmp("x.sweepscan"), "--scan /nope");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("the bag has no topic /nope"), std::string::npos) << r.out;
  // One line that points at the help (the whole help used to follow it).
  r = Cli("import " + Tmp("lab_none.bag"));
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.out,
            "sweepscan-cli: error: import needs --out NAME.sweepscan (see `sweepscan-cli help "
            "import`)\n");
}

// A chunk whose header claims more bytes than its data decompress to is
// refused by name. The claim is not allocated on trust: bz2 grows its
// buffer with what the data really give, lz4 is bounded by its best ratio
// (the fuzzer's out-of-memory: a 4 GiB claim in a 29 KB bag). The import
// runs under a 3 GiB address-space limit, which the 4 GiB buffer broke.
TEST_F(CliRosTest, AChunkClaimingFourGigabytesIsRefusedWithoutAllocatingThem) {
  for (const std::string c : {"bz2", "lz4"}) {
    std::string bag = ReadFile(Tmp("lab_" + c + ".bag"));
    const size_t compression = bag.find("compression=" + c);
    ASSERT_NE(compression, std::string::npos) << c;
    const size_t size = bag.find("size=", compression);
    ASSERT_LT(size, compression + 64) << c;
    uint32_t claimed = 0;
    std::memcpy(&claimed, bag.data() + size + 5, 4);
    const uint32_t huge = 0xFFFFFFF0u;
    std::memcpy(&bag[size + 5], &huge, 4);
    const std::string bad = Tmp("huge_chunk_" + c + ".bag");
    std::ofstream(bad, std::ios::binary).write(bag.data(), static_cast<std::streamsize>(bag.size()));
    RunCommand("rm -rf " + Tmp("huge.sweepscan"));
    CommandRun r = RunCommand("ulimit -v 3145728 && " + std::string(SWEEPSCAN_CLI) + " import " + bad +
                              " --out " + Tmp("huge.sweepscan"));
    EXPECT_EQ(r.code, 2) << c << ": " << r.out;
    const std::string said =
        c == "bz2" ? "the chunk decompresses to " + std::to_string(claimed) + " bytes, its header says 4294967280"
                   : "the chunk's header says it decompresses to 4294967280 bytes, more than its";
    EXPECT_NE(r.out.find(said), std::string::npos) << c << ": " << r.out;
    // One byte fewer than the data give: refused too (bzip2's BZ_OUTBUFF_FULL).
    if (c == "bz2") {
      const uint32_t short_by_one = claimed - 1;
      std::memcpy(&bag[size + 5], &short_by_one, 4);
      std::ofstream(bad, std::ios::binary).write(bag.data(), static_cast<std::streamsize>(bag.size()));
      r = Import(bad, Tmp("huge.sweepscan"));
      EXPECT_EQ(r.code, 2) << r.out;
      EXPECT_NE(r.out.find("its bz2 data do not decompress (bzip2 error -8)"), std::string::npos) << r.out;
    }
  }
}

// A driver that stamps on its own clock (from boot, or 0) while the other
// sensors stamp on the robot's: the import compares each topic's stamps
// with its log times, times that topic by its log time instead (moved onto
// the others' clock) and says so. The bag's log times equal its stamps, so
// the cloud is the well-stamped bag's to the byte; before, it came out
// without a word and wrong (the odometry 54 years before the scans).
TEST_F(CliRosTest, ATopicStampedOnAnotherClockIsTimedByItsLogTime) {
  const std::string reference = Tmp("clock_reference.sweepscan");
  CommandRun r = Import(Tmp("lab_none.bag"), reference);
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_EQ(Cli("reconstruct " + reference + " --out " + reference + ".ply").code, 0);
  const std::string expected = ReadFile(reference + ".ply");
  ASSERT_GT(expected.size(), 1000000u);
  const std::pair<std::string, std::string> cases[] = {{"/odom", "boot:1234.5"},
                                                       {"/imu/data", "zero"}};
  for (const auto& [topic, mode] : cases) {
    SCOPED_TRACE(topic);
    const std::string bag = Tmp("clock_" + mode.substr(0, 4) + ".bag");
    r = RunCommand(std::string(SWEEPSCAN_PYTHON3) + " " +
                   Source("tests/core/io/ros/restamp_bag.py") + " " + Tmp("lab_none.bag") + " " +
                   bag + " " + topic + " " + mode);
    ASSERT_EQ(r.code, 0) << r.out;
    const std::string session = Tmp("clock_" + mode.substr(0, 4) + ".sweepscan");
    r = Import(bag, session, "--json");
    ASSERT_EQ(r.code, 0) << r.out;
    const nlohmann::json report = nlohmann::json::parse(r.out);
    EXPECT_EQ(report["stamps_from_log_time_ns"], nlohmann::json({{topic, 0}})) << r.out;
    std::string said;
    for (const auto& w : report["warnings"]) said += w.get<std::string>() + "\n";
    EXPECT_NE(said.find(topic + ": header stamps are -"), std::string::npos) << said;
    // /scan is logged at its last beam, 0.14 s after its stamp (the first
    // beam's); the other of /odom and /imu/data at its stamp: the least
    // latency, the offset used.
    const std::string other = topic == "/odom" ? "/imu/data" : "/odom";
    EXPECT_NE(
        said.find(
            " s from their log times, but " + other +
            "'s are 0.000 s: stamped on another clock (from boot, or left 0?); its times are its "
            "log times instead"),
        std::string::npos)
        << said;
    ASSERT_EQ(Cli("reconstruct " + session + " --out " + session + ".ply").code, 0);
    EXPECT_TRUE(ReadFile(session + ".ply") == expected);
  }
}

// Exit codes: 2 for the bag, 1 for the output. A bag whose path starts with
// the --out text is still the bag's fault; a session that cannot be written
// while the bag is read (the file size limit standing for a full disk) is
// the output's, and leaves nothing behind.
TEST_F(CliRosTest, WriteFailuresExitOneBagFailuresTwo) {
  std::ofstream(Tmp("out_named.sweepscan.bag")) << "hello\n";
  CommandRun r = Import(Tmp("out_named.sweepscan.bag"), Tmp("out_named.sweepscan"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("not a ROS bag"), std::string::npos) << r.out;

  const std::string session = Tmp("too_big.sweepscan");
  RunCommand("rm -rf " + session);
  // A file size limit of 1 MiB: meta.json fits, the records do not (the
  // writer's 4 MiB buffer is written out while the bag is read).
  r = RunCommand("sh -c \"trap '' XFSZ; ulimit -f 1024; " + std::string(SWEEPSCAN_CLI) +
                 " import " + Tmp("lab_none.bag") + " --out " + session + "\"");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_EQ(r.out.find(Tmp("lab_none.bag") + ": "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(session), std::string::npos) << r.out;
  struct stat st;
  EXPECT_NE(stat(session.c_str(), &st), 0) << "the failed import left " << session;
}

// The automatic calibration on an imported three-turn circle finds the
// scenario's hidden mounting error as it does on the native session.
TEST(CliRosCalibrationTest, AutomaticCalibrationOnAnImportedCircle) {
  SimulateAndWriteBag("lab_circle_three_turns", "circle", {"lz4"});
  CommandRun r = Import(Tmp("circle_lz4.bag"), Tmp("circle_imported.sweepscan"));
  ASSERT_EQ(r.code, 0) << r.out;
  r = Cli("calibrate " + Tmp("circle_imported.sweepscan") + " --auto --out " + Tmp("circle_cal.json") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ExpectScenarioMountingError(j, "lab_circle_three_turns", r.out);
  r = Cli("evaluate " + Tmp("circle_imported.sweepscan") + " --calibration " + Tmp("circle_cal.json") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
}

// Back to ROS: the cloud and poses in a ROS 1 bag that ROS's own Python
// reader reads: the same points as reconstruct's PLY, the intensities of
// the samples, the poses in the odometry frame.
TEST(CliRosExportTest, CloudAndPathReadByRosbag) {
  const std::string bag = Source("tests/data/ros/datmo_parallel.bag");
  CommandRun r = Import(bag, Tmp("exp.sweepscan"), "--mount=-0.12,0,0.1,0,0,0");
  ASSERT_EQ(r.code, 0) << r.out;
  r = Cli("export " + Tmp("exp.sweepscan") + " --format rosbag --out " + Tmp("exp.bag") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_EQ(Cli("reconstruct " + Tmp("exp.sweepscan") + " --out " + Tmp("exp.ply")).code, 0);
  std::vector<sweepscan::CloudPoint> ply;
  ASSERT_TRUE(sweepscan::LoadCloud(Tmp("exp.ply"), &ply).ok());
  r = RunCommand(std::string(SWEEPSCAN_PYTHON3) + " " + Source("tests/tools/read_rosbag1_export.py") + " " + Tmp("exp.bag"));
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["types"]["/sweepscan/cloud"], "sensor_msgs/PointCloud2");
  EXPECT_EQ(j["types"]["/sweepscan/path"], "nav_msgs/Path");
  EXPECT_EQ(j["cloud"]["frame"], "odom");
  EXPECT_EQ(j["cloud"]["fields"], nlohmann::json::array({"x", "y", "z", "intensity", "time"}));
  ASSERT_EQ(j["cloud"]["points"].get<size_t>(), ply.size());
  // 37343 valid beams in the bag (tests/data/ros/README.md), less those
  // before the first IMU reading (no pose yet: this bag has no odometry).
  EXPECT_GT(ply.size(), 37000u);
  EXPECT_LE(ply.size(), 37343u);
  EXPECT_EQ(j["cloud"]["first"][0].get<float>(), ply.front().x);
  EXPECT_EQ(j["cloud"]["last"][2].get<float>(), ply.back().z);
  // The intensity of each placed point is its beam's in the bag, as the
  // CSV export of the session has it (every beam's: 1755121 in all).
  RunCommand("rm -rf " + Tmp("exp_csv"));
  ASSERT_EQ(Cli("export " + Tmp("exp.sweepscan") + " --out " + Tmp("exp_csv")).code, 0);
  std::map<std::pair<unsigned, unsigned>, double> intensity;
  std::ifstream csv(Tmp("exp_csv") + "/lidar.csv");
  std::string line;
  std::getline(csv, line);
  double all = 0.0;
  while (std::getline(csv, line)) {
    unsigned scan = 0, beam = 0;
    double t = 0, r = 0, th = 0, i = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%u,%u,%lf,%lf,%lf", &t, &scan, &beam, &r, &th, &i), 6) << line;
    intensity[{scan, beam}] = i;
    all += i;
  }
  EXPECT_EQ(all, 1755121.0);  // python3-rosbag's sum over the bag
  double placed = 0.0;
  for (const sweepscan::CloudPoint& p : ply) placed += intensity.at({p.scan, p.beam});
  EXPECT_EQ(j["cloud"]["intensity_sum"].get<double>(), placed);
  // Stamps back on the bag's clock: the first beam of the recording, 2019-12-08.
  EXPECT_NEAR(j["cloud"]["first"][4].get<double>(), 1575811285.36, 0.5);
  EXPECT_GT(j["path"]["poses"].get<int>(), 100);
}

// A real Husky's odometry and IMU, no laser: the session has poses only.
TEST(CliRosRealBagTest, HuskyOdometryAndImu) {
  CommandRun r = Import(Source("tests/data/ros/husky_test1.bag"), Tmp("husky.sweepscan"), "--json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  EXPECT_EQ(j["topics"]["odometry"], "/husky_velocity_controller/odom");
  EXPECT_EQ(j["topics"]["imu"], "/imu/data");
  EXPECT_EQ(j["topics"]["scan"], "");
  EXPECT_EQ(j["odometry"], 3952);
  EXPECT_EQ(j["imu"], 11865);
  r = Cli("info " + Tmp("husky.sweepscan"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("0 scans (0 samples), 11865 IMU records, 3952 wheel records"), std::string::npos) << r.out;
  r = Cli("info " + Source("tests/data/ros/husky_test1.bag") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["compression"], "bz2");
  // The IMU's mount is in robot_localization's launch file, not in the bag
  // (static_transform_publisher 0 -0.3 0.52 -1.5708 0 1.5708 base_link
  // imu_link): without it the yaw rate is read on the wrong axis.
  r = Import(Source("tests/data/ros/husky_test1.bag"), Tmp("husky_imu.sweepscan"),
             "--imu-mount 0,-0.3,0.52,1.570796327,0,-1.570796327 --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json k = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  EXPECT_EQ(k["imu_mount"], "--imu-mount");
  // With the mount, the IMU's yaw rate integrates to the odometry's turn
  // (-3.46 rad over the drive); without, to -0.13 rad.
  RunCommand("rm -rf " + Tmp("husky_csv"));
  ASSERT_EQ(Cli("export " + Tmp("husky_imu.sweepscan") + " --out " + Tmp("husky_csv")).code, 0);
  std::ifstream imu(Tmp("husky_csv") + "/imu.csv");
  std::string line;
  std::getline(imu, line);
  double turned = 0.0, last_t = -1.0;
  while (std::getline(imu, line)) {
    const double t = std::stod(line), w = std::stod(line.substr(line.find(',') + 1));
    if (last_t >= 0.0) turned += w * (t - last_t);
    last_t = t;
  }
  EXPECT_NEAR(turned, -3.46, 0.15);
}

// A real RPLIDAR: every count as python3-rosbag reads the bag
// (tests/data/ros/README.md), intensities through to the CSV, and the
// driver's wrong time_increment reported.
TEST(CliRosRealBagTest, RplidarScansOfARealCar) {
  const std::string bag = Source("tests/data/ros/datmo_parallel.bag");
  CommandRun r = Import(bag, Tmp("datmo.sweepscan"), "--mount=-0.12,0,0.1,0,0,0");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("219 scans, 37343 samples (41446 beams without a return, 51 out of range)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("beam times look wrong"), std::string::npos) << r.out;
  RunCommand("rm -rf " + Tmp("datmo_csv"));
  r = Cli("export " + Tmp("datmo.sweepscan") + " --out " + Tmp("datmo_csv"));
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream csv(Tmp("datmo_csv") + "/lidar.csv");
  std::string header, first;
  std::getline(csv, header);
  std::getline(csv, first);
  EXPECT_EQ(header, "robot_time_s,scan,beam,range_m,theta_rad,intensity");
  // The first scan's first valid beam: beam 0, 4.970 m at -3.124139 rad, intensity 47.
  EXPECT_NE(first.find(",0,0,4.9700,-3.124139,47"), std::string::npos) << first;
  double sum = 0.0;
  size_t rows = 1;
  for (std::string line; std::getline(csv, line); ++rows) sum += std::stod(line.substr(line.rfind(',') + 1));
  sum += 47.0;
  EXPECT_EQ(rows, 37343u);
  EXPECT_EQ(sum, 1755121.0);  // python3-rosbag's sum of the valid beams' intensities
}

}  // namespace
