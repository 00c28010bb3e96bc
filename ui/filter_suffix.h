// A name chosen in a save dialog without a suffix takes the chosen filter's
// first one ("PLY (*.ply)" -> name.ply): Qt's own dialog (the one under X11
// without a desktop's theme) leaves it bare, and the writer then refused
// "unknown cloud format". Used by every save dialog of the app.
#ifndef SWEEPSCAN_UI_FILTER_SUFFIX_H_
#define SWEEPSCAN_UI_FILTER_SUFFIX_H_

#include <QFileInfo>
#include <QString>

namespace sweepscan::ui {

inline QString WithFilterSuffix(const QString& path, const QString& filter) {
  if (path.isEmpty() || !QFileInfo(path).suffix().isEmpty()) return path;
  const int star = filter.indexOf(QStringLiteral("*."));
  if (star < 0) return path;
  int end = star + 2;
  while (end < filter.size() && filter[end].isLetterOrNumber()) ++end;
  return path + filter.mid(star + 1, end - star - 1);
}

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_FILTER_SUFFIX_H_
