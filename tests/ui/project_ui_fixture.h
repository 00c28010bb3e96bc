// The project UI tests' fixture (tests/ui/project_ui_test.cc,
// project_anchor_ui_test.cc, plan_ui_test.cc, pair_picking_ui_test.cc):
// the office floor's three drives recorded once a binary, a fresh project
// of them made by the CLI, and the event loop watched while the project's
// job runs.
#ifndef SWEEPSCAN_TESTS_UI_PROJECT_UI_FIXTURE_H_
#define SWEEPSCAN_TESTS_UI_PROJECT_UI_FIXTURE_H_

#include <gtest/gtest.h>

#include <QString>
#include <functional>
#include <memory>
#include <string>

#include "core/geometry/transform.h"
#include "core/scenario/scenario.h"
#include "tests/testing/event_loop_turns.h"
#include "tests/testing/run_command.h"
#include "tests/ui/app_fixture.h"
#include "ui/main_window.h"
#include "ui/project/project_controller.h"

namespace sweepscan::testing {

// The most GUI-thread CPU time one event-loop turn may take while a
// project's job runs: a software-rendered frame of a session's cloud.
constexpr double kFrameCpuBoundMs = 400.0;

// Where a scenario puts the robot down (resources/scenarios/), as a pose.
inline Rigid3d StartOf(const char* scenario) {
  sim::SimConfig c;
  EXPECT_TRUE(LoadScenario(kResources.toStdString() + "/scenarios/" + scenario, &c).ok());
  return Rigid3d::FromPose(c.start.x, c.start.y, 0, 0, 0, c.start.yaw);
}

// The three drives recorded once for the whole binary (OfficeFloorAppFixture).
class ProjectUiFixture : public OfficeFloorAppFixture {
 protected:
  // A fresh project of a, b, c (a the anchor, the others unplaced), made
  // by the CLI beside the sessions; `then` is a CLI command run on it after
  // (e.g. "project align --session b --to a").
  QString MakeProject(const std::string& name, const std::string& then = "") {
    const std::string file = Dir() + "/" + name + ".sweepscan-project";
    const std::string cli = SWEEPSCAN_CLI;
    const auto run =
        RunCommand("cd " + Dir() + " && rm -f " + file + " && " + cli + " project new " + file +
                   " a.sweepscan && " + cli + " project add " + file + " b.sweepscan c.sweepscan" +
                   (then.empty() ? "" : " && " + cli + " " + then + " " + file));
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
  // Runs the event loop until `done` (expected before the timeout),
  // measuring its turns.
  EventLoopTurns Turns(const std::function<bool()>& done, int timeout_ms) {
    const EventLoopTurns t = MeasureTurnsUntil(done, timeout_ms);
    EXPECT_TRUE(t.done) << "not done after " << timeout_ms << " ms";
    return t;
  }
  // The outcome of the project's next alignment (alignFinished), watched
  // from this call on.
  struct AlignOutcome {
    bool finished = false, placed = false;
    QString message;
  };
  std::shared_ptr<AlignOutcome> WatchAlign() {
    auto outcome = std::make_shared<AlignOutcome>();
    QObject::connect(project(), &ui::ProjectController::alignFinished, window_.get(),
                     [outcome](bool ok, const QString& m) {
                       outcome->finished = true;
                       outcome->placed = ok;
                       outcome->message = m;
                     });
    return outcome;
  }
  // Opens the project and waits for its sessions to load.
  void OpenAndLoad(const QString& file) {
    ASSERT_TRUE(project()->OpenProject(file));
    TurnsWhileBusy(60000);
  }
};

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_UI_PROJECT_UI_FIXTURE_H_
