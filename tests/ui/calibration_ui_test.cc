// The calibration panel driven through the real widgets (QTest) under a
// real display (xvfb-run in CI): picks through the view on the simulated
// diamond drive, undo / redo, the pairs file, the refined solve against the
// truth, cancelling, the automatic mode against the CLI, and a noisy IMU
// refused.
#include <QVTKOpenGLNativeWidget.h>
#include <gtest/gtest.h>
#include <vtkPropCollection.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>
#include <vtkScalarBarActor.h>
#include <vtkScalarsToColors.h>

#include <QAction>
#include <QApplication>
#include <QCheckBox>
#include <QComboBox>
#include <QDir>
#include <QDoubleSpinBox>
#include <QElapsedTimer>
#include <QFile>
#include <QFileDialog>
#include <QFileInfo>
#include <QImage>
#include <QLineEdit>
#include <QProcess>
#include <QPushButton>
#include <QRegularExpression>
#include <QSettings>
#include <QStatusBar>
#include <QSurfaceFormat>
#include <QTableWidget>
#include <QTemporaryDir>
#include <QTest>
#include <QThread>
#include <QTimer>
#include <QUndoGroup>
#include <QUndoStack>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>

#include "core/calibration/calibration_file.h"
#include "core/calibration/picks.h"
#include "core/cloud/cloud_io.h"
#include "core/session/session.h"
#include "hardware/codecs/hi219_codec.h"
#include "hardware/link/qt_transport.h"
#include "tests/testing/event_loop_turns.h"
#include "tests/testing/run_command.h"
#include "tests/ui/app_fixture.h"
#include "tests/ui/file_chooser.h"
#include "tests/ui/pick_truth.h"
#include "ui/main_window.h"
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

class CalibrationTest : public testing::AppFixture {
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
  const std::vector<CloudPoint> before = workspace_->CloudSnapshot().Flatten();
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
    return p.size() * 2 - ((!p.empty() && !p.back().complete()) ? 1 : 0);
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
      ASSERT_TRUE(testing::ShiftClick(view, px));
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
  window_->undo_group()->undo();
  EXPECT_EQ(panel->pairs().size(), 3u);
  EXPECT_EQ(panel->pair_count(), 4);  // The last pair is waiting for its B again.
  window_->undo_group()->redo();
  ASSERT_EQ(panel->pairs().size(), 4u);
  panel->DeletePair(1);
  EXPECT_EQ(panel->pairs().size(), 3u);
  window_->undo_group()->undo();
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
  // Combined with the room's planes by default (kept in the settings), for
  // the refined solve only.
  auto* combine = panel->findChild<QCheckBox*>(QStringLiteral("combineWithPlanes"));
  ASSERT_NE(combine, nullptr);
  EXPECT_TRUE(combine->isChecked());
  panel->SetRefine(false);
  EXPECT_FALSE(thickness->isEnabled());
  EXPECT_FALSE(combine->isEnabled());
  panel->SetRefine(true);
  EXPECT_TRUE(thickness->isEnabled());
  EXPECT_TRUE(combine->isEnabled());
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
  // How the board's edges held: the refined fit's counts, as the summary has them.
  EXPECT_GT(r->summary.edge_points, 0);
  EXPECT_GE(r->summary.rejected_edge_points, 0);
  EXPECT_GE(r->summary.shifted_edge_points, 0);
  EXPECT_NE(panel->result_text().indexOf(QStringLiteral("%1 edge points kept, %2 rejected, %3 a sample off")
                                             .arg(r->summary.edge_points)
                                             .arg(r->summary.rejected_edge_points)
                                             .arg(r->summary.shifted_edge_points)),
            -1)
      << panel->result_text().toStdString();
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
  // Those gaps are the fitted corners', not the picks' in each row: the
  // column says so.
  auto* table = panel->findChild<QTableWidget*>();
  ASSERT_NE(table, nullptr);
  EXPECT_EQ(table->horizontalHeaderItem(2)->text(), "corner\ngap (mm)");
  for (int k = 0; k < 4; ++k) {
    EXPECT_LT((r->corners[0].corners[k] - r->corners[1].corners[k]).norm(), 0.01) << k;
    EXPECT_LT((r->corners[0].corners[k] - kDiamondCorners[k]).norm(), 0.03) << k;
  }
  // The board and the room's planes, each alone, beside their combination
  // (workflow.h, combine_with_planes), as `sweepscan-cli calibrate --refine`.
  EXPECT_EQ(r->summary.method, "refined-corners+planes");
  ASSERT_TRUE(r->has_board_alone && r->has_planes);
  EXPECT_GE(r->planes_chi2, 0.0);
  const QString text = panel->result_text();
  EXPECT_NE(text.indexOf(QStringLiteral("combined with the room's planes (agreement chi² %1")
                             .arg(r->planes_chi2, 0, 'f', 1)),
            -1)
      << text.toStdString();
  EXPECT_NE(text.indexOf(QStringLiteral("board alone: %1 ± %2")
                             .arg(r->board_alone.angles.alpha * 1e3, 0, 'f', 2)
                             .arg(r->board_alone.sigma_rad[0] * 1e3, 0, 'f', 2)),
            -1)
      << text.toStdString();
  EXPECT_NE(text.indexOf(QStringLiteral("planes alone: %1 ± %2")
                             .arg(r->planes.angles.alpha * 1e3, 0, 'f', 2)
                             .arg(r->planes.sigma_rad[0] * 1e3, 0, 'f', 2)),
            -1)
      << text.toStdString();
  // Unticked (a click, kept in the settings): the board's angles alone, the
  // very part shown beside the combination; the rest goes on with it.
  const CalibrationSummary board_alone = r->board_alone;
  QTest::mouseClick(combine, Qt::LeftButton, {}, QPoint(8, combine->height() / 2));
  EXPECT_FALSE(combine->isChecked());
  EXPECT_FALSE(QSettings().value(QStringLiteral("calibration/combine_with_planes")).toBool());
  panel->Solve();
  ASSERT_TRUE(WaitForSolve(panel)) << panel->result_text().toStdString();
  r = workspace_->calibration_result();
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->summary.method, "refined-corners");
  EXPECT_FALSE(r->has_board_alone);
  EXPECT_NEAR(r->summary.angles.alpha, board_alone.angles.alpha, 1e-12);
  EXPECT_NEAR(r->summary.angles.beta, board_alone.angles.beta, 1e-12);
  EXPECT_NEAR(r->summary.angles.gamma, board_alone.angles.gamma, 1e-12);
  EXPECT_EQ(panel->result_text().indexOf(QStringLiteral("board alone")), -1);
  panel->SetCombineWithPlanes(true);

  // After: the session re-assembled under the solved angles, the passes
  // labelled again.
  bool replayed = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { replayed = true; });
  panel->ShowAfter(true);
  ASSERT_TRUE(WaitFor([&] { return replayed; }, 120000));
  const std::vector<CloudPoint> after = workspace_->CloudSnapshot().Flatten();
  ASSERT_EQ(after.size(), before.size());
  double moved = 0.0;
  for (size_t i = 0; i < after.size(); i += 97)
    moved = std::max(moved, double(std::abs(after[i].z - before[i].z)));
  EXPECT_GT(moved, 0.01);  // 35 mrad of roll moves points centimetres at 1-2 m.
  EXPECT_TRUE(WaitFor(
      [&] { return view->has_point_values(CloudView::ColorMode::kPass); }, 10000));
  // The status bar says the cloud shown is the calibrated one, and back.
  EXPECT_EQ(window_->pose_source_status(), "Poses: EKF · calibrated");
  replayed = false;
  panel->ShowAfter(false);
  ASSERT_TRUE(WaitFor([&] { return replayed; }, 120000));
  EXPECT_EQ(window_->pose_source_status(), "Poses: EKF");
  const std::vector<CloudPoint> again = workspace_->CloudSnapshot().Flatten();
  ASSERT_EQ(again.size(), before.size());
  for (size_t i = 0; i < again.size(); i += 97) ASSERT_EQ(again[i].z, before[i].z) << i;
  replayed = false;
  panel->ShowAfter(true);
  ASSERT_TRUE(WaitFor([&] { return replayed; }, 120000));

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
  // Step 3 says the drive being recorded is picked once opened (its live
  // cloud's picks are cleared then), and after it, to open it.
  EXPECT_TRUE(panel->pick_prompt().startsWith("Recording: when the drive ends"))
      << panel->pick_prompt().toStdString();
  ASSERT_TRUE(workspace_->StopRecording(&error)) << error.toStdString();
  EXPECT_NE(panel->pick_prompt().indexOf("open its session"), -1)
      << panel->pick_prompt().toStdString();
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
  // The event loop's turns for 400 ms while the job runs: a solve on the
  // GUI thread would hold it for seconds; its turns took at most 10 ms of CPU
  // measured (24 ms of wall time alone, up to 200 before, under load).
  const testing::EventLoopTurns turns = testing::MeasureTurnsUntil([] { return false; }, 400);
  testing::ExpectResponsive("solve", turns, 150.0, 1000);
  std::printf("frames %llu, last %.0f ms, view %dx%d (was %d)\n",
              static_cast<unsigned long long>(window_->view()->frames_rendered() - frames_before),
              window_->view()->last_render_ms(), window_->view()->width(), window_->view()->height(),
              height_before);
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

// Picks are points of the session they were picked in: the same session
// opened again keeps them and their undo history; another one clears both,
// and the panel says what went.
TEST_F(CalibrationTest, PairsStayWithTheirSessionAndGoWhenAnotherOpens) {
  OpenDiamond();
  CalibrationPanel* panel = window_->calibration_panel();
  for (int i = 0; i < 2; ++i) {
    panel->AddPick(kDiamondCorners[i]);
    panel->AddPick(kDiamondCorners[i]);
  }
  panel->AddPick(kDiamondCorners[2]);
  ASSERT_EQ(panel->pair_points().size(), 3u);
  QUndoStack* history = window_->session_undo_stack();
  const int commands = history->count();
  ASSERT_EQ(commands, 5);

  OpenDiamond();
  EXPECT_EQ(panel->pair_points().size(), 3u);
  EXPECT_EQ(history->count(), commands);
  EXPECT_EQ(panel->pick_prompt().indexOf("cleared"), -1) << panel->pick_prompt().toStdString();

  workspace_->NewSession();
  EXPECT_TRUE(panel->pair_points().empty());
  EXPECT_EQ(history->count(), 0);
  EXPECT_FALSE(window_->undo_group()->canUndo());
  EXPECT_NE(panel->pick_prompt().indexOf("the 3 pairs picked in diamond.sweepscan were cleared"),
            -1)
      << panel->pick_prompt().toStdString();
  // Picking again: the note has been read.
  panel->AddPick(kDiamondCorners[0]);
  EXPECT_EQ(panel->pick_prompt().indexOf("cleared"), -1) << panel->pick_prompt().toStdString();
  EXPECT_EQ(history->count(), 1);
  // A pick on the live cloud goes with it too: New Session starts another.
  workspace_->NewSession();
  EXPECT_TRUE(panel->pair_points().empty());
  EXPECT_EQ(history->count(), 0);
  EXPECT_NE(panel->pick_prompt().indexOf("the pair picked in the live cloud was cleared"), -1)
      << panel->pick_prompt().toStdString();
}

// A pair may start in either pass. Its first pick, made with pass B shown,
// is listed under pass B and the prompt asks for the same corner in pass A
// (it was listed under "pass A (m)", and the prompt asked for pass B). A
// pick again in the pass the open pair has replaces that pick; with both
// passes shown a pair takes A, then B; Undo takes back each pick. Before a
// session is open, the prompt says to open one.
TEST_F(CalibrationTest, APairStartedInPassBWaitsForItsPickInPassA) {
  CalibrationPanel* panel = window_->calibration_panel();
  // No session: step 3 says where pairs come from, not which pass to pick in.
  EXPECT_NE(panel->pick_prompt().indexOf("open its session"), -1)
      << panel->pick_prompt().toStdString();
  OpenDiamond();
  auto* table = panel->findChild<QTableWidget*>();
  ASSERT_NE(table, nullptr);
  const Eigen::Vector3d in_b = kDiamondCorners[0] + Eigen::Vector3d(0.02, 0.0, 0.0);
  const Eigen::Vector3d again = kDiamondCorners[0] + Eigen::Vector3d(0.0, 0.01, 0.0);
  const Eigen::Vector3d in_a = kDiamondCorners[0];
  panel->ShowPass(1);
  panel->AddPick(in_b);
  ASSERT_EQ(panel->pair_points().size(), 1u);
  EXPECT_EQ(table->item(0, 0)->text(), QStringLiteral("(pick A)"));
  EXPECT_NE(table->item(0, 1)->text(), QStringLiteral("(pick B)"));
  EXPECT_NE(panel->pick_prompt().indexOf("same corner in pass A"), -1)
      << panel->pick_prompt().toStdString();
  EXPECT_TRUE(panel->pairs().empty());
  panel->AddPick(again);  // pass B again: the corner picked anew
  ASSERT_EQ(panel->pair_points().size(), 1u);
  EXPECT_FALSE(panel->pair_points()[0].has_a);
  EXPECT_EQ(panel->pair_points()[0].b, again);
  panel->ShowPass(0);
  panel->AddPick(in_a);
  ASSERT_EQ(panel->pairs().size(), 1u);
  EXPECT_EQ(panel->pairs()[0].pass1.world, in_a);
  EXPECT_EQ(panel->pairs()[0].pass2.world, again);
  EXPECT_NE(panel->pick_prompt().indexOf("1 complete pairs"), -1)
      << panel->pick_prompt().toStdString();
  // Both passes shown: A, then B.
  panel->ShowPass(-1);
  panel->AddPick(kDiamondCorners[1]);
  EXPECT_NE(panel->pick_prompt().indexOf("same corner in pass B"), -1)
      << panel->pick_prompt().toStdString();
  panel->AddPick(kDiamondCorners[2]);
  ASSERT_EQ(panel->pairs().size(), 2u);
  EXPECT_EQ(panel->pairs()[1].pass1.world, kDiamondCorners[1]);
  EXPECT_EQ(panel->pairs()[1].pass2.world, kDiamondCorners[2]);
  // Undo, a pick at a time: back to the first pair complete, then waiting
  // for pass A with its second pass-B pick, then with its first.
  QUndoStack* history = window_->session_undo_stack();
  history->undo();
  history->undo();
  history->undo();
  ASSERT_EQ(panel->pair_points().size(), 1u);
  EXPECT_FALSE(panel->pair_points()[0].has_a);
  EXPECT_EQ(panel->pair_points()[0].b, again);
  history->undo();
  ASSERT_EQ(panel->pair_points().size(), 1u);
  EXPECT_EQ(panel->pair_points()[0].b, in_b);
  EXPECT_EQ(table->item(0, 0)->text(), QStringLiteral("(pick A)"));
}

// The pairs' Save… (offered with a complete pair) and Load… through
// their file choosers: opened beside
// the session, named after it; a name typed without a suffix gets .json;
// a pick waiting for its partner is said not to be saved; a file that is
// no pairs file is an error message (it was a line in step 4, scrolled out
// of view), and the pairs stay.
TEST_F(CalibrationTest, PairsFilesBesideTheSessionAndTheirErrorsSaid) {
  OpenDiamond();
  CalibrationPanel* panel = window_->calibration_panel();
  auto* save = window_->findChild<QPushButton*>(QStringLiteral("savePairs"));
  ASSERT_NE(save, nullptr);
  EXPECT_FALSE(save->isEnabled());  // nothing to save
  panel->AddPick(kDiamondCorners[0]);
  EXPECT_FALSE(save->isEnabled());  // half a pair
  panel->AddPick(kDiamondCorners[0]);
  panel->AddPick(kDiamondCorners[1]);  // its partner not yet picked
  EXPECT_TRUE(save->isEnabled());
  // Delete with a pair selected only.
  auto* remove = window_->findChild<QPushButton*>(QStringLiteral("deletePair"));
  auto* table = panel->findChild<QTableWidget*>();
  ASSERT_TRUE(remove != nullptr && table != nullptr);
  table->clearSelection();
  table->setCurrentCell(-1, -1);
  EXPECT_FALSE(remove->isEnabled());
  table->selectRow(0);
  EXPECT_TRUE(remove->isEnabled());
  table->setCurrentCell(-1, -1);
  const QString folder = QFileInfo(DiamondSession()).absolutePath();
  QString opened_in, suggested;
  testing::AnswerFileChooser(QStringLiteral("mine"), nullptr, &opened_in, &suggested);
  save->click();
  EXPECT_EQ(opened_in, folder);
  EXPECT_EQ(suggested, QStringLiteral("diamond-pairs.json"));
  std::vector<PickPair> saved;
  ASSERT_TRUE(LoadPairsFile((folder + "/mine.json").toStdString(), &saved).ok());
  EXPECT_EQ(saved.size(), 1u);
  EXPECT_NE(window_->statusBar()->currentMessage().indexOf("the unfinished pair is not saved"), -1)
      << window_->statusBar()->currentMessage().toStdString();

  QFile text(folder + "/notes.json");
  ASSERT_TRUE(text.open(QIODevice::WriteOnly));
  text.write("these are notes, not pairs\n");
  text.close();
  const int errors = window_->errors_shown();
  testing::AnswerFileChooser(QStringLiteral("notes.json"), nullptr, &opened_in, &suggested);
  window_->findChild<QPushButton*>(QStringLiteral("loadPairs"))->click();
  EXPECT_EQ(opened_in, folder);
  EXPECT_EQ(window_->errors_shown(), errors + 1);
  EXPECT_NE(window_->last_error().indexOf("notes.json"), -1) << window_->last_error().toStdString();
  EXPECT_EQ(panel->pair_points().size(), 2u);
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
  // The live plot's iterations, read after the panel has drawn each one
  // (connected after the panel's slot, so called after it).
  std::vector<int> live;
  const QRegularExpression iterations(QStringLiteral(", (\\d+) iterations"));
  const QMetaObject::Connection watch =
      QObject::connect(workspace_.get(), &Workspace::calibrationIteration, [&](int, double) {
        const QRegularExpressionMatch m = iterations.match(panel->cost_caption());
        if (m.hasMatch()) live.push_back(m.captured(1).toInt());
      });
  panel->SolveAutomatic();
  ASSERT_TRUE(WaitForSolve(panel)) << panel->result_text().toStdString();
  QObject::disconnect(watch);
  const PickCalibrationResult* r = workspace_->calibration_result();
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->summary.method, "auto-planes");
  // While solving, the plot grew through the rounds into the whole solve's
  // trace; it restarted at each round's first iteration.
  ASSERT_FALSE(live.empty());
  EXPECT_TRUE(std::is_sorted(live.begin(), live.end())) << ::testing::PrintToString(live);
  EXPECT_EQ(static_cast<size_t>(live.back()), r->summary.trace.size() - 1)
      << ::testing::PrintToString(live);
  EXPECT_NEAR(r->summary.angles.alpha, expected["alpha"].get<double>(), 1e-9);
  EXPECT_NEAR(r->summary.angles.beta, expected["beta"].get<double>(), 1e-9);
  EXPECT_NEAR(r->summary.angles.gamma, expected["gamma"].get<double>(), 1e-9);
  const double got[3] = {r->summary.angles.alpha, r->summary.angles.beta, r->summary.angles.gamma};
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(got[k], kTruthRad[k], 1e-3) << k;
  EXPECT_NE(panel->result_text().indexOf("planes"), -1);
  EXPECT_NE(panel->result_text().indexOf("smoothed over the drive"), -1)
      << panel->result_text().toStdString();
  // The cost beside the RMS is the whole solve's, from its first iteration
  // to its last (all rounds), without a percentage: the last round's alone
  // (it starts near the answer) read "-0.16 %" beside "60 mm -> 5.8 mm".
  const std::vector<CalibrationIteration>& trace = r->summary.trace;
  ASSERT_GE(trace.size(), 2u);
  EXPECT_LT(r->summary.final_rms_m, 0.5 * r->summary.initial_rms_m);
  EXPECT_LT(trace.back().cost, 0.5 * trace.front().cost)
      << "the whole solve's cost fell as its RMS";
  const QString caption = panel->cost_caption();
  EXPECT_TRUE(caption.startsWith(QStringLiteral("solver cost %1 -> %2, %3 iterations")
                                     .arg(trace.front().cost, 0, 'g', 3)
                                     .arg(trace.back().cost, 0, 'g', 3)
                                     .arg(trace.size() - 1)))
      << caption.toStdString();
  EXPECT_EQ(caption.indexOf('%'), -1) << caption.toStdString();
}

// Show calibrated on a session opened by streaming (its samples let go,
// as a long drive's are): re-assembling it reads the session again, a job.
// Cancelled, or refused while another task runs, the cloud stays as it was
// and the button says so (it stayed down, "Showing calibrated", over the
// uncalibrated cloud); with nothing in the way, it is done.
TEST_F(CalibrationTest, AShowCalibratedThatDidNotHappenIsNotShownAsDone) {
  workspace_->set_stream_open_above_bytes(0);
  OpenDiamond();
  CalibrationPanel* panel = window_->calibration_panel();
  const MountingError truth{kTruthRad[0], kTruthRad[1], kTruthRad[2]};
  const QString file = tmp_.path() + "/truth.json";
  ASSERT_TRUE(SaveCalibrationFile(file.toStdString(), truth, nullptr).ok());
  QString error;
  ASSERT_TRUE(panel->LoadCalibration(file, &error)) << error.toStdString();
  QPushButton* after = nullptr;
  for (QPushButton* b : panel->findChildren<QPushButton*>())
    if (b->text() == "Show calibrated") after = b;
  ASSERT_NE(after, nullptr);
  const auto shown_truth = [&] { return workspace_->shown_calibration().gamma == truth.gamma; };

  after->click();
  ASSERT_TRUE(workspace_->job_running());  // the session read again
  workspace_->CancelJob();
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running(); }, 30000));
  EXPECT_FALSE(shown_truth());
  EXPECT_FALSE(after->isChecked());
  EXPECT_EQ(after->text(), "Show calibrated");

  workspace_->ExportCloud(tmp_.path() + "/busy.ply");  // a task in the way
  QString refused;
  const auto c = QObject::connect(workspace_.get(), &Workspace::jobFinished,
                                  [&](const QString&, bool ok, const QString& m) {
                                    if (!ok) refused = m;
                                  });
  after->click();
  QObject::disconnect(c);
  EXPECT_TRUE(refused.contains("still running")) << refused.toStdString();
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running(); }, 30000));
  EXPECT_FALSE(shown_truth());
  EXPECT_FALSE(after->isChecked());

  bool replayed = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { replayed = true; });
  after->click();
  ASSERT_TRUE(WaitFor([&] { return replayed && !workspace_->job_running(); }, 120000));
  EXPECT_TRUE(shown_truth());
  EXPECT_TRUE(after->isChecked());
  EXPECT_EQ(after->text(), "Showing calibrated");
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

// The colour bar after Evaluate, on a calibration drive coloured by pass and
// then by deviation, in the test window's narrow view: one bar, its labels
// drawn once (the passes' two names and no numbers; then five numbers and
// no names), its title and labels inside the view, and no plane's label on
// it (the planes' names, drawn over the view, covered "pass A (near side)"
// and left "side)" showing; the deviation's title ran off the right edge).
TEST_F(CalibrationTest, ColourBarIsOneLegendClearOfThePlaneLabelsAfterEvaluate) {
  OpenDiamond();
  CloudView* view = window_->view();
  ASSERT_EQ(view->color_mode(), CloudView::ColorMode::kPass);
  EvaluationPanel* evaluation = window_->evaluation_panel();
  bool done = false, ok = false;
  QObject context;
  QObject::connect(evaluation, &EvaluationPanel::evaluated, &context, [&](bool r) {
    done = true;
    ok = r;
  });
  evaluation->Evaluate();
  ASSERT_TRUE(WaitFor([&] { return done; }, 180000));
  ASSERT_TRUE(ok) << evaluation->summary_text().toStdString();
  ASSERT_GT(view->plane_count(), 4u);
  vtkRenderer* renderer = view->renderWindow()->GetRenderers()->GetFirstRenderer();
  const QRectF widget(0, 0, view->width(), view->height());
  for (const bool deviation : {false, true}) {
    SCOPED_TRACE(deviation ? "deviation" : "pass");
    evaluation->ShowDeviations(deviation);
    view->ViewOblique();
    view->RenderNow();
    std::vector<vtkScalarBarActor*> bars;
    vtkPropCollection* props = renderer->GetViewProps();
    props->InitTraversal();
    while (vtkProp* prop = props->GetNextProp()) {
      if (auto* bar = vtkScalarBarActor::SafeDownCast(prop)) bars.push_back(bar);
    }
    ASSERT_EQ(bars.size(), 1u);
    vtkScalarBarActor* bar = bars[0];
    EXPECT_TRUE(bar->GetVisibility());
    vtkScalarsToColors* lut = bar->GetLookupTable();
    if (deviation) {
      EXPECT_FALSE(lut->GetIndexedLookup());
      EXPECT_EQ(lut->GetNumberOfAnnotatedValues(), 0);
      EXPECT_EQ(bar->GetNumberOfLabels(), 5);
      EXPECT_STREQ(bar->GetTitle(), "deviation (mm)");
    } else {
      EXPECT_TRUE(lut->GetIndexedLookup());
      EXPECT_EQ(lut->GetNumberOfAnnotatedValues(), 2);
      // Indexed: the two names, and no numbers beside them (VTK draws no
      // tick labels for an indexed table).
      EXPECT_STREQ(bar->GetTitle(), "pass");
    }
    // The bar as VTK drew it, within the legend's box, itself in the view.
    int rect[4];
    bar->GetScalarBarRect(rect, renderer);
    const double ratio = view->devicePixelRatioF();
    const QRectF drawn(rect[0] / ratio, view->height() - (rect[1] + rect[3]) / ratio,
                       rect[2] / ratio, rect[3] / ratio);
    const QRectF legend = view->color_bar_box();
    EXPECT_TRUE(legend.contains(drawn.adjusted(1, 1, -1, -1)))
        << drawn.x() << " " << drawn.y() << " " << drawn.width() << " " << drawn.height();
    EXPECT_TRUE(widget.contains(legend))
        << legend.x() << " " << legend.y() << " " << legend.width() << " " << legend.height()
        << " in " << widget.width() << " x " << widget.height();
    EXPECT_FALSE(view->plane_label_boxes().empty());
    for (const CloudView::PlaneLabelBox& b : view->plane_label_boxes()) {
      EXPECT_FALSE(b.box.intersects(legend)) << "plane " << b.plane + 1 << "'s label";
    }
  }
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
