// Long commands show their progress on a terminal (a real pseudo-terminal,
// made by util-linux's `script`) and nowhere else: one line on stderr,
// rewritten in place and cleared at the end, never in a pipe, a file or
// beside --json.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/testing/run_command.h"

namespace {

using sweepscan::testing::RunCommand;

std::string Tmp(const std::string& name) {
  return ::testing::TempDir() + "/sweepscan_progress_" + name;
}
std::string Scenario(const std::string& name) {
  return std::string(SWEEPSCAN_SOURCE_DIR) + "/resources/scenarios/" + name + ".json";
}
std::string Read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs `args` with stderr on a pseudo-terminal and stdout to a file:
// returns what the terminal showed; *stdout_text what went to the file.
std::string OnATerminal(const std::string& args, std::string* stdout_text, int* code) {
  // Each test is a process of its own (ctest runs them side by side).
  const std::string out =
      Tmp(std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + ".txt");
  const std::string command = std::string(SWEEPSCAN_CLI) + " " + args + " > " + out;
  const auto r = RunCommand("script -qec '" + command + "' /dev/null");
  *code = r.code;
  *stdout_text = Read(out);
  return r.out;
}

// The progress lines shown, in order: each "\r\033[K" starts one.
std::vector<std::string> Lines(const std::string& terminal) {
  std::vector<std::string> lines;
  const std::string start = "\r\033[K";
  for (size_t at = terminal.find(start); at != std::string::npos;) {
    const size_t next = terminal.find(start, at + start.size());
    lines.push_back(
        terminal.substr(at + start.size(),
                        (next == std::string::npos ? terminal.size() : next) - at - start.size()));
    at = next;
  }
  return lines;
}

// Where each stage's first line is, and that its percentages never fall.
size_t StageAt(const std::vector<std::string>& lines, const std::string& prefix) {
  size_t first = lines.size();
  int last = -1;
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].rfind(prefix, 0) != 0) continue;
    if (first == lines.size()) first = i;
    int percent = -1;
    EXPECT_EQ(std::sscanf(lines[i].c_str() + prefix.size(), " %d %%", &percent), 1) << lines[i];
    EXPECT_GE(percent, last) << lines[i];
    last = percent;
  }
  EXPECT_LT(first, lines.size()) << "no line '" << prefix << "'";
  return first;
}

TEST(CliProgressTest, SimulateShowsItsStagesOnATerminalAndClearsThem) {
  std::string report;
  int code = -1;
  const std::string terminal = OnATerminal(
      "simulate --scenario " + Scenario("lab") + " --out " + Tmp("lab.ply") + " --overwrite",
      &report, &code);
  ASSERT_EQ(code, 0) << terminal;
  const std::vector<std::string> lines = Lines(terminal);
  const size_t recording = StageAt(lines, "simulate lab: recording the drive");
  const size_t poses = StageAt(lines, "simulate lab: estimating the poses");
  const size_t placing = StageAt(lines, "simulate lab: placing the points");
  EXPECT_LT(recording, poses);
  EXPECT_LT(poses, placing);
  EXPECT_NE(terminal.find("simulate lab: placing the points 100 %"), std::string::npos);
  // Cleared at the end: the last is an empty line, so the report (on
  // stdout) starts on a clean one.
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines.back(), "");
  EXPECT_NE(report.find("recorded session"), std::string::npos) << report;
  EXPECT_EQ(report.find('\033'), std::string::npos);

  // With --json, on the same terminal: nothing but the JSON.
  const std::string json_terminal = OnATerminal(
      "simulate --scenario " + Scenario("lab") + " --out " + Tmp("lab.ply") + " --overwrite --json",
      &report, &code);
  ASSERT_EQ(code, 0) << json_terminal;
  EXPECT_EQ(json_terminal.find('\033'), std::string::npos);
  EXPECT_EQ(report.front(), '{');
  // --direct (no session, the simulator's records): its own three stages.
  std::string direct_report;
  const std::string direct = OnATerminal("simulate --scenario " + Scenario("lab") + " --out " +
                                             Tmp("direct.ply") + " --overwrite --direct",
                                         &direct_report, &code);
  ASSERT_EQ(code, 0) << direct;
  const std::vector<std::string> direct_lines = Lines(direct);
  const size_t simulating = StageAt(direct_lines, "simulate lab: simulating the drive");
  const size_t reconstructing = StageAt(direct_lines, "simulate lab: reconstructing the cloud");
  const size_t writing = StageAt(direct_lines, "simulate lab: writing the points");
  EXPECT_LT(simulating, reconstructing);
  EXPECT_LT(reconstructing, writing);
  EXPECT_NE(direct.find("simulate lab: simulating the drive 100 %"), std::string::npos);
  EXPECT_NE(direct.find("simulate lab: writing the points 100 %"), std::string::npos);
  ASSERT_FALSE(direct_lines.empty());
  EXPECT_EQ(direct_lines.back(), "");
  // The same cloud as without a terminal (the records made a second at a
  // time are those made at once).
  const auto quiet =
      RunCommand(std::string(SWEEPSCAN_CLI) + " simulate --scenario " + Scenario("lab") +
                 " --out " + Tmp("direct_quiet.ply") + " --overwrite --direct");
  ASSERT_EQ(quiet.code, 0) << quiet.out;
  EXPECT_EQ(Read(Tmp("direct.ply")), Read(Tmp("direct_quiet.ply")));

  // In a pipe (stderr and stdout): no progress either.
  const auto piped = RunCommand(std::string(SWEEPSCAN_CLI) + " simulate --scenario " +
                                Scenario("lab") + " --out " + Tmp("lab.ply") + " --overwrite");
  ASSERT_EQ(piped.code, 0) << piped.out;
  EXPECT_EQ(piped.out.find('\033'), std::string::npos);
}

TEST(CliProgressTest, ReconstructShowsBothPassesOnATerminal) {
  const std::string session = Tmp("rec.sweepscan");
  ASSERT_EQ(RunCommand(std::string(SWEEPSCAN_CLI) + " simulate --scenario " + Scenario("lab") +
                       " --out " + Tmp("rec.ply") + " --session " + session + " --overwrite")
                .code,
            0);
  std::string report;
  int code = -1;
  const std::string terminal =
      OnATerminal("reconstruct " + session + " --out " + Tmp("again.ply"), &report, &code);
  ASSERT_EQ(code, 0) << terminal;
  const std::vector<std::string> lines = Lines(terminal);
  const std::string title = "reconstruct " + session + ": ";
  EXPECT_LT(StageAt(lines, title + "estimating the poses"),
            StageAt(lines, title + "placing the points"));
  EXPECT_NE(terminal.find(title + "placing the points 100 %"), std::string::npos);
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines.back(), "");
  EXPECT_NE(report.find("points"), std::string::npos) << report;

  // export SESSION --out CLOUD is the same work, titled as it was asked.
  const std::string exported_cloud =
      OnATerminal("export " + session + " --out " + Tmp("again.pcd"), &report, &code);
  ASSERT_EQ(code, 0) << exported_cloud;
  EXPECT_NE(exported_cloud.find("export " + session + ": placing the points 100 %"),
            std::string::npos);
  EXPECT_EQ(exported_cloud.find("reconstruct "), std::string::npos);

  // evaluate: reading the session, then the evaluation's own stages.
  const std::string shown = OnATerminal("evaluate " + session, &report, &code);
  ASSERT_EQ(code, 0) << shown;
  const std::vector<std::string> evaluated = Lines(shown);
  const size_t read = StageAt(evaluated, "evaluate " + session + ": placing the points");
  EXPECT_LT(read, StageAt(evaluated, "evaluate uncalibrated: neighbours"));
  EXPECT_LT(StageAt(evaluated, "evaluate uncalibrated: neighbours"),
            StageAt(evaluated, "evaluate uncalibrated: planes"));
  ASSERT_FALSE(evaluated.empty());
  EXPECT_EQ(evaluated.back(), "");
  EXPECT_EQ(report.find('\033'), std::string::npos);

  // project export: each session's passes, named.
  const std::string project = Tmp("rec.sweepscan-project");
  std::remove(project.c_str());
  ASSERT_EQ(RunCommand(std::string(SWEEPSCAN_CLI) + " project new " + project + " " + session).code,
            0);
  const std::string exported =
      OnATerminal("project export " + project + " --out " + Tmp("rec.las"), &report, &code);
  ASSERT_EQ(code, 0) << exported;
  const std::vector<std::string> stages = Lines(exported);
  const std::string as = "project export " + Tmp("rec.las") + ": ";
  EXPECT_LT(StageAt(stages, as + "reading 'sweepscan_progress_rec' for the extent (1 of 1)"),
            StageAt(stages, as + "reading 'sweepscan_progress_rec' (1 of 1)"));
  ASSERT_FALSE(stages.empty());
  EXPECT_EQ(stages.back(), "");
}

}  // namespace
