// Keeps a dock's panel tall enough for its word-wrapped labels.
//
// A QDockWidget sizes its widget from minimumSizeHint / sizeHint, which a
// layout computes without heightForWidth: a wrapped label is counted at the
// width its own size hint guesses, so in a dock narrower than that guess
// its last line is cut off (the Session and replay dock's pose note, the
// Drive panel's hint). On every resize this filter sets the panel's minimum
// height to what its layout needs at the width it was given.
#ifndef SWEEPSCAN_UI_PANELS_FIT_HEIGHT_TO_WIDTH_H_
#define SWEEPSCAN_UI_PANELS_FIT_HEIGHT_TO_WIDTH_H_

#include <QEvent>
#include <QLayout>
#include <QObject>
#include <QWidget>

namespace sweepscan::ui {

class FitHeightToWidth : public QObject {
 public:
  // Watches `panel` (and is owned by it).
  static void Install(QWidget* panel) { panel->installEventFilter(new FitHeightToWidth(panel)); }

  bool eventFilter(QObject* watched, QEvent* event) override {
    if (event->type() == QEvent::Resize || event->type() == QEvent::LayoutRequest) {
      auto* panel = static_cast<QWidget*>(watched);
      QLayout* layout = panel->layout();
      if (layout != nullptr && layout->hasHeightForWidth()) {
        const int needed = layout->heightForWidth(panel->width());
        if (needed > 0 && needed != panel->minimumHeight()) panel->setMinimumHeight(needed);
      }
    }
    return false;
  }

 private:
  explicit FitHeightToWidth(QObject* parent) : QObject(parent) {}
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PANELS_FIT_HEIGHT_TO_WIDTH_H_
