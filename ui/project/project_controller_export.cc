// ProjectController's export: File > Export Project Cloud (and Export Cloud
// when the project is what the view shows).
#include <QAction>
#include <QFileInfo>
#include <QMenu>
#include <QStringList>
#include <memory>

#include "hardware/station/project_export.h"
#include "ui/cloud_export_chooser.h"
#include "ui/project/project_controller.h"

namespace sweepscan::ui {

QAction* ProjectController::AddExportAction(QMenu* file) {
  export_ = file->addAction(tr("Export Pro&ject Cloud…"), this, [this] { ExportWithDialog(); });
  UpdateActions();
  return export_;
}

void ProjectController::ExportWithDialog() {
  if (!document_.is_open()) return;
  // Said before a file is asked for, not after.
  if (!SayIfNothingToExport()) return;
  const QFileInfo project(document_.path());
  const QString path = ChooseCloudExport(window_, tr("Export project cloud"),
                                         project.completeBaseName(), project.absolutePath());
  if (!path.isEmpty()) ExportCloud(path);
}

namespace {

// What the operator is told beside the count: the visible sessions left
// out for want of a placement, and the export's warnings.
QStringList Notes(const std::vector<std::string>& unplaced,
                  const hardware::ProjectExportResult& result) {
  QStringList notes;
  if (!unplaced.empty()) {
    QStringList ids;
    for (const std::string& id : unplaced) ids << QString::fromStdString(id);
    notes << QObject::tr("not placed, left out: %1").arg(ids.join(QStringLiteral(", ")));
  }
  for (const std::string& w : result.warnings) notes << QString::fromStdString(w);
  return notes;
}

}  // namespace

Status ProjectController::ExportCloudNow(const QString& path, QStringList* notes) {
  if (!document_.is_open()) return Status::Error("no project is open");
  std::vector<std::string> unplaced;
  const Project& project = document_.project();
  const std::vector<size_t> chosen = hardware::PlacedVisibleSessions(project, &unplaced);
  hardware::ProjectExportResult result;
  const Status s = hardware::ExportProjectCloud(document_.path().toStdString(), project, chosen,
                                                path.toStdString(), hardware::SessionCloudOptions(),
                                                nullptr, &result);
  if (s.ok() && notes != nullptr) *notes = Notes(unplaced, result);
  return s;
}

bool ProjectController::SayIfNothingToExport() {
  if (!hardware::PlacedVisibleSessions(document_.project(), nullptr).empty()) return true;
  show_error_(tr("Cannot export the project's cloud"),
              tr("No session of %1 is both placed and shown: align a session (or show one) first.")
                  .arg(QFileInfo(document_.path()).fileName()));
  return false;
}

bool ProjectController::ExportCloud(const QString& path) {
  if (!document_.is_open() || !SayIfNothingToExport()) return false;
  const Project project = document_.project();
  std::vector<std::string> unplaced;
  const std::vector<size_t> chosen = hardware::PlacedVisibleSessions(project, &unplaced);
  const std::string file = document_.path().toStdString();
  const std::string out = path.toStdString();
  auto result = std::make_shared<hardware::ProjectExportResult>();
  const bool started = jobs_.Run(
      tr("Exporting %1").arg(QFileInfo(path).fileName()),
      [project, chosen, file, out, result](std::atomic<bool>* cancel,
                                           const ProjectJobs::Progress& progress) {
        const Status s = hardware::ExportProjectCloud(
            file, project, chosen, out, hardware::SessionCloudOptions(),
            [&](const std::string& stage, double f) {
              // "Export: reading 'a' for the extent (1 of 2)": the bar says what runs.
              QString text = QString::fromStdString(stage);
              if (!text.isEmpty()) text[0] = text[0].toLower();
              progress(tr("Export: %1").arg(text), f);
              return !*cancel;
            },
            result.get());
        if (*cancel) return tr("cancelled");
        return s.ok() ? QString() : QString::fromStdString(s.message());
      },
      [this, path, result, unplaced, sessions = chosen.size()](const QString& error) {
        if (jobs_.cancelled()) {
          emit message(tr("Export cancelled: %1 was not written").arg(path));
          return;
        }
        if (!error.isEmpty()) {
          show_error_(tr("Cannot export the project's cloud"), error);
          return;
        }
        const QStringList notes = Notes(unplaced, *result);
        QString said = tr("Exported %1 points of %2 session(s) to %3")
                           .arg(result->points)
                           .arg(sessions)
                           .arg(path);
        if (!notes.isEmpty()) said += QStringLiteral(" (%1)").arg(notes.join(QStringLiteral("; ")));
        emit message(said);
      });
  if (!started) {
    show_error_(tr("Cannot export the project's cloud"),
                tr("The project is busy (loading or aligning): export when it has finished."));
  }
  return started;
}

}  // namespace sweepscan::ui
