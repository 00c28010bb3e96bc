#include "ui/project/project_document.h"

#include <QDir>
#include <QFile>
#include <QFileInfo>

#include "core/project/project_merge.h"

namespace sweepscan::ui {
namespace {

// The file's bytes, "" if it cannot be read (or is not there).
std::string FileText(const QString& path) {
  QFile f(path);
  if (!f.open(QIODevice::ReadOnly)) return std::string();
  return f.readAll().toStdString();
}

}  // namespace

void ProjectDocument::New(const QString& path) {
  const bool was = modified();
  path_ = path;
  project_ = Project();
  project_.name = QFileInfo(path).completeBaseName().toStdString();
  saved_json_.clear();  // Not on disk yet: modified until saved.
  // A file already there is the one the operator chose to replace (New
  // Project… asked): Save overwrites it without calling it another
  // program's change; one that appears later still counts as that.
  disk_text_ = FileText(path);
  ++generation_;
  ++opened_count_;
  emit opened();
  Changed(was);
}

Status ProjectDocument::Open(const QString& path) {
  Project p;
  const std::string text = FileText(path);
  std::vector<std::string> repairs;
  const Status s = ProjectFromJson(text, path.toStdString(), &p, &repairs);
  if (!s.ok()) {
    // An unreadable file says so (cannot open: why), else the parse error.
    const Status read = LoadProject(path.toStdString(), &p);
    return read.ok() ? s : read;
  }
  Adopt(path, std::move(p), &ProjectDocument::opened);
  disk_text_ = text;
  repairs_ = std::move(repairs);
  if (!repairs_.empty()) {  // Not as on disk: saved on the next Save.
    saved_json_.clear();
    emit modifiedChanged(true);
  }
  return Status::Ok();
}

bool ProjectDocument::ChangedOnDisk() const {
  return is_open() && (QFileInfo::exists(path_) || !disk_text_.empty()) &&
         FileText(path_) != disk_text_;
}

Status ProjectDocument::Save() {
  const Status s = SaveProject(path_.toStdString(), project_);
  if (!s.ok()) return s;
  const bool was = modified();
  saved_json_ = ProjectToJson(project_);
  disk_text_ = saved_json_;
  if (was) emit modifiedChanged(false);
  return s;
}

Status ProjectDocument::SaveMerging(Merge* merge) {
  *merge = Merge();
  if (!ChangedOnDisk()) return Save();
  const std::string path = path_.toStdString();
  if (disk_text_.empty()) {
    merge->refused = "it was not there when the project was made here";
    return Status::Error(path + ": " + merge->refused);
  }
  if (!QFileInfo::exists(path_)) {
    merge->refused = "it was removed";
    return Status::Error(path + ": " + merge->refused);
  }
  // Both as Open reads them: repaired, as the document was when opened.
  Project base, file;
  std::vector<std::string> repairs;
  Status s = ProjectFromJson(disk_text_, path, &base, &repairs);
  if (s.ok()) s = ProjectFromJson(FileText(path_), path, &file, &repairs);
  if (!s.ok()) {
    merge->refused = "it cannot be read now: " + s.message();
    return Status::Error(path + ": " + merge->refused);
  }
  ProjectMerge m = MergeProjects(base, project_, file);
  if (!m.conflicts.empty()) {
    merge->conflicts = std::move(m.conflicts);
    merge->refused = "sessions changed both there and here";
    return Status::Error(path + ": " + merge->refused);
  }
  s = SaveProject(path, m.merged);
  if (!s.ok()) return s;
  merge->from_file = std::move(m.from_file);
  const bool was = modified();
  const bool took = ProjectToJson(m.merged) != ProjectToJson(project_);
  project_ = std::move(m.merged);
  saved_json_ = ProjectToJson(project_);
  disk_text_ = saved_json_;
  if (took) {
    ++generation_;
    emit merged();
    Changed(was);
  } else if (was) {
    emit modifiedChanged(false);
  }
  return Status::Ok();
}

Status ProjectDocument::SaveAs(const QString& path) {
  if (!is_open()) return Status::Error("no project is open");
  Project p = project_;
  const QDir to(QFileInfo(path).absolutePath());
  for (ProjectSession& session : p.sessions) {
    const QString folder = QString::fromStdString(ResolveSessionPath(path_.toStdString(), session));
    session.path = to.relativeFilePath(QFileInfo(folder).absoluteFilePath()).toStdString();
  }
  if (p.name == QFileInfo(path_).completeBaseName().toStdString()) {
    p.name = QFileInfo(path).completeBaseName().toStdString();
  }
  const Status s = SaveProject(path.toStdString(), p);
  if (!s.ok()) return s;
  Adopt(path, std::move(p), &ProjectDocument::renamed);
  disk_text_ = saved_json_;
  return Status::Ok();
}

void ProjectDocument::Adopt(const QString& path, Project project, void (ProjectDocument::*what)()) {
  const bool was = modified();
  path_ = path;
  project_ = std::move(project);
  saved_json_ = ProjectToJson(project_);
  ++generation_;
  if (what == &ProjectDocument::opened) ++opened_count_;
  emit(this->*what)();
  Changed(was);
}

void ProjectDocument::Close() {
  const bool was = modified();
  path_.clear();
  project_ = Project();
  saved_json_.clear();
  disk_text_.clear();
  ++generation_;
  ++opened_count_;
  emit opened();
  Changed(was);
}

void ProjectDocument::Set(const Project& project) {
  const bool was = modified();
  project_ = project;
  Changed(was);
}

std::string ProjectDocument::StoredPath(const QString& dir) const {
  const QString folder = QFileInfo(path_).absolutePath();
  return QDir(folder).relativeFilePath(QFileInfo(dir).absoluteFilePath()).toStdString();
}

void ProjectDocument::Changed(bool was_modified) {
  emit changed();
  if (modified() != was_modified) emit modifiedChanged(modified());
}

}  // namespace sweepscan::ui
