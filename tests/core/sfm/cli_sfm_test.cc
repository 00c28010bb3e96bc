// `sweepscan-cli p3l` as a script would run it: the issue's JSON in, the
// issue's JSON out, degenerate problems exit 2 with one line.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "core/cloud/cloud_io.h"
#include "core/pose/pose_estimator.h"
#include "core/sfm/synthetic.h"
#include "tests/testing/run_command.h"

namespace sweepscan::sfm {
namespace {

testing::CommandRun Cli(const std::string& args) {
  return testing::RunCommand(std::string(SWEEPSCAN_CLI) + " " + args + " 2>/dev/null");
}
testing::CommandRun CliWithErrors(const std::string& args) {
  return testing::RunCommand(std::string(SWEEPSCAN_CLI) + " " + args);
}
std::string Tmp(const std::string& name) { return ::testing::TempDir() + "/sweepscan_p3l_" + name; }

nlohmann::json ProblemJson(const SyntheticProblem& sp) {
  nlohmann::json planes = nlohmann::json::array(), lines = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) {
    const WorldPlane& p = sp.planes[i];
    planes.push_back({{"normal", {p.normal.x(), p.normal.y(), p.normal.z()}}, {"d", p.d}});
    nlohmann::json line = nlohmann::json::array();
    for (const Eigen::Vector3d& q : sp.lines[i].points) line.push_back({q.x(), q.y(), q.z()});
    lines.push_back(line);
  }
  return {{"planes", planes}, {"lines", lines}};
}

TEST(CliP3lTest, SolvesTheIssuesFormat) {
  std::mt19937_64 rng(21);
  for (int k = 0; k < 5; ++k) {
    const SyntheticProblem sp = MakeSyntheticProblem({}, &rng);
    const std::string path = Tmp("problem.json");
    std::ofstream(path) << ProblemJson(sp).dump(2);
    const testing::CommandRun r = Cli("p3l " + path);
    ASSERT_EQ(r.code, 0) << r.out;
    const nlohmann::json out = nlohmann::json::parse(r.out);
    ASSERT_EQ(out.size(), 1u);
    ASSERT_TRUE(out["solutions"].is_array());
    bool found = false;
    for (const nlohmann::json& s : out["solutions"]) {
      ASSERT_EQ(s.size(), 2u);
      Eigen::Matrix3d R;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) R(a, b) = s["R"][a][b].get<double>();
      const Eigen::Vector3d t(s["t"][0].get<double>(), s["t"][1].get<double>(), s["t"][2].get<double>());
      if ((R - sp.R_true).cwiseAbs().maxCoeff() < 1e-6 && (t - sp.t_true).cwiseAbs().maxCoeff() < 1e-6) found = true;
    }
    EXPECT_TRUE(found) << r.out;
  }
}

// The hand-checked corner of tests/core/sfm/p3l_test.cc, written out.
TEST(CliP3lTest, HandWrittenCorner) {
  const std::string path = Tmp("corner.json");
  std::ofstream(path) << R"({"planes": [{"normal": [1, 0, 0], "d": -1}, {"normal": [0, 1, 0], "d": -1},
                                       {"normal": [0, 0, 1], "d": -1}, {"normal": [0, 0, -1], "d": -1}],
                            "lines": [[[0.8, 0.3, -0.1], [0.8, 1.3, 1.9]], [[0.3, 1.3, -0.1], [1.8, 1.3, 0.9]],
                                      [[-0.2, -0.7, 0.9], [0.8, 1.3, 0.9]], [[0, 0, -1.1], [1, 0.5, -1.1]]]})";
  const testing::CommandRun r = Cli("p3l " + path);
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json s = nlohmann::json::parse(r.out)["solutions"][0];  // the 4th pair ranks it first
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) EXPECT_NEAR(s["R"][a][b].get<double>(), a == b ? 1.0 : 0.0, 1e-9);
  EXPECT_NEAR(s["t"][0].get<double>(), 0.2, 1e-9);
  EXPECT_NEAR(s["t"][1].get<double>(), -0.3, 1e-9);
  EXPECT_NEAR(s["t"][2].get<double>(), 0.1, 1e-9);
}

TEST(CliP3lTest, DegenerateAndBadInputExitTwoWithOneLine) {
  const std::string path = Tmp("bad.json");
  auto expect_one_line = [&](const std::string& doc, const std::string& needle) {
    std::ofstream(path) << doc;
    const testing::CommandRun r = CliWithErrors("p3l " + path);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
    EXPECT_NE(r.out.find(needle), std::string::npos) << r.out;
  };
  expect_one_line(R"({"planes": [{"normal": [1, 0, 0], "d": -1}, {"normal": [1, 0, 0], "d": 1},
      {"normal": [0, 0, 1], "d": -1}], "lines": [[[0, 0, 0], [0, 1, 0]], [[0, 0, 0], [0, 0, 1]], [[0, 0, 0], [1, 0, 0]]]})",
                  "planes[0] and planes[1] are parallel");
  expect_one_line(R"({"planes": [{"normal": [1, 0, 0], "d": -1}, {"normal": [0, 1, 0], "d": -1},
      {"normal": [0, 0, 1], "d": -1}], "lines": [[[0, 0, 0], [0, 1, 0]], [[0, 0, 3], [0, 2, 3]], [[0, 0, 0], [1, 0, 0]]]})",
                  "lines[0] and lines[1] are parallel");
  expect_one_line(R"({"planes": [{"normal": [1, 0, 0], "d": NaN}]})", "not valid JSON");
  expect_one_line(R"({"planes": [{"normal": [1, 0, 0], "d": -1}, {"normal": [0, 1, 0], "d": -1},
      {"normal": [0, 0, 1], "d": -1}], "lines": [[[0, 0, 0], [0, 1, 0]], [[0, 0, 0], [0, "x", 1]], [[0, 0, 0], [1, 0, 0]]]})",
                  "lines[1][1]: expected 3 numbers");
  expect_one_line(R"({"planes": [], "lines": []})", "planes: expected at least 3 planes");
  EXPECT_EQ(Cli("p3l").code, 2);
  EXPECT_EQ(Cli("p3l /nonexistent/problem.json").code, 2);
}

TEST(CliP3lTest, ProtocolWritesCsv) {
  const std::string csv = Tmp("protocol.csv");
  const testing::CommandRun r = Cli("p3l --protocol --trials 50 --steps 2 --noise-max 0.02 --csv " + csv);
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream in(csv);
  std::string header, row;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("noise_width_m,trials,solved,truth_found_1e-6", 0), 0u);
  std::getline(in, row);
  EXPECT_EQ(row.rfind("0,50,50,", 0), 0u) << row;  // noise-free: all 50 solved, truth among candidates
  EXPECT_EQ(row.substr(0, 11), "0,50,50,50,") << row;
}

// `sweepscan-cli sfm --rig-scenario room` on a short walk: the poses CSV,
// the planes JSON, the cloud, the initialisation file written and read back.
TEST(CliSfmTest, RoomScenario) {
  const std::string init = Tmp("sfm_init.json"), poses = Tmp("sfm_poses.csv"), planes = Tmp("sfm_planes.json"),
                    cloud = Tmp("sfm_cloud.ply");
  testing::CommandRun run = Cli("sfm --rig-scenario room --frames 120 --json --write-init " + init + " --poses " +
                                poses + " --planes " + planes + " --out " + cloud);
  ASSERT_EQ(run.code, 0) << run.out;
  const nlohmann::json out = nlohmann::json::parse(run.out);
  EXPECT_EQ(out["frames"], 120);
  EXPECT_EQ(out["scans"], 240);
  EXPECT_LT(out["refined"]["rot_mean_deg"].get<double>(), 0.5);
  EXPECT_LT(out["refined"]["trans_mean_m"].get<double>(), 0.02);
  EXPECT_EQ(out["planes_true"], out["planes"].size());
  std::ifstream csv(poses);
  std::string line;
  int rows = 0;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, 121);
  // Every point placed by the SfM says so (its pose source byte was 0, the
  // EKF's, though no EKF ran).
  std::vector<CloudPoint> points;
  ASSERT_TRUE(LoadCloud(cloud, &points).ok());
  ASSERT_GT(points.size(), 10000u);
  for (const CloudPoint& p : points)
    ASSERT_EQ(p.pose_source, static_cast<uint8_t>(PoseSource::kSfm));
  // The written initialisation reads back and gives the same run.
  run = Cli("sfm --rig-scenario room --frames 120 --json --init " + init);
  ASSERT_EQ(run.code, 0) << run.out;
  EXPECT_NEAR(nlohmann::json::parse(run.out)["refined"]["trans_mean_m"].get<double>(),
              out["refined"]["trans_mean_m"].get<double>(), 1e-9);
}

TEST(CliSfmTest, BadInputExits2) {
  const std::string init = Tmp("sfm_bad_init.json");
  std::ofstream(init) << R"({"planes": [{"normal": [1, 0, 0], "d": 0, "lines": [{"lidar": 0, "line": 0}]},
                                        {"lines": [{"lidar": 0, "line": 1}]},
                                        {"normal": [0, 0, 1], "d": 0, "lines": [{"lidar": 0, "line": 2}]}]})";
  testing::CommandRun run = CliWithErrors("sfm --rig-scenario room --frames 10 --init " + init);
  EXPECT_EQ(run.code, 2);
  EXPECT_NE(run.out.find("all three planes or for none"), std::string::npos) << run.out;
  EXPECT_EQ(CliWithErrors("sfm --rig-scenario attic").code, 2);
  EXPECT_EQ(CliWithErrors("sfm").code, 2);
}

// `sfm SESSION` and `reconstruct SESSION --pose-source sfm` on a session
// that `simulate` recorded (the lab drive, through the real bytes).
TEST(CliSfmTest, WheeledSession) {
  const std::string dir = Tmp("lab.sweepscan"), poses = Tmp("wheeled_poses.csv"), planes = Tmp("wheeled_planes.json");
  testing::CommandRun run = Cli("simulate --scenario " + std::string(SWEEPSCAN_SOURCE_DIR) +
                                "/resources/scenarios/lab.json --out " + Tmp("lab_ekf.ply") + " --session " + dir +
                                " --overwrite --json");
  ASSERT_EQ(run.code, 0) << run.out;
  run = Cli("sfm " + dir + " --out " + Tmp("lab_sfm.ply") + " --poses " + poses + " --planes " + planes + " --json");
  ASSERT_EQ(run.code, 0) << run.out;
  const nlohmann::json out = nlohmann::json::parse(run.out);
  EXPECT_EQ(out["motion_prior"], "ekf");
  const int scans = out["scans"].get<int>();
  EXPECT_GT(scans, 350);
  EXPECT_GE(out["planes"].size(), 4u);
  EXPECT_GT(out["points"].get<int>(), 200000);
  // A session has no truth; the SfM poses against the EKF's: within a
  // centimetre (both are within one of the truth on this drive).
  EXPECT_FALSE(out.contains("sfm_vs_truth"));
  EXPECT_LT(out["sfm_vs_prior"]["lateral_mean_m"].get<double>(), 0.01);
  EXPECT_LT(out["sfm_vs_prior"]["along_mean_m"].get<double>(), 0.01);
  std::ifstream csv(poses);
  std::string line;
  int rows = 0;
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("scan,time_s,x,y,z,qw,qx,qy,qz,yaw_deg,prior_x", 0), 0u) << line;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, scans);
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(planes))["planes"].size(), out["planes"].size());
  // reconstruct --pose-source sfm places every sample the EKF places.
  run = Cli("reconstruct " + dir + " --pose-source sfm --out " + Tmp("lab_rs.ply") + " --json");
  ASSERT_EQ(run.code, 0) << run.out;
  const nlohmann::json rs = nlohmann::json::parse(run.out);
  EXPECT_EQ(rs["pose_source"], "sfm");
  EXPECT_EQ(rs["sfm"]["planes"], out["planes"].size());
  run = Cli("reconstruct " + dir + " --out " + Tmp("lab_re.ply") + " --json");
  ASSERT_EQ(run.code, 0) << run.out;
  EXPECT_EQ(nlohmann::json::parse(run.out)["points"], rs["points"]);
}

TEST(CliSfmTest, WheeledBadInputExits2WithOneLine) {
  const std::string lab = std::string(SWEEPSCAN_SOURCE_DIR) + "/resources/scenarios/lab.json";
  auto expect_one_line = [](const testing::CommandRun& r, const std::string& what) {
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find(what), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find('\n'), r.out.size() - 1) << r.out;
  };
  expect_one_line(CliWithErrors("sfm " + Tmp("no_such.sweepscan") + " --out " + Tmp("x.ply")), "no_such.sweepscan");
  expect_one_line(CliWithErrors("sfm --scenario " + lab), "--out");
  expect_one_line(CliWithErrors("sfm --scenario " + lab + " --out " + Tmp("x.ply") + " --motion-prior gps"), "gps");
  expect_one_line(CliWithErrors("sfm --scenario " + lab + " --rig-scenario room --out " + Tmp("x.ply")), "one of them");
  expect_one_line(CliWithErrors("sfm --scenario " + lab + " --frames 10 --out " + Tmp("x.ply")), "--rig-scenario");
  expect_one_line(CliWithErrors("simulate --scenario " + lab + " --out " + Tmp("x.ply") + " --pose-source sfm"),
                  "pose-source");
  const std::string init = Tmp("wheeled_bad_init.json");
  std::ofstream(init) << R"({"planes": [{"lines": [{"lidar": 0, "line": 0}, {"lidar": 0, "line": 1}]},
                                        {"lines": [{"lidar": 0, "line": 1}, {"lidar": 0, "line": 2}]},
                                        {"lines": [{"lidar": 0, "line": 2}, {"lidar": 0, "line": 3}]}]})";
  expect_one_line(CliWithErrors("sfm --scenario " + lab + " --out " + Tmp("x.ply") + " --init " + init),
                  "three planes given");
}

}  // namespace
}  // namespace sweepscan::sfm
