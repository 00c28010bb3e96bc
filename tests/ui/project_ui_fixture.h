// The project UI tests' fixture (tests/ui/project_ui_test.cc,
// project_anchor_ui_test.cc): the office floor's three drives recorded
// once a binary, a fresh project of them made by the CLI, and the event
// loop watched while the project's job runs.
#ifndef SWEEPSCAN_TESTS_UI_PROJECT_UI_FIXTURE_H_
#define SWEEPSCAN_TESTS_UI_PROJECT_UI_FIXTURE_H_

#include <gtest/gtest.h>

#include <QString>
#include <string>

#include "tests/testing/event_loop_turns.h"
#include "tests/testing/run_command.h"
#include "tests/ui/app_fixture.h"
#include "ui/main_window.h"
#include "ui/project/project_controller.h"

namespace sweepscan::testing {

// The most GUI-thread CPU time one event-loop turn may take while a
// project's job runs: a software-rendered frame of a session's cloud.
constexpr double kFrameCpuBoundMs = 400.0;

// The three drives recorded once for the whole binary (OfficeFloorAppFixture).
class ProjectUiFixture : public OfficeFloorAppFixture {
 protected:
  // A fresh project of a, b, c (a the anchor, the others unplaced), made
  // by the CLI beside the sessions.
  QString MakeProject(const std::string& name) {
    const std::string file = Dir() + "/" + name + ".sweepscan-project";
    const std::string cli = SWEEPSCAN_CLI;
    const auto run =
        RunCommand("cd " + Dir() + " && rm -f " + file + " && " + cli + " project new " + file +
                   " a.sweepscan && " + cli + " project add " + file + " b.sweepscan c.sweepscan");
    EXPECT_EQ(run.code, 0) << run.out;
    return QString::fromStdString(file);
  }

  ui::ProjectController* project() { return window_->project(); }

  // Runs the event loop while the project's job runs, measuring its turns
  // (tests/testing/event_loop_turns.h).
  EventLoopTurns TurnsWhileBusy(int timeout_ms) {
    const EventLoopTurns t = MeasureTurnsUntil([&] { return !project()->busy(); }, timeout_ms);
    EXPECT_TRUE(t.done) << "still busy after " << timeout_ms << " ms";
    return t;
  }
};

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_UI_PROJECT_UI_FIXTURE_H_
