// Aligning a session by picked pairs (issue 29, docs/desktop-app.md,
// "Projects"): a mode of the Project panel and the view for a session the
// planes cannot place (a corridor) or placed wrongly.
//
//   Start(c, a)   c (unplaced: drawn beside the project; placed: where it
//                 is) and its reference a are drawn, hidden or not;
//   AddPick(hit)  Shift + click a point in c, then the same physical point
//                 in a, and again (>= 3 pairs, not on one line); each pick
//                 is the point in its session's own frame (PickHit::local),
//                 so the pairs hold whatever pose c is drawn at;
//   Align(hold)   the controller's Align with the pairs (coarse by pairs,
//                 then ICP; `hold` keeps a corridor's free direction at the
//                 pairs' pose instead of refusing). A placement is one
//                 undoable edit on the project's stack and ends the mode; a
//                 refusal keeps the picks to mend.
//
// The picks have their own QUndoStack, the window's active history while
// the mode is on (UndoRouter): Ctrl+Z / Ctrl+Shift+Z undo and redo a pick
// (the keys are taken before the Edit menu's shortcuts, which could act on
// another history by then), and no history holds picks of a mode that has
// ended. Esc cancels the mode and leaves the project as it was. The mode
// ends, and says why, when its session or reference leaves the project or
// the reference is no longer placed (the panel's edits are disabled while
// it runs; an undo or a closed project still can). The view
// shows each pair's two points numbered: in the session yellow, in the
// reference cyan, the pick waiting for its partner larger.
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_PROJECT_PAIR_PICKING_H_
#define SWEEPSCAN_UI_PROJECT_PAIR_PICKING_H_

#include <Eigen/Core>
#include <QColor>
#include <QObject>
#include <QString>
#include <QUndoStack>
#include <string>
#include <vector>

#include "core/registration/registration.h"
#include "ui/view/cloud_view.h"

class QWidget;

namespace sweepscan::ui {

class ProjectController;

class PairPicking : public QObject {
  Q_OBJECT
 public:
  // A pair as picked: `source` in the session's frame, `target` in the
  // reference's; the last one may wait for its target.
  struct Pick {
    Eigen::Vector3d source = Eigen::Vector3d::Zero(), target = Eigen::Vector3d::Zero();
    bool has_target = false;
  };
  static constexpr int kMinPairs = 3;
  static const QColor kSourceColor, kTargetColor;

  PairPicking(ProjectController* controller, CloudView* view, QWidget* window);
  ~PairPicking() override;

  bool active() const { return !session_.empty(); }
  const std::string& session() const { return session_; }
  const std::string& reference() const { return reference_; }
  // False if it cannot start: a job runs, unknown ids, the reference not
  // placed, `id` the anchor or the reference itself.
  bool Start(const std::string& id, const std::string& reference);
  void Cancel();  // Esc: the picks dropped, the project untouched.
  // Ended by something else (the project closed, another one opened): the
  // picks dropped, `why` said.
  void Abandon(const QString& why);
  // The click's point, if it is in the session expected next (else a
  // message says where to click, and false).
  bool AddPick(const PickHit& hit);
  QUndoStack* undo_stack() { return &undo_; }
  const std::vector<Pick>& picks() const { return picks_; }
  std::vector<PointPair> pairs() const;  // the complete ones
  void SetPicks(const std::vector<Pick>& picks);  // the undo commands' way in
  // Registers with the pairs on the job thread; false if it cannot start.
  bool Align(bool hold_free);
  bool aligning() const { return aligning_; }
  // Enough pairs, and no job running (the clouds' loading included).
  bool can_align() const;
  // What to do next, for the panel.
  QString instruction() const;

 signals:
  void changed();  // the mode, the picks or the outcome
  void message(const QString& text);

 protected:
  bool eventFilter(QObject* watched, QEvent* event) override;

 private:
  void End();
  void ShowMarkers();

  ProjectController* controller_;
  CloudView* view_;
  QWidget* window_;
  std::string session_, reference_;
  std::vector<Pick> picks_;
  QUndoStack undo_;
  bool aligning_ = false;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PROJECT_PAIR_PICKING_H_
