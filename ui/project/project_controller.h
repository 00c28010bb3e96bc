// The desktop app's side of projects (issue 29, docs/desktop-app.md,
// "Projects"): the File menu's project actions and recent projects, the
// Project panel, the project's sessions in the cloud view, and alignment.
//
// * Edits (visibility, colour, adding, removing, a placement) are
//   ProjectEditCommands on the project's own QUndoStack, one of the
//   window's histories (UndoRouter) and cleared with the project it belongs
//   to; the document says whether the project differs from its file (the
//   window's [*]).
// * Clouds are built on a job thread (ProjectJobs: progress and cancel in
//   the panel), each session once per folder and calibration, and kept
//   while the project is open; the view draws the placed, visible ones
//   (ProjectLayer).
// * Align runs the CLI's registration step (hardware/station/
//   project_align.h) of one session against one placed reference on the
//   job thread; success is an undoable placement, a refusal changes nothing
//   and says why. The registration's coarse step is planes, or the
//   operator's picked pairs (PairPicking: a mode of the panel and the view).
// * Export writes the building's cloud as one file, session by session
//   streamed on the job thread (project_controller_export.cc).
// * While pairs are picked, the session and its reference are previewed:
//   drawn even if hidden, and an unplaced session beside the project (its
//   frame's origin moved, never rotated) so that both can be clicked.
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_PROJECT_PROJECT_CONTROLLER_H_
#define SWEEPSCAN_UI_PROJECT_PROJECT_CONTROLLER_H_

#include <QObject>
#include <QString>
#include <QStringList>
#include <QUndoStack>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "hardware/station/project_align.h"
#include "ui/project/project_document.h"
#include "ui/project/project_jobs.h"

class QAction;
class QMenu;
class QTimer;
class QWidget;

namespace sweepscan::ui {

class CloudView;
class PairPicking;
class ProjectLayer;
class ProjectPanel;

class ProjectController : public QObject {
  Q_OBJECT
 public:
  // `show_error(title, message)` reports failures (a message box when the
  // window is interactive); `interactive()` says whether dialogs may open.
  ProjectController(QWidget* window, CloudView* view,
                    std::function<void(const QString&, const QString&)> show_error,
                    std::function<bool()> interactive);
  ~ProjectController() override;

  ProjectDocument* document() { return &document_; }
  ProjectPanel* panel() const { return panel_; }
  const ProjectLayer* layer() const { return layer_.get(); }
  ProjectJobs* jobs() { return &jobs_; }
  // The project's edits; empty after Open, New, Close and Save As (older
  // edits would hold another project, or the old file's relative paths).
  QUndoStack* undo_stack() { return &undo_; }
  // File menu: New Project…, Open Project…, Open Recent Project, Save
  // Project, Save Project As…, Add Session to Project…, Close Project.
  void AddFileMenuActions(QMenu* file);
  QAction* save_action() const { return save_; }
  // File > Export Project Cloud… (project_controller_export.cc): the
  // placed, visible sessions as one file in the project's frame
  // (hardware/station/project_export.h, what `sweepscan-cli project
  // export` writes), LAS 1.4, PLY or PCD, on the job thread with the
  // panel's progress and cancel.
  QAction* AddExportAction(QMenu* file);
  void ExportWithDialog();
  // The export to `path` once chosen (tests call it); false if it cannot
  // start (no project, no placed and visible session, a job runs), said
  // through show_error. The end is said as message() or show_error.
  bool ExportCloud(const QString& path);
  // The same, here and now (the command line's --export-cloud at quit);
  // *notes gets what the status bar would add (sessions left out, damage).
  Status ExportCloudNow(const QString& path, QStringList* notes);
  // True if a session is placed and shown; else says so (show_error).
  bool SayIfNothingToExport();
  // The window title's part: "floor.sweepscan-project[*]", "" without a project.
  QString title() const;

  // What the actions do, once their files are chosen (tests call these).
  bool NewProject(const QString& path);
  bool OpenProject(const QString& path);
  bool SaveProject();
  bool SaveProjectAs(const QString& path);  // ProjectDocument::SaveAs
  bool AddSession(const QString& dir);  // undoable
  // Asks to save a modified project (interactive); false: the operator cancelled.
  bool ConfirmClose();
  bool CloseProject();  // after ConfirmClose()

  // Undoable edits by session id.
  void SetVisible(const std::string& id, bool visible);
  void SetColor(const std::string& id, const QString& color);  // "#rrggbb"
  void RemoveSession(const std::string& id);
  void ShowOnly(const std::string& id);
  // Makes session `id` the anchor (Project::ChangeAnchor): the project's
  // frame becomes its start pose, the building unmoved; what core/project
  // refuses is said (show_error) and changes nothing.
  void MakeAnchor(const std::string& id);
  // Registers session `id` against the placed `reference` on the job
  // thread (loading either cloud first if needed). False if it cannot start
  // (a job runs, unknown ids, the reference unplaced or placed against
  // `id`, `id` the anchor).
  // `options` as the CLI's (pairs: coarse by them, kept as the evidence).
  bool Align(const std::string& id, const std::string& reference,
             const hardware::SessionRegistrationOptions& options = {});
  PairPicking* pair_picking() const { return picking_; }
  // Sessions drawn whatever the project says (visible; an unplaced one
  // beside the project); {} ends the preview. Their clouds load if needed.
  void SetPreview(const std::vector<std::string>& ids);
  // The project as drawn: the document with the preview applied.
  Project ShownProject() const;
  void Cancel() { jobs_.Cancel(); }
  // A job runs or loaded points are still on their way to the view.
  bool busy() const;
  // The clouds built so far, by id.
  const std::map<std::string, ProjectCloudPtr>& clouds() const { return clouds_; }
  // Why session `id`'s cloud could not be built ("" if it was, or was not
  // tried). Not tried again until its folder or calibration changes.
  QString load_failure(const std::string& id) const;

 signals:
  void titleChanged();
  // The project's first clouds are drawn: time for the room view.
  void shown();
  void message(const QString& text);  // for the status bar
  // An alignment ended: placed, or refused / cancelled with the reason.
  void alignFinished(bool placed, const QString& message);
  // clouds() changed (a session's cloud built, or the project closed).
  void cloudsChanged();

 private:
  void Push(const Project& after, const QString& text);
  void OnChanged();
  void Show();  // The layer from the project and the clouds; pumps what is new.
  // Builds the clouds of placed, visible sessions not built yet (one job).
  void LoadMissing();
  // A project file to write, from a save dialog that adds the suffix and
  // asks before replacing a file (empty: cancelled).
  QString ChooseProjectFile(const QString& title, const QString& start);
  void AddRecent(const QString& path);
  void RebuildRecentMenu();
  void UpdateActions();
  // Where an unplaced previewed session is drawn: its box beside (+x) the
  // placed sessions' box, 2 m apart, bottoms aligned; identity until its
  // cloud is built.
  Rigid3d BesideProject(const std::string& id) const;

  QWidget* window_;
  CloudView* view_;
  QUndoStack undo_;
  std::function<void(const QString&, const QString&)> show_error_;
  std::function<bool()> interactive_;
  ProjectDocument document_;
  ProjectJobs jobs_;
  std::unique_ptr<ProjectLayer> layer_;
  ProjectPanel* panel_;
  std::map<std::string, ProjectCloudPtr> clouds_;
  struct LoadFailure {
    std::string key;  // CloudKey() of the failed build
    QString why;
  };
  std::map<std::string, LoadFailure> load_failures_;
  std::vector<std::string> preview_;
  PairPicking* picking_ = nullptr;
  QTimer* pump_ = nullptr;
  bool shown_pending_ = false;  // shown() once the first clouds of an opened project draw
  QMenu* recent_menu_ = nullptr;
  QAction* save_ = nullptr;
  QAction* save_as_ = nullptr;
  QAction* add_ = nullptr;
  QAction* close_ = nullptr;
  QAction* export_ = nullptr;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PROJECT_PROJECT_CONTROLLER_H_
