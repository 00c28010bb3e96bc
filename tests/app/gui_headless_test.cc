// The desktop app asked for help, its version or to start on a machine with
// no display (an operator over ssh): answers without Qt's platform-plugin
// abort. Runs the real binary with the display variables removed.
#include <gtest/gtest.h>

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

}  // namespace
