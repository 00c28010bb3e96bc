// The desktop app driven through its real widgets (QTest) and its workspace,
// under a real display (xvfb-run in CI): the built-in simulator over loopback
// TCP, the VTK view's rendered image, the emergency stop on Space, a wrong
// key against a sweepscan-sim process, save / open, corrupt sessions, and
// replay against `sweepscan-cli reconstruct`.
#include "ui/main_window.h"

#include <QVTKOpenGLNativeWidget.h>
#include <gtest/gtest.h>

#include <QApplication>
#include <QDir>
#include <QElapsedTimer>
#include <QFile>
#include <QImage>
#include <QLineEdit>
#include <QProcess>
#include <QPushButton>
#include <QSettings>
#include <QSurfaceFormat>
#include <QTemporaryDir>
#include <QTest>
#include <QThread>
#include <QTimer>
#include <QUndoStack>
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
#include "ui/panels/calibration_panel.h"
#include "ui/panels/connection_panel.h"
#include "ui/panels/device_check_dialog.h"
#include "ui/panels/drive_panel.h"
#include "ui/panels/evaluation_panel.h"
#include "ui/view/cloud_view.h"
#include "ui/workspace/sim_robot.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

const QString kResources = QStringLiteral(SWEEPSCAN_SOURCE_DIR "/resources");

bool WaitFor(const std::function<bool()>& done, int timeout_ms) {
  QElapsedTimer clock;
  clock.start();
  while (!done()) {
    if (clock.elapsed() > timeout_ms) return false;
    QCoreApplication::processEvents(QEventLoop::AllEvents, 10);
    QThread::msleep(2);
  }
  return true;
}

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

class AppTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(tmp_.isValid());
    QSettings::setDefaultFormat(QSettings::IniFormat);
    QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, tmp_.path() + "/settings");
    workspace_ = std::make_unique<Workspace>();
    workspace_->set_sessions_root(tmp_.path() + "/sessions");
    window_ = std::make_unique<MainWindow>(workspace_.get(), kResources);
    window_->SetInteractive(false);
    window_->resize(1100, 700);
    window_->show();
    ASSERT_TRUE(QTest::qWaitForWindowExposed(window_.get()));
  }
  void TearDown() override {
    window_.reset();
    workspace_.reset();
  }

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

  QTemporaryDir tmp_;
  std::unique_ptr<Workspace> workspace_;
  std::unique_ptr<MainWindow> window_;
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
  const std::string dir = tmp_.path().toStdString();
  const auto sim = testing::RunCommand(std::string(SWEEPSCAN_CLI) + " simulate --scenario " +
                                       kResources.toStdString() + "/scenarios/lab.json --out " +
                                       dir + "/lab.ply");
  ASSERT_EQ(sim.code, 0) << sim.out;
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

TEST_F(AppTest, OpeningShowsProgressAndCancelStopsIt) {
  const std::string dir = tmp_.path().toStdString();
  const auto sim = testing::RunCommand(std::string(SWEEPSCAN_CLI) + " simulate --scenario " +
                                       kResources.toStdString() + "/scenarios/lab.json --out " +
                                       dir + "/lab.ply");
  ASSERT_EQ(sim.code, 0) << sim.out;
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
TEST_F(AppTest, CalibrationPanelPicksSolvesAndShowsTheCalibratedCloud) {
  const std::string dir = tmp_.path().toStdString();
  const auto sim = testing::RunCommand(
      std::string(SWEEPSCAN_CLI) + " simulate --scenario " + kResources.toStdString() +
      "/scenarios/lab_circle_diamond.json --out " + dir + "/diamond.ply");
  ASSERT_EQ(sim.code, 0) << sim.out;
  bool replayed = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { replayed = true; });
  window_->OpenSessionPath(tmp_.path() + "/diamond.sweepscan");
  ASSERT_TRUE(WaitFor([&] { return replayed; }, 120000)) << window_->last_error().toStdString();
  const std::vector<CloudPoint> before = workspace_->CloudSnapshot();
  ASSERT_TRUE(WaitFor([&] { return window_->view()->point_count() == before.size(); }, 10000));
  CalibrationPanel* panel = window_->calibration_panel();

  // A Shift + click picks the cloud point under the cursor (pass A).
  CloudView* view = window_->view();
  view->ViewTop();
  view->RenderNow();
  const QPoint centre(view->width() / 2, view->height() / 2);
  QTest::mouseClick(view, Qt::LeftButton, Qt::ShiftModifier, centre);
  ASSERT_EQ(panel->pair_count(), 1);
  const QPointF back = view->WorldToWidget(panel->pair_points()[0].a);
  EXPECT_LT(std::hypot(back.x() - centre.x(), back.y() - centre.y()), 7.0);
  window_->undo_stack()->undo();
  EXPECT_EQ(panel->pair_count(), 0);
  window_->undo_stack()->redo();
  EXPECT_EQ(panel->pair_count(), 1);
  window_->undo_stack()->undo();

  // The target's four corners, picked in pass A and again in pass B.
  const double h = 0.3 * std::sqrt(2.0);
  const Eigen::Vector3d corners[4] = {
      {5.0, 0.16, 1.35 + h}, {5.0 + h, 0.16, 1.35}, {5.0, 0.16, 1.35 - h}, {5.0 - h, 0.16, 1.35}};
  for (const auto& c : corners) {
    panel->AddPick(c);
    panel->AddPick(c);
  }
  ASSERT_EQ(panel->pairs().size(), 4u);
  panel->DeletePair(1);
  EXPECT_EQ(panel->pairs().size(), 3u);
  window_->undo_stack()->undo();
  ASSERT_EQ(panel->pairs().size(), 4u);
  QString error;
  ASSERT_TRUE(panel->SavePairs(tmp_.path() + "/pairs.json", &error)) << error.toStdString();
  std::vector<PickPair> saved;
  ASSERT_TRUE(LoadPairsFile(dir + "/pairs.json", &saved).ok());
  ASSERT_EQ(saved.size(), 4u);
  EXPECT_NEAR(saved[1].pass2.world.x(), corners[1].x(), 1e-6);

  bool solved = false, solved_ok = false;
  QObject::connect(panel, &CalibrationPanel::solved, [&](bool ok) {
    solved = true;
    solved_ok = ok;
  });
  panel->SetRefine(true);
  panel->Solve();
  ASSERT_TRUE(WaitFor([&] { return solved; }, 120000));
  ASSERT_TRUE(solved_ok) << panel->result_text().toStdString();
  const PickCalibrationResult* r = workspace_->calibration_result();
  ASSERT_NE(r, nullptr);
  const double truth[3] = {-0.0058, 0.0126, 0.0355};
  const double got[3] = {r->summary.angles.alpha, r->summary.angles.beta, r->summary.angles.gamma};
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(got[k], truth[k], 3e-3) << k;
    EXPECT_GT(r->summary.sigma_rad[k], 0.0) << k;
  }
  EXPECT_GT(r->summary.initial_rms_m, 10.0 * r->summary.final_rms_m);
  EXPECT_NE(panel->result_text().indexOf("alpha"), -1);

  // After: the session re-assembled under the solved angles.
  replayed = false;
  panel->ShowAfter(true);
  ASSERT_TRUE(WaitFor([&] { return replayed; }, 120000));
  const std::vector<CloudPoint> after = workspace_->CloudSnapshot();
  ASSERT_EQ(after.size(), before.size());
  double moved = 0.0;
  for (size_t i = 0; i < after.size(); i += 97)
    moved = std::max(moved, double(std::abs(after[i].z - before[i].z)));
  EXPECT_GT(moved, 0.01);  // 35 mrad of roll moves points centimetres at 1-2 m.
  ASSERT_TRUE(panel->SaveCalibration(tmp_.path() + "/calibration.json", &error))
      << error.toStdString();
  MountingError loaded;
  ASSERT_TRUE(LoadCalibrationFile(dir + "/calibration.json", &loaded).ok());
  EXPECT_NEAR(loaded.gamma, r->summary.angles.gamma, 1e-9);

  // Kept for the robot: a new recording carries it, and a new window loads it.
  panel->UseForRobot();
  EXPECT_EQ(workspace_->robot_calibration().gamma, r->summary.angles.gamma);
  ConnectToSimulator("lab_circle_diamond.json");
  ASSERT_TRUE(workspace_->StartRecording(&error)) << error.toStdString();
  ASSERT_TRUE(workspace_->StopRecording(&error)) << error.toStdString();
  SessionMeta meta;
  ASSERT_TRUE(
      ReadSessionMeta((workspace_->session_dir() + "/meta.json").toStdString(), &meta).ok());
  EXPECT_NEAR(meta.calibration.gamma, r->summary.angles.gamma, 1e-12);
  workspace_->Disconnect();
  window_->close();
  Workspace second;
  MainWindow reopened(&second, kResources);
  EXPECT_NEAR(second.robot_calibration().beta, r->summary.angles.beta, 1e-12);
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
  // A second evaluation keeps the first as "before".
  done = false;
  panel->Evaluate();
  ASSERT_TRUE(WaitFor([&] { return done; }, 120000));
  ASSERT_NE(workspace_->previous_evaluation(), nullptr);
  EXPECT_NE(panel->summary_text().indexOf("previous evaluation"), -1);
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

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  // Listing the tests (CTest's discovery) needs no display; running them does
  // (xvfb-run in CI).
  if (::testing::GTEST_FLAG(list_tests)) return RUN_ALL_TESTS();
  QSurfaceFormat::setDefaultFormat(QVTKOpenGLNativeWidget::defaultFormat());
  QApplication app(argc, argv);
  return RUN_ALL_TESTS();
}
