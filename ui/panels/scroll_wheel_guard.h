// A wheel turned over a scrolled panel scrolls the panel.
//
// Qt gives the wheel to the widget under the cursor, and a spin box or a
// combo box takes it even without the focus: scrolling the Calibration
// panel down set the board thickness it passed over to 0 mm, which was
// saved at once and used by the next solve. In a scroll area those widgets
// now take the wheel only once they have the focus (a click, Tab), as in
// Qt Creator's and KDE's settings pages; until then the wheel goes to the
// scroll area.
#ifndef SWEEPSCAN_UI_PANELS_SCROLL_WHEEL_GUARD_H_
#define SWEEPSCAN_UI_PANELS_SCROLL_WHEEL_GUARD_H_

#include <QAbstractSpinBox>
#include <QApplication>
#include <QComboBox>
#include <QEvent>
#include <QObject>
#include <QScrollArea>
#include <QWidget>

namespace sweepscan::ui {

class ScrollWheelGuard : public QObject {
 public:
  // Guards `window`'s widgets, those it has and those it gets (floating
  // docks included); owned by `window`.
  static void Install(QWidget* window) {
    auto* guard = new ScrollWheelGuard(window);
    for (QWidget* w : window->findChildren<QWidget*>()) guard->Guard(w);
    qApp->installEventFilter(guard);
  }

  bool eventFilter(QObject* watched, QEvent* event) override {
    const QEvent::Type type = event->type();
    if (type != QEvent::Wheel && type != QEvent::Polish) return false;
    auto* w = qobject_cast<QWidget*>(watched);
    if (w == nullptr || !InWindow(w)) return false;
    if (type == QEvent::Polish) {
      Guard(w);
      return false;
    }
    QScrollArea* area = GuardedIn(w);
    if (area == nullptr || w->hasFocus()) return false;
    QCoreApplication::sendEvent(area->viewport(), event);
    return true;
  }

 private:
  explicit ScrollWheelGuard(QWidget* window) : QObject(window), window_(window) {}

  // `w` is `window_`'s, floating docks included (isAncestorOf stops at a
  // window: a floating dock is one).
  bool InWindow(const QObject* w) const {
    for (const QObject* o = w; o != nullptr; o = o->parent()) {
      if (o == window_) return true;
    }
    return false;
  }

  // The scroll area around a spin box or a combo box, or null.
  static QScrollArea* GuardedIn(QWidget* w) {
    if (qobject_cast<QAbstractSpinBox*>(w) == nullptr && qobject_cast<QComboBox*>(w) == nullptr) {
      return nullptr;
    }
    for (QWidget* p = w->parentWidget(); p != nullptr; p = p->parentWidget()) {
      if (auto* area = qobject_cast<QScrollArea*>(p)) return area;
    }
    return nullptr;
  }

  // Qt's wheel focus would give such a widget the focus (and the wheel)
  // before any filter sees the turn: a click or Tab gives it instead.
  static void Guard(QWidget* w) {
    if (GuardedIn(w) != nullptr && w->focusPolicy() == Qt::WheelFocus) {
      w->setFocusPolicy(Qt::StrongFocus);
    }
  }

  QWidget* window_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PANELS_SCROLL_WHEEL_GUARD_H_
