// The desktop app as its UI tests drive it (tests/ui/*_test.cc): a
// workspace and its main window, shown under a real display (xvfb-run in
// CI), with settings and sessions in a temporary folder, and a wait that
// keeps the event loop running.
#ifndef SWEEPSCAN_TESTS_UI_APP_FIXTURE_H_
#define SWEEPSCAN_TESTS_UI_APP_FIXTURE_H_

#include <QVTKOpenGLNativeWidget.h>
#include <gtest/gtest.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <QApplication>
#include <QCoreApplication>
#include <QElapsedTimer>
#include <QSettings>
#include <QSurfaceFormat>
#include <QTemporaryDir>
#include <QTest>
#include <QThread>
#include <clocale>
#include <csignal>
#include <functional>
#include <memory>

#include "tests/testing/qt_wait.h"
#include "tests/testing/run_command.h"
#include "ui/main_window.h"
#include "ui/panels/connection_panel.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::testing {

inline const QString kResources = QStringLiteral(SWEEPSCAN_SOURCE_DIR "/resources");

// Records the office floor's drives a, b and c (resources/scenarios/
// building_*.json) as sessions DIR/a.sweepscan ... with the CLI, the three
// at once; the project UI tests' shared set-up.
inline void RecordOfficeFloorSessions(const std::string& dir) {
  std::string cmd;
  for (const char* s : {"a", "b", "c"}) {
    cmd += std::string(SWEEPSCAN_CLI) + " simulate --scenario " + kResources.toStdString() + "/scenarios/building_" +
           s + ".json --out " + dir + "/" + s + ".ply --session " + dir + "/" + s + ".sweepscan > /dev/null & ";
  }
  const auto run = RunCommand(cmd + "wait");
  ASSERT_EQ(run.code, 0) << run.out;
}

class AppFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(tmp_.isValid());
    QSettings::setDefaultFormat(QSettings::IniFormat);
    QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, tmp_.path() + "/settings");
    workspace_ = std::make_unique<ui::Workspace>();
    workspace_->set_sessions_root(tmp_.path() + "/sessions");
    window_ = std::make_unique<ui::MainWindow>(workspace_.get(), kResources);
    window_->SetInteractive(false);
    window_->resize(1100, 700);
    window_->show();
    ASSERT_TRUE(QTest::qWaitForWindowExposed(window_.get()));
  }
  void TearDown() override {
    window_.reset();
    workspace_.reset();
  }

  // Records the lab drive through the real bytes with the CLI: tmp/lab.sweepscan.
  void SimulateLabSession() {
    const auto sim = RunCommand(std::string(SWEEPSCAN_CLI) + " simulate --scenario " +
                                kResources.toStdString() + "/scenarios/lab.json --out " +
                                tmp_.path().toStdString() + "/lab.ply");
    ASSERT_EQ(sim.code, 0) << sim.out;
  }
  void ConnectToSimulator(const QString& scenario = "lab.json") {
    ui::ConnectOptions o;
    o.kind = ui::LinkKind::kSimulator;
    o.scenario_path = kResources + "/scenarios/" + scenario;
    window_->connection_panel()->SetOptions(o);
    QString error;
    ASSERT_TRUE(window_->connection_panel()->ConnectNow(&error)) << error.toStdString();
    ASSERT_TRUE(WaitFor([&] { return workspace_->authenticated(); }, 10000))
        << hardware::LinkHealth::StateName(workspace_->health().state);
  }
  // Opens a session and waits until its replay has finished.
  void OpenAndReplay(const QString& session) {
    bool replayed = false;
    const auto c = QObject::connect(workspace_.get(), &ui::Workspace::replayFinished,
                                    [&] { replayed = true; });
    window_->OpenSessionPath(session);
    const bool done = WaitFor([&] { return replayed; }, 120000);
    QObject::disconnect(c);
    ASSERT_TRUE(done);
  }

  QTemporaryDir tmp_;
  std::unique_ptr<ui::Workspace> workspace_;
  std::unique_ptr<ui::MainWindow> window_;
};

// AppFixture with the office floor's three drives recorded once for the
// whole test binary (RecordOfficeFloorSessions, ~6 s in parallel) into
// Dir(): the project and plan UI tests' shared set-up.
class OfficeFloorAppFixture : public AppFixture {
 protected:
  static void SetUpTestSuite() {
    sessions_ = new QTemporaryDir;
    RecordOfficeFloorSessions(Dir());
  }
  static void TearDownTestSuite() {
    delete sessions_;
    sessions_ = nullptr;
  }
  static std::string Dir() { return sessions_->path().toStdString(); }

 private:
  inline static QTemporaryDir* sessions_ = nullptr;
};

// The UI tests' main(): listing the tests (CTest's discovery) needs no
// display; running them does (xvfb-run in CI).
//
// Each test runs in a session of its own, as an app started from a desktop
// does. Linux's scheduler shares the CPU fairly between sessions
// (autogroups) and by nice value within one. The app's background jobs run
// at nice 10 behind its GUI thread (ui/workspace/background_priority.h);
// under `ctest -j2` every test shares ctest's session, so the other test's
// GUI thread and renderer at nice 0 starved them: a floor plan that takes
// 1-2 s alone took 30-57 s beside CloudStoreUiTest, near its 60 s wait.
inline int RunUiTests(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  if (::testing::GTEST_FLAG(list_tests)) return RUN_ALL_TESTS();
  // Fails for a process group leader (a test run from a shell leads its
  // job's group): it then stays in the shell's session, as before. Out of
  // ctest's session, Ctrl+C on ctest no longer reaches it: it ends when
  // its parent does instead.
  if (setsid() >= 0) {
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() == 1) return 1;  // The parent ended before the line above.
  }
  QSurfaceFormat::setDefaultFormat(QVTKOpenGLNativeWidget::defaultFormat());
  QApplication app(argc, argv);
  std::setlocale(LC_NUMERIC, "C");  // As the app does (app/gui_main.cc).
  return RUN_ALL_TESTS();
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_UI_APP_FIXTURE_H_
