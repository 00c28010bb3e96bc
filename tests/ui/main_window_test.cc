// The desktop app driven through its real widgets (QTest) and its workspace,
// under a real display (xvfb-run in CI): the built-in simulator over loopback
// TCP, the VTK view's rendered image, the emergency stop on Space, a wrong
// key against a sweepscan-sim process, save / open, corrupt sessions,
// replay against `sweepscan-cli reconstruct`, and the pose source of opened
// sessions (EKF, odometry, SfM) against `reconstruct --pose-source`.
#include "ui/main_window.h"

#include <QVTKOpenGLNativeWidget.h>
#include <gtest/gtest.h>

#include <fstream>

#include <QAction>
#include <QApplication>
#include <QComboBox>
#include <QDir>
#include <QElapsedTimer>
#include <QFileInfo>
#include <QFile>
#include <QImage>
#include <QLineEdit>
#include <QProcess>
#include <QPushButton>
#include <QDoubleSpinBox>
#include <QSettings>
#include <QSurfaceFormat>
#include <QTemporaryDir>
#include <QTest>
#include <QThread>
#include <QTimer>
#include <QUndoStack>
#include <algorithm>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>

#include "core/calibration/calibration_file.h"
#include "core/calibration/picks.h"
#include "core/cloud/cloud_io.h"
#include "core/session/session.h"
#include "hardware/codecs/hi219_codec.h"
#include "hardware/link/qt_transport.h"
#include "tests/testing/run_command.h"
#include "tests/ui/app_fixture.h"
#include "ui/panels/calibration_panel.h"
#include "ui/panels/connection_panel.h"
#include "ui/panels/device_check_dialog.h"
#include "ui/panels/drive_panel.h"
#include "ui/panels/evaluation_panel.h"
#include "ui/panels/replay_panel.h"
#include "ui/view/cloud_view.h"
#include "ui/workspace/sim_robot.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

using testing::kResources;
using testing::WaitFor;

// Pixels that differ clearly from the view's gradient background.
int CountBrightPixels(const QImage& image) {
  int n = 0;
  const QImage rgb = image.convertToFormat(QImage::Format_RGB32);
  for (int y = 0; y < rgb.height(); ++y) {
    const QRgb* line = reinterpret_cast<const QRgb*>(rgb.constScanLine(y));
    for (int x = 0; x < rgb.width(); ++x) {
      const int r = qRed(line[x]), g = qGreen(line[x]), b = qBlue(line[x]);
      // Background is dark grey-blue (<= ~72); cloud colours are saturated.
      if (std::max({r, g, b}) - std::min({r, g, b}) > 60) ++n;
    }
  }
  return n;
}

class AppTest : public testing::AppFixture {
 protected:
  void ConnectToSimulator(const QString& scenario = "lab.json") {
    ConnectOptions o;
    o.kind = LinkKind::kSimulator;
    o.scenario_path = kResources + "/scenarios/" + scenario;
    window_->connection_panel()->SetOptions(o);
    QString error;
    ASSERT_TRUE(window_->connection_panel()->ConnectNow(&error)) << error.toStdString();
    ASSERT_TRUE(WaitFor([&] { return workspace_->authenticated(); }, 10000))
        << hardware::LinkHealth::StateName(workspace_->health().state);
  }

};

TEST_F(AppTest, DrivesTheSimulatorAndTheViewShowsTheGrowingCloud) {
  ConnectToSimulator();
  QString error;
  ASSERT_TRUE(workspace_->StartRecording(&error)) << error.toStdString();
  // Drive forward with the keyboard, as an operator would.
  QTest::keyPress(window_->view(), Qt::Key_Up);
  ASSERT_TRUE(WaitFor([&] { return window_->view()->point_count() > 20000; }, 20000))
      << window_->view()->point_count();
  const size_t first = window_->view()->point_count();
  ASSERT_TRUE(WaitFor([&] { return window_->view()->point_count() > first + 5000; }, 10000));
  EXPECT_GT(std::abs(workspace_->sim_robot()->TrueTwist().v), 0.05);
  QTest::keyRelease(window_->view(), Qt::Key_Up);
  // Releasing the key stops the robot (the agent ramps down).
  EXPECT_TRUE(
      WaitFor([&] { return std::abs(workspace_->sim_robot()->TrueTwist().v) < 1e-6; }, 2000));
  window_->view()->FitToCloud();
  const QImage image = window_->view()->GrabImage();
  ASSERT_FALSE(image.isNull());
  // The cloud covers a visible part of the view (not a blank or background-only image).
  EXPECT_GT(CountBrightPixels(image), image.width() * image.height() / 100)
      << "rendered " << image.width() << "x" << image.height();
  EXPECT_GT(window_->view()->frames_rendered(), 10u);
  EXPECT_TRUE(QFileInfo::exists(workspace_->session_dir() + "/frames.bin"));
}

TEST_F(AppTest, SpaceStopsTheSimulatedRobotWithin200msWhateverHasFocus) {
  ConnectToSimulator();
  workspace_->Drive(0.3, 0.0);
  ASSERT_TRUE(WaitFor([&] { return workspace_->sim_robot()->TrueTwist().v > 0.25; }, 5000));
  // Focus in a text field: Space must still stop the robot.
  auto* host = window_->connection_panel()->findChild<QLineEdit*>();
  ASSERT_NE(host, nullptr);
  host->setFocus();
  QElapsedTimer clock;
  clock.start();
  QTest::keyClick(host, Qt::Key_Space);
  // Halted: below 3 cm/s (1.5 mm of travel left). The emulated motor board follows its command with
  // a 50 ms first-order lag (docs/simulator.md), like real wheels: 0.3 m/s
  // falls below 3 cm/s 2.3 time constants (115 ms) after the command lands.
  ASSERT_TRUE(
      WaitFor([&] { return std::abs(workspace_->sim_robot()->TrueTwist().v) < 0.03; }, 1000));
  EXPECT_LT(clock.elapsed(), 200);
  std::printf("emergency stop: below 3 cm/s after %lld ms\n",
              static_cast<long long>(clock.elapsed()));
  EXPECT_TRUE(WaitFor([&] { return workspace_->sim_robot()->TrueTwist().v == 0.0; }, 1000));
  // Latched: drive commands are refused until cleared.
  workspace_->Drive(0.3, 0.0);
  QTest::qWait(300);
  EXPECT_EQ(workspace_->sim_robot()->TrueTwist().v, 0.0);
  workspace_->ClearEmergencyStop();
  workspace_->Drive(0.2, 0.0);
  EXPECT_TRUE(WaitFor([&] { return workspace_->sim_robot()->TrueTwist().v > 0.1; }, 3000));
}

TEST_F(AppTest, WrongKeyAgainstASimProcessIsRefusedWithAClearMessage) {
  const QString key = tmp_.path() + "/robot.key", wrong = tmp_.path() + "/wrong.key";
  {
    QFile f(key);
    ASSERT_TRUE(f.open(QIODevice::WriteOnly));
    f.write("the robot's real key\n");
    QFile g(wrong);
    ASSERT_TRUE(g.open(QIODevice::WriteOnly));
    g.write("not the key\n");
  }
  QProcess sim;
  sim.setProgram(QStringLiteral(SWEEPSCAN_SIM));
  sim.setArguments({"--scenario", kResources + "/scenarios/lab.json", "--listen", "127.0.0.1:0",
                    "--key-file", key});
  sim.start();
  ASSERT_TRUE(sim.waitForStarted(10000));
  ASSERT_TRUE(WaitFor([&] { return sim.canReadLine(); }, 20000));
  const QString line = QString::fromLocal8Bit(sim.readLine()).trimmed();  // listening on H:P
  const int port = line.section(':', -1).toInt();
  ASSERT_GT(port, 0) << line.toStdString();

  QString refused;
  QObject::connect(workspace_.get(), &Workspace::authenticationFailed,
                   [&](const QString& r) { refused = r; });
  ConnectOptions o;
  o.kind = LinkKind::kTcp;
  o.port = port;
  o.key_file = wrong;
  QString error;
  ASSERT_TRUE(workspace_->Connect(o, &error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return !refused.isEmpty(); }, 10000));
  EXPECT_FALSE(workspace_->authenticated());
  EXPECT_NE(window_->last_error().indexOf("refused"), -1) << window_->last_error().toStdString();
  EXPECT_NE(window_->last_error().indexOf("key"), -1) << window_->last_error().toStdString();
  // The app keeps working: disconnect and connect with the right key.
  workspace_->Disconnect();
  o.key_file = key;
  ASSERT_TRUE(workspace_->Connect(o, &error)) << error.toStdString();
  EXPECT_TRUE(WaitFor([&] { return workspace_->authenticated(); }, 10000));
  workspace_->Disconnect();
  sim.terminate();
  sim.waitForFinished(5000);
}

TEST_F(AppTest, SaveCloseAndOpenRestoreTheSameCloudPointForPoint) {
  ConnectToSimulator();
  QString error;
  ASSERT_TRUE(workspace_->StartRecording(&error)) << error.toStdString();
  workspace_->Drive(0.25, 0.2);
  ASSERT_TRUE(WaitFor([&] { return workspace_->point_count() > 30000; }, 30000));
  workspace_->StopMotion();
  const QString saved = tmp_.path() + "/saved.sweepscan";
  ASSERT_TRUE(window_->SaveSessionTo(saved)) << window_->last_error().toStdString();
  workspace_->Disconnect();
  QTest::qWait(300);
  const std::vector<CloudPoint> before = workspace_->CloudSnapshot();
  ASSERT_GT(before.size(), 30000u);

  // Close the window and start a fresh one (the app reopened next week).
  window_.reset();
  workspace_ = std::make_unique<Workspace>();
  window_ = std::make_unique<MainWindow>(workspace_.get(), kResources);
  window_->SetInteractive(false);
  window_->show();
  bool finished = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { finished = true; });
  window_->OpenSessionPath(saved);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 60000)) << window_->last_error().toStdString();
  const std::vector<CloudPoint> after = workspace_->CloudSnapshot();
  ASSERT_EQ(after.size(), before.size());
  for (size_t i = 0; i < before.size(); ++i) {
    ASSERT_EQ(after[i].x, before[i].x) << i;
    ASSERT_EQ(after[i].y, before[i].y) << i;
    ASSERT_EQ(after[i].z, before[i].z) << i;
    ASSERT_EQ(after[i].time_ns, before[i].time_ns) << i;
  }
  ASSERT_TRUE(WaitFor([&] { return window_->view()->point_count() == before.size(); }, 5000));
}

TEST_F(AppTest, CorruptOrTruncatedSessionsAreRefusedAndTheAppKeepsWorking) {
  // Record a short session through the real bytes with the CLI.
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  const QString good = tmp_.path() + "/lab.sweepscan";
  ASSERT_TRUE(QFileInfo::exists(good + "/meta.json"));

  // 1. A meta.json that is not JSON.
  const QString bad_meta = tmp_.path() + "/bad_meta.sweepscan";
  QDir().mkpath(bad_meta);
  QFile::copy(good + "/frames.bin", bad_meta + "/frames.bin");
  {
    QFile f(bad_meta + "/meta.json");
    ASSERT_TRUE(f.open(QIODevice::WriteOnly));
    f.write("{\"format_version\": 1, \"geometry\": ");
  }
  QString failed;
  QObject::connect(workspace_.get(), &Workspace::jobFinished,
                   [&](const QString&, bool ok, const QString& m) { failed = ok ? "" : m; });
  window_->OpenSessionPath(bad_meta);
  ASSERT_TRUE(WaitFor([&] { return !failed.isEmpty(); }, 20000));
  EXPECT_NE(failed.indexOf("meta.json"), -1) << failed.toStdString();
  EXPECT_EQ(window_->last_error(), failed);

  // 2. A frames.bin with a broken header.
  const QString bad_frames = tmp_.path() + "/bad_frames.sweepscan";
  QDir().mkpath(bad_frames);
  QFile::copy(good + "/meta.json", bad_frames + "/meta.json");
  {
    QFile f(bad_frames + "/frames.bin");
    ASSERT_TRUE(f.open(QIODevice::WriteOnly));
    f.write("not a session");
  }
  failed.clear();
  window_->OpenSessionPath(bad_frames);
  ASSERT_TRUE(WaitFor([&] { return !failed.isEmpty(); }, 20000));
  EXPECT_NE(failed.indexOf("frames.bin"), -1) << failed.toStdString();

  // 3. A truncated frames.bin (a crash mid-write) opens with what was recorded.
  const QString truncated = tmp_.path() + "/truncated.sweepscan";
  QDir().mkpath(truncated);
  QFile::copy(good + "/meta.json", truncated + "/meta.json");
  QFile::copy(good + "/frames.bin", truncated + "/frames.bin");
  {
    QFile f(truncated + "/frames.bin");
    ASSERT_TRUE(f.open(QIODevice::ReadWrite));
    ASSERT_TRUE(f.resize(f.size() / 2 + 7));
  }
  bool finished = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { finished = true; });
  failed.clear();
  window_->OpenSessionPath(truncated);
  ASSERT_TRUE(WaitFor([&] { return finished || !failed.isEmpty(); }, 60000));
  EXPECT_TRUE(finished) << failed.toStdString();
  EXPECT_GT(workspace_->CloudSnapshot().size(), 1000u);

  // The app still works: the simulator connects and streams.
  ConnectToSimulator();
}

TEST_F(AppTest, ReplayGivesTheCloudThatTheCliReconstructionGives) {
  const std::string dir = tmp_.path().toStdString();
  const std::string cli = SWEEPSCAN_CLI;
  const auto sim = testing::RunCommand(cli + " simulate --scenario " + kResources.toStdString() +
                                       "/scenarios/lab_circle.json --out " + dir + "/c.ply");
  ASSERT_EQ(sim.code, 0) << sim.out;
  const auto rec =
      testing::RunCommand(cli + " reconstruct " + dir + "/c.sweepscan --out " + dir + "/cli.ply");
  ASSERT_EQ(rec.code, 0) << rec.out;
  std::vector<CloudPoint> expected;
  ASSERT_TRUE(LoadCloud(dir + "/cli.ply", &expected).ok());
  ASSERT_GT(expected.size(), 10000u);

  bool finished = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { finished = true; });
  workspace_->OpenSession(QString::fromStdString(dir + "/c.sweepscan"), 0.0);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 120000));
  const std::vector<CloudPoint> replayed = workspace_->CloudSnapshot();
  ASSERT_EQ(replayed.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    ASSERT_EQ(replayed[i].x, expected[i].x) << i;
    ASSERT_EQ(replayed[i].y, expected[i].y) << i;
    ASSERT_EQ(replayed[i].z, expected[i].z) << i;
  }
}

// The cloud `sweepscan-cli reconstruct SESSION --pose-source SOURCE` writes.
std::vector<CloudPoint> CliCloud(const std::string& session, const std::string& source,
                                 const std::string& out) {
  const auto rec = testing::RunCommand(std::string(SWEEPSCAN_CLI) + " reconstruct " + session +
                                       " --pose-source " + source + " --out " + out);
  EXPECT_EQ(rec.code, 0) << rec.out;
  std::vector<CloudPoint> cloud;
  EXPECT_TRUE(LoadCloud(out, &cloud).ok()) << out;
  return cloud;
}

// Point for point, as the PLY holds them (float coordinates).
::testing::AssertionResult SameCloud(const std::vector<CloudPoint>& got,
                                     const std::vector<CloudPoint>& expected) {
  if (got.size() != expected.size()) {
    return ::testing::AssertionFailure() << got.size() << " points, expected " << expected.size();
  }
  for (size_t i = 0; i < expected.size(); ++i) {
    if (got[i].x != expected[i].x || got[i].y != expected[i].y || got[i].z != expected[i].z) {
      return ::testing::AssertionFailure() << "point " << i << ": (" << got[i].x << ", " << got[i].y
                                           << ", " << got[i].z << "), expected (" << expected[i].x
                                           << ", " << expected[i].y << ", " << expected[i].z << ")";
    }
  }
  return ::testing::AssertionSuccess();
}

// Tools > Pose Source on an opened session: SfM re-processes it on a job
// thread while the GUI keeps handling events, and the cloud is the one
// `sweepscan-cli reconstruct --pose-source sfm` gives, point for point;
// the status bar and the replay panel say so; the cloud can be evaluated
// and coloured by deviation; back to the EKF (from the replay panel) gives
// the EKF cloud again, and odometry the odometry cloud. The choice persists:
// the app started again opens the session with SfM straight away.
TEST_F(AppTest, PoseSourceSfmReprocessesTheSessionAsTheCliDoes) {
  const std::string dir = tmp_.path().toStdString();
  const auto sim = testing::RunCommand(std::string(SWEEPSCAN_CLI) + " simulate --scenario " +
                                       kResources.toStdString() +
                                       "/scenarios/lab_circle.json --out " + dir + "/c.ply");
  ASSERT_EQ(sim.code, 0) << sim.out;
  const std::string session = dir + "/c.sweepscan";
  const std::vector<CloudPoint> ekf = CliCloud(session, "ekf", dir + "/ekf.ply");
  const std::vector<CloudPoint> sfm = CliCloud(session, "sfm", dir + "/sfm.ply");
  const std::vector<CloudPoint> odometry = CliCloud(session, "odometry", dir + "/odo.ply");
  ASSERT_GT(sfm.size(), 10000u);
  ASSERT_FALSE(SameCloud(sfm, ekf));  // Else the test could not tell them apart.

  int replays = 0;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { ++replays; });
  QString failed;
  QObject::connect(workspace_.get(), &Workspace::jobFinished,
                   [&](const QString&, bool ok, const QString& m) {
                     if (!ok) failed = m;
                   });
  EXPECT_EQ(workspace_->pose_source(), PoseSource::kEkf);  // The default.
  EXPECT_NE(window_->pose_source_status().indexOf("live"), -1)
      << window_->pose_source_status().toStdString();
  window_->OpenSessionPath(QString::fromStdString(session));
  ASSERT_TRUE(WaitFor([&] { return replays == 1; }, 120000)) << failed.toStdString();
  EXPECT_TRUE(SameCloud(workspace_->CloudSnapshot(), ekf));
  EXPECT_EQ(window_->pose_source_status(), "Poses: EKF");

  // SfM from the menu. The view settles first, so that what is measured is
  // the job's effect on the event loop (see the calibration test).
  ASSERT_TRUE(WaitFor([&] { return !window_->view()->lod_active(); }, 10000));
  window_->view()->RenderNow();
  WaitFor([] { return false; }, 100);
  QAction* sfm_action = window_->pose_source_action(PoseSource::kSfm);
  ASSERT_NE(sfm_action, nullptr);
  replays = 0;
  sfm_action->trigger();
  EXPECT_TRUE(sfm_action->isChecked());
  EXPECT_TRUE(workspace_->job_running());  // SfM runs on a job thread...
  QElapsedTimer gap;
  gap.start();
  qint64 worst = 0;
  int job_events = 0;
  while (workspace_->job_running()) {  // ...and the GUI keeps going.
    QCoreApplication::processEvents(QEventLoop::AllEvents, 5);
    worst = std::max(worst, gap.restart());
    ++job_events;
  }
  EXPECT_LT(worst, 200) << job_events << " event loop passes";
  std::printf("sfm job: %d event loop passes, longest gap %lld ms\n", job_events,
              static_cast<long long>(worst));
  ASSERT_TRUE(WaitFor([&] { return replays == 1; }, 120000)) << failed.toStdString();
  EXPECT_EQ(workspace_->shown_pose_source(), PoseSource::kSfm);
  EXPECT_TRUE(SameCloud(workspace_->CloudSnapshot(), sfm));
  ASSERT_TRUE(WaitFor([&] { return window_->view()->point_count() == sfm.size(); }, 10000));
  EXPECT_EQ(window_->pose_source_status(), "Poses: SfM");
  QComboBox* box = window_->replay_panel()->pose_source_box();
  EXPECT_EQ(box->currentData().toInt(), static_cast<int>(PoseSource::kSfm));
  EXPECT_NE(window_->replay_panel()->pose_source_text().indexOf("planes"), -1)
      << window_->replay_panel()->pose_source_text().toStdString();
  EXPECT_EQ(QSettings().value("session/pose_source").toString(), "sfm");

  // The SfM cloud is evaluated and coloured like any other (once the
  // calibration panel has split this circle drive's passes: one job at a time).
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running(); }, 60000));
  EXPECT_EQ(workspace_->pass_labels().size(), sfm.size());
  EvaluationPanel* evaluation = window_->evaluation_panel();
  bool evaluated = false, evaluated_ok = false;
  QObject::connect(evaluation, &EvaluationPanel::evaluated, [&](bool ok) {
    evaluated = true;
    evaluated_ok = ok;
  });
  evaluation->Evaluate();
  ASSERT_TRUE(WaitFor([&] { return evaluated; }, 120000));
  ASSERT_TRUE(evaluated_ok) << failed.toStdString();
  EXPECT_EQ(workspace_->evaluation()->points_in, sfm.size());
  EXPECT_EQ(workspace_->deviation_map().size(), sfm.size());
  evaluation->ShowDeviations(true);
  EXPECT_EQ(window_->view()->color_mode(), CloudView::ColorMode::kDeviation);
  EXPECT_TRUE(window_->view()->has_point_values(CloudView::ColorMode::kDeviation));

  // Back to the EKF from the replay panel: the EKF cloud again, and the
  // deviations of the SfM cloud are gone with it.
  replays = 0;
  box->setCurrentIndex(box->findData(static_cast<int>(PoseSource::kEkf)));
  emit box->activated(box->currentIndex());
  EXPECT_TRUE(window_->pose_source_action(PoseSource::kEkf)->isChecked());
  ASSERT_TRUE(WaitFor([&] { return replays == 1; }, 120000)) << failed.toStdString();
  EXPECT_TRUE(SameCloud(workspace_->CloudSnapshot(), ekf));
  EXPECT_EQ(window_->pose_source_status(), "Poses: EKF");
  EXPECT_NE(window_->view()->color_mode(), CloudView::ColorMode::kDeviation);
  EXPECT_TRUE(workspace_->deviation_map().empty());
  // Odometry alone, as `reconstruct --pose-source odometry`.
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running(); }, 60000));
  replays = 0;
  window_->pose_source_action(PoseSource::kOdometry)->trigger();
  ASSERT_TRUE(WaitFor([&] { return replays == 1; }, 120000)) << failed.toStdString();
  EXPECT_TRUE(SameCloud(workspace_->CloudSnapshot(), odometry));
  EXPECT_EQ(QSettings().value("session/pose_source").toString(), "odometry");
  EXPECT_TRUE(failed.isEmpty()) << failed.toStdString();

  // SfM chosen, the app closed and started again: the choice is back, and
  // opening the session computes the SfM poses in the open job.
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running(); }, 60000));
  sfm_action->trigger();
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running() && replays == 2; }, 120000));
  window_->close();
  window_.reset();
  workspace_ = std::make_unique<Workspace>();
  window_ = std::make_unique<MainWindow>(workspace_.get(), kResources);
  window_->SetInteractive(false);
  window_->show();
  EXPECT_EQ(workspace_->pose_source(), PoseSource::kSfm);
  EXPECT_TRUE(window_->pose_source_action(PoseSource::kSfm)->isChecked());
  EXPECT_EQ(window_->replay_panel()->pose_source_box()->currentData().toInt(),
            static_cast<int>(PoseSource::kSfm));
  bool reopened = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { reopened = true; });
  window_->OpenSessionPath(QString::fromStdString(session));
  ASSERT_TRUE(WaitFor([&] { return reopened; }, 120000)) << window_->last_error().toStdString();
  EXPECT_EQ(workspace_->shown_pose_source(), PoseSource::kSfm);
  EXPECT_TRUE(SameCloud(workspace_->CloudSnapshot(), sfm));
}

// A cancelled SfM leaves the cloud as it was and gives the choice back to
// the poses shown; live recording always uses the EKF whatever the choice.
TEST_F(AppTest, CancelledSfmKeepsTheCloudAndLiveUsesTheEkf) {
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  ASSERT_NO_FATAL_FAILURE(OpenAndReplay(tmp_.path() + "/lab.sweepscan"));
  const std::vector<CloudPoint> before = workspace_->CloudSnapshot();
  QString message;
  bool finished = false;
  QObject::connect(workspace_.get(), &Workspace::jobFinished,
                   [&](const QString&, bool ok, const QString& m) {
                     finished = true;
                     message = ok ? QString() : m;
                   });
  bool replayed = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { replayed = true; });
  window_->pose_source_action(PoseSource::kSfm)->trigger();
  workspace_->CancelJob();
  ASSERT_TRUE(WaitFor([&] { return finished; }, 60000));
  EXPECT_NE(message.indexOf("ancel"), -1) << message.toStdString();
  EXPECT_EQ(workspace_->pose_source(), PoseSource::kEkf);
  EXPECT_TRUE(window_->pose_source_action(PoseSource::kEkf)->isChecked());
  EXPECT_EQ(workspace_->shown_pose_source(), PoseSource::kEkf);
  WaitFor([] { return false; }, 300);
  EXPECT_FALSE(replayed);  // Nothing re-processed.
  EXPECT_TRUE(SameCloud(workspace_->CloudSnapshot(), before));

  // SfM chosen, then a live recording: the EKF places the scans.
  window_->pose_source_action(PoseSource::kSfm)->trigger();
  finished = false;
  ASSERT_TRUE(WaitFor([&] { return finished && replayed; }, 60000)) << message.toStdString();
  EXPECT_EQ(workspace_->shown_pose_source(), PoseSource::kSfm);
  ConnectToSimulator();
  QString error;
  ASSERT_TRUE(workspace_->StartRecording(&error)) << error.toStdString();
  EXPECT_EQ(workspace_->shown_pose_source(), PoseSource::kEkf);
  EXPECT_EQ(workspace_->pose_source(), PoseSource::kSfm);  // Kept for the next session opened.
  EXPECT_NE(window_->pose_source_status().indexOf("EKF (live)"), -1)
      << window_->pose_source_status().toStdString();
  EXPECT_NE(window_->replay_panel()->pose_source_text().indexOf("live"), -1);
  ASSERT_TRUE(workspace_->StopRecording(&error)) << error.toStdString();
}

TEST_F(AppTest, OpeningShowsProgressAndCancelStopsIt) {
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  const QString session = tmp_.path() + "/lab.sweepscan";
  std::vector<double> fractions;
  QString finished_message;
  bool finished = false, finished_ok = false;
  QObject::connect(workspace_.get(), &Workspace::jobProgress,
                   [&](const QString&, double f) { fractions.push_back(f); });
  QObject::connect(workspace_.get(), &Workspace::jobFinished,
                   [&](const QString&, bool ok, const QString& m) {
                     finished = true;
                     finished_ok = ok;
                     finished_message = m;
                   });
  // Cancelled at once: the job ends without a session and says so.
  workspace_->OpenSession(session);
  workspace_->CancelJob();
  ASSERT_TRUE(WaitFor([&] { return finished; }, 20000));
  EXPECT_FALSE(finished_ok);
  EXPECT_NE(finished_message.indexOf("ancel"), -1) << finished_message.toStdString();
  EXPECT_TRUE(workspace_->session_dir().isEmpty());
  // Opened in full: progress is monotone and ends at 1.
  fractions.clear();
  finished = false;
  workspace_->OpenSession(session);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 20000));
  EXPECT_TRUE(finished_ok) << finished_message.toStdString();
  ASSERT_GE(fractions.size(), 3u);
  EXPECT_EQ(fractions.front(), -1.0);  // The job starts indeterminate...
  for (size_t i = 2; i < fractions.size(); ++i) EXPECT_GE(fractions[i], fractions[i - 1]) << i;
  EXPECT_EQ(fractions.back(), 1.0);  // ...and reports its end.
  EXPECT_EQ(workspace_->session_dir(), session);
}

// The calibration panel on the recommended set-up (docs/calibration.md): the
// diamond target on a two-turn 0.05 m/s circle, recorded through the bytes.
// Picking through the view's picking layer, undo / redo, the pairs file, the
// solve with refined corners (each angle within 3 mrad of the truth, as the
// CLI's test), the before / after cloud and the calibration file.
// The simulated diamond calibration drive (lab_circle_diamond.json: the
// paper's mounting error -5.8, 12.6, 35.5 mrad), recorded once for the
// calibration tests.
QString DiamondSession() {
  static QTemporaryDir dir;
  static bool made = false;
  if (!made) {
    const auto sim = testing::RunCommand(
        std::string(SWEEPSCAN_CLI) + " simulate --scenario " + kResources.toStdString() +
        "/scenarios/lab_circle_diamond.json --out " + dir.path().toStdString() + "/diamond.ply");
    EXPECT_EQ(sim.code, 0) << sim.out;
    made = sim.code == 0;
  }
  return dir.path() + "/diamond.sweepscan";
}

// The diamond's corners (truth, world frame) and its centre.
const double kDiamondHalf = 0.3 * std::sqrt(2.0);
const Eigen::Vector3d kDiamondCentre(5.0, 0.16, 1.35);
const Eigen::Vector3d kDiamondCorners[4] = {
    kDiamondCentre + Eigen::Vector3d(0, 0, kDiamondHalf),
    kDiamondCentre + Eigen::Vector3d(kDiamondHalf, 0, 0),
    kDiamondCentre + Eigen::Vector3d(0, 0, -kDiamondHalf),
    kDiamondCentre + Eigen::Vector3d(-kDiamondHalf, 0, 0)};
const double kTruthRad[3] = {-0.0058, 0.0126, 0.0355};

// On the board (the diamond |x - 5| + |z - 1.35| <= 0.42 in its plane),
// with room for the uncalibrated ghost, but not the sill's edge below it.
bool OnDiamond(const Eigen::Vector3d& p) {
  return std::abs(p.y() - 0.157) < 0.07 &&
         std::abs(p.x() - kDiamondCentre.x()) + std::abs(p.z() - kDiamondCentre.z()) < 0.48 &&
         p.z() > 0.88;
}

class CalibrationTest : public AppTest {
 protected:
  // Opens the diamond drive and waits for its replay and its pass split.
  void OpenDiamond() { OpenCircleDrive(DiamondSession()); }

  // Opens a circle drive's session and waits for its replay and its pass
  // split (a job: nothing else can run on the job thread before it ends).
  void OpenCircleDrive(const QString& session) {
    ASSERT_TRUE(QFileInfo::exists(session)) << session.toStdString();
    bool replayed = false, split = false;
    // Disconnected when this returns: the lambdas hold references to these
    // locals, and later replays (Show calibrated) emit the same signals.
    QObject context;
    QObject::connect(workspace_.get(), &Workspace::replayFinished, &context,
                     [&] { replayed = true; });
    QObject::connect(workspace_.get(), &Workspace::passesSplit, &context, [&] { split = true; });
    window_->OpenSessionPath(session);
    ASSERT_TRUE(WaitFor([&] { return replayed; }, 120000)) << window_->last_error().toStdString();
    ASSERT_TRUE(workspace_->circle_drive()) << workspace_->circle_drive_note().toStdString();
    ASSERT_TRUE(WaitFor([&] { return split; }, 60000));
    ASSERT_TRUE(WaitFor(
        [&] { return window_->view()->has_point_values(CloudView::ColorMode::kPass); }, 10000));
  }

  // Waits for the panel's solve; true if it succeeded.
  bool WaitForSolve(CalibrationPanel* panel, int timeout_ms = 180000) {
    bool done = false, ok = false;
    auto c = QObject::connect(panel, &CalibrationPanel::solved, [&](bool r) {
      done = true;
      ok = r;
    });
    EXPECT_TRUE(WaitFor([&] { return done; }, timeout_ms));
    QObject::disconnect(c);
    return ok;
  }
};

// The operator's workflow on the simulated diamond drive, every pick a
// Shift + click at a screen position through the view's picker: the passes
// split and shown one at a time, four corner pairs, undo / redo / delete,
// the refined solve (within the CLI's 3 mrad; the ghost at least ten times
// smaller), per-pair gaps and fitted corners, the calibrated cloud, the
// calibration saved, loaded and kept for the robot's next recording.
TEST_F(CalibrationTest, PicksThroughTheViewSolveAndTheCalibrationIsKept) {
  OpenDiamond();
  CalibrationPanel* panel = window_->calibration_panel();
  CloudView* view = window_->view();
  const std::vector<CloudPoint> before = workspace_->CloudSnapshot();
  ASSERT_TRUE(WaitFor([&] { return view->point_count() == before.size(); }, 10000));

  // The split: every point labelled, both passes substantial, and a pass
  // shown alone draws exactly its points.
  const std::vector<float>& labels = workspace_->pass_labels();
  ASSERT_EQ(labels.size(), before.size());
  size_t in_pass[2] = {0, 0};
  for (float v : labels) {
    if (v == 0.0f || v == 1.0f) ++in_pass[static_cast<int>(v)];
  }
  EXPECT_GT(in_pass[0], before.size() / 4);
  EXPECT_GT(in_pass[1], before.size() / 4);
  EXPECT_EQ(view->color_mode(), CloudView::ColorMode::kPass);
  panel->ShowPass(0);
  EXPECT_EQ(view->drawn_point_count(), in_pass[0]);
  panel->ShowPass(1);
  EXPECT_EQ(view->drawn_point_count(), in_pass[1]);

  // Facing the board from 4 m, each corner clicked where the pass shown
  // has it (its sighting of the board's extreme point in the corner's
  // direction, as the operator sees it; a few cm inside, on the board) in
  // pass A, then in pass B.
  view->LookAt(kDiamondCentre, kDiamondCentre + Eigen::Vector3d(0, 4.0, 0));
  auto sighted_corner = [&](int pass, const Eigen::Vector3d& corner) {
    const Eigen::Vector3d dir = (corner - kDiamondCentre).normalized();
    std::vector<std::pair<double, Eigen::Vector3d>> board;
    for (size_t i = 0; i < before.size(); ++i) {
      const Eigen::Vector3d p(before[i].x, before[i].y, before[i].z);
      // The board's sightings (not the sill below it or the wall behind).
      if (labels[i] != pass || std::abs(p.y() - 0.157) > 0.07 || !OnDiamond(p)) continue;
      board.emplace_back((p - kDiamondCentre).dot(dir), p);
    }
    // Near the extreme, where the samples are dense enough to see (the very
    // tip holds a few scattered ones): the 2 % point from the top.
    EXPECT_GT(board.size(), 200u);
    const size_t k = board.size() / 50;
    std::nth_element(board.begin(), board.begin() + k, board.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    return board[k].second;
  };
  auto picks_made = [&] {
    const auto& p = panel->pair_points();
    return p.size() * 2 - ((!p.empty() && !p.back().has_b) ? 1 : 0);
  };
  for (const Eigen::Vector3d& corner : kDiamondCorners) {
    for (int pass = 0; pass < 2; ++pass) {
      panel->ShowPass(pass);
      const Eigen::Vector3d seen = sighted_corner(pass, corner);
      // Where the view shows the board near that point (an operator moves
      // the cursor until it is on the board): up to 10 cm inwards.
      view->RenderNow();
      Eigen::Vector3d inside = seen, under;
      for (int step = 0; step < 10; ++step) {
        inside = seen + 0.01 * (step + 1) * (kDiamondCentre - seen).normalized();
        if (view->PickPoint(view->WorldToWidget(inside).toPoint(), &under) && OnDiamond(under)) {
          break;
        }
      }
      const QPoint px = view->WorldToWidget(inside).toPoint();
      const size_t made = picks_made();
      QTest::mouseClick(view, Qt::LeftButton, Qt::ShiftModifier, px);
      ASSERT_EQ(picks_made(), made + 1) << "no pick at " << inside.transpose() << " (pass "
                                        << pass << ", pixel " << px.x() << ", " << px.y() << ")";
    }
  }
  ASSERT_EQ(panel->pair_count(), 4);
  ASSERT_EQ(panel->pairs().size(), 4u);
  for (const auto& p : panel->pair_points()) {
    // Each pick on the board (its sighting within a few cm of the plane
    // y = 0.16), the two picks of a pair in different sightings.
    EXPECT_NEAR(p.a.y(), 0.16, 0.06);
    EXPECT_NEAR(p.b.y(), 0.16, 0.06);
    EXPECT_GT((p.a - p.b).norm(), 1e-4);
  }
  // Undo takes back the last pick, redo restores it; delete is undoable.
  const auto picked = panel->pair_points();
  window_->undo_stack()->undo();
  EXPECT_EQ(panel->pairs().size(), 3u);
  EXPECT_EQ(panel->pair_count(), 4);  // The last pair is waiting for its B again.
  window_->undo_stack()->redo();
  ASSERT_EQ(panel->pairs().size(), 4u);
  panel->DeletePair(1);
  EXPECT_EQ(panel->pairs().size(), 3u);
  window_->undo_stack()->undo();
  ASSERT_EQ(panel->pairs().size(), 4u);
  EXPECT_EQ(panel->pair_points()[1].b, picked[1].b);
  QString error;
  ASSERT_TRUE(panel->SavePairs(tmp_.path() + "/pairs.json", &error)) << error.toStdString();
  std::vector<PickPair> saved;
  ASSERT_TRUE(LoadPairsFile(tmp_.path().toStdString() + "/pairs.json", &saved).ok());
  ASSERT_EQ(saved.size(), 4u);
  EXPECT_NEAR(saved[1].pass2.world.x(), picked[1].b.x(), 1e-6);

  panel->ShowPass(-1);
  // The board's thickness: 5 mm by default, typed into its box, kept in the
  // settings, and only for the refined solve.
  auto* thickness = panel->findChild<QDoubleSpinBox*>(QStringLiteral("boardThickness"));
  ASSERT_NE(thickness, nullptr);
  EXPECT_DOUBLE_EQ(thickness->value(), 5.0);
  thickness->selectAll();
  QTest::keyClicks(thickness, QStringLiteral("12"));
  EXPECT_DOUBLE_EQ(thickness->value(), 12.0);
  EXPECT_DOUBLE_EQ(QSettings().value(QStringLiteral("calibration/board_thickness_mm")).toDouble(), 12.0);
  panel->SetRefine(false);
  EXPECT_FALSE(thickness->isEnabled());
  panel->SetRefine(true);
  EXPECT_TRUE(thickness->isEnabled());
  thickness->selectAll();
  QTest::keyClicks(thickness, QStringLiteral("5"));
  panel->Solve();
  ASSERT_TRUE(WaitForSolve(panel)) << panel->result_text().toStdString();
  const PickCalibrationResult* r = workspace_->calibration_result();
  ASSERT_NE(r, nullptr);
  EXPECT_DOUBLE_EQ(r->summary.board_thickness_m, 0.005);
  const double got[3] = {r->summary.angles.alpha, r->summary.angles.beta, r->summary.angles.gamma};
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(got[k], kTruthRad[k], 3e-3) << k;
    EXPECT_GT(r->summary.sigma_rad[k], 0.0) << k;
  }
  EXPECT_GT(r->summary.initial_rms_m, 10.0 * r->summary.final_rms_m);
  EXPECT_NE(panel->result_text().indexOf("alpha"), -1);
  // Each pair's gap before and after, and the fitted corners of both passes
  // (which the solve made coincide).
  ASSERT_EQ(r->pair_checks.size(), 4u);
  double gaps_before = 0, gaps_after = 0;
  for (const auto& c : r->pair_checks) {
    gaps_before += c.before_m;
    gaps_after += c.after_m;
  }
  EXPECT_LT(gaps_after, gaps_before);
  ASSERT_TRUE(r->has_corners);
  for (int k = 0; k < 4; ++k) {
    EXPECT_LT((r->corners[0].corners[k] - r->corners[1].corners[k]).norm(), 0.01) << k;
    EXPECT_LT((r->corners[0].corners[k] - kDiamondCorners[k]).norm(), 0.03) << k;
  }

  // After: the session re-assembled under the solved angles, the passes
  // labelled again.
  bool replayed = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { replayed = true; });
  panel->ShowAfter(true);
  ASSERT_TRUE(WaitFor([&] { return replayed; }, 120000));
  const std::vector<CloudPoint> after = workspace_->CloudSnapshot();
  ASSERT_EQ(after.size(), before.size());
  double moved = 0.0;
  for (size_t i = 0; i < after.size(); i += 97)
    moved = std::max(moved, double(std::abs(after[i].z - before[i].z)));
  EXPECT_GT(moved, 0.01);  // 35 mrad of roll moves points centimetres at 1-2 m.
  EXPECT_TRUE(WaitFor(
      [&] { return view->has_point_values(CloudView::ColorMode::kPass); }, 10000));

  // Saved, loaded back as the result, kept for the robot.
  ASSERT_TRUE(panel->SaveCalibration(tmp_.path() + "/calibration.json", &error))
      << error.toStdString();
  MountingError loaded;
  ASSERT_TRUE(LoadCalibrationFile(tmp_.path().toStdString() + "/calibration.json", &loaded).ok());
  EXPECT_NEAR(loaded.gamma, r->summary.angles.gamma, 1e-9);
  const MountingError solved = r->summary.angles;
  ASSERT_TRUE(panel->LoadCalibration(tmp_.path() + "/calibration.json", &error))
      << error.toStdString();
  EXPECT_NEAR(workspace_->calibration_result()->summary.angles.beta, solved.beta, 1e-9);
  panel->UseForRobot();
  EXPECT_NEAR(workspace_->robot_calibration().gamma, solved.gamma, 1e-9);
  ConnectToSimulator("lab_circle_diamond.json");
  ASSERT_TRUE(workspace_->StartRecording(&error)) << error.toStdString();
  ASSERT_TRUE(workspace_->StopRecording(&error)) << error.toStdString();
  SessionMeta meta;
  ASSERT_TRUE(
      ReadSessionMeta((workspace_->session_dir() + "/meta.json").toStdString(), &meta).ok());
  EXPECT_NEAR(meta.calibration.gamma, solved.gamma, 1e-9);
  workspace_->Disconnect();
  window_->close();
  Workspace second;
  MainWindow reopened(&second, kResources);
  EXPECT_NEAR(second.robot_calibration().beta, solved.beta, 1e-9);
}

// Solve runs on a job thread: the GUI keeps handling events while it runs,
// and Cancel stops it with a message and the panel ready again.
TEST_F(CalibrationTest, SolveCanBeCancelledAndTheAppStaysResponsive) {
  OpenDiamond();
  CalibrationPanel* panel = window_->calibration_panel();
  for (const Eigen::Vector3d& c : kDiamondCorners) {
    panel->AddPick(c);
    panel->AddPick(c);
  }
  ASSERT_EQ(panel->pairs().size(), 4u);
  bool done = false, ok = true;
  QObject::connect(panel, &CalibrationPanel::solved, [&](bool r) {
    done = true;
    ok = r;
  });
  panel->SetRefine(true);
  // Whatever the view had to draw is drawn first (a full-detail frame of a
  // million points takes a good part of a second under Xvfb's software
  // renderer): what is measured below is the solve's effect on the GUI.
  // (the full-detail frame once the view has settled after the replay).
  ASSERT_TRUE(WaitFor([&] { return !window_->view()->lod_active(); }, 10000));
  window_->view()->RenderNow();
  WaitFor([] { return false; }, 100);
  const uint64_t frames_before = window_->view()->frames_rendered();
  const int height_before = window_->view()->height();
  panel->Solve();
  EXPECT_TRUE(panel->solving());
  // The event loop's longest gap while the job runs.
  QElapsedTimer clock, gap;
  clock.start();
  gap.start();
  qint64 worst = 0;
  while (clock.elapsed() < 400) {
    QCoreApplication::processEvents(QEventLoop::AllEvents, 5);
    worst = std::max(worst, gap.restart());
  }
  EXPECT_LT(worst, 200) << "frames " << window_->view()->frames_rendered() - frames_before
                        << ", last " << window_->view()->last_render_ms() << " ms, view "
                        << window_->view()->width() << "x" << window_->view()->height()
                        << " (was " << height_before << ")";
  // Another task asked for meanwhile is refused with the name of the one
  // in the way (the operator knows what to wait for or cancel).
  QString refused;
  {
    QObject context;
    QObject::connect(workspace_.get(), &Workspace::jobFinished, &context,
                     [&](const QString&, bool ok, const QString& m) { refused = ok ? "" : m; });
    workspace_->SetPoseSource(PoseSource::kOdometry);
  }
  EXPECT_TRUE(refused.startsWith("Calibrating is still running")) << refused.toStdString();
  EXPECT_EQ(workspace_->pose_source(), PoseSource::kEkf);
  panel->CancelSolve();
  ASSERT_TRUE(WaitFor([&] { return done; }, 30000));
  EXPECT_FALSE(ok);
  EXPECT_FALSE(panel->solving());
  EXPECT_NE(panel->result_text().indexOf("Cancelled"), -1) << panel->result_text().toStdString();
  EXPECT_FALSE(workspace_->job_running());
}

// The automatic mode, one button beside Solve, gives what
// `sweepscan-cli calibrate SESSION --auto` gives.
TEST_F(CalibrationTest, AutomaticModeGivesTheCliAnswer) {
  const QString session = DiamondSession();
  const auto cli = testing::RunCommand(std::string(SWEEPSCAN_CLI) + " calibrate " +
                                       session.toStdString() + " --auto --json");
  ASSERT_EQ(cli.code, 0) << cli.out;
  const nlohmann::json expected = nlohmann::json::parse(cli.out)["mounting_error_rad"];
  OpenDiamond();
  CalibrationPanel* panel = window_->calibration_panel();
  panel->SolveAutomatic();
  ASSERT_TRUE(WaitForSolve(panel)) << panel->result_text().toStdString();
  const PickCalibrationResult* r = workspace_->calibration_result();
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->summary.method, "auto-planes");
  EXPECT_NEAR(r->summary.angles.alpha, expected["alpha"].get<double>(), 1e-9);
  EXPECT_NEAR(r->summary.angles.beta, expected["beta"].get<double>(), 1e-9);
  EXPECT_NEAR(r->summary.angles.gamma, expected["gamma"].get<double>(), 1e-9);
  const double got[3] = {r->summary.angles.alpha, r->summary.angles.beta, r->summary.angles.gamma};
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(got[k], kTruthRad[k], 1e-3) << k;
  EXPECT_NE(panel->result_text().indexOf("planes"), -1);
  EXPECT_NE(panel->result_text().indexOf("smoothed over the drive"), -1)
      << panel->result_text().toStdString();
}

// An IMU whose tilt readings are far noisier than its data sheet (3 deg;
// the diamond drive otherwise): the Automatic button refuses, as the CLI
// does, with the reason in the panel; nothing is kept and the app goes on.
TEST_F(CalibrationTest, AutomaticRefusesAnImuFarNoisierThanItsDataSheet) {
  std::ifstream in(kResources.toStdString() + "/scenarios/lab_circle_diamond.json");
  nlohmann::json scenario = nlohmann::json::parse(in);
  scenario["imu"]["tilt_noise_rad"] = 3.0 * M_PI / 180.0;
  const std::string dir = tmp_.path().toStdString();
  std::ofstream(dir + "/shaky.json") << scenario.dump();
  const auto sim = testing::RunCommand(std::string(SWEEPSCAN_CLI) + " simulate --scenario " + dir +
                                       "/shaky.json --out " + dir + "/shaky.ply");
  ASSERT_EQ(sim.code, 0) << sim.out;
  ASSERT_NO_FATAL_FAILURE(OpenCircleDrive(tmp_.path() + "/shaky.sweepscan"));
  CalibrationPanel* panel = window_->calibration_panel();
  panel->SolveAutomatic();
  EXPECT_FALSE(WaitForSolve(panel));
  const QString text = panel->result_text();
  EXPECT_NE(text.indexOf("Not solved"), -1) << text.toStdString();
  EXPECT_NE(text.indexOf("tilt readings scatter"), -1) << text.toStdString();
  EXPECT_EQ(workspace_->calibration_result(), nullptr);
  EXPECT_TRUE(window_->isVisible());
  EXPECT_FALSE(workspace_->job_running());
}

// The evaluation panel gives what `sweepscan-cli evaluate SESSION` gives for
// the same recording (the same cloud, the same EvaluateCloud), and keeps the
// previous evaluation beside the new one.
TEST_F(AppTest, EvaluationPanelMatchesTheCliOnTheSameSession) {
  const std::string dir = tmp_.path().toStdString();
  const std::string cli = SWEEPSCAN_CLI;
  const auto sim = testing::RunCommand(cli + " simulate --scenario " + kResources.toStdString() +
                                       "/scenarios/lab.json --out " + dir + "/lab.ply");
  ASSERT_EQ(sim.code, 0) << sim.out;
  const auto eval = testing::RunCommand(cli + " evaluate " + dir + "/lab.sweepscan --json");
  ASSERT_EQ(eval.code, 0) << eval.out;
  const nlohmann::json expected = nlohmann::json::parse(eval.out)["uncalibrated"];

  bool replayed = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { replayed = true; });
  window_->OpenSessionPath(tmp_.path() + "/lab.sweepscan");
  ASSERT_TRUE(WaitFor([&] { return replayed; }, 120000));
  EvaluationPanel* panel = window_->evaluation_panel();
  bool done = false, ok = false;
  QObject::connect(panel, &EvaluationPanel::evaluated, [&](bool r) {
    done = true;
    ok = r;
  });
  QTest::mouseClick(panel->findChild<QPushButton*>(), Qt::LeftButton);
  ASSERT_TRUE(WaitFor([&] { return done; }, 120000));
  ASSERT_TRUE(ok) << panel->summary_text().toStdString();
  const CloudEvaluation* e = workspace_->evaluation();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->points_in, expected["points"].get<size_t>());
  EXPECT_EQ(e->planes.size(), expected["planes"].size());
  EXPECT_EQ(panel->plane_rows(), static_cast<int>(expected["planes"].size()));
  EXPECT_NEAR(e->mean_nn_distance_m, expected["mean_nn_distance_m"].get<double>(), 1e-9);
  for (size_t i = 0; i < e->planes.size() && i < expected["planes"].size(); ++i) {
    EXPECT_EQ(e->planes[i].kind, expected["planes"][i]["kind"].get<std::string>()) << i;
    EXPECT_NEAR(e->planes[i].plane.rms, expected["planes"][i]["rms_m"].get<double>(), 1e-9) << i;
  }
  // In the view: one rectangle per plane, each around its inliers.
  CloudView* view = window_->view();
  EXPECT_EQ(view->plane_count(), e->planes.size());
  for (const EvaluatedPlane& p : e->planes) {
    for (const Eigen::Vector3d& c : p.outline) {
      EXPECT_NEAR(p.plane.SignedDistance(c), 0.0, 1e-9);  // in the plane
    }
    EXPECT_GT((p.outline[2] - p.outline[0]).norm(), 0.5) << p.kind;  // spans the surface
  }
  // The deviation map: a value for every point; on the floor (the first
  // plane's inliers, at the floor's height) they match its RMS.
  const std::vector<float>& dev = workspace_->deviation_map();
  const std::vector<CloudPoint> cloud = workspace_->CloudSnapshot();
  ASSERT_EQ(dev.size(), cloud.size());
  const EvaluatedPlane* floor = nullptr;
  for (const EvaluatedPlane& p : e->planes) {
    if (p.kind == "floor") floor = &p;
  }
  ASSERT_NE(floor, nullptr);
  double sum2 = 0;
  size_t n = 0, on_planes = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (std::isnan(dev[i])) continue;
    ++on_planes;
    const double d = floor->plane.SignedDistance(Eigen::Vector3d(cloud[i].x, cloud[i].y, cloud[i].z));
    if (std::abs(d) < 0.03 && std::abs(d * 1e3 - dev[i]) < 1e-3) {
      sum2 += double(dev[i]) * dev[i];
      ++n;
    }
  }
  EXPECT_GT(on_planes, cloud.size() / 2);
  ASSERT_GT(n, floor->plane.count / 2);
  EXPECT_NEAR(std::sqrt(sum2 / n), floor->plane.rms * 1e3, 0.5 * floor->plane.rms * 1e3);
  panel->ShowDeviations(true);
  EXPECT_EQ(view->color_mode(), CloudView::ColorMode::kDeviation);
  EXPECT_TRUE(view->has_point_values(CloudView::ColorMode::kDeviation));
  panel->ShowDeviations(false);
  EXPECT_EQ(view->color_mode(), CloudView::ColorMode::kHeight);

  // A second evaluation keeps the first as "before".
  done = false;
  panel->Evaluate();
  ASSERT_TRUE(WaitFor([&] { return done; }, 120000));
  ASSERT_NE(workspace_->previous_evaluation(), nullptr);
  EXPECT_NE(panel->summary_text().indexOf("previous evaluation"), -1);

  // The report: JSON with the CLI's numbers and the previous evaluation,
  // and the view's image beside it.
  QString error;
  ASSERT_TRUE(panel->ExportReport(tmp_.path() + "/report.json", &error)) << error.toStdString();
  QFile file(tmp_.path() + "/report.json");
  ASSERT_TRUE(file.open(QIODevice::ReadOnly));
  const nlohmann::json report = nlohmann::json::parse(file.readAll().toStdString());
  EXPECT_EQ(report["format"], "sweepscan-evaluation-report");
  EXPECT_EQ(report["image"], "report.png");
  EXPECT_EQ(report["evaluation"]["points"], expected["points"]);
  EXPECT_EQ(report["evaluation"]["planes"].size(), expected["planes"].size());
  EXPECT_NEAR(report["evaluation"]["mean_nn_distance_m"].get<double>(),
              expected["mean_nn_distance_m"].get<double>(), 1e-12);
  EXPECT_TRUE(report.contains("previous"));
  const QImage image(tmp_.path() + "/report.png");
  ASSERT_FALSE(image.isNull());
  EXPECT_GT(CountBrightPixels(image), 1000);
}

// The distance tool: two Shift + clicks on cloud points measure the
// distance between the points under the cursor.
TEST_F(AppTest, MeasureDistanceBetweenTwoClickedPoints) {
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  ASSERT_NO_FATAL_FAILURE(OpenAndReplay(tmp_.path() + "/lab.sweepscan"));
  const std::vector<CloudPoint> cloud = workspace_->CloudSnapshot();
  CloudView* view = window_->view();
  ASSERT_TRUE(WaitFor([&] { return view->point_count() == cloud.size(); }, 10000));
  // Seen from above with everything over 10 cm hidden: the floor.
  view->SetClipHeight(0.10);
  view->ViewTop();
  view->RenderNow();
  // Two floor-level points far apart, found where the top view shows them.
  const CloudPoint* a = nullptr;
  const CloudPoint* b = nullptr;
  for (const CloudPoint& p : cloud) {
    if (p.z > 0.02) continue;
    if (a == nullptr || p.x < a->x) a = &p;
    if (b == nullptr || p.x > b->x) b = &p;
  }
  ASSERT_TRUE(a != nullptr && b != nullptr);
  window_->measure_action()->setChecked(true);
  const int picks_before = window_->calibration_panel()->pair_count();
  Eigen::Vector3d picked[2];
  int k = 0;
  for (const CloudPoint* p : {a, b}) {
    const QPointF px = view->WorldToWidget(Eigen::Vector3d(p->x, p->y, p->z));
    ASSERT_TRUE(view->PickPoint(px.toPoint(), &picked[k]));
    QTest::mouseClick(view, Qt::LeftButton, Qt::ShiftModifier, px.toPoint());
    ++k;
  }
  // The clicks measured; they did not add calibration picks.
  EXPECT_EQ(window_->calibration_panel()->pair_count(), picks_before);
  EXPECT_NEAR(window_->measured_distance(), (picked[1] - picked[0]).norm(), 1e-9);
  // A pixel or so from the wanted point (the top view is ~1 cm per pixel
  // here), or a wall's foot (below 10 cm) above it.
  const double truth = std::hypot(b->x - a->x, b->y - a->y);
  EXPECT_NEAR(window_->measured_distance(), truth, 0.15);
  EXPECT_GT(truth, 3.0);
}

TEST_F(AppTest, DeviceCheckReadsAnImuOnASerialLine) {
  // An HI219 on a pseudo-terminal: the master side streams 0x91 frames at 100 Hz.
  hardware::PtyMasterStream imu;
  QString error;
  ASSERT_TRUE(imu.Open(&error)) << error.toStdString();
  int sent = 0;
  QTimer stream;
  QObject::connect(&stream, &QTimer::timeout, [&] {
    hardware::ImuSample sample;
    sample.yaw_deg = static_cast<float>(sent++);
    sample.gyro_dps = {0.f, 0.f, 5.f};
    sample.fields = hardware::kImuGyro | hardware::kImuEuler;
    const auto frame = hardware::EncodeHi219Packet91Frame(sample);
    imu.Write(frame.data(), frame.size());
  });
  stream.start(10);
  DeviceCheckDialog dialog(workspace_.get(), window_.get());
  dialog.SetKind(hardware::DirectDevice::Kind::kHi219);
  dialog.SetPort(imu.SlavePath());
  dialog.show();
  bool done = false;
  QObject::connect(&dialog, &DeviceCheckDialog::finished, [&](bool) { done = true; });
  QTest::mouseClick(dialog.findChild<QPushButton*>(), Qt::LeftButton);
  ASSERT_TRUE(WaitFor([&] { return done; }, 10000));
  EXPECT_TRUE(dialog.passed()) << dialog.report().toStdString();
  EXPECT_NE(dialog.report().indexOf("HI219 samples"), -1) << dialog.report().toStdString();
  EXPECT_NE(dialog.report().indexOf(" 0 checksum errors"), -1) << dialog.report().toStdString();
  // A port that does not exist is a clear failure, and the app keeps going.
  done = false;
  dialog.SetPort("/dev/does-not-exist");
  dialog.StartCheck();
  ASSERT_TRUE(WaitFor([&] { return done; }, 10000));
  EXPECT_FALSE(dialog.passed());
  EXPECT_NE(dialog.report().indexOf("Cannot open"), -1) << dialog.report().toStdString();
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
