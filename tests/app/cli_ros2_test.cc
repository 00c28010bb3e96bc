// `sweepscan-cli import` and `info BAG` on ROS 2 bags written by independent
// writers from simulated drives with ground truth
// (tests/tools/session_to_ros2.mjs: @foxglove/rosmsg2-serialization's CDR,
// @mcap/core's McapWriter with zstd or lz4 chunks, a rosbag2 sqlite3 folder
// by Python's sqlite3): the same drive as cli_ros_test.cc's ROS 1 bags, so
// the same cloud. Needs node and tests/tools/node_modules
// (scripts/install-test-tools.sh).
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
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

// Rows of a CSV file of export, less its header: one ROS message each.
int CsvRows(const std::string& path) {
  const std::string text = ReadFile(path);
  return static_cast<int>(std::count(text.begin(), text.end(), '\n')) - 1;
}

// The three ROS 2 storages the tests write, as NAME_<storage> in Tmp().
struct Storage {
  const char* name;     // zstd, lz4, sqlite
  const char* bag;      // the bag's name after NAME_
  const char* options;  // session_to_ros2.mjs options
  const char* format;   // what import and info call it
};
const Storage kStorages[] = {
    {"zstd", "zstd.mcap", "--compression zstd", "mcap"},
    {"lz4", "lz4.mcap", "--compression lz4", "mcap"},
    {"sqlite", "sqlite", "--format sqlite", "rosbag2-sqlite3"},
};
std::string Bag(const std::string& name, const Storage& s) { return Tmp(name + "_" + s.bag); }

// Simulates SCENARIO into a native session, then writes the same drive as
// ROS 2 bags with session_to_ros2.mjs in each storage of STORAGES.
void SimulateAndWriteBags(const std::string& scenario, const std::string& name,
                          const std::vector<Storage>& storages) {
  CommandRun r = Cli("simulate --scenario " + Source("resources/scenarios/" + scenario + ".json") + " --out " +
                     Tmp(name + ".ply") + " --session " + Tmp(name + ".sweepscan") + " --overwrite");
  ASSERT_EQ(r.code, 0) << r.out;
  RunCommand("rm -rf " + Tmp(name + "_csv"));
  r = Cli("export " + Tmp(name + ".sweepscan") + " --out " + Tmp(name + "_csv"));
  ASSERT_EQ(r.code, 0) << r.out;
  for (const Storage& s : storages) {
    RunCommand("rm -rf " + Bag(name, s));
    r = RunCommand(std::string(SWEEPSCAN_NODE) + " " + Source("tests/tools/session_to_ros2.mjs") + " " +
                   Tmp(name + "_csv") + " " + Tmp(name + ".sweepscan/meta.json") + " " + Bag(name, s) + " " +
                   s.options + " --python " + SWEEPSCAN_PYTHON3);
    ASSERT_EQ(r.code, 0) << r.out << "\n(tests/tools/node_modules missing? run scripts/install-test-tools.sh)";
  }
}

CommandRun Import(const std::string& bag, const std::string& session, const std::string& extra = "") {
  RunCommand("rm -rf " + session);
  return Cli("import " + bag + " --out " + session + " " + extra);
}

class CliRos2Test : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SimulateAndWriteBags("lab", "lab", {std::begin(kStorages), std::end(kStorages)});
    ASSERT_EQ(Cli("reconstruct " + Tmp("lab.sweepscan") + " --out " + Tmp("native.ply")).code, 0);
  }
  static void TearDownTestSuite() { RunCommand("rm -rf " + Tmp("")); }
};

// Each storage's bag, imported, gives the native session's cloud: the same
// points in the same order, each within the test writer's binning (0.05 deg
// bins: 0.025 deg at most, 2.2 mm at 5 m), as the ROS 1 bags do
// (cli_ros_test.cc); and the three give the same PLY to the byte.
TEST_F(CliRos2Test, EveryStorageGivesTheNativeCloud) {
  std::vector<sweepscan::CloudPoint> native;
  ASSERT_TRUE(sweepscan::LoadCloud(Tmp("native.ply"), &native).ok());
  ASSERT_GT(native.size(), 200000u);
  std::string first;
  for (const Storage& s : kStorages) {
    SCOPED_TRACE(s.name);
    const std::string session = Tmp(std::string("imported_") + s.name + ".sweepscan");
    CommandRun r = Import(Bag("lab", s), session, "--json");
    ASSERT_EQ(r.code, 0) << r.out;
    const nlohmann::json report = nlohmann::json::parse(r.out);
    EXPECT_EQ(report["format"], s.format);
    EXPECT_EQ(report["topics"]["scan"], "/scan");
    EXPECT_EQ(report["topics"]["odometry"], "/odom");
    EXPECT_EQ(report["topics"]["imu"], "/imu/data");
    EXPECT_EQ(report["mount"]["source"], "tf: base_footprint -> laser");
    EXPECT_EQ(report["imu_mount"], "tf: base_footprint -> imu_link");
    EXPECT_EQ(report["out_of_order"], 0);
    r = Cli("reconstruct " + session + " --out " + session + ".ply --json");
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_EQ(nlohmann::json::parse(r.out)["samples_without_pose"], 0);

    std::vector<sweepscan::CloudPoint> imported;
    ASSERT_TRUE(sweepscan::LoadCloud(session + ".ply", &imported).ok());
    ASSERT_EQ(imported.size(), native.size());
    EXPECT_TRUE(sweepscan::testing::SameCloudWithinBinning(native, imported));

    const std::string cloud = ReadFile(session + ".ply");
    if (first.empty()) {
      first = cloud;
    } else {
      EXPECT_TRUE(cloud == first) << "the PLY differs from the " << kStorages[0].name << " bag's";
    }
  }
}

TEST_F(CliRos2Test, InfoDescribesTheMcap) {
  CommandRun r = Cli("info " + Bag("lab", kStorages[0]) + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["format"], "mcap");
  EXPECT_EQ(j["compression"], "zstd");
  std::map<std::string, int> counts;
  for (const auto& t : j["topics"]) {
    counts[t["topic"]] = t["messages"];
    EXPECT_EQ(t["serialization"], "cdr") << t;
    EXPECT_TRUE(t["sweepscan_reads"].get<bool>()) << t;
  }
  // The native session's records, one message each (export's CSV rows).
  const int wheels = CsvRows(Tmp("lab_csv/wheels.csv")), imu = CsvRows(Tmp("lab_csv/imu.csv"));
  ASSERT_GT(wheels, 2000);
  EXPECT_EQ(counts["/odom"], wheels);
  EXPECT_EQ(counts["/tf"], wheels);
  EXPECT_EQ(counts["/imu/data"], imu);
  EXPECT_GT(counts["/scan"], 350);
  EXPECT_EQ(counts["/tf_static"], 1);
  EXPECT_EQ(counts.size(), 5u);
  EXPECT_EQ(j["messages"], counts["/odom"] + counts["/tf"] + counts["/imu/data"] + counts["/scan"] + 1);
  EXPECT_EQ(j["tf"], nlohmann::json::array({"base_footprint -> imu_link (static)", "base_footprint -> laser (static)",
                                            "odom -> base_footprint"}));
  r = Cli("info " + Bag("lab", kStorages[0]));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("/scan                        sensor_msgs/msg/LaserScan"), std::string::npos) << r.out;
  r = Cli("info " + Bag("lab", kStorages[1]) + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["compression"], "lz4");
}

// A recording cut short (the robot lost power): import keeps what the file
// holds and says, in its report, where the file ended and what was lost;
// info says it too. A folder without metadata.yaml holding one .mcap (a
// bag copied without its metadata) is a bag, as docs/ros-bags.md says.
TEST_F(CliRos2Test, ACutMcapSaysWhatWasLostAndAFolderWithOneMcapIsABag) {
  const std::string full = ReadFile(Bag("lab", kStorages[1]));
  const std::string cut = Tmp("lab_cut.mcap");
  std::ofstream(cut, std::ios::binary)
      .write(full.data(), static_cast<std::streamsize>(full.size() * 6 / 10));
  CommandRun r = Import(cut, Tmp("cut.sweepscan"), "--json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json report = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  std::string said;
  for (const auto& w : report["warnings"]) said += w.get<std::string>() + "\n";
  EXPECT_NE(said.find(cut + ": file ends at byte " + std::to_string(full.size() * 6 / 10)),
            std::string::npos)
      << said;
  // Once, though the import reads the bag in four passes.
  EXPECT_EQ(said.find("file ends at byte"), said.rfind("file ends at byte")) << said;
  EXPECT_GT(report["scans"].get<int>(), 100);
  r = Cli("info " + cut);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("warning: " + cut + ": file ends at byte"), std::string::npos) << r.out;
  // --strict refuses it, as it refuses a damaged session; it was exit 0.
  r = Cli("info " + cut + " --strict");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("sweepscan-cli: error: " + cut + ": damaged (--strict)\n"),
            std::string::npos)
      << r.out;
  r = Cli("info " + Bag("lab", kStorages[1]) + " --strict");
  EXPECT_EQ(r.code, 0) << r.out;
  // A byte of the summary section changed, the messages intact: described
  // by scanning, with a warning, and refused by --strict (it was exit 0:
  // the message read stops at Data End and never sees the summary). The
  // footer (29 bytes, then the 8-byte magic) holds summary_start.
  std::string flipped = full;
  uint64_t summary_start = 0;
  std::memcpy(&summary_start, flipped.data() + flipped.size() - 37 + 9, 8);
  ASSERT_GT(summary_start, 8u);
  ASSERT_LT(summary_start + 12, flipped.size() - 37);
  flipped[summary_start + 12] ^= 0x01;
  const std::string bad_summary = Tmp("lab_bad_summary.mcap");
  std::ofstream(bad_summary, std::ios::binary)
      .write(flipped.data(), static_cast<std::streamsize>(flipped.size()));
  r = Cli("info " + bad_summary);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("CRC-32 does not match the footer's; scanning the file instead"),
            std::string::npos)
      << r.out;
  r = Cli("info " + bad_summary + " --strict");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find(bad_summary + ": damaged (--strict)"), std::string::npos) << r.out;

  const std::string folder = Tmp("copied_bag");
  RunCommand("rm -rf " + folder + " && mkdir -p " + folder + " && cp " + Bag("lab", kStorages[1]) +
             " " + folder);
  r = Import(folder, Tmp("copied.sweepscan"), "--json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["format"], "mcap");

  // Rates: a bag without a summary section is scanned, which gives each
  // topic's span; a summary counts a channel's messages but gives no times:
  // no rate rather than 0 Hz.
  r = Cli("info " + Source("tests/data/ros2/ros2_lz4_nosummary.mcap") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  int rated = 0;
  const nlohmann::json scanned = nlohmann::json::parse(r.out);
  for (const auto& t : scanned["topics"]) {
    if (t["messages"].get<int>() < 2) continue;
    ASSERT_TRUE(t["rate_hz"].is_number()) << t;
    EXPECT_GT(t["rate_hz"].get<double>(), 0.0) << t;
    ++rated;
  }
  EXPECT_GT(rated, 0) << r.out;
  r = Cli("info " + Bag("lab", kStorages[0]) + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json summarized = nlohmann::json::parse(r.out);
  for (const auto& t : summarized["topics"]) EXPECT_TRUE(t["rate_hz"].is_null()) << t;
}

// A valid MCAP whose chunks are not in log-time order (the spec allows it;
// here @mcap/core rewrote the bag with blocks of messages swapped, so
// chunks go back in time and overlap): the messages are read in log-time
// order, and the cloud is the in-order bag's to the byte. Before, the
// import stopped: "the clock jumped back".
TEST_F(CliRos2Test, ChunksOutOfLogTimeOrderGiveTheSameCloud) {
  const std::string shuffled = Tmp("lab_shuffled.mcap");
  CommandRun r = RunCommand("cd " + Source("tests/tools") + " && " + SWEEPSCAN_NODE +
                            " --input-type=module - " + Bag("lab", kStorages[0]) + " " + shuffled +
                            " 700 < " + Source("tests/core/io/ros2/mcap_out_of_order.mjs"));
  ASSERT_EQ(r.code, 0) << r.out;
  std::string cloud[2];
  int k = 0;
  for (const std::string& bag : {Bag("lab", kStorages[0]), shuffled}) {
    const std::string session = Tmp("order_" + std::to_string(k) + ".sweepscan");
    r = Import(bag, session, "--json");
    ASSERT_EQ(r.code, 0) << r.out;
    const nlohmann::json report = nlohmann::json::parse(r.out);
    EXPECT_EQ(report["out_of_order"], 0);
    EXPECT_TRUE(report["warnings"].empty()) << r.out;
    ASSERT_EQ(Cli("reconstruct " + session + " --out " + session + ".ply").code, 0);
    cloud[k++] = ReadFile(session + ".ply");
  }
  ASSERT_GT(cloud[0].size(), 1000000u);
  EXPECT_TRUE(cloud[0] == cloud[1]);
}

// A recording torn before its first sensor message: the refusal ("no
// LaserScan ... topic") says where the file ends, the reason there is none.
TEST_F(CliRos2Test, AnMcapTornBeforeItsSensorsSaysWhere) {
  const std::string full = ReadFile(Bag("lab", kStorages[1]));
  const std::string cut = Tmp("lab_torn_early.mcap");
  std::ofstream(cut, std::ios::binary).write(full.data(), 300);
  const CommandRun r = Import(cut, Tmp("torn_early.sweepscan"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("no sensor_msgs/LaserScan"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(cut + ": file ends at byte 300"), std::string::npos) << r.out;
}

// A .db3 cut short (sqlite: "database disk image is malformed") imports
// the messages sqlite can still read, and says the file is damaged; the
// bag's metadata.yaml names the bag as its folder does (as in the app).
TEST_F(CliRos2Test, ATruncatedDb3ImportsWhatItHoldsAndMetadataYamlNamesItsBag) {
  const std::string folder = Bag("lab", kStorages[2]);
  CommandRun r = Import(folder + "/metadata.yaml", Tmp("by_yaml.sweepscan"), "--json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json whole = nlohmann::json::parse(r.out);
  EXPECT_EQ(whole["format"], "rosbag2-sqlite3");
  EXPECT_EQ(whole["bag"], folder);

  const std::string cut = Tmp("lab_cut.db3");
  r = RunCommand("cp " + folder + "/*.db3 " + cut);
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string bytes = ReadFile(cut);
  std::ofstream(cut, std::ios::binary | std::ios::trunc)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size() * 6 / 10));
  r = Import(cut, Tmp("cut_db3.sweepscan"), "--json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json report = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  std::string said;
  for (const auto& w : report["warnings"]) said += w.get<std::string>() + "\n";
  EXPECT_NE(said.find(cut + ": the database is damaged or truncated (sqlite: "), std::string::npos)
      << said;
  EXPECT_GT(report["scans"].get<int>(), whole["scans"].get<int>() / 3);
  EXPECT_LT(report["scans"].get<int>(), whole["scans"].get<int>());
  // Its damage is found only by reading the messages, as --strict does.
  r = Cli("info " + cut + " --strict");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find(": the database is damaged or truncated (sqlite: "), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("sweepscan-cli: error: " + cut + ": damaged (--strict)\n"),
            std::string::npos)
      << r.out;
  r = Cli("info " + folder + " --strict");
  EXPECT_EQ(r.code, 0) << r.out;
}

// `info BAG --strict` refuses damage, not an intact bag's warnings: a topic
// in another serialization format (here /tf said to be 'ros1') is skipped
// with a warning, and the bag is whole. It was refused as damaged.
TEST(CliRos2StrictTest, AnIntactBagsWarningsAreNotDamage) {
  const std::string bag = Tmp("ros1_tf_bag");
  CommandRun r = RunCommand(
      "rm -rf " + bag + " && cp -r " + Source("tests/data/ros2/sqlite_bag") + " " + bag + " && " +
      SWEEPSCAN_PYTHON3 +
      " -c \"import sqlite3, sys; c = sqlite3.connect(sys.argv[1]); "
      "c.execute(\\\"UPDATE topics SET serialization_format = 'ros1' WHERE name = '/tf'\\\"); "
      "c.commit()\" " +
      bag + "/sqlite_bag_0.db3");
  ASSERT_EQ(r.code, 0) << r.out;
  r = Cli("info " + bag + " --strict");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("topic /tf (tf2_msgs/msg/TFMessage) is in serialization format 'ros1'"),
            std::string::npos)
      << r.out;
  RunCommand("rm -rf " + bag);
}

class CliRos2CalibrationTest : public ::testing::Test {
 protected:
  static void TearDownTestSuite() { RunCommand("rm -rf " + Tmp("")); }
};

// The automatic calibration on an imported three-turn circle (MCAP) finds
// the scenario's hidden mounting error as it does on the native session.
TEST_F(CliRos2CalibrationTest, AutomaticCalibrationOnAnImportedCircle) {
  SimulateAndWriteBags("lab_circle_three_turns", "circle", {kStorages[0]});
  CommandRun r = Import(Bag("circle", kStorages[0]), Tmp("circle_imported.sweepscan"));
  ASSERT_EQ(r.code, 0) << r.out;
  r = Cli("calibrate " + Tmp("circle_imported.sweepscan") + " --auto --out " + Tmp("circle_cal.json") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ExpectScenarioMountingError(j, "lab_circle_three_turns", r.out);
}

}  // namespace
