// Whether a widget belongs to the main window for its keys: inside it, or
// inside one of its floating docks (a floating QDockWidget is a window of
// its own, so `w->window() == main` misses it; Space must still stop the
// robot there).
#ifndef SWEEPSCAN_UI_OWN_WINDOW_H_
#define SWEEPSCAN_UI_OWN_WINDOW_H_

#include <QDockWidget>
#include <QWidget>

namespace sweepscan::ui {

inline bool InWindowOf(const QWidget* w, const QWidget* main) {
  const QWidget* top = w->window();
  if (top == main) return true;
  const auto* dock = qobject_cast<const QDockWidget*>(top);
  return dock != nullptr && dock->parentWidget() == main;
}

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_OWN_WINDOW_H_
