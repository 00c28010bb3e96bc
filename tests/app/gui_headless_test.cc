// The desktop app asked for help, its version or to start on a machine with
// no display (an operator over ssh): answers without Qt's platform-plugin
// abort. Runs the real binary with the display variables removed.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "tests/testing/run_command.h"

namespace {

sweepscan::testing::CommandRun Headless(const std::string& args) {
  return sweepscan::testing::RunCommand("env -u DISPLAY -u WAYLAND_DISPLAY -u QT_QPA_PLATFORM " +
                                        std::string(SWEEPSCAN_GUI) + " " + args);
}

TEST(GuiHeadlessTest, HelpAndVersionNeedNoDisplay) {
  auto r = Headless("--help");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("--simulate"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("platform plugin"), std::string::npos) << r.out;
  r = Headless("--version");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out, "sweepscan 0.1.0\n");
}

TEST(GuiHeadlessTest, StartingWithoutADisplaySaysSoInOneLine) {
  const auto r = Headless("--simulate");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_EQ(r.out,
            "sweepscan: no display (DISPLAY is not set): run it on a desktop, over ssh -X, or under "
            "xvfb-run; sweepscan-cli does the processing without one\n");
}

// A number option that is not a number is refused by name, before anything
// starts: "--memory-budget 2G" was read as a zero-byte budget (every chunk
// paged out); "--speed fast" was as fast as possible, "--orbit-benchmark abc"
// one frame, and a --plan-height of 0 silently the last cut. Needs a display
// (QApplication parses the options).
TEST(GuiHeadlessTest, ANumberOptionThatIsNotANumberIsRefusedByName) {
  if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no display (run under xvfb-run)";
  const std::string gui = SWEEPSCAN_GUI;
  for (const std::string& bad :
       {std::string("--memory-budget 2G"), std::string("--rest-budget lots"),
        std::string("--quit-after -3"), std::string("--speed fast"), std::string("--speed -5"),
        std::string("--orbit-benchmark abc"), std::string("--orbit-benchmark 0"),
        std::string("--plan-height 0"), std::string("--plan-height 12")}) {
    const auto r = sweepscan::testing::RunCommand(gui + " " + bad);
    EXPECT_EQ(r.code, 2) << bad << ": " << r.out;
    const std::string option = bad.substr(0, bad.find(' '));
    const std::string value = bad.substr(bad.find(' ') + 1);
    EXPECT_NE(
        r.out.find("sweepscan: " + option + " '" + value + "' is not a number the option takes"),
        std::string::npos)
        << r.out;
  }
}

// `sweepscan PATH` opens what it names (it was ignored without a word): a
// session as File > Open Session; a folder that is none is said; two paths,
// or a PATH beside --replay, are refused. --export-cloud beside --project
// writes the project's cloud.
TEST(GuiHeadlessTest, APathOnTheCommandLineIsOpened) {
  if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no display (run under xvfb-run)";
  const std::string gui = SWEEPSCAN_GUI;
  auto r = sweepscan::testing::RunCommand(gui + " a.sweepscan b.sweepscan");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("one PATH to open"), std::string::npos) << r.out;
  const std::string dir = "/tmp/sweepscan_gui_path_test";
  sweepscan::testing::ShellOrFail("rm -rf " + dir + " && mkdir -p " + dir + "/photos");
  r = sweepscan::testing::RunCommand(gui + " " + dir + "/photos --quit-after 2");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("photos is not a sweepscan session"), std::string::npos) << r.out;
  r = sweepscan::testing::RunCommand(std::string(SWEEPSCAN_CLI) +
                                     " simulate --scenario " SWEEPSCAN_SOURCE_DIR
                                     "/resources/scenarios/lab.json --out " +
                                     dir + "/lab.ply");
  ASSERT_EQ(r.code, 0) << r.out;
  r = sweepscan::testing::RunCommand(gui + " " + dir + "/lab.sweepscan --quit-after 20");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("\"session\":\"" + dir + "/lab.sweepscan\""), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"last_error\":\"\""), std::string::npos) << r.out;

  // --export-cloud with a project and no session writes the project's
  // cloud, as File > Export Cloud does then: what `project export` writes,
  // byte for byte.
  const std::string cli = SWEEPSCAN_CLI;
  sweepscan::testing::ShellOrFail(cli + " project new " + dir + "/p.sweepscan-project " + dir +
                                  "/lab.sweepscan");
  sweepscan::testing::ShellOrFail(cli + " project export " + dir + "/p.sweepscan-project --out " +
                                  dir + "/cli.las");
  r = sweepscan::testing::RunCommand(gui + " --project " + dir +
                                     "/p.sweepscan-project --quit-after 5 --export-cloud " + dir +
                                     "/app.las");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(sweepscan::testing::RunCommand("cmp " + dir + "/cli.las " + dir + "/app.las").code, 0);
  sweepscan::testing::ShellOrFail("rm -rf " + dir);
}

}  // namespace
