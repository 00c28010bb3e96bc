// CalibrationPanel's files: the pairs and the calibration written and read
// through their Save… and Load… buttons, their choosers opened beside the
// session shown and named after it.
#include <QDir>
#include <QFileDialog>
#include <QFileInfo>
#include <QSettings>

#include "core/calibration/calibration_file.h"
#include "core/calibration/picks.h"
#include "core/common/checked_file.h"
#include "ui/filter_suffix.h"
#include "ui/panels/calibration_panel.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {

void CalibrationPanel::ChooseFileAnd(bool save, const QString& title, const QString& what,
                                     const QString& filter,
                                     const std::function<bool(const QString&, QString*)>& act,
                                     const std::function<QString(const QString&)>& done) {
  const QString suggested = SuggestedFile(what);
  const QString path =
      save ? WithFilterSuffix(QFileDialog::getSaveFileName(this, title, suggested, filter), filter)
           : QFileDialog::getOpenFileName(this, title, QFileInfo(suggested).absolutePath(), filter);
  if (path.isEmpty()) return;
  QString error;
  if (!act(path, &error)) {
    // A message: in the panel, it went to step 4's line, scrolled out of view.
    emit fileError(title, error);
    return;
  }
  QSettings().setValue(QStringLiteral("calibration/files_dir"), QFileInfo(path).absolutePath());
  const QString said = done(path);
  if (!said.isEmpty()) emit message(said);
}

QString CalibrationPanel::SuggestedFile(const QString& what) const {
  const QString session = workspace_->session_dir();
  if (!session.isEmpty()) {
    const QFileInfo info(session);
    return info.absolutePath() + QLatin1Char('/') + info.completeBaseName() + QLatin1Char('-') +
           what + QStringLiteral(".json");
  }
  const QString dir =
      QSettings().value(QStringLiteral("calibration/files_dir"), QDir::homePath()).toString();
  return dir + QLatin1Char('/') + what + QStringLiteral(".json");
}

bool CalibrationPanel::SavePairs(const QString& path, QString* error) const {
  const Status s = WriteFileChecked(path.toStdString(), PairsToJson(pairs()));
  if (!s.ok()) {
    *error = QString::fromStdString(s.message());
    return false;
  }
  return true;
}

bool CalibrationPanel::SaveCalibration(const QString& path, QString* error) const {
  const PickCalibrationResult* r = workspace_->calibration_result();
  if (r == nullptr) {
    *error = tr("Solve first.");
    return false;
  }
  const Status s = SaveCalibrationFile(path.toStdString(), r->summary.angles, &r->summary);
  if (!s.ok()) {
    *error = QString::fromStdString(s.message());
    return false;
  }
  return true;
}

bool CalibrationPanel::LoadCalibration(const QString& path, QString* error) {
  return workspace_->LoadCalibration(path, error);
}

}  // namespace sweepscan::ui
