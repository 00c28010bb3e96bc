// The Project panel's pair picking (PairPicking): shown while the mode is
// on, below the session list. What to click next, the pairs picked (each
// point in its own session's frame), "Hold the free direction", Undo Pick,
// Align by Pairs and Cancel (Esc). It only calls PairPicking.
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_PROJECT_PAIR_PICK_BOX_H_
#define SWEEPSCAN_UI_PROJECT_PAIR_PICK_BOX_H_

#include <QGroupBox>

class QCheckBox;
class QLabel;
class QPushButton;
class QTreeWidget;

namespace sweepscan::ui {

class PairPicking;

class PairPickBox : public QGroupBox {
  Q_OBJECT
 public:
  explicit PairPickBox(PairPicking* picking, QWidget* parent = nullptr);

  // For tests.
  QTreeWidget* list() const { return list_; }
  QLabel* instruction() const { return instruction_; }
  QCheckBox* hold_free() const { return hold_free_; }
  QPushButton* undo_button() const { return undo_; }
  QPushButton* align_button() const { return align_; }
  QPushButton* cancel_button() const { return cancel_; }

 private:
  void Refresh();

  PairPicking* picking_;
  QLabel* instruction_;
  QTreeWidget* list_;
  QCheckBox* hold_free_;
  QPushButton* undo_;
  QPushButton* align_;
  QPushButton* cancel_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PROJECT_PAIR_PICK_BOX_H_
