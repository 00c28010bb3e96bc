// The operator's main window: the cloud view in the centre, dockable panels
// (connection, drive, replay), File / Edit / View / Robot / Tools / Help
// menus with the usual shortcuts, a status bar (link, pose, speeds, points,
// frame rate, job progress with cancel), keyboard teleop and an emergency
// stop on Space that works whatever has focus. Window layout and last
// settings (the pose source of opened sessions among them) persist in
// QSettings.
//
// A GUI timer (30 Hz) drains the workspace's mailbox into the view and
// renders at most once per tick. GUI thread only.
#ifndef SWEEPSCAN_UI_MAIN_WINDOW_H_
#define SWEEPSCAN_UI_MAIN_WINDOW_H_

#include <QElapsedTimer>
#include <QMainWindow>
#include <QSet>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "ui/workspace/workspace.h"

class QAction;
class QDockWidget;
class QActionGroup;
class QLabel;
class QMenu;
class QProgressBar;
class QToolButton;
class QUndoGroup;
class QUndoStack;

namespace sweepscan::ui {

class CloudView;
class ConnectionPanel;
class DrivePanel;
class ReplayPanel;
class CalibrationPanel;
class EvaluationPanel;
class PlanPanel;
class ProjectController;
class RosImportDialog;
class UndoRouter;
struct PickHit;

class MainWindow : public QMainWindow {
  Q_OBJECT
 public:
  MainWindow(Workspace* workspace, const QString& resources_dir, QWidget* parent = nullptr);
  ~MainWindow() override;

  CloudView* view() const { return view_; }
  ConnectionPanel* connection_panel() const { return connection_panel_; }
  DrivePanel* drive_panel() const { return drive_panel_; }
  ReplayPanel* replay_panel() const { return replay_panel_; }
  CalibrationPanel* calibration_panel() const { return calibration_panel_; }
  EvaluationPanel* evaluation_panel() const { return evaluation_panel_; }
  // Edit > Undo / Redo act on the active one of the window's histories
  // (UndoRouter): the opened session's (calibration picks), the project's
  // (project()->undo_stack()) or pair picking's, whichever was edited last.
  QUndoGroup* undo_group() const;
  QUndoStack* session_undo_stack() const { return session_undo_; }
  // Projects (ui/project/): File menu actions, the Project panel, the
  // project's sessions in the view.
  ProjectController* project() const { return project_.get(); }
  // View > Floor Plan (ui/plan/): the plan view's dock and File > Export Floor Plan….
  PlanPanel* plan_panel() const { return plan_panel_; }
  // A Shift + click's point: a pair's pick while pairs are picked, else an
  // end of the distance tool when it is on, else a calibration pick. The
  // view's points come back after the click (CloudView::SetPickContext)
  // and go where the click was made: to the mode then, or nowhere if that
  // mode has ended (a pair's pick after pair picking ended, an end of the
  // distance tool after it was switched off).
  void PointPicked(const PickHit& hit) { RoutePick(hit, static_cast<int>(CurrentPickMode())); }
  // Dialogs (unsaved changes, errors) are shown unless disabled (tests, demos):
  // then errors go to lastError() and unsaved recordings stay where they are.
  void SetInteractive(bool interactive) { interactive_ = interactive; }
  QString last_error() const { return last_error_; }
  int errors_shown() const { return errors_shown_; }  // ShowError calls so far
  // Event-loop latency samples (ms) measured by the GUI tick, for figures,
  // from the view's first frame on (that frame loads the GL driver).
  const std::vector<double>& tick_latencies_ms() const { return latencies_ms_; }
  // Counted from here on (a benchmark's phase: --seek).
  void ClearTickFigures() {
    latencies_ms_.clear();
    insertion_ms_ = 0.0;
  }
  // GUI-thread time spent taking new points into the view (the mailbox's
  // batches: sealed chunks and the growing chunk's points), ms in all.
  double insertion_ms() const { return insertion_ms_; }
  double frames_per_second() const { return fps_; }

  // Actions the tests and the command line trigger.
  void OpenSessionPath(const QString& dir);
  // File > Import ROS Recording… with the bag chosen: the topic chooser,
  // shown once the bag is read (docs/ros-bags.md). Null if the operator
  // keeps an unsaved recording instead.
  RosImportDialog* ImportRosRecordingPath(const QString& path);
  bool SaveSessionTo(const QString& dir);
  // Where File > Open Session's and Save Session As's dialogs start: the
  // folder a session was last opened from, else the sessions folder, else
  // the home folder; the first that exists (a dialog given a missing folder
  // starts in the working directory).
  QString SessionDialogDir() const;
  // Tools > Sessions Folder… with the folder chosen: used and kept in the
  // settings (a --sessions-dir on the command line is used, not kept).
  void ChooseSessionsRoot(const QString& dir);
  void ShowError(const QString& title, const QString& message);
  // The distance tool (Tools > Measure Distance, M): two Shift + clicks.
  QAction* measure_action() const { return measure_; }
  double measured_distance() const { return measured_m_; }
  void Measure(const Eigen::Vector3d& point);
  // Tools > Pose Source: the checkable action of kEkf, kOdometry or kSfm
  // (an exclusive group; triggering one re-processes the opened session).
  QAction* pose_source_action(PoseSource source) const;
  QString pose_source_status() const;  // The status bar's "Poses: ..." text.
  // Brings a dock (by object name, e.g. "evaluationDock") to the front.
  void RaiseDock(const QString& name);
  // View > Panels > Reset Layout: the docks where a first start puts them
  // (scripted runs start so too: their screenshots and benchmarks do not
  // depend on how the operator left the window).
  void ResetLayout();
  // The room view: the ceiling the cloud shows hidden (View > Hide Ceiling,
  // C, checked; the status bar says so) and the camera looking into the
  // room. Done when an opened session has replayed, and once for a live
  // cloud when it first shows a ceiling; the operator's toggle is kept.
  void ApplyRoomView();
  QAction* ceiling_action() const { return ceiling_; }
  QString clip_status() const;  // The status bar's text about the clip.
  // Where C hides the points above: the operator's height (Clip Height…),
  // else just under the ceiling found (the walls to their top), else 2 m.
  double ClipHeightToApply() const;

 protected:
  void closeEvent(QCloseEvent* event) override;
  bool eventFilter(QObject* watched, QEvent* event) override;

 private:
  enum class PickMode { kCalibration, kMeasure, kPair };
  PickMode CurrentPickMode() const;
  void RoutePick(const PickHit& hit, int mode);  // `mode`: a PickMode
  void BuildMenus();
  void BuildFileMenu();
  void BuildEditMenu();
  void BuildViewMenu();
  void BuildRobotMenu();
  void BuildToolsMenu();
  void BuildHelpMenu();
  void BuildPoseSourceMenu(QMenu* parent);
  void BuildStatusBar();
  void ShowPoseSource();
  void RestoreSettings();
  QByteArray default_layout_;  // the docks as built, before RestoreSettings
  void SaveSettings();
  void OnTick();
  void UpdateTeleop();
  // Whether an unsaved recording may be left (asking to save it first).
  // False while it is being copied onto another disk: `retry` (the action
  // that asked) then runs again once it is saved.
  bool ConfirmDiscard(const std::function<void()>& retry);
  void AddRecent(const QString& dir);
  void RemoveRecent(const QString& dir);
  void RebuildRecentMenu();
  void UpdateActions();
  void UpdateLinkLabel();  // the status bar's "Link: ..."
  void UpdateTitle();  // The project's file, the session's folder.

  Workspace* workspace_;
  QString resources_dir_;
  CloudView* view_;
  ConnectionPanel* connection_panel_;
  DrivePanel* drive_panel_;
  ReplayPanel* replay_panel_;
  CalibrationPanel* calibration_panel_;
  EvaluationPanel* evaluation_panel_;
  UndoRouter* undo_;
  QUndoStack* session_undo_;
  // Destroyed before the view it draws into (a member, not a child).
  std::unique_ptr<ProjectController> project_;
  PlanPanel* plan_panel_ = nullptr;
  QMenu* recent_menu_ = nullptr;
  QAction* record_ = nullptr;
  QAction* stop_record_ = nullptr;
  QAction* estop_ = nullptr;
  QAction* connect_action_ = nullptr;
  QAction* disconnect_action_ = nullptr;
  QAction* clear_estop_ = nullptr;
  QAction* abort_script_ = nullptr;
  QActionGroup* color_group_ = nullptr;
  QActionGroup* pose_source_group_ = nullptr;
  QAction* measure_ = nullptr;
  QAction* ceiling_ = nullptr;
  double ceiling_z_ = std::numeric_limits<double>::quiet_NaN();  // NaN: none found.
  // The operator's own clip (View > Clip Height…) until the next cloud's
  // ceiling is found; NaN: the ceiling's.
  double chosen_clip_ = std::numeric_limits<double>::quiet_NaN();
  int plan_widened_from_ = 0;  // The plan's column width before showing it widened it (0: not).
  void WidenPlanColumn(QDockWidget* plan);   // View > Floor Plan shown
  void NarrowPlanColumn(QDockWidget* plan);  // ... and hidden
  // The room view waits for the next session opened (its replay finished,
  // its points drained into the view) or live cloud; a camera moved since
  // (by the operator, a script, a test) cancels it.
  bool room_view_pending_ = true;
  bool room_view_ready_ = false;
  uint64_t room_view_camera_ = 0;  // The view's camera generation when it was asked for.
  // A live cloud's ceiling, hidden once found (from this many points: a few
  // seconds of an X4), before the room view frames the cloud.
  static constexpr size_t kLiveCeilingPoints = 20'000;
  bool ceiling_found_live_ = false;
  // Hide Ceiling checked, the clip just under `ceiling` (found in the cloud).
  void HideCeilingAt(double ceiling);
  std::vector<Eigen::Vector3d> measure_points_;
  double measured_m_ = 0.0;

  QLabel* link_label_;
  QLabel* pose_label_;
  QLabel* speed_label_;
  QLabel* points_label_;
  QLabel* pose_source_label_;
  QLabel* fps_label_;
  QLabel* clip_label_;
  QProgressBar* progress_;
  QToolButton* cancel_;

  bool interactive_ = true;
  QString last_error_;
  QString session_dir_shown_;  // the session in the title, for Open Recent when it moves
  int errors_shown_ = 0;
  QSet<int> keys_held_;
  // Forgets the held drive keys and stops the keyboard's motion.
  void ReleaseDriveKeys();
  QElapsedTimer tick_clock_;
  QElapsedTimer fps_clock_;
  uint64_t fps_last_frames_ = 0;  // view_->frames_rendered() a second ago
  double fps_ = 0.0;
  std::vector<double> latencies_ms_;
  uint64_t frames_at_last_tick_ = 0;  // the view's frames when the last tick began
  double insertion_ms_ = 0.0;
  std::shared_ptr<const QuantizedValues>
      pending_intensity_;  // for the view, once it holds every point
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_MAIN_WINDOW_H_
