// The Edit menu's one Undo / Redo over the window's documents, each with
// its own history (a QUndoGroup of QUndoStacks):
//   the opened session  calibration pair picks (CalibrationPanel);
//   the project         visibility, colours, sessions added, removed and
//                       placed (ProjectController), cleared with the
//                       project it belongs to (Open, New, Close, Save As);
//   pair picking        the picks of the mode (PairPicking), while it runs.
// View appearance edits (colour mode, point size) go on whichever history
// is active: they belong to what the operator is looking at.
//
// The active history is the one edited last (a push, or an undo / redo
// driven from its own buttons), or the one a caller activates (pair
// picking when it starts). When the active history is cleared (the
// project closed, the picking ended), the most recently edited one that
// still holds commands takes over, so Ctrl+Z never undoes into a history
// that was thrown away and never silently does nothing while another
// document has something to undo.
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_UNDO_ROUTER_H_
#define SWEEPSCAN_UI_UNDO_ROUTER_H_

#include <QObject>
#include <QUndoGroup>
#include <vector>

class QAction;
class QUndoCommand;
class QUndoStack;

namespace sweepscan::ui {

class UndoRouter : public QObject {
  Q_OBJECT
 public:
  explicit UndoRouter(QObject* parent = nullptr);

  // `stack` joins the group; the first one added is the fallback history
  // for view edits when none is active. Not owned.
  void AddStack(QUndoStack* stack);
  void Activate(QUndoStack* stack);
  // `stack` is done for now (pair picking ended, even with no pick made,
  // when QUndoStack::clear() says nothing): if it is the active one, the
  // most recently edited history that holds commands takes over.
  void Leave(QUndoStack* stack);
  QUndoStack* active() const { return group_.activeStack(); }
  // Onto the active history (else the first one added).
  void Push(QUndoCommand* command);
  QUndoGroup* group() { return &group_; }

 private:
  void OnIndexChanged(QUndoStack* stack);
  void Touch(QUndoStack* stack);  // most recently edited first

  QUndoGroup group_;
  QUndoStack* fallback_ = nullptr;
  std::vector<QUndoStack*> recency_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_UNDO_ROUTER_H_
