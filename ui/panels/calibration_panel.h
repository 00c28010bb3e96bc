// Calibration panel: the mounting-error calibration of Miao et al. 2022
// (section 4, Eq. 15-17) step by step, on the session shown:
//   1. the target and the drive (a thin 0.6 m board turned 45 degrees, two
//      turns at 0.05 m/s: docs/calibration.md), with the circle drive;
//   2. the passes: an opened circle drive is split into pass A (near side)
//      and pass B (far side), coloured cyan and magenta, shown together or
//      one at a time;
//   3. picking: Shift + click a target corner in pass A, then the same
//      corner in pass B, at least four times; the pair list highlights its
//      pair in the view, deletes, undoes and redoes (Ctrl+Z / Ctrl+Shift+Z),
//      and saves / loads the pairs file the CLI reads;
//   4. Solve on a job thread (progress per LM iteration, Cancel), optionally
//      snapping the picks to the fitted board corners (refine), or the
//      automatic mode (no picks): alpha, beta, gamma with their 1-sigma from
//      the solver's covariance, each pair's distance before and after, the
//      ghost (RMS pair distance) before and after, the cost per iteration,
//      the fitted corners in the view;
//   5. before / after: the session re-assembled under the result; save or
//      load the calibration file, make it the robot's.
// GUI thread. Calls only the Workspace and the view's picking layer.
#ifndef SWEEPSCAN_UI_PANELS_CALIBRATION_PANEL_H_
#define SWEEPSCAN_UI_PANELS_CALIBRATION_PANEL_H_

#include <QWidget>
#include <functional>
#include <vector>

#include "core/calibration/picks.h"
#include "ui/workspace/workspace.h"

class QCheckBox;
class QDoubleSpinBox;
class QLabel;
class QPushButton;
class QTableWidget;
class QUndoStack;

namespace sweepscan::ui {

class CloudView;
class CostPlot;

class CalibrationPanel : public QWidget {
  Q_OBJECT
 public:
  CalibrationPanel(Workspace* workspace, CloudView* view, QUndoStack* undo,
                   QWidget* parent = nullptr);

  // A picked point (what Shift + click in the view does): completes the open
  // pair's B or starts a new pair with A. Undoable.
  void AddPick(const Eigen::Vector3d& world);
  void DeletePair(int index);           // Undoable.
  std::vector<PickPair> pairs() const;  // Complete pairs, as the CLI's pairs file.
  int pair_count() const { return static_cast<int>(pairs_.size()); }
  bool SavePairs(const QString& path, QString* error) const;
  bool LoadPairs(const QString& path, QString* error);  // Undoable as one step.
  void Solve();
  void SolveAutomatic();
  void CancelSolve();
  bool solving() const { return solving_; }
  void SetRefine(bool refine);
  // The target board's thickness for the refined solve (kept in the
  // settings; CalibrationOptions::board_thickness_m).
  void SetBoardThickness(double metres);
  double board_thickness() const;
  // The refined solve combined with the room's planes (the default, kept
  // in the settings) or the board's angles alone (workflow.h,
  // PickCalibrationOptions::combine_with_planes).
  void SetCombineWithPlanes(bool combine);
  // Step 2: pass A (0), pass B (1) or both (-1) in the view.
  void ShowPass(int pass);
  bool LoadCalibration(const QString& path, QString* error);
  void ShowAfter(bool after);  // The before / after toggle.
  // The toggle as the cloud shown is: down when it is under the result's angles.
  void SyncAfter();
  bool SaveCalibration(const QString& path, QString* error) const;
  // Makes the result the robot's calibration for live scans and new recordings.
  void UseForRobot();
  QString result_text() const;
  // The cost plot's caption: the solver's cost at the start and end of the
  // solve shown ("solver cost A -> B, N iterations, log scale").
  QString cost_caption() const;
  // Step 3's prompt: what to pick next, and what opening another session cleared.
  QString pick_prompt() const;

  // The pairs as the panel holds them: the last one may wait for its pick
  // in pass B, or in pass A when its first pick was made with pass B shown.
  struct PairPoints {
    Eigen::Vector3d a = Eigen::Vector3d::Zero(), b = Eigen::Vector3d::Zero();
    bool has_a = true, has_b = false;
    bool complete() const { return has_a && has_b; }
  };
  // For the undo commands.
  void SetPairs(const std::vector<PairPoints>& pairs);
  const std::vector<PairPoints>& pair_points() const { return pairs_; }

 signals:
  void solved(bool ok);
  void robotCalibrationChanged(const MountingError& calibration);
  // A file the operator chose could not be read or written: said in a
  // message box (MainWindow::ShowError), not in a step scrolled out of view.
  void fileError(const QString& title, const QString& message);
  // What a file operation did, for the status bar.
  void message(const QString& text);

 private:
  QWidget* BuildTargetStep();
  QWidget* BuildPassesStep();
  QWidget* BuildPickStep();
  QWidget* BuildSolveStep();
  QWidget* BuildKeepStep();
  void Refresh();
  void ShowResult(bool ok, const QString& message);
  void OnPassesSplit(bool ok, const QString& message);
  // Gives the view the pass labels once it holds every point (the view
  // takes points on the GUI tick, after the workspace has them).
  void ApplyPassLabels(int attempts_left = 100);
  // Gives the view back the colouring it had before ApplyPassLabels chose
  // the passes, once the cloud shown has no pass labels (another session,
  // the live cloud), unless the operator has chosen another since.
  void RestoreColorMode();
  void StartSolving();
  // A Save… or Load… button (calibration_panel_files.cc): `act` on the
  // file chosen, its error a message (fileError), its folder remembered,
  // and what `done` says of it in the status bar.
  void ChooseFileAnd(bool save, const QString& title, const QString& what, const QString& filter,
                     const std::function<bool(const QString&, QString*)>& act,
                     const std::function<QString(const QString&)>& done);
  // The Save and Load dialogs' file: beside the session shown, named after
  // it ("lab-pairs.json"), or the folder last used.
  QString SuggestedFile(const QString& what) const;

  Workspace* workspace_;
  CloudView* view_;
  QUndoStack* undo_;
  std::vector<PairPoints> pairs_;
  QTableWidget* table_;
  QPushButton* delete_pair_;  // with a pair selected
  QPushButton* save_pairs_;   // with a complete pair
  QCheckBox* refine_;
  QDoubleSpinBox* thickness_;
  QCheckBox* combine_;
  QPushButton* solve_;
  QPushButton* auto_;
  QPushButton* cancel_;
  bool solving_ = false;
  QLabel* passes_;
  QPushButton* pass_buttons_[3];  // both, A, B
  QPushButton* split_;
  int pass_shown_ = -1;
  bool passes_colored_ = false;  // The view shows the passes because this panel chose so.
  int color_before_passes_ = 0;  // A CloudView::ColorMode.
  QPushButton* after_;
  QPushButton* save_calibration_;
  QPushButton* use_for_robot_;
  QLabel* next_pick_;
  QLabel* result_;
  CostPlot* plot_;
  QString pairs_session_;  // the session the pairs were picked in
  QString dropped_note_;   // what opening another session cleared
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PANELS_CALIBRATION_PANEL_H_
