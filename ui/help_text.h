// Help > Keyboard and Mouse: what the keys and the mouse do. The menus'
// shortcuts are read from the menus themselves, so the help lists every
// one and cannot fall behind them; the keys and mouse gestures that no menu
// holds (driving, the emergency stop, the view's camera, picking, the floor
// plan's drag) are listed beside them.
#ifndef SWEEPSCAN_UI_HELP_TEXT_H_
#define SWEEPSCAN_UI_HELP_TEXT_H_

#include <QString>

class QMenuBar;
class QWidget;

namespace sweepscan::ui {

// The help as HTML (tables of key or gesture and what it does).
QString KeyboardAndMouseHelpHtml(const QMenuBar* menus);
// The same in a dialog that can stay open beside the window (not modal).
void ShowKeyboardAndMouseHelp(QWidget* parent, const QMenuBar* menus);
// Help > About: the version, the methods' papers and the libraries it is
// built on with their versions.
QString AboutHtml();

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_HELP_TEXT_H_
