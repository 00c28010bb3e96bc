// The main window's menus (File, Edit, View, Robot, Tools with the pose
// source, Help): their actions, shortcuts and the undoable view edits.
#include <QAction>
#include <QActionGroup>
#include <QApplication>
#include <QDockWidget>
#include <QFileDialog>
#include <QFileInfo>
#include <QInputDialog>
#include <QLabel>
#include <QMenu>
#include <QMenuBar>
#include <QMessageBox>
#include <QSettings>
#include <QStatusBar>
#include <QTimer>
#include <QUndoCommand>
#include <QUndoGroup>
#include <QUndoStack>
#include <algorithm>
#include <functional>

#include "ui/cloud_export_chooser.h"
#include "ui/filter_suffix.h"
#include "ui/help_text.h"
#include "ui/main_window.h"
#include "ui/panels/calibration_panel.h"
#include "ui/panels/connection_panel.h"
#include "ui/panels/device_check_dialog.h"
#include "ui/panels/drive_panel.h"
#include "ui/panels/evaluation_panel.h"
#include "ui/panels/replay_panel.h"
#include "ui/plan/plan_panel.h"
#include "ui/project/project_controller.h"
#include "ui/undo_router.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

// The pose sources an opened session can be made with, in menu order.
constexpr PoseSource kPoseSources[] = {PoseSource::kEkf, PoseSource::kOdometry, PoseSource::kSfm};

// View appearance changes are edits: undoable (Ctrl+Z / Ctrl+Shift+Z), on
// the active history (UndoRouter).
class ColorModeCommand : public QUndoCommand {
 public:
  ColorModeCommand(CloudView* view, CloudView::ColorMode to, std::function<void()> sync)
      : view_(view), from_(view->color_mode()), to_(to), sync_(std::move(sync)) {
    setText(QObject::tr("colour mode"));
  }
  void redo() override {
    view_->SetColorMode(to_);
    sync_();
  }
  void undo() override {
    view_->SetColorMode(from_);
    sync_();
  }

 private:
  CloudView* view_;
  CloudView::ColorMode from_, to_;
  std::function<void()> sync_;
};

class PointSizeCommand : public QUndoCommand {
 public:
  PointSizeCommand(CloudView* view, double to) : view_(view), from_(view->point_size()), to_(to) {
    setText(QObject::tr("point size"));
  }
  void redo() override { view_->SetPointSize(to_); }
  void undo() override { view_->SetPointSize(from_); }

 private:
  CloudView* view_;
  double from_, to_;
};

}  // namespace

void MainWindow::BuildMenus() {
  BuildFileMenu();
  BuildEditMenu();
  BuildViewMenu();
  BuildRobotMenu();
  BuildToolsMenu();
  BuildHelpMenu();
}

void MainWindow::BuildFileMenu() {
  QMenu* file = menuBar()->addMenu(tr("&File"));
  QAction* new_session = file->addAction(tr("&New Session"), this, [this] {
    const auto fresh = [this] { workspace_->NewSession(); };
    if (ConfirmDiscard(fresh)) fresh();
  });
  new_session->setShortcut(QKeySequence::New);
  QAction* open = file->addAction(tr("&Open Session…"), this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(
        this, tr("Open session folder (NAME.sweepscan)"), SessionDialogDir());
    if (dir.isEmpty()) return;
    QSettings().setValue(QStringLiteral("sessions/open_dir"), QFileInfo(dir).absolutePath());
    OpenSessionPath(dir);
  });
  open->setShortcut(QKeySequence::Open);
  recent_menu_ = file->addMenu(tr("Open &Recent"));
  // A ROS 1 .bag, an .mcap or .db3, or a ROS 2 bag folder's metadata.yaml.
  QAction* import_ros = file->addAction(tr("&Import ROS Recording…"), this, [this] {
    QSettings settings;
    const QString path = QFileDialog::getOpenFileName(
        this, tr("Import ROS recording"), settings.value(QStringLiteral("rosImport/dir")).toString(),
        tr("ROS bags (*.bag *.mcap *.db3 metadata.yaml);;All files (*)"));
    if (path.isEmpty()) return;
    settings.setValue(QStringLiteral("rosImport/dir"), QFileInfo(path).absolutePath());
    ImportRosRecordingPath(path);
  });
  import_ros->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_I));
  QAction* save_as = file->addAction(tr("Save Session &As…"), this, [this] {
    const QString dir = QFileDialog::getSaveFileName(
        this, tr("Save session as"), SessionDialogDir(), tr("Sessions (*.sweepscan)"));
    if (dir.isEmpty()) return;
    SaveSessionTo(dir);
  });
  // Spelled out: QKeySequence::SaveAs is empty under X11's generic theme
  // (and KDE's), which left Ctrl+Shift+S dead while Help listed it.
  save_as->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_S));
  file->addSeparator();
  project_->AddFileMenuActions(file);
  file->addSeparator();
  QAction* export_cloud = file->addAction(tr("&Export Cloud…"), this, [this] {
    // With a project shown and no session, the cloud in view is the
    // project's: that is what is exported.
    if (workspace_->CloudSize() == 0 && project_->document()->is_open()) {
      project_->ExportWithDialog();
      return;
    }
    // Named after the session, beside it (it opened in the working folder
    // with no name).
    const QFileInfo session(workspace_->session_dir());
    const bool named = !workspace_->session_dir().isEmpty();
    const QString path =
        ChooseCloudExport(this, tr("Export cloud"), named ? session.completeBaseName() : QString(),
                          named ? session.absolutePath() : QString());
    if (!path.isEmpty()) workspace_->ExportCloud(path);
  });
  export_cloud->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_E));
  project_->AddExportAction(file);
  plan_panel_->SetFileExportAction(
      file->addAction(tr("Export Floor P&lan…"), plan_panel_, &PlanPanel::ExportWithDialog));
  QAction* shot = file->addAction(tr("Save &Screenshot…"), this, [this] {
    QString filter;
    const QString path =
        WithFilterSuffix(QFileDialog::getSaveFileName(this, tr("Save screenshot"), QString(),
                                                      tr("PNG (*.png)"), &filter),
                         filter);
    QString error;
    if (!path.isEmpty() && !view_->SaveScreenshot(path, &error)) ShowError(tr("Screenshot"), error);
  });
  shot->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_P));
  file->addSeparator();
  QAction* quit = file->addAction(tr("&Quit"), this, &QWidget::close);
  quit->setShortcut(QKeySequence::Quit);
}

void MainWindow::BuildEditMenu() {
  QMenu* edit = menuBar()->addMenu(tr("&Edit"));
  QAction* undo = undo_->group()->createUndoAction(this, tr("&Undo"));
  undo->setShortcut(QKeySequence::Undo);
  QAction* redo = undo_->group()->createRedoAction(this, tr("&Redo"));
  // Ctrl+Shift+Z and Ctrl+Y, with the platform's own once: X11's Redo is
  // Ctrl+Shift+Z, and the same key twice on one action is an ambiguous
  // shortcut that Qt refuses ("Ambiguous shortcut overload"): no key redid.
  QList<QKeySequence> keys = {QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_Z),
                              QKeySequence(Qt::CTRL | Qt::Key_Y)};
  for (const QKeySequence& k : QKeySequence::keyBindings(QKeySequence::Redo)) {
    if (!keys.contains(k)) keys << k;
  }
  redo->setShortcuts(keys);
  edit->addAction(undo);
  edit->addAction(redo);
}

void MainWindow::BuildViewMenu() {
  QMenu* view = menuBar()->addMenu(tr("&View"));
  view->addAction(tr("&3D"), view_, &CloudView::ViewOblique)->setShortcut(Qt::Key_0);
  view->addAction(tr("&Top"), view_, &CloudView::ViewTop)->setShortcut(Qt::Key_1);
  view->addAction(tr("&Front"), view_, &CloudView::ViewFront)->setShortcut(Qt::Key_2);
  view->addAction(tr("&Side"), view_, &CloudView::ViewSide)->setShortcut(Qt::Key_3);
  view->addAction(tr("&Fit to Cloud"), view_, &CloudView::FitToCloud)->setShortcut(Qt::Key_F);
  view->addSeparator();
  QMenu* color = view->addMenu(tr("&Colour by"));
  color_group_ = new QActionGroup(this);
  const QString names[CloudView::kColorModes] = {
      tr("&Height"), tr("&Time"), tr("&Range"),
      tr("&Pass (circle drive: A cyan, B magenta)"),
      tr("&Deviation from Fitted Plane (after an evaluation)"),
      tr("&Intensity (lidars that report it, e.g. an imported bag; not the X4)")};
  for (int i = 0; i < CloudView::kColorModes; ++i) {
    QAction* a = color->addAction(names[i]);
    a->setCheckable(true);
    a->setData(i);
    color_group_->addAction(a);
    connect(a, &QAction::triggered, this, [this, i] {
      if (static_cast<int>(view_->color_mode()) == i) return;
      undo_->Push(new ColorModeCommand(view_, static_cast<CloudView::ColorMode>(i), [this] {
        color_group_->actions()[static_cast<int>(view_->color_mode())]->setChecked(true);
      }));
    });
  }
  color_group_->actions()[0]->setChecked(true);
  // Pass, deviation and intensity are offered when the cloud has them (a
  // circle drive split, an evaluation, a lidar that reports intensities);
  // chosen without them, every point was grey under a legend for nothing.
  const auto offer_colors = [this] {
    for (int i = 0; i < CloudView::kColorModes; ++i) {
      color_group_->actions()[i]->setEnabled(
          view_->has_point_values(static_cast<CloudView::ColorMode>(i)));
    }
  };
  connect(view_, &CloudView::pointValuesChanged, this, offer_colors);
  offer_colors();
  view->addAction(
          tr("Larger Points"), this,
          [this] {
            undo_->Push(new PointSizeCommand(view_, std::min(10.0, view_->point_size() + 1)));
          })
      ->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_Plus));
  view->addAction(
          tr("Smaller Points"), this,
          [this] {
            undo_->Push(new PointSizeCommand(view_, std::max(1.0, view_->point_size() - 1)));
          })
      ->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_Minus));
  view->addSeparator();
  auto toggle = [this, view](const QString& text, auto setter) {
    QAction* a = view->addAction(text);
    a->setCheckable(true);
    a->setChecked(true);
    connect(a, &QAction::toggled, view_, setter);
    return a;
  };
  toggle(tr("Show &Grid"), &CloudView::SetGridVisible);
  toggle(tr("Show &Axes"), &CloudView::SetAxesVisible);
  toggle(tr("Show Tra&jectory"), &CloudView::SetTrajectoryVisible);
  toggle(tr("Show &Robot"), &CloudView::SetRobotVisible);
  toggle(tr("Show Colour &Bar"), &CloudView::SetColorBarVisible);
  ceiling_ = view->addAction(tr("Hide &Ceiling"));
  ceiling_->setCheckable(true);
  ceiling_->setShortcut(QKeySequence(Qt::Key_C));
  ceiling_->setToolTip(tr("Hides the points above the ceiling's height found in the cloud (2 m "
                          "when it shows no ceiling), to see into the room"));
  connect(ceiling_, &QAction::toggled, view_, [this](bool on) {
    view_->SetClipHeight(on ? ClipHeightToApply() : std::numeric_limits<double>::quiet_NaN());
    clip_label_->setText(clip_status());
  });
  // A height of the operator's: a plan-like cut at 1 m, a shelf's top
  // (the clip was only ever the ceiling's).
  view->addAction(tr("Clip &Height…"), this,
                  [this] {
                    double now = view_->clip_height();
                    if (std::isnan(now)) now = ClipHeightToApply();
                    bool ok = false;
                    const double z = QInputDialog::getDouble(
                        this, tr("Clip height"), tr("Hide the points above this height (m):"), now,
                        -100.0, 1000.0, 2, &ok);
                    if (!ok) return;
                    chosen_clip_ = z;
                    if (!ceiling_->isChecked()) {
                      ceiling_->setChecked(true);  // applies it
                      return;
                    }
                    view_->SetClipHeight(z);
                    clip_label_->setText(clip_status());
                  })
      ->setShortcut(QKeySequence(Qt::SHIFT | Qt::Key_C));
  view->addSeparator();
  if (auto* plan = findChild<QDockWidget*>(QStringLiteral("planDock"))) {
    QAction* show_plan = plan->toggleViewAction();
    show_plan->setText(tr("Floor &Plan"));
    show_plan->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_F));
    view->addAction(show_plan);
    // A plan needs room: shown narrow (docked beside the panels), it takes
    // about half the window, and gives it back when hidden.
    connect(show_plan, &QAction::toggled, this, [this, plan](bool on) {
      if (!on) {
        NarrowPlanColumn(plan);
        return;
      }
      // Once laid out: shown at start (--floor-plan, a restored layout)
      // the docks have no widths yet, and widening them then left the 3D
      // view a strip of 300 px that the saved layout kept.
      QTimer::singleShot(0, plan, [this, plan] { WidenPlanColumn(plan); });
      // In front of the tabs it shares, now and once it is shown: raised
      // only inside this slot, the tab bar kept Evaluation in front when it
      // was the tab shown.
      plan->raise();
      QTimer::singleShot(0, plan, [plan] { plan->raise(); });
    });
  }
  // The panels as a first start places them: the left column from the top,
  // then the right. The floor plan is View > Floor Plan, above: one entry.
  QMenu* panels = view->addMenu(tr("&Panels"));
  panels->setObjectName(QStringLiteral("panelsMenu"));
  for (const char* name : {"connectionDock", "projectDock", "driveDock", "replayDock",
                           "calibrationDock", "evaluationDock"}) {
    if (auto* dock = findChild<QDockWidget*>(QLatin1String(name))) {
      panels->addAction(dock->toggleViewAction());
    }
  }
  panels->addSeparator();
  QAction* reset = panels->addAction(tr("&Reset Layout"), this, &MainWindow::ResetLayout);
  reset->setObjectName(QStringLiteral("resetLayout"));
  reset->setToolTip(tr("The panels where a first start puts them"));
}

void MainWindow::BuildRobotMenu() {
  QMenu* robot = menuBar()->addMenu(tr("&Robot"));
  // What the link's state allows, as the connection and drive panels'
  // buttons (UpdateActions); the menu checks again as it opens, for the
  // scripted drive, which says nothing when it starts.
  connect(robot, &QMenu::aboutToShow, this, &MainWindow::UpdateActions);
  connect_action_ =
      robot->addAction(tr("&Connect"), connection_panel_, &ConnectionPanel::RequestConnect);
  connect_action_->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_K));
  disconnect_action_ = robot->addAction(tr("&Disconnect"), workspace_, &Workspace::Disconnect);
  disconnect_action_->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_K));
  robot->addSeparator();
  record_ = robot->addAction(tr("&Record"), this, [this] {
    QString error;
    if (!workspace_->StartRecording(&error)) ShowError(tr("Cannot record"), error);
  });
  record_->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_R));
  stop_record_ = robot->addAction(tr("&Stop Recording"), this, [this] {
    QString error;
    if (!workspace_->StopRecording(&error)) ShowError(tr("Recording"), error);
  });
  stop_record_->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_R));
  robot->addSeparator();
  // Space is handled in eventFilter so that it works whatever has focus; the
  // action shows the binding in the menu. Always enabled: with no robot it
  // says so.
  estop_ = robot->addAction(tr("&Emergency Stop\tSpace"), workspace_, &Workspace::EmergencyStop);
  clear_estop_ =
      robot->addAction(tr("C&lear Emergency Stop"), workspace_, &Workspace::ClearEmergencyStop);
  abort_script_ =
      robot->addAction(tr("&Abort Scripted Drive"), workspace_, &Workspace::AbortScriptedDrive);
}

void MainWindow::BuildToolsMenu() {
  QMenu* tools = menuBar()->addMenu(tr("&Tools"));
  BuildPoseSourceMenu(tools);
  tools->addSeparator();
  tools->addAction(tr("&Sessions Folder…"), this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(this, tr("Where new recordings go"),
                                                          workspace_->sessions_root());
    if (!dir.isEmpty()) ChooseSessionsRoot(dir);
  });
  tools->addAction(tr("&Device Check…"), this, [this] {
    auto* dialog = new DeviceCheckDialog(workspace_, this);
    dialog->setAttribute(Qt::WA_DeleteOnClose);
    dialog->show();
  });
  measure_ = tools->addAction(tr("&Measure Distance"));
  measure_->setCheckable(true);
  measure_->setShortcut(Qt::Key_M);
  measure_->setToolTip(tr("Shift + click two points: the distance between them"));
  connect(measure_, &QAction::toggled, this, [this](bool on) {
    measure_points_.clear();
    if (!on) view_->ClearMeasurement();
    statusBar()->showMessage(on ? tr("Measure: Shift + click the first point") : QString(), 6000);
  });
  // The session's job (open, save, calibrate, evaluate, SfM) or the
  // project's (load, align, export): enabled only while one runs.
  QAction* cancel = tools->addAction(tr("&Cancel Running Task"), this, [this] {
    workspace_->CancelJob();
    if (project_ != nullptr) project_->Cancel();
  });
  cancel->setObjectName(QStringLiteral("cancelTaskAction"));
  connect(tools, &QMenu::aboutToShow, this, [this, cancel] {
    cancel->setEnabled(workspace_->job_running() || (project_ != nullptr && project_->busy()));
  });
}

void MainWindow::BuildPoseSourceMenu(QMenu* parent) {
  QMenu* menu = parent->addMenu(tr("&Pose Source"));
  menu->setObjectName(QStringLiteral("poseSourceMenu"));
  menu->setToolTipsVisible(true);
  // SfM is a batch method over the whole log: it cannot place scans as
  // they arrive, so the choice is for sessions opened, and says so.
  QAction* note = menu->addAction(tr("For opened sessions (live scans use the EKF)"));
  note->setEnabled(false);
  menu->addSeparator();
  pose_source_group_ = new QActionGroup(this);
  pose_source_group_->setExclusive(true);
  const QString texts[] = {tr("&EKF (wheels + IMU)"), tr("&Odometry (wheels only)"),
                           tr("&SfM (EKF corrected by planes)")};
  const QString tips[] = {
      tr("The wheel + IMU extended Kalman filter, as recorded live"),
      tr("Wheel odometry alone (no IMU): shows what the IMU adds"),
      tr("Lidar-only structure from motion: the EKF's poses corrected by the floor, ceiling and "
         "walls the scans cross (docs/sfm.md). Runs over the whole session, then replays it")};
  for (int i = 0; i < 3; ++i) {
    QAction* a = menu->addAction(texts[i]);
    a->setCheckable(true);
    a->setToolTip(tips[i]);
    a->setData(static_cast<int>(kPoseSources[i]));
    pose_source_group_->addAction(a);
  }
  pose_source_group_->actions().front()->setChecked(true);
  connect(pose_source_group_, &QActionGroup::triggered, this, [this](QAction* a) {
    workspace_->SetPoseSource(static_cast<PoseSource>(a->data().toInt()));
  });
}

QAction* MainWindow::pose_source_action(PoseSource source) const {
  for (QAction* a : pose_source_group_->actions()) {
    if (a->data().toInt() == static_cast<int>(source)) return a;
  }
  return nullptr;
}

QString MainWindow::pose_source_status() const { return pose_source_label_->text(); }

// The status bar says what the cloud shown is made with (the poses, and the
// mounting calibration when it is not zero), and while a new choice is
// being computed, what is coming.
void MainWindow::ShowPoseSource() {
  const PoseSource shown = workspace_->shown_pose_source();
  const PoseSource chosen = workspace_->pose_source();
  const bool opened = workspace_->recording_opened() != nullptr && !workspace_->recording();
  // A project's sessions are built with the EKF's poses (as `project
  // export` builds them), whatever the choice for opened sessions.
  const bool project =
      !opened && !workspace_->link_open() && project_ != nullptr && project_->document()->is_open();
  QString text = tr("Poses: %1").arg(PoseSourceTitle(shown));
  if (project) {
    text = tr("Poses: %1 (the project's sessions)").arg(PoseSourceTitle(PoseSource::kEkf));
  } else if (!opened) {
    text += tr(" (live)");
  } else if (chosen != shown) {
    text += tr(" → %1…").arg(PoseSourceTitle(chosen));
  }
  const MountingError& calibration = workspace_->shown_calibration();
  const bool calibrated =
      opened && (calibration.alpha != 0.0 || calibration.beta != 0.0 || calibration.gamma != 0.0);
  if (calibrated) text += tr(" · calibrated");
  pose_source_label_->setText(text);
  QString tip;
  if (project) {
    tip = tr("The project's sessions are drawn with the EKF poses, as `sweepscan-cli project "
             "export` builds them; Tools > Pose Source (now %1) applies to opened sessions.")
              .arg(PoseSourceTitle(chosen));
  } else if (opened) {
    tip = tr("The cloud of the opened session is made with the %1 poses.")
              .arg(PoseSourceTitle(shown));
  } else {
    tip = tr("Live clouds and recordings always use the EKF; Tools > Pose Source (now %1) applies "
             "to opened sessions.")
              .arg(PoseSourceTitle(chosen));
  }
  if (calibrated) {
    tip += QLatin1Char('\n') + tr("Mounting calibration applied: alpha %1, beta %2, gamma %3 mrad.")
                                   .arg(1e3 * calibration.alpha, 0, 'f', 2)
                                   .arg(1e3 * calibration.beta, 0, 'f', 2)
                                   .arg(1e3 * calibration.gamma, 0, 'f', 2);
  }
  if (!workspace_->sfm_summary().isEmpty()) tip += QLatin1Char('\n') + workspace_->sfm_summary();
  pose_source_label_->setToolTip(tip);
}

void MainWindow::BuildHelpMenu() {
  QMenu* help = menuBar()->addMenu(tr("&Help"));
  help->addAction(tr("&Keyboard and Mouse"), this,
                  [this] { ShowKeyboardAndMouseHelp(this, menuBar()); })
      ->setShortcut(QKeySequence::HelpContents);
  help->addAction(tr("&About sweepscan"), this,
                  [this] { QMessageBox::about(this, tr("About sweepscan"), AboutHtml()); });
}

// The plan's column widened to about half the window when it is narrower
// than a third, and narrowed to that when it leaves the 3D view less than
// a third (shown before the window's first layout, it took what the
// layout gave it).
void MainWindow::WidenPlanColumn(QDockWidget* plan) {
  if (!plan->isVisible() || plan->isFloating()) return;
  const int want =
      std::max(plan->minimumSizeHint().width(),
               std::min(width() * 9 / 20, plan->width() + view_->width() - width() / 3));
  if (plan->width() < width() / 3 && plan->width() < want) {
    if (plan_widened_from_ == 0) plan_widened_from_ = plan->width();
    resizeDocks({plan}, {want}, Qt::Horizontal);
  } else if (view_->width() < width() / 3 && plan->width() > want) {
    resizeDocks({plan}, {want}, Qt::Horizontal);
  }
}

// The plan's column back to its width before the plan widened it, or, if
// the plan was shown wide from a saved layout, to the width its panels ask
// for (as on a first start). Left wide, the 3D view stayed a third of the
// window, and the saved layout kept it so.
void MainWindow::NarrowPlanColumn(QDockWidget* plan) {
  const int was = plan_widened_from_;
  plan_widened_from_ = 0;
  if (plan->isFloating()) return;
  QList<QDockWidget*> others;
  for (QDockWidget* dock : findChildren<QDockWidget*>()) {
    if (dock != plan && dock->isVisible() && !dock->isFloating() &&
        dockWidgetArea(dock) == dockWidgetArea(plan)) {
      others << dock;
    }
  }
  if (others.isEmpty()) return;
  // The plan's width is the column's; a panel tabbed behind the plan keeps
  // the width it had when last in front.
  const int column = plan->width();
  int asked = 0;
  for (QDockWidget* dock : others) asked = std::max(asked, dock->sizeHint().width());
  const int target = was > 0 ? was : std::min(column, asked);
  if (target >= column) return;
  QList<int> widths;
  for (int i = 0; i < others.size(); ++i) widths << target;
  resizeDocks(others, widths, Qt::Horizontal);
}

}  // namespace sweepscan::ui
