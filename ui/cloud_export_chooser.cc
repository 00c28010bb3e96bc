#include "ui/cloud_export_chooser.h"

#include <QFileDialog>
#include <QFileInfo>
#include <QSettings>
#include <QStringList>

#include "ui/filter_suffix.h"

namespace sweepscan::ui {

QString ChooseCloudExport(QWidget* parent, const QString& title, const QString& base_name,
                          const QString& beside) {
  QSettings settings;
  const QString dir = settings.value(QStringLiteral("export/dir"), beside).toString();
  const QStringList filters = {QObject::tr("PLY (*.ply)"), QObject::tr("LAS 1.4 (*.las)"),
                               QObject::tr("PCD (*.pcd)")};
  const QString suffix = settings.value(QStringLiteral("export/suffix"), "ply").toString();
  QString filter = filters[0];
  for (const QString& f : filters) {
    if (f.contains(QStringLiteral("*.") + suffix)) filter = f;
  }
  const QString name = base_name.isEmpty() ? QString() : base_name + '.' + suffix;
  const QString path =
      WithFilterSuffix(QFileDialog::getSaveFileName(
                           parent, title, dir.isEmpty() ? name : dir + QLatin1Char('/') + name,
                           filters.join(QStringLiteral(";;")), &filter),
                       filter);
  if (path.isEmpty()) return path;
  settings.setValue(QStringLiteral("export/dir"), QFileInfo(path).absolutePath());
  const QString used = QFileInfo(path).suffix().toLower();
  if (used == "ply" || used == "las" || used == "pcd")
    settings.setValue(QStringLiteral("export/suffix"), used);
  return path;
}

}  // namespace sweepscan::ui
