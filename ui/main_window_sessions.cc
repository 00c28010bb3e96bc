// MainWindow's session files: asking before a recording is discarded,
// opening, saving under a new name, importing a ROS recording, and the
// Open Recent list. The window itself: main_window.cc; its menus:
// main_window_menus.cc.
#include <QFileDialog>
#include <QFileInfo>
#include <QMenu>
#include <QMessageBox>
#include <QSettings>
#include <QStatusBar>
#include <QTimer>
#include <memory>

#include "ui/main_window.h"
#include "ui/panels/replay_panel.h"
#include "ui/panels/ros_import_dialog.h"
#include "ui/project/project_controller.h"
#include "ui/project/project_layer.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

constexpr int kMaxRecent = 8;

}  // namespace

bool MainWindow::ConfirmDiscard(const std::function<void()>& retry) {
  if (!workspace_->unsaved() && !workspace_->recording()) return true;
  if (workspace_->saving()) {
    ShowError(tr("Unsaved session"),
              tr("The recording is being saved (%1): wait for the copy, or cancel it.")
                  .arg(workspace_->job_name()));
    return false;
  }
  if (!interactive_) return true;  // The recording stays in its folder either way.
  const auto answer = QMessageBox::question(
      this, tr("Unsaved session"),
      tr("The current recording has not been saved elsewhere. It stays in\n%1\n\n"
         "Save it under a new name first?")
          .arg(workspace_->session_dir()),
      QMessageBox::Save | QMessageBox::Discard | QMessageBox::Cancel, QMessageBox::Save);
  if (answer == QMessageBox::Cancel) return false;
  if (answer == QMessageBox::Save) {
    QString error;
    if (workspace_->recording() && !workspace_->StopRecording(&error)) {
      ShowError(tr("Recording"), error);
      return false;
    }
    const QString dir = QFileDialog::getSaveFileName(
        this, tr("Save session as"), SessionDialogDir(), tr("Sessions (*.sweepscan)"));
    if (dir.isEmpty() || !SaveSessionTo(dir)) return false;
    if (!workspace_->unsaved()) return true;  // moved at once
    // Being copied onto another disk (SaveSessionAs refuses while another
    // job runs): the action goes on once it is saved, after the job's own
    // slots; not if the copy fails or is cancelled. A successful copy
    // renames the session before its job finishes.
    const QString job = workspace_->job_name();
    auto* once = new QObject(this);
    auto fired = std::make_shared<bool>(false);
    connect(workspace_, &Workspace::sessionRenamed, once, [this, once, retry, fired] {
      if (*fired) return;
      *fired = true;
      once->deleteLater();
      QTimer::singleShot(0, this, retry);
    });
    connect(workspace_, &Workspace::jobFinished, once, [once, job](const QString& what) {
      if (what == job) once->deleteLater();
    });
    return false;
  }
  return true;
}

RosImportDialog* MainWindow::ImportRosRecordingPath(const QString& path) {
  if (!ConfirmDiscard([this, path] { ImportRosRecordingPath(path); })) return nullptr;
  // A ROS 2 bag is its folder; its metadata.yaml is what a file chooser picks.
  const QFileInfo f(path);
  const QString bag = f.fileName() == QStringLiteral("metadata.yaml") ? f.absolutePath() : path;
  return new RosImportDialog(workspace_, bag, replay_panel_->speed(), this);
}

void MainWindow::OpenSessionPath(const QString& dir) {
  // Said plainly, before asking to discard anything: "DIR/meta.json: cannot
  // open for reading" read like a damaged session. A recent session that
  // is gone leaves the list.
  const QFileInfo folder(dir);
  if (!folder.exists()) {
    RemoveRecent(dir);
    ShowError(tr("Open session"), tr("%1 does not exist (moved or deleted?).").arg(dir));
    return;
  }
  if (!folder.isDir() || !QFileInfo::exists(dir + QStringLiteral("/meta.json"))) {
    ShowError(tr("Open session"),
              tr("%1 is not a sweepscan session: a session is a folder holding meta.json and "
                 "frames.bin (NAME.sweepscan).")
                  .arg(dir));
    return;
  }
  if (!ConfirmDiscard([this, dir] { OpenSessionPath(dir); })) return;
  workspace_->OpenSession(dir, replay_panel_->speed());
  // Both are drawn: the session in its own frame, the project's sessions
  // in the anchor's. The same room may show twice, apart; said, not left
  // for the operator to puzzle over.
  if (project_->layer()->shown_points() > 0) {
    statusBar()->showMessage(
        tr("%1 is drawn in its own frame beside the open project (in its anchor's frame): "
           "File > Close Project shows the session alone.")
            .arg(QFileInfo(dir).fileName()),
        15000);
  }
}

bool MainWindow::SaveSessionTo(const QString& chosen) {
  // A session is a NAME.sweepscan folder, whichever dialog named it.
  const QString dir = chosen.endsWith(QStringLiteral(".sweepscan"))
                          ? chosen
                          : chosen + QStringLiteral(".sweepscan");
  QString error;
  if (workspace_->recording() && !workspace_->StopRecording(&error)) {
    ShowError(tr("Recording"), error);
    return false;
  }
  if (!workspace_->SaveSessionAs(dir, &error)) {
    ShowError(tr("Cannot save the session"), error);
    return false;
  }
  return true;  // saved (sessionRenamed), or being copied on the job thread
}

void MainWindow::AddRecent(const QString& dir) {
  QSettings s;
  QStringList recent = s.value(QStringLiteral("sessions/recent")).toStringList();
  recent.removeAll(dir);
  recent.prepend(dir);
  while (recent.size() > kMaxRecent) recent.removeLast();
  s.setValue(QStringLiteral("sessions/recent"), recent);
  RebuildRecentMenu();
}

void MainWindow::RemoveRecent(const QString& dir) {
  QSettings settings;
  QStringList recent = settings.value(QStringLiteral("sessions/recent")).toStringList();
  if (recent.removeAll(dir) == 0) return;
  settings.setValue(QStringLiteral("sessions/recent"), recent);
  RebuildRecentMenu();
}

void MainWindow::RebuildRecentMenu() {
  recent_menu_->clear();
  const QStringList recent = QSettings().value(QStringLiteral("sessions/recent")).toStringList();
  for (const QString& dir : recent) {
    recent_menu_->addAction(QFileInfo(dir).fileName(), this, [this, dir] { OpenSessionPath(dir); })
        ->setToolTip(dir);
  }
  recent_menu_->setEnabled(!recent.isEmpty());
}

}  // namespace sweepscan::ui
