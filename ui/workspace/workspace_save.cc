// Workspace, by concern: Save Session As. A new recording is given its name
// by moving its folder; an opened session's folder, or a new recording's
// onto another disk, is copied on the job thread (an hour of scanning is
// about 0.5 GB of frames).
#include <QDir>
#include <QFileInfo>
#include <QMetaObject>
#include <memory>

#include "core/common/checked_file.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

// The files of a session folder (frames.bin, meta.json, what else was kept
// beside them), not the checked writer's temporaries.
QFileInfoList SessionFiles(const QString& dir) {
  QFileInfoList files;
  for (const QFileInfo& f : QDir(dir).entryInfoList(QDir::Files)) {
    if (!IsTemporaryFileName(f.fileName().toStdString())) files.push_back(f);
  }
  return files;
}

// Copies `from`'s files into the new folder `to`, each through the checked
// writer; `progress` hears the fraction of bytes copied and cancels by
// returning false. On any failure the new folder is removed.
QString CopySession(const QString& from, const QString& to,
                    const std::function<bool(double)>& progress) {
  const QFileInfoList files = SessionFiles(from);
  double total = 0.0;
  for (const QFileInfo& f : files) total += static_cast<double>(f.size());
  if (!QDir().mkpath(to)) return QStringLiteral("%1: cannot create the folder").arg(to);
  double before = 0.0;
  for (const QFileInfo& f : files) {
    const auto file_progress = [&](uint64_t bytes) {
      return !progress || progress(total > 0 ? (before + static_cast<double>(bytes)) / total : 1.0);
    };
    const Status s =
        CopyFileChecked(f.absoluteFilePath().toStdString(),
                        (to + QLatin1Char('/') + f.fileName()).toStdString(), file_progress);
    if (!s.ok()) {
      QDir(to).removeRecursively();
      return QString::fromStdString(s.message());
    }
    before += static_cast<double>(f.size());
  }
  return QString();
}

}  // namespace

bool Workspace::SaveSessionAs(const QString& dir, QString* error) {
  if (saving()) {  // Its folder is being read: neither moved nor copied twice.
    *error =
        QStringLiteral("The session is being saved already: wait for %1 to finish, or cancel it.")
            .arg(job_what_);
    return false;
  }
  if (recording_) {
    *error = QStringLiteral("Stop the recording before saving it.");
    return false;
  }
  if (session_dir_.isEmpty()) {
    *error = QStringLiteral("There is no session to save: record or open one first.");
    return false;
  }
  if (QFileInfo::exists(dir)) {
    *error = QStringLiteral("%1 exists already; choose a new name").arg(dir);
    return false;
  }
  const auto renamed = [this, dir] {
    session_dir_ = dir;
    unsaved_ = false;
    emit sessionRenamed(dir);
  };
  // A new recording is moved: at once on the same disk (copying it took
  // seconds on the GUI thread for an hour of scanning).
  if (unsaved_ && QDir().rename(session_dir_, dir)) {
    renamed();
    return true;
  }
  // An opened session, or a new recording saved onto another disk: copied
  // on the job thread (progress; Cancel removes the copy). The session shown
  // stays the original until it is done; a new recording's original folder
  // stays where it was recorded.
  if (job_running()) {  // Said here, not as a failed job the caller cannot tell from the copy's.
    *error = QStringLiteral("%1 is still running: let it finish (or cancel it), then save.")
                 .arg(job_what_);
    return false;
  }
  const QString from = session_dir_;
  const QString what = tr("Saving %1").arg(dir);
  save_job_ = what;
  RunJob(
      what,
      [this, from, dir, what](std::atomic<bool>* cancel) -> QString {
        return CopySession(from, dir, JobProgress(what, cancel));
      },
      [this, from, renamed] {
        if (session_dir_ == from) renamed();  // not if another session was opened since
      });
  return true;
}

}  // namespace sweepscan::ui
