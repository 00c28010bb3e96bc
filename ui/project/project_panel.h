// The Project panel (a dock): the project's sessions with a visibility
// check box, a colour swatch (double-click or "Colour…" for QColorDialog)
// and the placement (anchor; method, reference, rms, overlap and 1-sigma;
// or "not placed"); the reference to align the selected session to and
// Align, or Pick Pairs… for the pairs' mode (PairPickBox below the list);
// the job's progress with Cancel; a context menu (Align to, Colour,
// Show Only This, Make Anchor, Remove from Project; its edits disabled
// while pairs are picked, and a change of anchor or a removal core/project
// refuses disabled with the reason);
// the last alignment's outcome while it is true (not once undone or the
// project closed). It only calls the controller, which makes every edit an
// undoable command. The content scrolls in its dock.
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_PROJECT_PROJECT_PANEL_H_
#define SWEEPSCAN_UI_PROJECT_PROJECT_PANEL_H_

#include <QString>
#include <QWidget>
#include <string>

class QComboBox;
class QLabel;
class QMenu;
class QProgressBar;
class QPushButton;
class QToolButton;
class QTreeWidget;
class QTreeWidgetItem;
class QUndoCommand;

namespace sweepscan::ui {

class PairPickBox;
class ProjectController;

class ProjectPanel : public QWidget {
  Q_OBJECT
 public:
  explicit ProjectPanel(ProjectController* controller, QWidget* parent = nullptr);

  // The list again from the project (keeps the selection).
  void Refresh();
  // fraction in 0..1, < 0 busy without one, -2 hides the progress.
  void ShowProgress(const QString& what, double fraction);

  // For tests and the context menu.
  QTreeWidget* tree() const { return tree_; }
  QComboBox* reference_box() const { return reference_; }
  QPushButton* align_button() const { return align_; }
  QPushButton* pick_button() const { return pick_; }
  PairPickBox* pair_box() const { return pair_box_; }
  QToolButton* cancel_button() const { return cancel_; }
  QLabel* status_label() const { return status_; }
  void SelectSession(const std::string& id);
  std::string selected() const;
  QTreeWidgetItem* item(const std::string& id) const;
  // The context menu of a session (its actions trigger the edits).
  QMenu* ContextMenu(const std::string& id);

 private:
  void UpdateAlign();
  // An alignment's outcome, said while the project is as it left it.
  void ShowOutcome(bool placed, const QString& text);
  void UpdateOutcome();
  void ChooseColor(const std::string& id);

  ProjectController* controller_;
  QLabel* name_;
  QTreeWidget* tree_;
  QComboBox* reference_;
  QPushButton* align_;
  QPushButton* pick_;
  PairPickBox* pair_box_;
  QPushButton* add_;
  QProgressBar* progress_;
  QToolButton* cancel_;
  QLabel* status_;
  bool refreshing_ = false;
  bool status_is_progress_ = false;
  QString outcome_;
  int outcome_index_ = 0;                          // the undo stack's index as the outcome came
  const QUndoCommand* outcome_command_ = nullptr;  // the command below that index
  bool outcome_placed_ = false;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PROJECT_PROJECT_PANEL_H_
