// The desktop app's --orbit-benchmark, which scripts/gui-bench.sh and
// docs/performance.md read: run on a simulated session and on a project of
// two simulated sessions, its JSON line against what the app was given
// (the points the simulator wrote, the view's budgets). Not timed: the
// figures are only checked to be there and sane.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "tests/testing/remove_at_exit.h"
#include "tests/testing/run_command.h"

namespace {

using sweepscan::testing::RunCommand;

const std::string& Dir() {
  static const std::string dir = sweepscan::testing::RemoveAtExit(
      "/tmp/sweepscan_gui_benchmark_test_" + std::to_string(getpid()));
  return dir;
}

// The vertex count of a PLY's header (what the simulator wrote).
size_t PlyVertices(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream words(line);
    std::string a, b;
    size_t n = 0;
    if (words >> a >> b >> n && a == "element" && b == "vertex") return n;
  }
  return 0;
}

// Simulates `scenario` into DIR/NAME.sweepscan (and DIR/NAME.ply); returns
// its points.
size_t Simulate(const std::string& scenario, const std::string& name) {
  const auto r = RunCommand(std::string(SWEEPSCAN_CLI) +
                            " simulate --scenario " SWEEPSCAN_SOURCE_DIR "/resources/scenarios/" +
                            scenario + " --out " + Dir() + "/" + name + ".ply --session " + Dir() +
                            "/" + name + ".sweepscan --overwrite");
  EXPECT_EQ(r.code, 0) << r.out;
  return PlyVertices(Dir() + "/" + name + ".ply");
}

// The app's JSON line (its last line that is one; stderr is left out).
nlohmann::json Benchmark(const std::string& args) {
  const auto r = RunCommand("(" + std::string(SWEEPSCAN_GUI) + " " + args + " 2>/dev/null)");
  EXPECT_EQ(r.code, 0) << r.out;
  std::istringstream lines(r.out);
  std::string line, last;
  while (std::getline(lines, line)) {
    if (!line.empty() && line.front() == '{') last = line;
  }
  nlohmann::json j = nlohmann::json::parse(last, nullptr, false);
  EXPECT_TRUE(j.is_object()) << r.out;
  return j.is_object() ? j : nlohmann::json::object();
}

void ExpectOrbitAndRestFigures(const nlohmann::json& j) {
  EXPECT_GT(j.value("fps_full", 0.0), 0.0);
  EXPECT_GT(j.value("fps_lod", 0.0), 0.0);
  EXPECT_GT(j.value("open_and_show_s", 0.0), 0.0);
  ASSERT_TRUE(j.contains("rest_passes") && j.contains("memory"));
  EXPECT_GE(j["rest_passes"].value("passes", 0), 1);
  EXPECT_GT(j.value("pick_hits_of_25", 0), 0);  // The picks land on the room.
  EXPECT_GT(j.value("rss_mib", 0.0), 100.0);
  EXPECT_GT(j["memory"].value("peak_rss_mib", 0.0), 0.0);
}

TEST(OrbitBenchmarkTest, ASessionsFiguresCountTheCloudItWasGiven) {
  if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no display (run under xvfb-run)";
  sweepscan::testing::ShellOrFail("mkdir -p " + Dir());
  const size_t points = Simulate("lab.json", "lab");
  ASSERT_GT(points, 100000u);
  const nlohmann::json j = Benchmark(
      "--replay " + Dir() + "/lab.sweepscan --speed 0 --orbit-benchmark 6 --lod-budget 20000");
  ASSERT_TRUE(j.is_object());
  EXPECT_EQ(j.value("points", size_t{0}), points);  // Every point given is in the view.
  // The rest level within the cloud, the motion level within its budget.
  EXPECT_GT(j.value("rest_points", size_t{0}), points / 2);
  EXPECT_LE(j.value("rest_points", size_t{0}), points);
  EXPECT_GT(j.value("lod_points", size_t{0}), 10000u);
  EXPECT_LE(j.value("lod_points", size_t{0}), 20000u);
  ExpectOrbitAndRestFigures(j);
  ASSERT_TRUE(j.contains("click_to_highlight_ms") && j.contains("zoomed"));
  EXPECT_GT(j["click_to_highlight_ms"].value("clicks", 0), 0);
  EXPECT_GT(j["zoomed"].value("spot_points", 0), 0);  // The far wall's spot is drawn.
}

TEST(OrbitBenchmarkTest, AProjectsFiguresCountItsPlacedSessions) {
  if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no display (run under xvfb-run)";
  sweepscan::testing::ShellOrFail("mkdir -p " + Dir());
  const size_t a = Simulate("building_a.json", "building_a");
  const size_t b = Simulate("building_b.json", "building_b");
  const std::string project = Dir() + "/floor.sweepscan-project";
  const std::string cli = SWEEPSCAN_CLI;
  sweepscan::testing::ShellOrFail(
      cli + " project new " + project + " " + Dir() + "/building_a.sweepscan " + Dir() +
      "/building_b.sweepscan > /dev/null && " + cli +
      " project align --session building_b --to building_a " + project + " > /dev/null 2>&1");
  // A rest budget above both sessions: every point drawn at rest.
  const nlohmann::json j = Benchmark(
      "--project " + project + " --orbit-benchmark 6 --rest-budget 2000000 --lod-budget 30000");
  ASSERT_TRUE(j.is_object());
  EXPECT_EQ(j.value("sessions", 0), 2);
  EXPECT_EQ(j.value("points", size_t{0}), a + b);
  EXPECT_EQ(j.value("rest_points", size_t{0}), a + b);
  // The motion level: the sessions' shares of the LOD budget (at most a
  // point more a piece of 65 536 for rounding).
  EXPECT_GT(j.value("lod_points", size_t{0}), 20000u);
  EXPECT_LE(j.value("lod_points", size_t{0}), 30000u + (a + b) / 65536 + 2);
  ExpectOrbitAndRestFigures(j);
  EXPECT_FALSE(j.contains("lod_level"));  // The session cloud's grid: none here.
  EXPECT_EQ(j["memory"].value("layer_vtk_points", size_t{0}),
            j.value("points", size_t{0}) + j.value("lod_points", size_t{0}));
}

// A project none of whose sessions can be drawn (the anchor's folder is
// gone) gives no figures: said, exit 1, and no hang.
TEST(OrbitBenchmarkTest, AProjectWithNothingToDrawIsRefused) {
  if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no display (run under xvfb-run)";
  sweepscan::testing::ShellOrFail("mkdir -p " + Dir());
  Simulate("lab.json", "gone");
  const std::string project = Dir() + "/gone.sweepscan-project";
  sweepscan::testing::ShellOrFail(std::string(SWEEPSCAN_CLI) + " project new " + project + " " +
                                  Dir() + "/gone.sweepscan > /dev/null && rm -rf " + Dir() +
                                  "/gone.sweepscan");
  const auto r =
      RunCommand(std::string(SWEEPSCAN_GUI) + " --project " + project + " --orbit-benchmark 6");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("--orbit-benchmark: 0 of the project's 1 placed, visible sessions drawn"),
            std::string::npos)
      << r.out;
}

// Nothing to measure: refused at once, not a wait without end.
TEST(OrbitBenchmarkTest, WithoutASessionOrAProjectItIsRefused) {
  if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no display (run under xvfb-run)";
  const auto r = RunCommand(std::string(SWEEPSCAN_GUI) + " --orbit-benchmark 6");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--orbit-benchmark measures --replay SESSION or --project FILE"),
            std::string::npos)
      << r.out;
}

}  // namespace
