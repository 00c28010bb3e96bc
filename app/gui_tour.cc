#include "app/gui_tour.h"

#include <QAction>
#include <QCoreApplication>
#include <QDir>
#include <QElapsedTimer>
#include <QGuiApplication>
#include <QMenu>
#include <QMenuBar>
#include <QPixmap>
#include <QScreen>
#include <QThread>
#include <cstdio>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>

#include "ui/main_window.h"
#include "ui/panels/calibration_panel.h"
#include "ui/panels/evaluation_panel.h"
#include "ui/view/cloud_view.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::app {
namespace {

using ui::CalibrationPanel;
using ui::CloudView;

// The tour runs its steps in order and waits for each job by spinning the
// event loop, as an operator waits for a progress bar.
bool WaitFor(const std::function<bool()>& done, int timeout_ms) {
  QElapsedTimer clock;
  clock.start();
  while (!done()) {
    if (clock.elapsed() > timeout_ms) return false;
    QCoreApplication::processEvents(QEventLoop::AllEvents, 20);
    QThread::msleep(2);
  }
  return true;
}

class Tour {
 public:
  Tour(QString pairs, QString out_dir, ui::Workspace* w, ui::MainWindow* m)
      : pairs_(std::move(pairs)), out_(std::move(out_dir)), workspace_(w), window_(m) {
    clock_.start();
  }

  void Run() {
    CalibrationPanel* panel = window_->calibration_panel();
    CloudView* view = window_->view();
    QDir().mkpath(out_);
    window_->RaiseDock(QStringLiteral("calibrationDock"));
    // 1. The passes, split when the replay ended.
    if (!Step("passes split", [&] { return view->has_point_values(CloudView::ColorMode::kPass); },
              60000)) {
      return Finish();
    }
    QString error;
    if (!panel->LoadPairs(pairs_, &error)) {
      Fail(error);
      return Finish();
    }
    // Look at the target from the circle's side, under the ceiling.
    Eigen::Vector3d target = Eigen::Vector3d::Zero();
    for (const auto& p : panel->pair_points()) target += 0.5 * (p.a + p.b);
    target /= std::max<size_t>(1, panel->pair_points().size());
    const Eigen::Vector2d centre = workspace_->circle_centre();
    Eigen::Vector3d from(centre.x(), centre.y(), target.z() + 0.5);
    from = target + 3.0 * (from - target).normalized();
    view->SetClipHeight(2.0);
    view->LookAt(target, from);
    panel->ShowPass(-1);
    Shot("calibration-1-passes.png");
    // 2, 3. Picking: one pass at a time, the picks of that pass marked.
    panel->ShowPass(0);
    Shot("calibration-2-pick-pass-a.png");
    panel->ShowPass(1);
    Shot("calibration-3-pick-pass-b.png");
    // 4. Solve (refined corners): the result, the fitted corners.
    panel->ShowPass(-1);
    panel->SetRefine(true);
    bool solved = false, ok = false;
    QObject::connect(panel, &CalibrationPanel::solved, window_, [&](bool r) {
      solved = true;
      ok = r;
    });
    QElapsedTimer solve_clock;
    solve_clock.start();
    panel->Solve();
    if (!Step("solved", [&] { return solved; }, 300000) || !ok) return Finish();
    const double pairs_s = solve_clock.nsecsElapsed() * 1e-9;
    Shot("calibration-4-solved.png");
    // The automatic mode, timed as the operator sees it (button to result).
    solved = false;
    solve_clock.restart();
    panel->SolveAutomatic();
    if (!Step("automatic solve", [&] { return solved; }, 300000) || !ok) return Finish();
    const double auto_s = solve_clock.nsecsElapsed() * 1e-9;
    std::printf("%s\n", nlohmann::json({{"solve_4_pairs_refined_s", pairs_s},
                                        {"solve_automatic_s", auto_s}})
                            .dump()
                            .c_str());
    // Back to the picks' result for the rest of the tour.
    solved = false;
    panel->Solve();
    if (!Step("solved again", [&] { return solved; }, 300000) || !ok) return Finish();
    // Evaluate before, then show calibrated (the ghost falls together) and
    // evaluate after.
    Evaluate();
    bool replayed = false;
    QObject::connect(workspace_, &ui::Workspace::replayFinished, window_,
                     [&] { replayed = true; });
    panel->ShowAfter(true);
    if (!Step("calibrated replay", [&] { return replayed; }, 300000)) return Finish();
    WaitFor([&] { return view->has_point_values(CloudView::ColorMode::kPass); }, 20000);
    view->LookAt(target, from);
    Shot("calibration-5-calibrated.png");
    Evaluate();
    window_->RaiseDock(QStringLiteral("evaluationDock"));
    window_->evaluation_panel()->ShowDeviations(true);
    view->ViewOblique();
    Shot("evaluation-panel.png");
    Finish();
  }

 private:
  bool Step(const char* what, const std::function<bool()>& done, int timeout_ms) {
    if (WaitFor(done, timeout_ms)) return true;
    Fail(QStringLiteral("timed out waiting for: %1").arg(QString::fromLatin1(what)));
    return false;
  }

  void Evaluate() {
    bool done = false;
    auto c = QObject::connect(window_->evaluation_panel(), &ui::EvaluationPanel::evaluated,
                              window_, [&](bool) { done = true; });
    window_->evaluation_panel()->Evaluate();
    Step("evaluation", [&] { return done; }, 300000);
    QObject::disconnect(c);
  }

  void Shot(const QString& name) {
    window_->view()->SetLodActive(false);
    for (int i = 0; i < 5; ++i) QCoreApplication::processEvents(QEventLoop::AllEvents, 20);
    window_->view()->RenderNow();
    const QString path = QDir(out_).filePath(name);
    const bool saved = window_->grab().save(path);
    const nlohmann::json j = {{"file", path.toStdString()},
                              {"saved", saved},
                              {"t_s", clock_.nsecsElapsed() * 1e-9}};
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
    if (!saved) Fail(path + QStringLiteral(": cannot write the image"));
  }

  void Fail(const QString& message) {
    std::fprintf(stderr, "sweepscan: tour: %s\n", qPrintable(message));
    failed_ = true;
  }

  void Finish() {
    window_->SetInteractive(false);
    window_->close();
    QCoreApplication::exit(failed_ ? 1 : 0);
  }

  QString pairs_, out_;
  ui::Workspace* workspace_;
  ui::MainWindow* window_;
  QElapsedTimer clock_;
  bool failed_ = false;
};

// The pose source tour: SfM chosen from Tools > Pose Source on the session
// shown, then the menu open over the SfM cloud. Menus are windows of their
// own, so the picture is the screen's (the window at its top left).
void RunPoseSourceTour(const QString& png, ui::Workspace* workspace, ui::MainWindow* window) {
  auto fail = [window](const QString& message) {
    std::fprintf(stderr, "sweepscan: pose source tour: %s\n", qPrintable(message));
    window->SetInteractive(false);
    window->close();
    QCoreApplication::exit(1);
  };
  QAction* sfm = window->pose_source_action(PoseSource::kSfm);
  auto* submenu = window->findChild<QMenu*>(QStringLiteral("poseSourceMenu"));
  QMenu* tools = nullptr;
  for (QAction* a : window->menuBar()->actions()) {
    if (a->menu() != nullptr && a->menu()->actions().contains(submenu->menuAction())) {
      tools = a->menu();
    }
  }
  if (sfm == nullptr || submenu == nullptr || tools == nullptr) {
    return fail(QStringLiteral("no Tools > Pose Source"));
  }
  bool replayed = false;
  auto c =
      QObject::connect(workspace, &ui::Workspace::replayFinished, window, [&] { replayed = true; });
  // One job at a time: a circle drive's pass split runs after its replay.
  WaitFor([&] { return !workspace->job_running(); }, 60000);
  QElapsedTimer clock;
  clock.start();
  sfm->trigger();
  // Done, or refused / failed (the choice went back to the EKF).
  const bool done = WaitFor(
      [&] {
        return !workspace->job_running() &&
               (replayed || workspace->pose_source() != PoseSource::kSfm);
      },
      300000);
  QObject::disconnect(c);
  if (!done || workspace->shown_pose_source() != PoseSource::kSfm) {
    return fail(QStringLiteral("SfM did not finish: %1").arg(window->last_error()));
  }
  const double sfm_s = clock.nsecsElapsed() * 1e-9;
  // Into the room: the ceiling hidden (View > Hide Ceiling), the walls and
  // the floor the SfM planes came from in sight.
  window->view()->SetClipHeight(2.0);
  window->view()->ViewOblique();
  window->view()->SetLodActive(false);
  window->view()->RenderNow();
  // Tools opened from the menu bar, its Pose Source submenu beside it.
  window->menuBar()->setActiveAction(tools->menuAction());
  WaitFor([&] { return tools->isVisible(); }, 2000);
  tools->setActiveAction(submenu->menuAction());
  submenu->popup(tools->mapToGlobal(tools->actionGeometry(submenu->menuAction()).topRight()));
  submenu->setActiveAction(sfm);
  WaitFor([] { return false; }, 300);
  const QPixmap shot = QGuiApplication::primaryScreen()->grabWindow(0);
  const QRect area = window->frameGeometry().united(submenu->geometry()).united(tools->geometry());
  const bool saved = shot.copy(area).save(png);
  const nlohmann::json j = {{"file", png.toStdString()},
                            {"saved", saved},
                            {"reprocess_sfm_s", sfm_s},
                            {"status", window->pose_source_status().toStdString()}};
  std::printf("%s\n", j.dump().c_str());
  std::fflush(stdout);
  submenu->close();
  tools->close();
  if (!saved) return fail(png + QStringLiteral(": cannot write the image"));
  window->SetInteractive(false);
  window->close();
  QCoreApplication::exit(0);
}

}  // namespace

void StartPoseSourceTour(const QString& png, ui::Workspace* workspace, ui::MainWindow* window) {
  auto started = std::make_shared<bool>(false);
  // A session that does not open ends the tour (else it would wait forever).
  QObject::connect(workspace, &ui::Workspace::jobFinished, window,
                   [=](const QString& what, bool ok, const QString& message) {
                     if (*started || ok) return;
                     *started = true;
                     std::fprintf(stderr, "sweepscan: pose source tour: %s: %s\n", qPrintable(what),
                                  qPrintable(message));
                     window->SetInteractive(false);
                     window->close();
                     QCoreApplication::exit(1);
                   });
  QObject::connect(workspace, &ui::Workspace::replayFinished, window,
                   [=] {
                     if (*started) return;
                     *started = true;
                     RunPoseSourceTour(png, workspace, window);
                   },
                   Qt::QueuedConnection);
}

void StartCalibrationTour(const QString& pairs, const QString& out_dir, ui::Workspace* workspace,
                          ui::MainWindow* window) {
  auto started = std::make_shared<bool>(false);
  QObject::connect(workspace, &ui::Workspace::replayFinished, window,
                   [=] {
                     if (*started) return;
                     *started = true;
                     Tour(pairs, out_dir, workspace, window).Run();
                   },
                   Qt::QueuedConnection);
}

}  // namespace sweepscan::app
