// The project open in the app (core/project/project.h): its file, its
// contents and whether they differ from the file. Every edit comes through
// Set(), called by the undo commands (project_commands.h), so that the main
// window's QUndoStack undoes project edits like any other.
//
// "Modified" is a comparison, not a counter: the contents as JSON against
// what was last read or written, so that undoing back to the saved state
// is unmodified again whatever else the undo stack holds.
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_PROJECT_PROJECT_DOCUMENT_H_
#define SWEEPSCAN_UI_PROJECT_PROJECT_DOCUMENT_H_

#include <QObject>
#include <QString>
#include <cstdint>
#include <string>
#include <vector>

#include "core/project/project.h"

namespace sweepscan::ui {

class ProjectDocument : public QObject {
  Q_OBJECT
 public:
  explicit ProjectDocument(QObject* parent = nullptr) : QObject(parent) {}

  bool is_open() const { return !path_.isEmpty(); }
  QString path() const { return path_; }
  const Project& project() const { return project_; }
  bool modified() const { return is_open() && ProjectToJson(project_) != saved_json_; }
  // Changes on every Open / New / Close: undo commands of an older project
  // become obsolete instead of editing this one.
  uint64_t generation() const { return generation_; }
  // Changes on every Open / New / Close, not on Save As: the result of a
  // job on this project (an alignment, a session's cloud) still applies
  // after Save As, whose sessions are the same folders under the same ids.
  uint64_t opened_count() const { return opened_count_; }

  // A new, empty project to be saved at `path` (nothing written yet). A
  // file already at `path` is replaced by the first Save, as the caller
  // has confirmed (ChangedOnDisk() only sees changes after this).
  void New(const QString& path);
  // Reads `path`; on failure the open project stays. References a file
  // may hold from before 2026-11-29 (a loop, a session against itself) are
  // repaired as LoadProject's `repairs` says (repairs()), and the project is
  // then modified until saved.
  Status Open(const QString& path);
  const std::vector<std::string>& repairs() const { return repairs_; }
  // Writes the project atomically to its path.
  Status Save();
  // What SaveMerging did.
  struct Merge {
    // Why the file could not be merged ("" if it was, or had not changed):
    // the sessions changed both there and here (`conflicts`), or it cannot
    // be read now, or it was never read here (a new project's file).
    // Nothing was written then.
    std::string refused;
    std::vector<std::string> conflicts;  // MergeProjects's "ID: why"
    std::vector<std::string> from_file;  // the sessions the merge took from the file
  };
  // Save(), merged with what another program saved to the file meanwhile
  // (ChangedOnDisk(); core/project/project_merge.h, against the file as
  // read or written here), as `sweepscan-cli project align` merges. When
  // the merge took anything from the file, the document holds the merge and
  // a new generation begins (merged()): the undo commands hold projects
  // without the file's changes, and undoing one would drop them.
  Status SaveMerging(Merge* merge);
  // Writes the project atomically to `path` and makes that its file: every
  // session's folder stored again relative to the new file's folder (the
  // same folders, so no cloud is built again), the name following the
  // file's when it was the old file's. The undo history of the project ends
  // here (a generation, as Open): older commands hold the old folder's
  // relative paths. On failure nothing changes.
  Status SaveAs(const QString& path);
  void Close();
  // Whether the file was changed by another program (`sweepscan-cli
  // project align` in a terminal) since it was opened or last saved here:
  // its bytes differ from what was read or written (a file that appeared
  // where a new project is to go counts too).
  bool ChangedOnDisk() const;
  // The contents (the undo commands' way in).
  void Set(const Project& project);
  // The session folder `dir` as the project stores it: relative to the
  // project file's folder, so that the folder of both can move.
  std::string StoredPath(const QString& dir) const;

 signals:
  void opened();   // another project (or none) is open
  void renamed();  // the same project, saved under another file (SaveAs)
  void merged();   // the project holds another program's changes (SaveMerging)
  void changed();  // the contents changed (after opened(), too)
  void modifiedChanged(bool modified);

 private:
  void Changed(bool was_modified);
  // `project`, as on disk at `path`, is the document now (a new
  // generation); `what` (opened or renamed) says so.
  void Adopt(const QString& path, Project project, void (ProjectDocument::*what)());

  QString path_;
  Project project_;
  std::string saved_json_;
  std::string disk_text_;  // the file's bytes as read or written here ("" if none)
  std::vector<std::string> repairs_;  // what Open repaired
  uint64_t generation_ = 0;
  uint64_t opened_count_ = 0;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PROJECT_PROJECT_DOCUMENT_H_
