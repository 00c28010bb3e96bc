// The main window: docks, status bar, the GUI tick, teleop keys, settings,
// sessions and errors. Its menus are built in main_window_menus.cc.
#include "ui/main_window.h"

#include <QAction>
#include <QActionGroup>
#include <QApplication>
#include <QCloseEvent>
#include <QDir>
#include <QDockWidget>
#include <QFileDialog>
#include <QFileInfo>
#include <QKeyEvent>
#include <QLabel>
#include <QLineEdit>
#include <QMenu>
#include <QMenuBar>
#include <QMessageBox>
#include <QProgressBar>
#include <QScrollArea>
#include <QScrollBar>
#include <QSettings>
#include <QStatusBar>
#include <QTimer>
#include <QToolButton>
#include <QUndoCommand>
#include <QUndoStack>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "ui/own_window.h"
#include "ui/panels/calibration_panel.h"
#include "ui/panels/connection_panel.h"
#include "ui/panels/device_check_dialog.h"
#include "ui/panels/drive_panel.h"
#include "ui/panels/evaluation_panel.h"
#include "ui/panels/fit_height_to_width.h"
#include "ui/panels/replay_panel.h"
#include "ui/panels/ros_import_dialog.h"
#include "ui/panels/scroll_wheel_guard.h"
#include "ui/plan/plan_panel.h"
#include "ui/project/pair_picking.h"
#include "ui/project/project_controller.h"
#include "ui/project/project_layer.h"
#include "ui/project/project_panel.h"
#include "ui/undo_router.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

constexpr int kTickMs = 33;  // ~30 Hz: drain the mailbox, render once.
const QString kPoseSourceKey = QStringLiteral("session/pose_source");

bool IsDriveKey(int key) {
  switch (key) {
    case Qt::Key_Up:
    case Qt::Key_Down:
    case Qt::Key_Left:
    case Qt::Key_Right:
    case Qt::Key_W:
    case Qt::Key_A:
    case Qt::Key_S:
    case Qt::Key_D:
      return true;
    default:
      return false;
  }
}

}  // namespace

MainWindow::MainWindow(Workspace* workspace, const QString& resources_dir, QWidget* parent)
    : QMainWindow(parent), workspace_(workspace), resources_dir_(resources_dir) {
  setWindowTitle(QStringLiteral("sweepscan"));
  setObjectName(QStringLiteral("MainWindow"));
  view_ = new CloudView(this);
  setCentralWidget(view_);
  undo_ = new UndoRouter(this);
  session_undo_ = new QUndoStack(this);
  undo_->AddStack(session_undo_);

  connection_panel_ = new ConnectionPanel(workspace_, resources_dir + QStringLiteral("/scenarios"));
  drive_panel_ = new DrivePanel(workspace_);
  replay_panel_ = new ReplayPanel(workspace_);
  calibration_panel_ = new CalibrationPanel(workspace_, view_, session_undo_);
  auto add_dock = [this](QWidget* w, const QString& title, const QString& name,
                         Qt::DockWidgetArea area) {
    auto* dock = new QDockWidget(title, this);
    dock->setObjectName(name);
    dock->setWidget(w);
    addDockWidget(area, dock);
    return dock;
  };
  // A panel in a scroll area that scrolls up and down only: its labels
  // wrap instead, and the area is at least as wide as the panel can be
  // (`at_least` px or more). A few pixels short, a button given the focus
  // at the panel's right edge had it scrolled left with its titles cut
  // (". Solve"); the scroll bar is kept at 0 for any content that grows
  // wider later.
  auto upright = [](QScrollArea* scroll, QWidget* panel, int at_least) {
    scroll->setWidget(panel);
    scroll->setWidgetResizable(true);
    scroll->setHorizontalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
    scroll->setMinimumWidth(std::max(at_least, panel->minimumSizeHint().width() +
                                                   scroll->verticalScrollBar()->sizeHint().width() +
                                                   2 * scroll->frameWidth()));
    QScrollBar* sideways = scroll->horizontalScrollBar();
    connect(sideways, &QScrollBar::valueChanged, scroll, [sideways](int v) {
      if (v != 0) sideways->setValue(0);
    });
    return scroll;
  };
  // A panel of short rows in a scroll area: the dock column can then be
  // shorter than its panels' sum (a laptop's screen), and a panel keeps the
  // height its wrapped labels need at the width it gets (FitHeightToWidth)
  // instead of clipping their last line.
  auto scrolled = [&upright](QWidget* panel) {
    auto* scroll = new QScrollArea;
    scroll->setFrameShape(QFrame::NoFrame);
    scroll->setSizePolicy(panel->sizePolicy());
    FitHeightToWidth::Install(panel);
    return upright(scroll, panel, 0);
  };
  QDockWidget* connection_dock = add_dock(scrolled(connection_panel_), tr("Connection"),
                                          QStringLiteral("connectionDock"), Qt::LeftDockWidgetArea);
  QDockWidget* drive_dock = add_dock(scrolled(drive_panel_), tr("Drive"),
                                     QStringLiteral("driveDock"), Qt::LeftDockWidgetArea);
  add_dock(scrolled(replay_panel_), tr("Session and replay"), QStringLiteral("replayDock"),
           Qt::RightDockWidgetArea);
  // The calibration steps scroll when the window is short.
  QDockWidget* calibration_dock =
      add_dock(upright(new QScrollArea, calibration_panel_, 380), tr("Calibration"),
               QStringLiteral("calibrationDock"), Qt::RightDockWidgetArea);
  evaluation_panel_ = new EvaluationPanel(workspace_, view_);
  QScrollArea* evaluation_scroll = upright(new QScrollArea, evaluation_panel_, 0);
  QDockWidget* evaluation_dock =
      add_dock(evaluation_scroll, tr("Evaluation"), QStringLiteral("evaluationDock"),
               Qt::RightDockWidgetArea);
  tabifyDockWidget(calibration_dock, evaluation_dock);
  calibration_dock->raise();
  project_ = std::make_unique<ProjectController>(
      this, view_, [this](const QString& t, const QString& m) { ShowError(t, m); },
      [this] { return interactive_; });
  // A tab beside Connection: the left column then fits a laptop's screen
  // with the Drive panel whole; it comes to the front with a project.
  QDockWidget* project_dock = add_dock(project_->panel(), tr("Project"),
                                       QStringLiteral("projectDock"), Qt::LeftDockWidgetArea);
  tabifyDockWidget(connection_dock, project_dock);
  connection_dock->raise();
  // The Drive panel whole (its calibration circle too); the connection's
  // health text scrolls instead. A saved layout overrides this.
  resizeDocks({drive_dock}, {drive_panel_->sizeHint().height() + 8}, Qt::Vertical);
  // ... and room for its sessions, placements and alignment (it had the
  // connection's 230 px, which cut them): half the column, or what its
  // content asks up to three fifths, the Drive panel scrolling below (its
  // emergency stop stays on top). Only ever grown: an operator's own split
  // stays.
  connect(project_.get(), &ProjectController::shown, this, [this, project_dock, drive_dock] {
    project_dock->raise();
    const auto* scroll =
        project_->panel()->findChild<QScrollArea*>(QStringLiteral("projectScroll"));
    const QWidget* content = scroll != nullptr ? scroll->widget() : project_->panel();
    const int column = centralWidget()->height();
    // The dock's title bar and the tab bar under it take about 50 px.
    const int want =
        std::min(std::max(content->sizeHint().height() + 80, column / 2), column * 3 / 5);
    if (project_dock->height() < want) {
      resizeDocks({project_dock, drive_dock}, {want, column - want}, Qt::Vertical);
    }
  });
  connect(project_.get(), &ProjectController::titleChanged, this, &MainWindow::UpdateTitle);
  // The status bar's poses: a project's sessions' when one is shown.
  connect(project_->document(), &ProjectDocument::opened, this, &MainWindow::ShowPoseSource);
  connect(project_.get(), &ProjectController::message, this,
          [this](const QString& m) { statusBar()->showMessage(m, 10000); });
  // A project opened: into the building, its ceilings hidden, once its
  // first sessions are drawn.
  connect(project_.get(), &ProjectController::shown, this, &MainWindow::ApplyRoomView);
  undo_->AddStack(project_->undo_stack());
  undo_->AddStack(project_->pair_picking()->undo_stack());
  // Pair picking's history is the one Edit > Undo offers while it runs.
  connect(project_->pair_picking(), &PairPicking::changed, this, [this] {
    PairPicking* picking = project_->pair_picking();
    if (picking->active() && undo_->active() != picking->undo_stack()) {
      undo_->Activate(picking->undo_stack());
    } else if (!picking->active()) {
      undo_->Leave(picking->undo_stack());
    }
  });
  connect(project_->pair_picking(), &PairPicking::message, this,
          [this](const QString& m) { statusBar()->showMessage(m, 10000); });
  // The floor plan: a dock shown from View > Floor Plan (built only while
  // shown), a tab beside calibration and evaluation: the tallest place.
  plan_panel_ = new PlanPanel(project_.get(), workspace_,
                              [this](const QString& t, const QString& m) { ShowError(t, m); });
  QDockWidget* plan_dock =
      add_dock(plan_panel_, tr("Floor Plan"), QStringLiteral("planDock"), Qt::RightDockWidgetArea);
  tabifyDockWidget(evaluation_dock, plan_dock);
  plan_dock->hide();
  calibration_dock->raise();
  connect(calibration_panel_, &CalibrationPanel::fileError, this, &MainWindow::ShowError);
  connect(calibration_panel_, &CalibrationPanel::message, this,
          [this](const QString& m) { statusBar()->showMessage(m, 10000); });
  connect(calibration_panel_, &CalibrationPanel::robotCalibrationChanged, this,
          [this](const MountingError& c) {
            QSettings().setValue(QStringLiteral("robot/calibration_rad"),
                                 QVariantList{c.alpha, c.beta, c.gamma});
            statusBar()->showMessage(
                tr("Robot calibration set: alpha %1, beta %2, gamma %3 mrad (live scans and new "
                   "recordings)")
                    .arg(c.alpha * 1e3, 0, 'f', 2)
                    .arg(c.beta * 1e3, 0, 'f', 2)
                    .arg(c.gamma * 1e3, 0, 'f', 2),
                8000);
          });
  view_->SetPickContext([this] { return static_cast<int>(CurrentPickMode()); });
  connect(view_, &CloudView::pointPicked, this, &MainWindow::RoutePick);
  // A project's change of anchor: the clip moved with the frame; the
  // ceiling Hide Ceiling restores moves with it, and the status says so.
  connect(view_, &CloudView::movedWithFrame, this, [this](double dz) {
    if (!std::isnan(ceiling_z_)) ceiling_z_ += dz;
    clip_label_->setText(clip_status());
  });
  connect(view_, &CloudView::colorModeChanged, this, [this](int mode) {
    if (mode >= 0 && mode < color_group_->actions().size()) {
      color_group_->actions()[mode]->setChecked(true);
    }
  });
  connect(connection_panel_, &ConnectionPanel::errorOccurred, this,
          [this](const QString& m) { ShowError(tr("Cannot connect"), m); });
  // Connecting replaces the session shown (as New Session does).
  connection_panel_->SetConfirm(
      [this](const std::function<void()>& retry) { return ConfirmDiscard(retry); });

  BuildMenus();
  BuildStatusBar();
  default_layout_ = saveState();  // before the operator's (View > Panels > Reset Layout)
  RestoreSettings();

  connect(workspace_, &Workspace::message, this,
          [this](const QString& m) { statusBar()->showMessage(m, 6000); });
  // A link outage stays in the status bar until the link is back.
  connect(workspace_, &Workspace::linkOutage, this,
          [this](bool open, double seconds, const QString& text) {
            if (open) {
              // The gist first: a narrow window shows only the start.
              statusBar()->showMessage(
                  tr("Link lost, reconnecting… (%1). The robot is stopped; Disconnect stops "
                     "trying.")
                      .arg(text));
            } else {
              statusBar()->showMessage(
                  tr("Link reconnected after %1 s (%2). The robot stays stopped until you "
                     "drive; a recording goes on in the same session.")
                      .arg(seconds, 0, 'f', 1)
                      .arg(text),
                  20000);
            }
          });
  connect(workspace_, &Workspace::recordingFailed, this,
          [this](const QString& message) { ShowError(tr("Recording"), message); });
  // Keys held before an emergency stop do not drive off again once it is
  // cleared: they must be pressed anew.
  connect(workspace_, &Workspace::emergencyStopped, this, [this] { keys_held_.clear(); });
  connect(workspace_, &Workspace::authenticationFailed, this, [this](const QString& reason) {
    // "busy" and "retry later" are retried by the connection: said in the
    // status bar, not a box each retry.
    if (reason.contains(QLatin1String("busy")) || reason.contains(QLatin1String("retry later"))) {
      statusBar()->showMessage(tr("The robot answered: %1 (trying again)").arg(reason), 10000);
      return;
    }
    const QString key = connection_panel_->options().key_file;
    ShowError(tr("Connection refused"),
              tr("The robot refused this workstation: %1\n\nCheck the key file%2.")
                  .arg(reason, key.isEmpty() ? QString() : QStringLiteral(" ") + key));
  });
  connect(workspace_, &Workspace::jobProgress, this, [this](const QString& what, double f) {
    progress_->setVisible(true);
    cancel_->setVisible(true);
    progress_->setFormat(what);
    progress_->setRange(0, f < 0 ? 0 : 1000);
    if (f >= 0) progress_->setValue(static_cast<int>(1000 * f));
  });
  // An opened session whose lidar reports intensities (an imported bag):
  // View > Colour by > Intensity has values once the replay is complete,
  // they are mapped (a worker thread's) and the view holds every point
  // (OnTick: the replay's last batches may still be in the mailbox).
  connect(workspace_, &Workspace::intensitiesMapped, this,
          [this](std::shared_ptr<const QuantizedValues> values) {
            pending_intensity_ = std::move(values);
          });
  connect(workspace_, &Workspace::sessionChanged, this, [this] {
    pending_intensity_.reset();
    room_view_pending_ = true;
    ceiling_found_live_ = false;
    room_view_ready_ = false;
    room_view_camera_ = view_->camera_generation();
  });
  // A session opened: into the room once it has replayed, at the next tick
  // (which drains its last batches into the view).
  connect(workspace_, &Workspace::replayFinished, this, [this] {
    if (room_view_pending_) room_view_ready_ = true;
  });
  connect(workspace_, &Workspace::jobFinished, this,
          [this](const QString& what, bool ok, const QString& message) {
            // A job whose success starts the next one (a session re-opened
            // for SfM or a calibration) keeps the bar and Cancel for it.
            if (!workspace_->job_running()) {
              progress_->setVisible(false);
              cancel_->setVisible(false);
            }
            // The operator's own Cancel is not an error: a note in the
            // status bar, no box to dismiss (RunJob reports it as this
            // message; a job's own "Cancelled." too), nor one the app made
            // for a reason it gives ("Cancelled: a recording started...").
            if (!ok && message == QLatin1String("Cancelled.")) {
              statusBar()->showMessage(tr("%1: cancelled").arg(what), 6000);
            } else if (!ok && message.startsWith(QLatin1String("Cancelled: "))) {
              statusBar()->showMessage(tr("%1: %2").arg(what, message), 10000);
            } else if (!ok) {
              ShowError(what, message);
            }
          });
  // A new recording is listed in Open Recent as it starts: one the operator
  // chose not to save stays in its folder, and this is where it is found
  // again. Saved under a new name, the listing follows it.
  connect(workspace_, &Workspace::sessionChanged, this, [this](const QString& dir) {
    UpdateTitle();
    session_dir_shown_ = dir;
    if (!dir.isEmpty()) AddRecent(dir);
    UpdateActions();
    ShowPoseSource();
  });
  connect(workspace_, &Workspace::sessionRenamed, this, [this](const QString& dir) {
    UpdateTitle();
    UpdateActions();
    if (!session_dir_shown_.isEmpty() && !QFileInfo::exists(session_dir_shown_)) {
      RemoveRecent(session_dir_shown_);  // moved
    }
    session_dir_shown_ = dir;
    AddRecent(dir);
    statusBar()->showMessage(tr("Saved %1").arg(dir), 6000);
  });
  connect(workspace_, &Workspace::recordingChanged, this, &MainWindow::UpdateActions);
  // The choice (menu, replay panel) follows the workspace, which may give it
  // back to the cloud shown when SfM fails; it is kept for the next start.
  connect(workspace_, &Workspace::poseSourceChanged, this, [this](int source) {
    const auto s = static_cast<PoseSource>(source);
    if (QAction* a = pose_source_action(s)) a->setChecked(true);
    QSettings().setValue(kPoseSourceKey, QString::fromLatin1(PoseSourceName(s)));
    ShowPoseSource();
  });
  connect(workspace_, &Workspace::shownPoseSourceChanged, this, &MainWindow::ShowPoseSource);
  connect(workspace_, &Workspace::recordingChanged, this, &MainWindow::ShowPoseSource);
  connect(workspace_, &Workspace::recordingChanged, this, &MainWindow::UpdateLinkLabel);
  connect(workspace_, &Workspace::poseSourceFailed, this,
          [this](const QString& m) { ShowError(tr("Pose source"), m); });
  connect(workspace_, &Workspace::authenticatedChanged, this, &MainWindow::UpdateActions);
  connect(workspace_, &Workspace::linkStateChanged, this, &MainWindow::UpdateActions);
  connect(workspace_, &Workspace::linkStateChanged, this, &MainWindow::ShowPoseSource);

  qApp->installEventFilter(this);
  ScrollWheelGuard::Install(this);
  auto* tick = new QTimer(this);
  tick->setTimerType(Qt::PreciseTimer);
  connect(tick, &QTimer::timeout, this, &MainWindow::OnTick);
  tick->start(kTickMs);
  tick_clock_.start();
  fps_clock_.start();
  UpdateActions();
}

MainWindow::~MainWindow() { qApp->removeEventFilter(this); }

QUndoGroup* MainWindow::undo_group() const { return undo_->group(); }

void MainWindow::UpdateTitle() {
  QStringList parts;
  if (!workspace_->session_dir().isEmpty()) parts << QFileInfo(workspace_->session_dir()).fileName();
  if (!project_->title().isEmpty()) parts << project_->title();
  parts << QStringLiteral("sweepscan");
  setWindowTitle(parts.join(QStringLiteral(" - ")));
  setWindowModified(project_->document()->modified());
}

void MainWindow::RaiseDock(const QString& name) {
  if (auto* dock = findChild<QDockWidget*>(name)) {
    dock->show();
    dock->raise();
  }
}

MainWindow::PickMode MainWindow::CurrentPickMode() const {
  if (project_->pair_picking()->active()) return PickMode::kPair;
  return measure_->isChecked() ? PickMode::kMeasure : PickMode::kCalibration;
}

void MainWindow::RoutePick(const PickHit& hit, int mode) {
  const PickMode now = CurrentPickMode();
  switch (static_cast<PickMode>(mode)) {
    case PickMode::kPair:
      if (now == PickMode::kPair) project_->pair_picking()->AddPick(hit);
      break;
    case PickMode::kMeasure:
      // A project session's point too: the view's frame.
      if (now == PickMode::kMeasure) Measure(hit.world);
      break;
    case PickMode::kCalibration:
      // Clicked before the distance tool or pair picking began: still the
      // calibration's, which did not end.
      calibration_panel_->AddPick(hit.world);
      break;
  }
}

void MainWindow::Measure(const Eigen::Vector3d& point) {
  if (measure_points_.size() == 2) measure_points_.clear();
  measure_points_.push_back(point);
  if (measure_points_.size() == 1) {
    view_->ClearMeasurement();
    statusBar()->showMessage(tr("Measure: Shift + click the second point"), 6000);
    return;
  }
  const Eigen::Vector3d d = measure_points_[1] - measure_points_[0];
  measured_m_ = d.norm();
  view_->SetMeasurement(measure_points_[0], measure_points_[1]);
  statusBar()->showMessage(tr("Distance %1 m (horizontal %2 m, vertical %3 m)")
                               .arg(measured_m_, 0, 'f', 3)
                               .arg(d.head<2>().norm(), 0, 'f', 3)
                               .arg(std::abs(d.z()), 0, 'f', 3));
}

void MainWindow::BuildStatusBar() {
  link_label_ = new QLabel;
  link_label_->setObjectName(QStringLiteral("statusLink"));
  pose_label_ = new QLabel;
  speed_label_ = new QLabel;
  points_label_ = new QLabel;
  points_label_->setObjectName(QStringLiteral("statusPoints"));
  pose_source_label_ = new QLabel;
  pose_source_label_->setObjectName(QStringLiteral("statusPoseSource"));
  pose_source_label_->setContentsMargins(12, 0, 12, 0);  // Apart from the speeds beside it.
  fps_label_ = new QLabel;
  fps_label_->setObjectName(QStringLiteral("statusFps"));
  fps_label_->setToolTip(
      tr("Frames drawn in the last second. The view draws only when something "
         "changes: the camera, the cloud or a finer pass at rest."));
  clip_label_ = new QLabel;
  clip_label_->setObjectName(QStringLiteral("statusClip"));
  progress_ = new QProgressBar;
  progress_->setMaximumWidth(260);
  progress_->setTextVisible(true);
  progress_->setVisible(false);
  cancel_ = new QToolButton;
  cancel_->setText(tr("Cancel"));
  cancel_->setVisible(false);
  connect(cancel_, &QToolButton::clicked, workspace_, &Workspace::CancelJob);
  statusBar()->addPermanentWidget(progress_);
  statusBar()->addPermanentWidget(cancel_);
  for (QLabel* l :
       {link_label_, pose_label_, speed_label_, pose_source_label_, clip_label_, points_label_,
        fps_label_}) {
    // A gap before each field, so that a long message on the left (a
    // session's path) is cut off visibly apart from the first field
    // instead of running into it.
    l->setContentsMargins(12, 0, 0, 0);
    statusBar()->addPermanentWidget(l);
  }
}

void MainWindow::ResetLayout() {
  restoreState(default_layout_);
  plan_widened_from_ = 0;
}

void MainWindow::RestoreSettings() {
  QSettings s;
  restoreGeometry(s.value(QStringLiteral("window/geometry")).toByteArray());
  restoreState(s.value(QStringLiteral("window/state")).toByteArray());
  ConnectOptions o;
  o.kind = static_cast<LinkKind>(s.value(QStringLiteral("link/kind"), 0).toInt());
  o.scenario_path = s.value(QStringLiteral("link/scenario"),
                            resources_dir_ + QStringLiteral("/scenarios/lab.json"))
                        .toString();
  o.host = s.value(QStringLiteral("link/host"), o.host).toString();
  o.port = s.value(QStringLiteral("link/port"), o.port).toInt();
  o.key_file = s.value(QStringLiteral("link/key_file")).toString();
  o.serial_port = s.value(QStringLiteral("link/serial_port")).toString();
  o.baud = s.value(QStringLiteral("link/baud"), o.baud).toInt();
  connection_panel_->SetOptions(o);
  const int color = s.value(QStringLiteral("view/color"), 0).toInt();
  if (color >= 0 && color < 3) {
    view_->SetColorMode(static_cast<CloudView::ColorMode>(color));
    color_group_->actions()[color]->setChecked(true);
  }
  view_->SetPointSize(s.value(QStringLiteral("view/point_size"), 2.0).toDouble());
  const QVariantList calibration = s.value(QStringLiteral("robot/calibration_rad")).toList();
  if (calibration.size() == 3) {
    workspace_->SetRobotCalibration(
        {calibration[0].toDouble(), calibration[1].toDouble(), calibration[2].toDouble()});
  }
  const QString root = s.value(QStringLiteral("sessions/root")).toString();
  if (!root.isEmpty()) workspace_->set_sessions_root(root);
  PoseSource source = PoseSource::kEkf;
  if (ParsePoseSource(s.value(kPoseSourceKey).toString().toStdString(), &source) &&
      pose_source_action(source) != nullptr) {
    workspace_->SetPoseSource(source);
    pose_source_action(source)->setChecked(true);
  }
  ShowPoseSource();
  RebuildRecentMenu();
}

void MainWindow::SaveSettings() {
  QSettings s;
  s.setValue(QStringLiteral("window/geometry"), saveGeometry());
  s.setValue(QStringLiteral("window/state"), saveState());
  const ConnectOptions o = connection_panel_->options();
  s.setValue(QStringLiteral("link/kind"), static_cast<int>(o.kind));
  s.setValue(QStringLiteral("link/scenario"), o.scenario_path);
  s.setValue(QStringLiteral("link/host"), o.host);
  s.setValue(QStringLiteral("link/port"), o.port);
  s.setValue(QStringLiteral("link/key_file"), o.key_file);
  s.setValue(QStringLiteral("link/serial_port"), o.serial_port);
  s.setValue(QStringLiteral("link/baud"), o.baud);
  s.setValue(QStringLiteral("view/color"), static_cast<int>(view_->color_mode()));
  s.setValue(QStringLiteral("view/point_size"), view_->point_size());
  s.setValue(kPoseSourceKey, QString::fromLatin1(PoseSourceName(workspace_->pose_source())));
}

QString MainWindow::SessionDialogDir() const {
  for (const QString& dir : {QSettings().value(QStringLiteral("sessions/open_dir")).toString(),
                             workspace_->sessions_root()}) {
    if (!dir.isEmpty() && QFileInfo(dir).isDir()) return dir;
  }
  return QDir::homePath();
}

void MainWindow::ChooseSessionsRoot(const QString& dir) {
  workspace_->set_sessions_root(dir);
  QSettings().setValue(QStringLiteral("sessions/root"), dir);
}

double MainWindow::ClipHeightToApply() const {
  if (!std::isnan(chosen_clip_)) return chosen_clip_;
  return std::isnan(ceiling_z_) ? 2.0 : ceiling_z_ - 0.05;
}

QString MainWindow::clip_status() const {
  if (std::isnan(view_->clip_height())) return QString();
  if (!std::isnan(chosen_clip_))
    return tr("Hidden above %1 m (C)").arg(view_->clip_height(), 0, 'f', 2);
  return tr("Ceiling hidden above %1 m (C)").arg(view_->clip_height(), 0, 'f', 2);
}

void MainWindow::ApplyRoomView() {
  room_view_pending_ = room_view_ready_ = false;
  const double ceiling = view_->ShowRoom();
  if (!std::isnan(ceiling)) HideCeilingAt(ceiling);
}

void MainWindow::HideCeilingAt(double ceiling) {
  ceiling_z_ = ceiling;
  chosen_clip_ = std::numeric_limits<double>::quiet_NaN();  // a new cloud's ceiling
  ceiling_->setChecked(true);
  view_->SetClipHeight(ClipHeightToApply());  // Also when it was checked already.
  clip_label_->setText(clip_status());
}

void MainWindow::OnTick() {
  // Event-loop latency: how late this tick is against its period.
  const double elapsed = tick_clock_.nsecsElapsed() * 1e-6;
  tick_clock_.restart();
  // Counted once the view had drawn before the last tick: the first frame
  // loads the GL driver on this thread (under Mesa's llvmpipe, libLLVM and
  // its JIT: 0.2-0.5 s of dynamic linking and fresh pages, perf), once per
  // process, whatever the app then does.
  if (frames_at_last_tick_ > 0) latencies_ms_.push_back(std::max(0.0, elapsed - kTickMs));
  frames_at_last_tick_ = view_->frames_rendered();

  for (LiveBatch& b : workspace_->mailbox()->TakeAll()) {
    if (b.reset) view_->Clear();
    QElapsedTimer insertion;
    insertion.start();
    view_->AppendSealed(b.sealed, b.unpacked);
    view_->AppendPoints(std::move(b.points));  // Kept by the view, not copied.
    insertion_ms_ += insertion.nsecsElapsed() * 1e-6;
    view_->AppendTrajectory(b.trajectory);
    if (b.has_pose) {
      view_->SetRobotPose(b.pose);
      pose_label_->setText(tr("x %1  y %2 m  yaw %3°")
                               .arg(b.pose.x, 0, 'f', 2)
                               .arg(b.pose.y, 0, 'f', 2)
                               .arg(b.pose.yaw * 180.0 / M_PI, 0, 'f', 1));
    }
    workspace_->NoteBatch(b.total_points, b.scans);
  }
  if (room_view_ready_) {
    // Not over a camera someone has placed since the session opened.
    if (view_->camera_generation() == room_view_camera_) {
      ApplyRoomView();
    } else {
      room_view_pending_ = room_view_ready_ = false;
    }
  }
  if (pending_intensity_ != nullptr && view_->point_count() == pending_intensity_->q.size()) {
    view_->SetPointValues(CloudView::ColorMode::kIntensity, *pending_intensity_);
    pending_intensity_.reset();
  }
  if (!keys_held_.isEmpty())
    UpdateTeleop();  // Re-send while held (10 Hz is plenty; 30 Hz is fine).
  view_->RenderIfDirty();

  if (fps_clock_.elapsed() >= 1000) {
    const uint64_t frames = view_->frames_rendered();
    const bool still = frames == fps_last_frames_;
    fps_ = (frames - fps_last_frames_) * 1000.0 / fps_clock_.elapsed();
    fps_last_frames_ = frames;
    fps_clock_.restart();
    UpdateLinkLabel();
    // The view draws only when something changes: no frame in the last
    // second is a still view, not a stalled one ("0 fps" read as a hang).
    fps_label_->setText(still ? tr("view still") : tr("%1 fps").arg(fps_, 0, 'f', 0));
    // A live cloud: its ceiling hidden as soon as one shows (the first
    // 40 s of a drive were a roof over the room), once: the operator may
    // show it again; the camera into the room once the cloud is large
    // enough to frame.
    if (room_view_pending_ && workspace_->recording_opened() == nullptr &&
        view_->camera_generation() == room_view_camera_) {
      if (!ceiling_found_live_ && view_->point_count() > kLiveCeilingPoints) {
        const double ceiling = view_->FindCeiling();
        if (!std::isnan(ceiling)) {
          ceiling_found_live_ = true;
          HideCeilingAt(ceiling);
        }
      }
      if (view_->point_count() > 200'000 && !std::isnan(view_->FindCeiling())) ApplyRoomView();
    }
  }
  const Twist2d c = workspace_->commanded();
  speed_label_->setText(tr("v %1 m/s  w %2 rad/s").arg(c.v, 0, 'f', 2).arg(c.w, 0, 'f', 2));
  QString points = tr("%L1 points").arg(view_->point_count());
  const size_t project_points = project_->layer()->shown_points();
  if (project_points > 0) {
    points = view_->point_count() == 0 ? tr("project %L1 points").arg(project_points)
                                       : points + tr(" · project %L1").arg(project_points);
  }
  points_label_->setText(points);
  drive_panel_->ShowCommand(c);
}

bool MainWindow::eventFilter(QObject* watched, QEvent* event) {
  const QEvent::Type type = event->type();
  // The window lost the keyboard (Alt+Tab, a message box, a click into a
  // floating dock): the releases of held drive keys will not come here, so
  // the robot stops now rather than drive on at the keys' speed.
  if (type == QEvent::WindowDeactivate && watched == this) ReleaseDriveKeys();
  if (type != QEvent::KeyPress && type != QEvent::KeyRelease && type != QEvent::ShortcutOverride) {
    return QMainWindow::eventFilter(watched, event);
  }
  auto* key = static_cast<QKeyEvent*>(event);
  // Only keys meant for this window or its floating docks (not for a modal
  // dialog on top of it).
  QWidget* w = qobject_cast<QWidget*>(watched);
  if (w == nullptr || !InWindowOf(w, this)) return QMainWindow::eventFilter(watched, event);
  const bool text_field = qobject_cast<QLineEdit*>(w) != nullptr ||
                          w->inherits("QAbstractSpinBox") || w->inherits("QComboBox");
  // The emergency stop wins over whatever widget has focus while a robot is
  // connected (a text field included: a panicked Space must stop it). With
  // none, a text field types its space (a key file's path had its spaces
  // eaten, and a stop was announced for no robot).
  if (key->key() == Qt::Key_Space && key->modifiers() == Qt::NoModifier &&
      (workspace_->link_open() || !text_field)) {
    if (type == QEvent::KeyPress && !key->isAutoRepeat()) workspace_->EmergencyStop();
    event->accept();
    return true;
  }
  // A held drive key's release always counts, whatever the modifiers held
  // with it (W, then Shift for a Shift+click) and wherever the focus went.
  if (type == QEvent::KeyRelease && IsDriveKey(key->key()) && !key->isAutoRepeat() &&
      keys_held_.remove(key->key())) {
    UpdateTeleop();
    return text_field ? QMainWindow::eventFilter(watched, event) : true;
  }
  if (IsDriveKey(key->key()) && key->modifiers() == Qt::NoModifier &&
      (type == QEvent::KeyPress || type == QEvent::KeyRelease)) {
    // Text fields keep their letters; the arrows and WASD drive elsewhere.
    if (text_field) return QMainWindow::eventFilter(watched, event);
    if (key->isAutoRepeat() || type == QEvent::KeyRelease) return true;
    keys_held_.insert(key->key());
    UpdateTeleop();
    return true;
  }
  return QMainWindow::eventFilter(watched, event);
}

void MainWindow::ReleaseDriveKeys() {
  if (keys_held_.isEmpty()) return;
  keys_held_.clear();
  UpdateTeleop();
}

void MainWindow::UpdateTeleop() {
  double v = 0.0, w = 0.0;
  const DriveLimits& l = workspace_->limits();
  if (keys_held_.contains(Qt::Key_Up) || keys_held_.contains(Qt::Key_W)) v += l.v_max_mps;
  if (keys_held_.contains(Qt::Key_Down) || keys_held_.contains(Qt::Key_S)) v -= l.v_max_mps;
  if (keys_held_.contains(Qt::Key_Left) || keys_held_.contains(Qt::Key_A)) w += l.w_max_radps;
  if (keys_held_.contains(Qt::Key_Right) || keys_held_.contains(Qt::Key_D)) w -= l.w_max_radps;
  if (workspace_->scripted_drive_running() && keys_held_.isEmpty()) return;
  if (!keys_held_.isEmpty()) workspace_->AbortScriptedDrive();
  if (v == 0.0 && w == 0.0) {
    workspace_->StopMotion();
  } else {
    workspace_->Drive(v, w);
  }
}

// "Link: connected · REC": the link's state, refreshed once a second, and at
// once when a recording starts or stops.
void MainWindow::UpdateLinkLabel() {
  const hardware::LinkHealth& h = workspace_->health();
  QString link = QString::fromLatin1(hardware::LinkHealth::StateName(h.state));
  if (workspace_->authenticated()) link = tr("connected");
  if (h.outage_open) link = tr("reconnecting (%1 s)").arg(h.outage_s, 0, 'f', 0);
  if (workspace_->recording()) link += tr(" · REC");
  link_label_->setText(tr("Link: %1").arg(link));
}

void MainWindow::UpdateActions() {
  const bool open = workspace_->link_open();
  record_->setEnabled(open && !workspace_->recording());
  stop_record_->setEnabled(workspace_->recording());
  connect_action_->setEnabled(!open);
  disconnect_action_->setEnabled(open);
  clear_estop_->setEnabled(workspace_->authenticated());
  abort_script_->setEnabled(workspace_->scripted_drive_running());
}

void MainWindow::ShowError(const QString& title, const QString& message) {
  last_error_ = message;
  ++errors_shown_;
  // The first line: the bar has one (a refusal's first line says what
  // failed, the reader's details follow in the box).
  statusBar()->showMessage(title + QStringLiteral(": ") + message.section(QLatin1Char('\n'), 0, 0),
                           10000);
  if (interactive_) QMessageBox::warning(this, title, message);
}

void MainWindow::closeEvent(QCloseEvent* event) {
  // A saved or opened session being copied under a new name: quitting
  // stops the copy (its partial folder is removed), so it is asked. A new
  // recording being copied is ConfirmDiscard's: it refuses to quit then.
  if (workspace_->saving() && !workspace_->unsaved() && interactive_ &&
      QMessageBox::question(this, tr("Saving"),
                            tr("%1 is still running. Quit and stop the copy? The session "
                               "itself stays as it was; the partial copy is removed.")
                                .arg(workspace_->job_name()),
                            QMessageBox::Yes | QMessageBox::No,
                            QMessageBox::No) != QMessageBox::Yes) {
    event->ignore();
    return;
  }
  if (!ConfirmDiscard([this] { close(); }) || !project_->ConfirmClose()) {
    event->ignore();
    return;
  }
  SaveSettings();
  workspace_->Disconnect();
  event->accept();
}

}  // namespace sweepscan::ui
