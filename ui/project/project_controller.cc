#include "ui/project/project_controller.h"

#include <QAction>
#include <QDockWidget>
#include <QFile>
#include <QFileDialog>
#include <QFileInfo>
#include <QMenu>
#include <QMessageBox>
#include <QSettings>
#include <QTimer>
#include <QUndoStack>
#include <cmath>
#include <optional>

#include "core/registration/registration.h"
#include "core/session/session.h"
#include "hardware/station/project_align.h"
#include "ui/project/pair_picking.h"
#include "ui/project/project_commands.h"
#include "ui/project/project_layer.h"
#include "ui/project/project_panel.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

constexpr int kMaxRecent = 8;
const QString kRecentKey = QStringLiteral("projects/recent");

QString Id(const std::string& id) { return QString::fromStdString(id); }

// The CLI's "placed ... against ...: rms, overlap, 1-sigma" line.
QString PlacedText(const std::string& id, const hardware::RegistrationAttempt& a) {
  const RegistrationResult& r = a.fine;
  QString text = QObject::tr("Placed '%1' against '%2' (%3): rms %4 mm, overlap %5 %, 1-sigma %6 mm / %7 deg")
                     .arg(Id(id), Id(a.reference), Id(a.method))
                     .arg(r.rms_m * 1e3, 0, 'f', 1)
                     .arg(std::lround(r.overlap * 100))
                     .arg(r.TranslationSigmaM() * 1e3, 0, 'f', 1)
                     .arg(r.RotationSigmaDeg(), 0, 'g', 3);
  if (r.degenerate) text += QObject::tr("; held along the free direction, not measured");
  return text;
}

}  // namespace

ProjectController::ProjectController(QWidget* window, CloudView* view,
                                     std::function<void(const QString&, const QString&)> show_error,
                                     std::function<bool()> interactive)
    : window_(window),
      view_(view),
      show_error_(std::move(show_error)),
      interactive_(std::move(interactive)),
      layer_(std::make_unique<ProjectLayer>(view)) {
  picking_ = new PairPicking(this, view, window);
  panel_ = new ProjectPanel(this);
  // The sessions' points go to the view a few pieces a tick (ProjectLayer).
  pump_ = new QTimer(this);
  pump_->setInterval(33);
  connect(pump_, &QTimer::timeout, this, [this] {
    if (layer_->Pump()) return;
    pump_->stop();
    // No longer busy(): Align and Pick Pairs… wait for this (they stayed
    // disabled after an alignment until the selection changed).
    panel_->Refresh();
    if (!jobs_.running()) LoadMissing();  // Says shown() when all is drawn.
  });
  connect(&document_, &ProjectDocument::opened, this, [this] {
    // Another project: its own clouds, and none of the old one's jobs.
    jobs_.Cancel();
    // "Cancelled: the project is unchanged" read as if the close had not
    // happened.
    picking_->Abandon(document_.is_open() ? tr("another project was opened")
                                          : tr("the project was closed"));
    preview_.clear();
    clouds_.clear();
    load_failures_.clear();
    layer_->Clear();
    emit cloudsChanged();
    shown_pending_ = document_.is_open();
    UpdateActions();
    undo_.clear();
  });
  connect(&document_, &ProjectDocument::changed, this, &ProjectController::OnChanged);
  connect(&document_, &ProjectDocument::modifiedChanged, this, &ProjectController::titleChanged);
  connect(&document_, &ProjectDocument::renamed, this, &ProjectController::titleChanged);
  connect(&document_, &ProjectDocument::renamed, &undo_, &QUndoStack::clear);
  // Its commands hold projects without the other program's changes.
  connect(&document_, &ProjectDocument::merged, &undo_, &QUndoStack::clear);
  connect(&jobs_, &ProjectJobs::progress, panel_, &ProjectPanel::ShowProgress);
  connect(&jobs_, &ProjectJobs::finished, panel_, [this] {
    panel_->ShowProgress(QString(), -2.0);
    panel_->Refresh();
  });
}

ProjectController::~ProjectController() { jobs_.Cancel(); }

bool ProjectController::busy() const { return jobs_.running() || layer_->pending(); }

QString ProjectController::title() const {
  if (!document_.is_open()) return QString();
  return QFileInfo(document_.path()).fileName() + QStringLiteral("[*]");
}

void ProjectController::AddFileMenuActions(QMenu* file) {
  file->addAction(tr("New &Project…"), this, [this] {
    if (!ConfirmClose()) return;
    const QString path = ChooseProjectFile(tr("New project"), QString());
    if (!path.isEmpty()) NewProject(path);
  })->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_N));
  file->addAction(tr("Open Pro&ject…"), this, [this] {
    if (!ConfirmClose()) return;
    const QString path = QFileDialog::getOpenFileName(
        window_, tr("Open project"), QString(), tr("sweepscan projects (*.sweepscan-project);;All files (*)"));
    if (!path.isEmpty()) OpenProject(path);
  })->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_O));
  recent_menu_ = file->addMenu(tr("Open Recent Projec&t"));
  // Ctrl+S: the project is what this window saves (recordings are on
  // disk as they are made; Save Session As has Ctrl+Shift+S).
  save_ = file->addAction(tr("Sa&ve Project"), this, [this] { SaveProject(); });
  save_->setShortcut(QKeySequence::Save);
  // No shortcut: QKeySequence::SaveAs (Ctrl+Shift+S) is Save Session As.
  save_as_ = file->addAction(tr("Save Project &As…"), this, [this] {
    const QString path = ChooseProjectFile(tr("Save project as"), document_.path());
    if (!path.isEmpty()) SaveProjectAs(path);
  });
  add_ = file->addAction(tr("A&dd Session to Project…"), this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(
        window_, tr("Add a session folder (NAME.sweepscan)"),
        QFileInfo(document_.path()).absolutePath());
    if (!dir.isEmpty()) AddSession(dir);
  });
  add_->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_A));
  close_ = file->addAction(tr("C&lose Project"), this, [this] {
    if (ConfirmClose()) CloseProject();
  });
  close_->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_W));
  RebuildRecentMenu();
  UpdateActions();
}

void ProjectController::UpdateActions() {
  for (QAction* a : {save_, save_as_, add_, close_, export_}) {
    if (a != nullptr) a->setEnabled(document_.is_open());
  }
}

QString ProjectController::ChooseProjectFile(const QString& title, const QString& start) {
  // The dialog adds the suffix itself, so that its overwrite question is
  // about the file written: "floor" typed over floor.sweepscan-project was
  // replaced without a word when the suffix was added after the dialog.
  QFileDialog dialog(window_, title, start,
                     tr("sweepscan projects (*%1)").arg(QLatin1String(kProjectSuffix)));
  dialog.setAcceptMode(QFileDialog::AcceptSave);
  dialog.setFileMode(QFileDialog::AnyFile);
  dialog.setDefaultSuffix(QString::fromLatin1(kProjectSuffix).mid(1));
  dialog.setOption(QFileDialog::DontConfirmOverwrite, false);
  if (dialog.exec() != QDialog::Accepted || dialog.selectedFiles().isEmpty()) return QString();
  QString path = dialog.selectedFiles().front();
  if (path.endsWith(QLatin1String(kProjectSuffix))) return path;
  // A platform's dialog that left the suffix off: its question was about
  // another name, so ask about this one.
  path += QLatin1String(kProjectSuffix);
  if (QFileInfo::exists(path) &&
      QMessageBox::question(
          window_, title, tr("%1 already exists.\n\nReplace it?").arg(QFileInfo(path).fileName()),
          QMessageBox::Yes | QMessageBox::No, QMessageBox::No) != QMessageBox::Yes) {
    return QString();
  }
  return path;
}

bool ProjectController::NewProject(const QString& path) {
  document_.New(path);
  // The panel to the front, as when a project opens (there are no clouds
  // to wait for: shown() never comes for an empty project).
  if (auto* dock = qobject_cast<QDockWidget*>(panel_->parentWidget())) dock->raise();
  emit message(tr("New project %1: add sessions (File > Add Session to Project…), then save (Ctrl+S)")
                   .arg(QFileInfo(path).fileName()));
  return true;
}

bool ProjectController::OpenProject(const QString& path) {
  const Status s = document_.Open(path);
  if (!s.ok()) {
    show_error_(tr("Cannot open the project"), QString::fromStdString(s.message()));
    return false;
  }
  AddRecent(QFileInfo(path).absoluteFilePath());
  emit message(tr("Opened %1: %2 session(s)").arg(path).arg(document_.project().sessions.size()));
  if (!document_.repairs().empty()) {
    QString what;
    for (const std::string& r : document_.repairs())
      what += QString::fromStdString(r) + QStringLiteral("\n");
    show_error_(
        tr("The project was repaired"),
        tr("%1 held references no sweepscan can use (saved by an older one):\n\n%2\nSave the "
           "project to keep the repair.")
            .arg(path, what));
  }
  return true;
}

bool ProjectController::SaveProject() {
  if (!document_.is_open()) return false;
  // Another program (the CLI in a terminal) may have changed the file since
  // it was opened here: its changes are merged with this window's, as the
  // CLI's align merges, and only what cannot be merged is asked about.
  ProjectDocument::Merge merge;
  const Project before = document_.project();
  Status s = document_.SaveMerging(&merge);
  // The file's change of anchor (`sweepscan-cli project anchor`) moved the
  // frame under the building: the camera moves with it, as after Make
  // Anchor here. (A merge holds no placement in the old frame.)
  const Project& after = document_.project();
  if (s.ok() && after.Anchor() >= 0 && before.Anchor() >= 0 &&
      after.sessions[after.Anchor()].id != before.sessions[before.Anchor()].id) {
    const int i = before.Find(after.sessions[after.Anchor()].id);
    if (i >= 0 && before.sessions[i].project_from_session)
      view_->MoveCameraWithFrame(before.sessions[i].project_from_session->inverse());
  }
  if (!merge.refused.empty()) {
    const QString file = QFileInfo(document_.path()).fileName();
    QString why = Id(merge.refused);
    if (!merge.conflicts.empty()) {
      QStringList lines;
      for (const std::string& c : merge.conflicts) lines << Id(c);
      why = tr("these changed both there and here:\n%1").arg(lines.join(QLatin1Char('\n')));
    }
    if (!interactive_()) {
      show_error_(tr("Cannot save the project"),
                  tr("%1 was changed by another program since it was opened here, and its "
                     "changes cannot be merged with this window's: %2\n\nSaving would overwrite "
                     "them. Save it under another name, or open it again.")
                      .arg(document_.path(), why));
      return false;
    }
    const auto answer = QMessageBox::warning(
        window_, tr("Project changed on disk"),
        tr("%1 was changed by another program (sweepscan-cli?) since it was opened here, and its "
           "changes cannot be merged with this window's: %2\n\n"
           "Overwrite all its changes with the project as it is here?")
            .arg(file, why),
        QMessageBox::Save | QMessageBox::Cancel, QMessageBox::Cancel);
    if (answer != QMessageBox::Save) return false;
    s = document_.Save();
  }
  if (!s.ok()) {
    show_error_(tr("Cannot save the project"), QString::fromStdString(s.message()));
    return false;
  }
  AddRecent(QFileInfo(document_.path()).absoluteFilePath());
  if (merge.from_file.empty()) {
    emit message(tr("Saved %1").arg(document_.path()));
  } else {
    QStringList ids;
    for (const std::string& id : merge.from_file) ids << QStringLiteral("'%1'").arg(Id(id));
    emit message(tr("Saved %1 with another program's changes to %2 (the undo history starts again)")
                     .arg(document_.path(), ids.join(QStringLiteral(", "))));
  }
  return true;
}

bool ProjectController::SaveProjectAs(const QString& path) {
  if (!document_.is_open()) return false;
  const Status s = document_.SaveAs(path);
  if (!s.ok()) {
    show_error_(tr("Cannot save the project"), QString::fromStdString(s.message()));
    return false;
  }
  AddRecent(QFileInfo(path).absoluteFilePath());
  emit message(tr("Saved as %1").arg(path));
  return true;
}

bool ProjectController::AddSession(const QString& dir) {
  if (!document_.is_open()) return false;
  if (!QFileInfo::exists(dir + QStringLiteral("/meta.json"))) {
    show_error_(tr("Cannot add the session"), tr("%1: not a session folder (no meta.json)").arg(dir));
    return false;
  }
  // As `sweepscan-cli project add`: a meta.json that does not read is
  // refused now, not at the alignment.
  SessionMeta meta;
  if (const Status m = ReadSessionMeta(
          QFile::encodeName(dir + QStringLiteral("/meta.json")).toStdString(), &meta);
      !m.ok()) {
    show_error_(tr("Cannot add the session"), QString::fromStdString(m.message()));
    return false;
  }
  Project after = document_.project();
  ProjectSession* added = nullptr;
  const Status s =
      after.AddSession(document_.StoredPath(dir), &added, document_.path().toStdString());
  if (!s.ok()) {
    show_error_(tr("Cannot add the session"), QString::fromStdString(s.message()));
    return false;
  }
  added->recorded_utc = meta.created_utc;  // which recording was placed
  Push(after, tr("add session '%1'").arg(Id(added->id)));
  return true;
}

bool ProjectController::ConfirmClose() {
  if (!document_.modified() || !interactive_()) return true;
  const auto answer = QMessageBox::question(
      window_, tr("Unsaved project"),
      tr("The project %1 has changes that are not saved.\n\nSave them first?")
          .arg(QFileInfo(document_.path()).fileName()),
      QMessageBox::Save | QMessageBox::Discard | QMessageBox::Cancel, QMessageBox::Save);
  if (answer == QMessageBox::Cancel) return false;
  return answer == QMessageBox::Discard || SaveProject();
}

bool ProjectController::CloseProject() {
  document_.Close();
  return true;
}

void ProjectController::Push(const Project& after, const QString& text) {
  undo_.push(new ProjectEditCommand(&document_, after, text));
}

void ProjectController::SetVisible(const std::string& id, bool visible) {
  Project after = document_.project();
  const int i = after.Find(id);
  if (i < 0 || after.sessions[i].visible == visible) return;
  after.sessions[i].visible = visible;
  Push(after, visible ? tr("show '%1'").arg(Id(id)) : tr("hide '%1'").arg(Id(id)));
}

void ProjectController::SetColor(const std::string& id, const QString& color) {
  Project after = document_.project();
  const int i = after.Find(id);
  const std::string c = color.toLower().toStdString();
  if (i < 0 || after.sessions[i].color == c) return;
  after.sessions[i].color = c;
  Push(after, tr("colour of '%1'").arg(Id(id)));
}

void ProjectController::RemoveSession(const std::string& id) {
  Project after = document_.project();
  std::string anchor;
  const Status s = after.RemoveSession(id, &anchor);
  if (!s.ok()) {
    show_error_(tr("Cannot remove the session"), QString::fromStdString(s.message()));
    return;
  }
  Push(after, tr("remove '%1'").arg(Id(id)));
  if (!anchor.empty()) {
    emit message(
        tr("'%1' is the anchor now: the project's frame is its start pose").arg(Id(anchor)));
  }
}

void ProjectController::MakeAnchor(const std::string& id) {
  Project after = document_.project();
  Project::AnchorChange change;
  const bool was = after.Anchor() == after.Find(id);
  const Status s = after.ChangeAnchor(id, &change);
  if (!s.ok()) {
    show_error_(tr("Cannot make the session the anchor"), QString::fromStdString(s.message()));
    return;
  }
  if (was) return;
  // The building stays where it is and the frame moves under it; the view's
  // camera moves with the frame, or the building would seem to jump by the
  // change on screen. A session unplaced until now (nothing else was placed)
  // has no pose in the old frame: the old anchor is not drawn after it.
  // A copy: the push replaces the document's project.
  const std::optional<Rigid3d> was_placed =
      document_.project().sessions[document_.project().Find(id)].project_from_session;
  if (was_placed) {
    CloudView* view = view_;
    undo_.push(new ProjectEditCommand(
        &document_, after, tr("make '%1' the anchor").arg(Id(id)),
        [view](const Rigid3d& new_from_old) { view->MoveCameraWithFrame(new_from_old); },
        was_placed->inverse()));
  } else {
    Push(after, tr("make '%1' the anchor").arg(Id(id)));
  }
  QString text = tr("'%1' is the anchor now: the project's frame is its start pose").arg(Id(id));
  if (!change.reversed.empty()) {
    QStringList turned;
    for (const std::string& r : change.reversed) turned << QStringLiteral("'%1'").arg(Id(r));
    text += tr("; placed the other way round now: %1").arg(turned.join(QStringLiteral(", ")));
  }
  if (change.old_anchor_unplaced) {
    text += tr("; '%1', the old anchor, is not placed now").arg(Id(change.old_anchor));
  } else if (const int a = after.Find(change.old_anchor);
             a >= 0 && after.sessions[a].registration.method == "manual") {
    text += tr("; '%1', the old anchor, is held where it is by hand").arg(Id(change.old_anchor));
  }
  emit message(text);
}

void ProjectController::ShowOnly(const std::string& id) {
  Project after = document_.project();
  for (ProjectSession& s : after.sessions) s.visible = s.id == id;
  if (ProjectToJson(after) == ProjectToJson(document_.project())) return;
  Push(after, tr("show only '%1'").arg(Id(id)));
}

void ProjectController::SetPreview(const std::vector<std::string>& ids) {
  if (ids == preview_) return;
  preview_ = ids;
  Show();
  LoadMissing();
}

Rigid3d ProjectController::BesideProject(const std::string& id) const {
  const auto c = clouds_.find(id);
  if (c == clouds_.end() || c->second->bounds.isEmpty()) return Rigid3d();
  Eigen::AlignedBox3d placed;
  for (const ProjectSession& s : document_.project().sessions) {
    const auto pc = clouds_.find(s.id);
    if (!s.project_from_session || pc == clouds_.end() || pc->second->bounds.isEmpty()) continue;
    const Eigen::AlignedBox3d b = pc->second->bounds.cast<double>();
    for (int k = 0; k < 8; ++k) placed.extend(*s.project_from_session * b.corner(Eigen::AlignedBox3d::CornerType(k)));
  }
  if (placed.isEmpty()) return Rigid3d();
  const Eigen::AlignedBox3d own = c->second->bounds.cast<double>();
  return Rigid3d::Translation({placed.max().x() + 2.0 - own.min().x(), placed.min().y() - own.min().y(), 0.0});
}

Project ProjectController::ShownProject() const {
  Project p = document_.project();
  for (const std::string& id : preview_) {
    const int i = p.Find(id);
    if (i < 0) continue;
    p.sessions[i].visible = true;
    if (!p.sessions[i].project_from_session) p.sessions[i].project_from_session = BesideProject(id);
  }
  return p;
}

void ProjectController::Show() {
  layer_->Sync(ShownProject(), clouds_);
  if (layer_->pending() && !pump_->isActive()) pump_->start();
}

void ProjectController::OnChanged() {
  Show();
  panel_->Refresh();
  UpdateActions();
  emit titleChanged();
  LoadMissing();
}

QString ProjectController::load_failure(const std::string& id) const {
  const auto f = load_failures_.find(id);
  if (f == load_failures_.end()) return QString();
  const int i = document_.project().Find(id);
  if (i < 0 ||
      CloudKey(document_.path().toStdString(), document_.project().sessions[i]) != f->second.key) {
    return QString();  // Changed since: it will be tried again.
  }
  return f->second.why;
}

void ProjectController::LoadMissing() {
  if (jobs_.running() || !document_.is_open()) return;
  std::vector<ProjectSession> todo;
  for (const ProjectSession& s : ShownProject().sessions) {
    const std::string key = CloudKey(document_.path().toStdString(), s);
    const auto c = clouds_.find(s.id);
    const auto failed = load_failures_.find(s.id);
    if (s.project_from_session && s.visible && (c == clouds_.end() || c->second->key != key) &&
        (failed == load_failures_.end() || failed->second.key != key)) {
      todo.push_back(s);
    }
  }
  if (todo.empty()) {
    if (shown_pending_ && !layer_->pending() && layer_->drawn_points() > 0) {
      shown_pending_ = false;
      emit shown();
    }
    return;
  }
  const std::string file = document_.path().toStdString();
  const uint64_t generation = document_.opened_count();
  jobs_.Run(
      tr("Loading the project"),
      [this, todo, file, generation](std::atomic<bool>* cancel,
                                     const ProjectJobs::Progress& progress) {
        QString failures;
        for (size_t k = 0; k < todo.size() && !*cancel; ++k) {
          const QString what = tr("Loading '%1' (%2 of %3)").arg(Id(todo[k].id)).arg(k + 1).arg(todo.size());
          ProjectCloudPtr cloud;
          const Status s = BuildProjectCloud(file, todo[k], [&](double f) {
            progress(what, f);
            return !*cancel;
          }, &cloud);
          if (*cancel) return tr("cancelled");
          if (!s.ok()) {
            // One unreadable session costs its own cloud, not the others'.
            const QString why = QString::fromStdString(s.message());
            failures += (failures.isEmpty() ? QString() : QStringLiteral("\n")) + why;
            QMetaObject::invokeMethod(
                this, [this, id = todo[k].id, key = CloudKey(file, todo[k]), why, generation] {
                  if (document_.opened_count() != generation) return;
                  load_failures_[id] = {key, why};
                  panel_->Refresh();
                });
            continue;
          }
          // Drawn as soon as built, not after the last one.
          QMetaObject::invokeMethod(this, [this, cloud, generation] {
            if (document_.opened_count() != generation) return;
            clouds_[cloud->id] = cloud;
            if (!cloud->damage.empty()) {
              emit message(tr("%1: %2").arg(Id(cloud->id), QString::fromStdString(cloud->damage)));
            }
            Show();
            panel_->Refresh();
            emit cloudsChanged();
          });
        }
        return failures;
      },
      [this, generation](const QString& error) {
        const bool stale = document_.opened_count() != generation;
        if (!error.isEmpty() && !jobs_.cancelled() && !stale) {
          // Once: a failed session is not tried again until its folder or
          // calibration changes (load_failures_); the others are drawn.
          show_error_(tr("Cannot load the project's sessions"),
                      error + tr("\n\nThe other sessions are shown."));
        }
        if (jobs_.cancelled() && !stale) {
          emit message(tr("Loading cancelled"));
          return;
        }
        LoadMissing();
      });
}

bool ProjectController::Align(const std::string& id, const std::string& reference,
                              const hardware::SessionRegistrationOptions& options) {
  const Project& p = document_.project();
  const int i = p.Find(id), r = p.Find(reference);
  if (jobs_.running() || i < 0 || r < 0 || i == r || i == p.Anchor() ||
      !p.sessions[r].project_from_session || p.PlacedThrough(reference, id)) {
    return false;  // A session placed against `id` would move with it.
  }
  const ProjectSession source = p.sessions[i], target = p.sessions[r];
  auto cached = [this](const ProjectSession& s) -> ProjectCloudPtr {
    const auto c = clouds_.find(s.id);
    return c != clouds_.end() && c->second->key == CloudKey(document_.path().toStdString(), s)
               ? c->second
               : nullptr;
  };
  struct Outcome {
    ProjectCloudPtr source, target;
    hardware::RegistrationAttempt attempt;
  };
  auto out = std::make_shared<Outcome>();
  out->source = cached(source);
  out->target = cached(target);
  const std::string file = document_.path().toStdString();
  const uint64_t generation = document_.opened_count();
  const QString what = tr("Aligning '%1' to '%2'").arg(Id(id), Id(reference));
  return jobs_.Run(
      what,
      [out, source, target, file, what, options](std::atomic<bool>* cancel,
                                                 const ProjectJobs::Progress& progress) {
        for (auto [s, cloud] : {std::pair{&source, &out->source}, std::pair{&target, &out->target}}) {
          if (*cloud) continue;
          const QString loading = tr("Loading '%1'").arg(Id(s->id));
          const Status st = BuildProjectCloud(file, *s, [&](double f) {
            progress(loading, f);
            return !*cancel;
          }, cloud);
          if (*cancel) return tr("cancelled");
          if (!st.ok()) return QString::fromStdString(st.message());
        }
        RegistrationControl control;
        control.cancel = cancel;
        control.progress = [&](const RegistrationProgress& p) {
          progress(tr("%1: %2").arg(what, QString::fromLatin1(RegistrationStageName(p.stage))), p.fraction);
          return !*cancel;
        };
        out->attempt = hardware::RegisterSession(out->source->positions, out->target->positions,
                                                 target.id, options, control);
        return QString();  // A refusal is an outcome, not a failed job.
      },
      [this, out, id, generation, options](const QString& error) {
        if (document_.opened_count() != generation) {
          // Another project: the result is not this one's to apply.
          emit alignFinished(false, tr("the project was closed"));
          return;
        }
        for (const ProjectCloudPtr& c : {out->source, out->target}) {
          if (c) clouds_[c->id] = c;
        }
        emit cloudsChanged();
        const Status& s = out->attempt.status;
        if (!error.isEmpty() || jobs_.cancelled() || s.message() == kRegistrationCancelled) {
          const QString why = error.isEmpty() ? tr("cancelled") : error;
          emit message(tr("Alignment of '%1': %2").arg(Id(id), why));
          emit alignFinished(false, why);
          return;
        }
        if (!s.ok()) {
          const QString why = tr("Cannot align '%1' to '%2': %3")
                                  .arg(Id(id), Id(out->attempt.reference),
                                       QString::fromStdString(s.message()));
          show_error_(tr("Alignment refused"), why);
          emit alignFinished(false, why);
          return;
        }
        // The project as it is now (the reference may have moved meanwhile).
        Project after = document_.project();
        const int i = after.Find(id), r = after.Find(out->attempt.reference);
        // `id` made the anchor meanwhile: the frame is its own now.
        if (i < 0 || r < 0 || i == after.Anchor() || !after.sessions[r].project_from_session ||
            after.PlacedThrough(out->attempt.reference, id)) {
          emit alignFinished(false, tr("the project changed meanwhile"));
          return;
        }
        const std::optional<Rigid3d> before = after.sessions[i].project_from_session;
        after.sessions[i].project_from_session =
            *after.sessions[r].project_from_session * out->attempt.fine.target_from_source;
        after.sessions[i].registration = hardware::EvidenceOf(out->attempt, options.pairs);
        // Sessions placed against it move with it (one undoable edit).
        const size_t moved = before
                                 ? after
                                       .MoveDependants(id, *after.sessions[i].project_from_session *
                                                               before->inverse())
                                       .size()
                                 : 0;
        // The clouds just built, shown at the new pose.
        QString text = PlacedText(id, out->attempt);
        if (moved > 0)
          text +=
              tr("; %n session(s) placed against it moved with it", "", static_cast<int>(moved));
        if (out->source->has_truth && out->target->has_truth) {
          // The simulation knows where each drive started: a check, never a placement.
          const Rigid3d truth = out->target->world_from_session_truth.inverse() *
                                out->source->world_from_session_truth;
          const Rigid3d diff = truth.inverse() * out->attempt.fine.target_from_source;
          text += tr("; against the simulation's truth: %1 mm, %2 deg")
                      .arg(diff.translation().norm() * 1e3, 0, 'f', 1)
                      .arg(Eigen::AngleAxisd(diff.rotation()).angle() * 180.0 / M_PI, 0, 'f', 3);
        }
        Push(after, tr("align '%1' to '%2'").arg(Id(id), Id(out->attempt.reference)));
        emit message(text);
        emit alignFinished(true, text);
      });
}

void ProjectController::AddRecent(const QString& path) {
  QSettings s;
  QStringList recent = s.value(kRecentKey).toStringList();
  recent.removeAll(path);
  recent.prepend(path);
  while (recent.size() > kMaxRecent) recent.removeLast();
  s.setValue(kRecentKey, recent);
  RebuildRecentMenu();
}

void ProjectController::RebuildRecentMenu() {
  if (recent_menu_ == nullptr) return;
  recent_menu_->clear();
  const QStringList recent = QSettings().value(kRecentKey).toStringList();
  for (const QString& path : recent) {
    recent_menu_
        ->addAction(QFileInfo(path).fileName(), this,
                    [this, path] {
                      if (!QFileInfo::exists(path)) {
                        // As Open Recent does for sessions: said plainly, and off the list.
                        QSettings s;
                        QStringList left = s.value(kRecentKey).toStringList();
                        left.removeAll(path);
                        s.setValue(kRecentKey, left);
                        RebuildRecentMenu();
                        show_error_(tr("Open project"),
                                    tr("%1 does not exist (moved or deleted?).").arg(path));
                        return;
                      }
                      if (ConfirmClose()) OpenProject(path);
                    })
        ->setToolTip(path);
  }
  recent_menu_->setEnabled(!recent.isEmpty());
}

}  // namespace sweepscan::ui
